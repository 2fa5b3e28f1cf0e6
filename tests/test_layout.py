"""Host dtypes (clrender/layout.py) and kernel structs (kernels/types.h) agree."""
import re

import numpy as np
import pyopencl as cl

from clrender import layout
from clrender.device import kernel_dir, kernel_source
from conftest import build_test_kernels

ORDER = [  # the argument order of struct_layout in kernels/tests.cl
    "WideBvhNode", "TriangleBlock", "Sphere", "TriangleShading", "TriangleInfo", "Material", "Texture", "Emitter",
    "Medium", "Camera", "Filter", "RenderParams", "AovSums", "GuideLobe"]


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


# ----- packed fields: the kernel accessors read the lanes layout.py names -------------------------
ACCESSOR_HEADERS = {"Material": ("materials/material.h", "material", layout.MATERIAL_FIELDS, layout.MATERIAL),
                    "Medium": ("media/medium_record.h", "medium", layout.MEDIUM_FIELDS, layout.MEDIUM)}


def accessor_program(context, struct):
    """The accessor header and a kernel, generated from the field table, that writes every
    accessor's lanes in table order (as floats)."""
    header, prefix, fields, _ = ACCESSOR_HEADERS[struct]
    pointer = "__global const Medium* r = records;" if struct == "Medium" else "Material copy = records[0]; const Material* r = &copy;"
    body = []
    for name, (_, _, count) in fields.items():
        call = f"{prefix}_{name}(r)"
        body += [f"    out[k++] = (float)({call});"] if count == 1 else [
            f"    out[k++] = (float)({call}.{lane});" for lane in "xyz"[:count]]
    source = kernel_source(header) + "\n".join([
        f"__kernel void read_fields(__global const {struct}* records, __global float* out) {{",
        f"    {pointer}", "    int k = 0;", *body, "}"])
    return cl.Program(context, source).build()


def test_accessors_read_the_lanes_named_in_layout(context, queue):
    for struct, (_, _, fields, dtype) in ACCESSOR_HEADERS.items():
        record = np.zeros(1, dtype)
        raw = record.view(np.uint8)
        # Every 4-byte lane gets a distinct small value (exact as float and as int).
        for member in dtype.names:
            base = record[member]
            values = np.arange(base[0].size).reshape(base[0].shape) + 100 * (dtype.names.index(member) + 1)
            record[member] = values.astype(base.dtype)
        expected = np.concatenate([np.atleast_1d(layout.field(record, fields, name)).ravel().astype(np.float32)
                                   for name in fields])
        out = np.full(expected.size, np.nan, np.float32)
        mf = cl.mem_flags
        out_buffer = cl.Buffer(context, mf.WRITE_ONLY, out.nbytes)
        accessor_program(context, struct).read_fields(
            queue, (1,), None, cl.Buffer(context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=raw), out_buffer)
        cl.enqueue_copy(queue, out, out_buffer)
        assert out.tolist() == expected.tolist(), struct


def test_lane_accessors_read_the_same_lanes(context, queue):
    # materials/material.h's *_at accessors (the packet kernel's, over lanes.h) against the
    # scalar accessors of the same fields, at one lane.
    fields = ("kind", "one_sided", "emission", "ior", "exterior_ior", "conductor_eta", "conductor_k", "alpha",
              "distribution", "masking", "reflection_tint", "albedo_tables", "nonlinear", "specular_sampling_weight",
              "coat_alpha_range", "coat_alpha_rows")
    record = np.zeros(1, layout.MATERIAL)
    raw = record.view(np.uint8)
    for member in record.dtype.names:   # distinct small values, exact as float and as int
        base = record[member]
        record[member] = (np.arange(base[0].size).reshape(base[0].shape) + 100 * (record.dtype.names.index(member) + 1)).astype(base.dtype)
    body = []
    for pattern in ("material_{}(&copy)", "material_{}_at(records, 0)"):   # scalar half, lane half
        for name in fields:
            call, count = pattern.format(name), layout.MATERIAL_FIELDS[name][2]
            body += [f"    out[k++] = (float)({call});"] if count == 1 else [
                f"    out[k++] = (float)({call}.{lane});" for lane in "xyz"[:count]]
    source = kernel_source("materials/material.h") + "\n".join([
        "__kernel void read_fields(__global const Material* records, __global float* out) {",
        "    Material copy = records[0];", "    int k = 0;", *body, "}"])
    out = np.full(len(body), np.nan, np.float32)
    mf = cl.mem_flags
    out_buffer = cl.Buffer(context, mf.WRITE_ONLY, out.nbytes)
    cl.Program(context, source).build().read_fields(
        queue, (1,), None, cl.Buffer(context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=raw), out_buffer)
    cl.enqueue_copy(queue, out, out_buffer)
    half = len(body) // 2
    assert out[:half].tolist() == out[half:].tolist() and not np.any(np.isnan(out))




def test_only_the_accessor_headers_read_packed_lanes():
    # Lanes of Material and Medium are read by name everywhere else (the Emitter and RenderParams
    # records are not covered here).
    # Members only these records have, through any variable; the commoner names (kind, color,
    # emission: other structs have them too) through the names material and medium records go by.
    lanes = re.compile(r"(->|\.)(params|maps|slot\[[^]]*\]|sigma_a|"
                       r"sigma_s|grid|resolution|majorant_resolution)\.[xyzw]|"
                       r"\b(m|md|mat|material|medium)(->|\.)(kind|color|emission)\.[xyzw]")
    root = kernel_dir()
    offenders = []
    for path in sorted(root.rglob("*.h")) + sorted(root.rglob("*.cl")):
        relative = path.relative_to(root).as_posix()
        # (textured_params.h replaces whole members by their textures' values, whatever they hold.)
        if relative in ("materials/material.h", "materials/textured_params.h", "media/medium_record.h"):
            continue
        offenders += [f"{relative}:{n}" for n, line in enumerate(path.read_text().splitlines(), 1)
                      if lanes.search(line) and "scene->params" not in line]
    assert offenders == []


# ----- packed shading normals (layout.pack_normals, scene.h unpack_normal) -----------------------
def test_packed_normals_keep_their_direction():
    rng = np.random.default_rng(7)
    normals = rng.normal(size=(20000, 3))
    normals = np.concatenate([normals, np.eye(3), -np.eye(3), [[1, 1, 0], [0, -1, -1], [-1, 1, -1]]])
    unit = normals / np.linalg.norm(normals, axis=1, keepdims=True)
    unpacked = layout.unpack_normals(layout.pack_normals(normals * rng.uniform(0.1, 10, (len(normals), 1))))
    unpacked = unpacked.astype(np.float64)
    angle = np.arctan2(np.linalg.norm(np.cross(unpacked, unit), axis=1), np.sum(unpacked * unit, axis=1))
    assert angle.max() < 1e-4   # snorm16 on the unfolded octahedron: 6.4e-5 at worst over 200k directions
    assert layout.pack_normals(np.zeros(3)) == 0 and np.allclose(layout.unpack_normals(0), [0, 0, 1])


def test_the_kernel_unpacks_normals_as_the_host_does(context, queue):
    rng = np.random.default_rng(8)
    packed = layout.pack_normals(rng.normal(size=(4096, 3)))
    mf = cl.mem_flags
    source = cl.Buffer(context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=packed)
    out = np.empty((len(packed), 4), np.float32)
    out_buffer = cl.Buffer(context, mf.WRITE_ONLY, out.nbytes)
    cl.Kernel(build_test_kernels(context), "unpack_normals")(queue, (len(packed),), None, source, out_buffer)
    cl.enqueue_copy(queue, out, out_buffer)
    np.testing.assert_allclose(out[:, :3], layout.unpack_normals(packed), atol=2e-7)
