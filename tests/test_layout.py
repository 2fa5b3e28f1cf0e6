"""Host dtypes (clrender/layout.py) and kernel structs (kernels/types.h) agree."""
import numpy as np
import pyopencl as cl

from clrender import layout
from conftest import build_test_kernels

ORDER = [  # the argument order of struct_layout in kernels/tests.cl
    "WideBvhNode", "Triangle", "Sphere", "TriangleShading", "TriangleInfo", "Material", "Emitter",
    "Medium", "Camera", "RenderParams", "AovSums"]


def expected_layout():
    values = []
    for name in ORDER:
        dtype = layout.STRUCTS[name]
        values.append(dtype.itemsize)
        values += [dtype.fields[field][1] for field in dtype.names]
    return values


def test_struct_sizes_and_offsets_match(context, queue):
    program = build_test_kernels(context)
    mf = cl.mem_flags
    structs = [cl.Buffer(context, mf.READ_WRITE, layout.STRUCTS[name].itemsize) for name in ORDER]
    expected = expected_layout()
    out = np.full(len(expected), -1, np.int32)
    out_buffer = cl.Buffer(context, mf.WRITE_ONLY, out.nbytes)
    program.struct_layout(queue, (1,), None, *structs, out_buffer)
    cl.enqueue_copy(queue, out, out_buffer)
    assert out.tolist() == expected


def test_enumerations_are_defined_once_for_host_and_kernel():
    text = layout.c_constants()
    for table, prefix in ((layout.MATERIAL_KINDS, "MATERIAL"), (layout.EMITTER_KINDS, "EMITTER")):
        for name, value in table.items():
            assert f"#define {prefix}_{name.upper()} {value}\n" in text
