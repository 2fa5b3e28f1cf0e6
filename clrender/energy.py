"""Energy-compensation tables of rough specular materials (kernels/materials/energy.h).

Each table is the directional albedo E(mu_o) of a material's single-scattering lobe, computed on
the device by the kernel code that renders it (kernels/tables.cl: the scalar microfacet code of
every render program, packets included), so host and kernel cannot disagree. Tables depend
only on the lobe (kind, indices, the microfacet model) and are cached for the session, and on
disk per program build (disk_cache.py).
"""
import numpy as np
import pyopencl as cl

from . import disk_cache, layout, plastic
from .device import build_program, program_key
from .features import TABLE_FEATURES

_cache = {}  # (device, *TABLE_FIELDS) -> float32 (sides, ALBEDO_TABLE_SIZE)

# The Material fields a table depends on.
TABLE_FIELDS = ("kind", "ior", "exterior_ior", "alpha", "distribution", "masking")


def _field(material, name):
    return layout.field(material, layout.MATERIAL_FIELDS, name)


def _table_key(queue, material):
    """A table depends on the device and the lobe."""
    return (queue.device.int_ptr, *(float(_field(material, name)) for name in TABLE_FIELDS))


def _disk_fields(key):
    """The disk cache's fields of a session key (the program's build key names the device)."""
    return ("albedo",) + key[1:]


def _sides(material):
    """Tables of a material: a dielectric's two sides, one otherwise."""
    return 2 if _field(material, "kind") == layout.MATERIAL_KINDS["dielectric"] else 1


class TablesProgram:
    """The tables' program (kernels/tables.cl) on a context: its build key (the disk cache's), and
    its kernels, the program built (or loaded) only when a table has to be computed."""

    def __init__(self, context):
        self.context = context
        self.key = program_key(context, TABLE_FEATURES, "tables.cl")

    def kernel(self, name):
        return cl.Kernel(build_program(self.context, TABLE_FEATURES, entry="tables.cl"), name)


def fill_albedo_tables(queue, arrays):
    """Fill arrays.specular_albedo for the materials in arrays.table_materials (plastic's coat
    tables: clrender/plastic.py)."""
    if not arrays.table_materials:
        return
    tables = TablesProgram(queue.context)
    materials = arrays.materials
    is_plastic = lambda index: _field(materials[index], "kind") == layout.MATERIAL_KINDS["plastic"]  # noqa: E731
    plastic.fill_coat_tables(queue, tables, arrays, [i for i in arrays.table_materials if is_plastic(i)])
    owners = [i for i in arrays.table_materials if not is_plastic(i)]
    if not owners:
        return
    size = layout.ALBEDO_TABLE_SIZE
    context = queue.context
    pending = []
    build_key = tables.key
    for index in owners:
        m = materials[index]
        key = _table_key(queue, m)
        if key in _cache:
            continue
        stored = disk_cache.load_table(build_key, _disk_fields(key), (_sides(m), size))
        if stored is not None:
            _cache[key] = stored
        else:
            pending.append((index, key))
    if pending:
        kernel = tables.kernel("specular_albedo_table")
        mf = cl.mem_flags
        material_buffer = cl.Buffer(context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=materials)
        out = np.full_like(arrays.specular_albedo, np.nan)
        out_buffer = cl.Buffer(context, mf.READ_WRITE | mf.COPY_HOST_PTR, hostbuf=out)
        for index, _ in pending:
            kernel(queue, (2, size), None, material_buffer, np.int32(index), out_buffer)
        cl.enqueue_copy(queue, out, out_buffer)
        for index, key in pending:
            offset = int(_field(materials[index], "albedo_tables"))
            sides = _sides(materials[index])
            _cache[key] = out[offset:offset + sides * size].reshape(sides, size).copy()
            disk_cache.store_table(build_key, _disk_fields(key), _cache[key])
    for index in owners:
        m = materials[index]
        key = _table_key(queue, m)
        offset = int(_field(m, "albedo_tables"))
        table = _cache[key]
        arrays.specular_albedo[offset:offset + table.size] = table.ravel()
