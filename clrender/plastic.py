"""Plastic on the host (kernels/materials/plastic.h): the fields of its Material record, and the
tables of its rough coat (kernels/materials/plastic_coat.h), computed on the device by the
kernel code that renders, as Mitsuba 3's roughplastic computes them when it loads, and cached
for the session per (device, ior, exterior ior, distribution, alpha range), and on disk per
program build (disk_cache.py: PoCL took 0.3 s a table)."""
import numpy as np
import pyopencl as cl

from . import disk_cache, layout
from .textures import LUMINANCE

MIN_TABLE_ALPHA = np.float32(1e-4)   # Mitsuba's least microfacet width
COAT_ROW = layout.COAT_TABLE_SIZE + 1

_cache = {}  # (device, ior, exterior ior, distribution, alpha range) -> float32 (rows, COAT_ROW)


def _set(record, name, value):
    layout.set_field(record, layout.MATERIAL_FIELDS, name, value)


def _get(record, name):
    return layout.field(record, layout.MATERIAL_FIELDS, name)


def set_fields(record, material, textures):
    """Write the plastic `material` (scene.Material) into its Material `record`; `textures`: the
    scene's (their means weigh the lobes, a textured alpha's values span the tables)."""
    _set(record, "color", material.albedo)
    _set(record, "reflection_tint", material.reflection_tint)
    _set(record, "ior", material.ior)
    _set(record, "exterior_ior", material.exterior_ior)
    alpha = np.float32(material.roughness) * np.float32(material.roughness)  # as the kernel would
    _set(record, "alpha", alpha)
    _set(record, "distribution", layout.MICROFACET_DISTRIBUTIONS[material.distribution])
    _set(record, "masking", layout.MASKINGS[material.masking])
    _set(record, "nonlinear", int(material.nonlinear))
    _set(record, "specular_sampling_weight", specular_sampling_weight(material, textures))
    low, high = alpha_range(material, textures, alpha)
    _set(record, "coat_alpha_range", (low, high))
    _set(record, "coat_alpha_rows", alpha_rows(low, high))


def mitsuba_mean(material, field, constant, textures):
    """The mean of a colour parameter as Mitsuba's Texture::mean() gives it: a constant's and a
    checkerboard's mean over channels, a bitmap's mean luminance."""
    if field not in material.textures:
        return float(np.mean(constant))
    texture = textures[material.textures[field]]
    mean = texture.mean()
    return float(mean @ LUMINANCE if texture.type == "bitmap" else np.mean(mean))


def specular_sampling_weight(material, textures):
    """Mitsuba's specular_sampling_weight: the specular reflectance's mean over the sum of both
    means (1/2 where both are black: the material is black then)."""
    specular = mitsuba_mean(material, "reflection_tint", material.reflection_tint, textures)
    diffuse = mitsuba_mean(material, "color", material.albedo, textures)
    return specular / (specular + diffuse) if specular + diffuse > 0 else 0.5


def alpha_range(material, textures, alpha):
    """The alphas of the first and last rows of the coat's tables: the constant alpha twice, or the
    range of a textured alpha's values; (0, 0) for a smooth coat (no tables: Mitsuba's plastic).
    Alphas are at least MIN_TABLE_ALPHA, as Mitsuba's microfacet widths."""
    if "alpha" in material.textures:
        low, high = textures[material.textures["alpha"]].number_range()
    else:
        low = high = alpha
    if not high > 0:
        return 0.0, 0.0
    return max(np.float32(low), MIN_TABLE_ALPHA), max(np.float32(high), MIN_TABLE_ALPHA)


def alpha_rows(low, high):
    """Rows of coat tables from alpha `low` to `high`: none for a smooth coat, one for a constant
    alpha, else evenly spaced in sqrt(alpha), at most COAT_SQRT_ALPHA_STEP apart."""
    if not high > 0:
        return 0
    if not high > low:
        return 1
    return 1 + max(1, int(np.ceil((np.sqrt(float(high)) - np.sqrt(float(low))) / layout.COAT_SQRT_ALPHA_STEP)))


def table_rows(record):
    """Rows of the coat tables of a plastic Material record."""
    return int(_get(record, "coat_alpha_rows"))


def table_floats(record):
    """Floats of Scene.specular_albedo that the coat tables of `record` take."""
    return table_rows(record) * COAT_ROW


def gauss_legendre(count):
    """(node, weight) pairs of the count-node Gauss-Legendre rule on [-1, 1], as float32 (Mitsuba's
    quad::gauss_legendre)."""
    nodes, weights = np.polynomial.legendre.leggauss(count)
    return np.stack([nodes, weights], axis=1).astype(np.float32)


def _key(queue, record):
    return (queue.device.int_ptr, float(_get(record, "ior")), float(_get(record, "exterior_ior")),
            int(_get(record, "distribution")), *map(float, _get(record, "coat_alpha_range")))


def _disk_fields(key):
    """The disk cache's fields of a session key (the program's build key names the device)."""
    return ("plastic coat",) + key[1:]


def fill_coat_tables(queue, tables, arrays, indices):
    """Fill arrays.specular_albedo with the coat tables of the plastic materials `indices`, from
    the disk cache or computed by `tables` (energy.TablesProgram)."""
    materials = arrays.materials
    pending = {}
    for index in indices:
        key = _key(queue, materials[index])
        if key not in _cache:
            pending.setdefault(key, index)
    build_key = tables.key
    for key, index in list(pending.items()):
        stored = disk_cache.load_table(build_key, _disk_fields(key), (table_rows(materials[index]), COAT_ROW))
        if stored is not None:
            _cache[key] = stored
            del pending[key]
    if pending:
        context = queue.context
        mf = cl.mem_flags
        kernel = tables.kernel("plastic_coat_table")
        buffer = lambda array: cl.Buffer(context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=array)  # noqa: E731
        material_buffer = buffer(materials)
        nodes = (buffer(gauss_legendre(32)), buffer(gauss_legendre(128)))
        for key, index in pending.items():
            rows = table_rows(materials[index])
            out = np.empty((rows, 2, layout.COAT_TABLE_SIZE), np.float32)
            out_buffer = cl.Buffer(context, mf.WRITE_ONLY, out.nbytes)
            kernel(queue, out.shape, None, material_buffer, np.int32(index), *nodes, out_buffer)
            cl.enqueue_copy(queue, out, out_buffer)
            _cache[key] = coat_rows(out)
            disk_cache.store_table(build_key, _disk_fields(key), _cache[key])
    for index in indices:
        offset = int(_get(materials[index], "albedo_tables"))
        table = _cache[_key(queue, materials[index])]
        arrays.specular_albedo[offset:offset + table.size] = table.ravel()


def coat_rows(entries):
    """Rows (T(mu_0..), r) from the kernel's entries (rows, 2, COAT_TABLE_SIZE): the internal
    reflectance r = 2 mean_k(R(mu_k) mu_k), Mitsuba's, in float32 as its scalar variants."""
    size = layout.COAT_TABLE_SIZE
    mu = np.maximum(np.float32(1e-6), np.linspace(0, 1, size, dtype=np.float32))
    rows = np.empty((len(entries), size + 1), np.float32)
    rows[:, :size] = entries[:, 0]
    rows[:, size] = 2 * np.mean(entries[:, 1] * mu, axis=1, dtype=np.float32)
    return rows
