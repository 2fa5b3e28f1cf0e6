"""Set-up in blocks: the shading normals (meshes.NORMALS_BLOCK), the gathered triangles and their
slots (arrays.SLOTS_AT_A_TIME) and the leaves' blocks (triangle_blocks.LEAVES_AT_A_TIME) are
computed a block at a time, so that a large mesh's temporaries are a block's, not copies of the
mesh (issue 24's peak-memory goal; docs/performance.md, "Start-up at scale"). The results do not
depend on the block sizes, and the peaks stay near what is kept."""
import dataclasses
import json
import tracemalloc

import numpy as np

from clrender import arrays, meshes, save_image, triangle_blocks
from clrender.scene import load_scene_dict
from mesh_writers import write_ply_file


def latitude_longitude_mesh(rows, columns):
    """Vertices (V, 3) and faces (F, 3) int64 of a sphere's latitude-longitude grid."""
    theta, phi = np.meshgrid(np.linspace(0.1, 3.0, rows + 1), np.linspace(0, 2 * np.pi, columns, endpoint=False),
                             indexing="ij")
    vertices = np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], -1).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(rows), np.arange(columns), indexing="ij")
    a, b = i * columns + j, i * columns + (j + 1) % columns
    c, d = a + columns, b + columns
    faces = np.concatenate([np.stack([a, c, b], -1).reshape(-1, 3), np.stack([b, c, d], -1).reshape(-1, 3)])
    return vertices, faces.astype(np.int64)


def mixed_scene(folder):
    """Smooth and flat meshes from a file (with texture coordinates and a triangle without area),
    a box, a tessellated and two analytic spheres (one a light), a bitmap texture."""
    vertices, faces = latitude_longitude_mesh(6, 10)
    faces = np.concatenate([faces, [[0, 0, 1]]])   # no area: skipped
    vertex = {name: ("float", vertices[:, k]) for k, name in enumerate("xyz")}
    vertex.update(u=("float", vertices[:, 0] * 0.5 + 0.5), v=("float", vertices[:, 1] * 0.5 + 0.5))
    write_ply_file(folder / "grid.ply", "binary_little_endian", vertex, faces.tolist())
    save_image(np.random.default_rng(3).uniform(0.2, 0.9, (4, 4, 3)).astype(np.float32), folder / "texture.exr")
    description = {
        "camera": {"position": [0, -6, 0], "look_at": [0, 0, 0], "up": [0, 0, 1], "fov": 40, "resolution": [8, 8]},
        "textures": [{"name": "paint", "type": "bitmap", "file": "texture.exr"}],
        "materials": [{"name": "painted", "type": "diffuse", "albedo": {"texture": "paint"}},
                      {"name": "grey", "type": "diffuse", "albedo": [0.5, 0.5, 0.5]},
                      {"name": "lamp", "type": "emissive", "radiance": [2, 2, 2]}],
        "shapes": [{"type": "mesh", "file": "grid.ply", "smooth": True, "material": "painted"},
                   {"type": "mesh", "file": "grid.ply", "material": "grey", "transform": {"translate": [2, 0, 0]}},
                   {"type": "box", "material": "grey", "transform": {"scale": 0.3, "translate": [0, 0, -2]}},
                   {"type": "sphere", "material": "grey", "mesh": True, "subdivisions": 2, "center": [-2, 0, 0]},
                   {"type": "sphere", "material": "lamp", "center": [0, 0, 3], "radius": 0.5},
                   {"type": "sphere", "material": "painted", "center": [0, 2, 0], "radius": 0.5}]}
    (folder / "scene.json").write_text(json.dumps(description))
    return description


def test_the_scene_arrays_do_not_depend_on_the_block_sizes(tmp_path, monkeypatch):
    description = mixed_scene(tmp_path)

    def build(cache):
        monkeypatch.setenv("CLRENDER_CACHE_DIR", str(tmp_path / cache))   # no shapes or BVH from the other build
        scene = load_scene_dict(description, tmp_path)
        return scene, arrays.build_scene_arrays(scene)

    whole_scene, whole = build("whole")
    monkeypatch.setattr(meshes, "NORMALS_BLOCK", 5)
    monkeypatch.setattr(arrays, "SLOTS_AT_A_TIME", 7)
    monkeypatch.setattr(triangle_blocks, "LEAVES_AT_A_TIME", 3)
    blocked_scene, blocked = build("blocked")
    assert whole.uvs.shape[0] > 3 and whole.sphere_count == 2 and whole.degenerate_triangles == 2   # once per mesh of the file
    for name in (f.name for f in dataclasses.fields(whole)):
        a, b = getattr(whole, name), getattr(blocked, name)
        if isinstance(a, np.ndarray):
            assert a.dtype == b.dtype and np.array_equal(a.view(np.uint8), b.view(np.uint8)), name
    for shape_a, shape_b in zip(whole_scene.shapes, blocked_scene.shapes):
        normals_a, normals_b = getattr(shape_a.mesh, "normals", None), getattr(shape_b.mesh, "normals", None)
        assert (normals_a is None) == (normals_b is None)
        assert normals_a is None or np.array_equal(normals_a, normals_b)


def test_vertex_normals_hold_little_besides_the_normals():
    # Before they were computed in blocks: 232 bytes a face of temporaries (float64 corners and
    # edges of every face); now the face normals and angles (48) and a block's temporaries.
    vertices, faces = latitude_longitude_mesh(200, 400)   # 160,000 faces: several blocks
    tracemalloc.start()
    try:
        normals = meshes.vertex_normals(vertices, faces)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert (peak - normals.nbytes) / len(faces) < 160


def test_the_scene_arrays_hold_little_besides_themselves(tmp_path, monkeypatch):
    # A 327,680-triangle mesh: the build's peak beyond the arrays it returns was 155 bytes a
    # triangle before the blocks (gathered records copied whole, float64 edges, a second copy of
    # every triangle's info); now the gathered corners, normals and info (88) and a block.
    monkeypatch.setenv("CLRENDER_CACHE_DIR", str(tmp_path))
    scene = load_scene_dict({
        "camera": {"position": [0, -4, 0], "look_at": [0, 0, 0], "up": [0, 0, 1], "fov": 40, "resolution": [8, 8]},
        "materials": [{"name": "grey", "type": "diffuse", "albedo": [0.5, 0.5, 0.5]},
                      {"name": "lamp", "type": "emissive", "radiance": [1, 1, 1]}],
        "shapes": [{"type": "sphere", "material": "grey", "mesh": True, "subdivisions": 7},
                   {"type": "sphere", "material": "lamp", "center": [0, 0, 3], "radius": 0.5}]})
    triangles = len(scene.shapes[0].mesh.faces)
    arrays.build_scene_arrays(scene)   # the BVH built and kept on disk: the next build reads it
    tracemalloc.start()
    try:
        built = arrays.build_scene_arrays(scene)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    kept = sum(a.nbytes for a in (getattr(built, f.name) for f in dataclasses.fields(built)) if isinstance(a, np.ndarray))
    assert (peak - kept) / triangles < 100
    # What is kept is the kernel's: one copy of the geometry, in the leaves' blocks (55 bytes a
    # triangle at these leaves' fill), with the nodes, shading normals and info; a per-slot copy of
    # every triangle besides them made it 150 bytes a triangle.
    assert kept / triangles < 120


def test_every_triangle_is_in_one_lane_of_the_blocks(tmp_path, monkeypatch):
    # The kernel reads a hit triangle's corners from its leaf's block (Hit.block_lane), the only
    # copy: each primitive slot's triangle there (slot_triangles) is its mesh's, at the kernel's
    # scale, and the spheres have the first slots.
    monkeypatch.setenv("CLRENDER_CACHE_DIR", str(tmp_path))
    scene = load_scene_dict(mixed_scene(tmp_path), tmp_path)
    built = arrays.build_scene_arrays(scene)
    v0, e1, e2 = triangle_blocks.slot_triangles(built.blocks, len(built.info))
    objects = built.info["info"][:, 1]
    assert built.sphere_count == 2 and set(objects[:2]) == {4, 5} and not np.any(np.isin(objects[2:], [4, 5]))
    for index, shape in enumerate(scene.shapes[:4]):
        corners = (shape.mesh.vertices[shape.mesh.faces] * built.length_scale).astype(np.float32)
        expected = {tuple(np.concatenate([c[0], c[1] - c[0], c[2] - c[0]])) for c in corners}
        slots = np.flatnonzero(objects == index)
        found = [tuple(row) for row in np.concatenate([v0[slots], e1[slots], e2[slots]], axis=1)]
        assert len(set(found)) == len(found) and set(found) <= expected
        assert len(found) == len(expected) - (1 if index < 2 else 0)   # the file's triangle without area
