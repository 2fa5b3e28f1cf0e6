"""Energy-compensation tables of rough specular materials (kernels/materials/energy.h).

Each table is the directional albedo E(mu_o) of a material's single-scattering lobe, computed on
the device by the kernel code that renders it, so host and kernel cannot disagree. Tables depend
only on (kind, ior, exterior ior, alpha) and are cached for the session.
"""
import numpy as np
import pyopencl as cl

from . import layout

_cache = {}  # (device, kind, ior, exterior_ior, alpha) -> float32 (sides, ALBEDO_TABLE_SIZE)


def _field(material, name):
    return layout.field(material, layout.MATERIAL_FIELDS, name)


def _table_key(queue, material):
    """A table depends on the device and the lobe: kind, ior, exterior ior, alpha."""
    return (queue.device.int_ptr, *(float(_field(material, name))
                                    for name in ("kind", "ior", "exterior_ior", "alpha")))


def fill_albedo_tables(queue, program, arrays):
    """Fill arrays.specular_albedo for the materials in arrays.table_materials."""
    if not arrays.table_materials:
        return
    size = layout.ALBEDO_TABLE_SIZE
    context = queue.context
    materials = arrays.materials
    pending = []
    for index in arrays.table_materials:
        m = materials[index]
        key = _table_key(queue, m)
        if key not in _cache:
            pending.append((index, key))
    if pending:
        kernel = cl.Kernel(program, "specular_albedo_table")
        mf = cl.mem_flags
        material_buffer = cl.Buffer(context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=materials)
        out = np.full_like(arrays.specular_albedo, np.nan)
        out_buffer = cl.Buffer(context, mf.READ_WRITE | mf.COPY_HOST_PTR, hostbuf=out)
        for index, _ in pending:
            kernel(queue, (2, size), None, material_buffer, np.int32(index), out_buffer)
        cl.enqueue_copy(queue, out, out_buffer)
        for index, key in pending:
            offset = int(_field(materials[index], "albedo_tables"))
            sides = 2 if _field(materials[index], "kind") == layout.MATERIAL_KINDS["dielectric"] else 1
            _cache[key] = out[offset:offset + sides * size].reshape(sides, size).copy()
    for index in arrays.table_materials:
        m = materials[index]
        key = _table_key(queue, m)
        offset = int(_field(m, "albedo_tables"))
        table = _cache[key]
        arrays.specular_albedo[offset:offset + table.size] = table.ravel()
