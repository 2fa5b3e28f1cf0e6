"""Scene loading: valid scenes load, invalid ones fail with errors naming the place."""
import json
import threading

import numpy as np
import pytest

import clrender
from clrender.arrays import active_environment, build_scene_arrays
from clrender.features import scene_features
from conftest import camera


def base_scene(**overrides):
    scene = {
        "camera": camera(),
        "materials": [{"name": "white", "type": "diffuse", "albedo": [0.5, 0.5, 0.5]},
                      {"name": "lamp", "type": "emissive", "radiance": 4.0}],
        "shapes": [{"type": "box", "material": "white"},
                   {"type": "rectangle", "material": "lamp",
                    "transform": {"translate": [0, 3, 0], "rotate": [90, 0, 0]}}],
    }
    scene.update(overrides)
    return scene


def error_of(data, tmp_path=None):
    with pytest.raises(clrender.SceneError) as error:
        clrender.load_scene_dict(data, base_dir=tmp_path or ".")
    return str(error.value)


def test_example_scenes_load():
    scene = clrender.load_scene("scenes/cornell_box.json")
    assert scene.camera.resolution == (256, 256)
    assert [m.name for m in scene.materials] == ["white", "red", "green", "light"]
    arrays = build_scene_arrays(scene)
    assert len(arrays.info) == 36 and arrays.sphere_count == 0 and len(arrays.emitters) == 2


@pytest.mark.parametrize("patch,where,message", [
    (lambda s: s["materials"][0].update(type="velvet"), "materials[0].type", "valid: diffuse, emissive"),
    (lambda s: s["materials"][0].update(albedo=[0.5, -1, 0.5]), "materials[0].albedo", "non-negative"),
    (lambda s: s["materials"][0].update(albedo=[0.5, 0.5]), "materials[0].albedo", "list of 3 numbers"),
    (lambda s: s["materials"][0].update(albedo=[2, 0, 0]), "materials[0].albedo", "<= 1"),
    (lambda s: s["materials"][1].update(name="white"), "materials[1].name", "duplicate"),
    (lambda s: s["materials"][0].update(colour=[1, 1, 1]), "materials[0].colour", "unknown field"),
    (lambda s: s["shapes"][1].update(material="wite"), "shapes[1].material", "unknown material 'wite'"),
    (lambda s: s["shapes"][0].update(type="cone"), "shapes[0].type", "valid: mesh, sphere, rectangle, box"),
    (lambda s: s["shapes"].append({"type": "sphere", "material": "white", "radius": 0}),
     "shapes[2].radius", "must be > 0"),
    (lambda s: s["shapes"][0].update(transform={"scale": 0}), "shapes[0].transform", "singular"),
    (lambda s: s["camera"].update(fov=180), "camera.fov", "<= 179"),
    (lambda s: s["camera"].update(resolution=[0, 10]), "camera.resolution", "integers"),
    (lambda s: s["camera"].update(look_at=[0, 0, 5]), "camera.look_at", "must differ"),
    (lambda s: s["camera"].update(filter={"type": "mitchell"}), "camera.filter.type", "valid: box, gaussian, tent"),
    (lambda s: s["camera"].update(filter={"type": "gaussian", "stddev": 5}), "camera.filter.stddev", "<= 4"),
    (lambda s: s["camera"].update(filter={"type": "tent", "radius": 0}), "camera.filter.radius", ">= 0.01"),
    (lambda s: s["camera"].update(filter={"type": "box", "radius": 2}), "camera.filter.radius", "unknown field"),
    (lambda s: s["camera"].update(filter="gaussian"), "camera.filter", "must be an object"),
    (lambda s: s["camera"].update(aperture_radius=-0.1), "camera.aperture_radius", ">= 0"),
    (lambda s: s["camera"].update(focus_distance=0), "camera.focus_distance", "> 0"),
    (lambda s: s.update(render={"spp": -1}), "render.spp", ">= 1"),
    (lambda s: s.update(render={"max_depth": 2.5}), "render.max_depth", "integer"),
    (lambda s: s.update(lights=[{"type": "area"}]), "lights[0].type", "valid: environment, point, spot, directional"),
    (lambda s: s.update(lights=[{"type": "spot", "direction": [0, -1, 0], "intensity": 1}]), "lights[0].position",
     "is required"),
    (lambda s: s.update(lights=[{"type": "spot", "position": [0, 1, 0], "direction": [0, 0, 0], "intensity": 1}]),
     "lights[0].direction", "must be non-zero"),
    (lambda s: s.update(lights=[{"type": "spot", "position": [0, 1, 0], "direction": [0, -1, 0], "intensity": 1,
                                 "cutoff_angle": 200}]), "lights[0].cutoff_angle", "<= 180"),
    (lambda s: s.update(lights=[{"type": "spot", "position": [0, 1, 0], "direction": [0, -1, 0], "intensity": 1,
                                 "beam_width": -5}]), "lights[0].beam_width", ">= 0"),
    (lambda s: s.update(lights=[{"type": "point", "position": [0, 1, 0], "intensity": -2}]),
     "lights[0].intensity", "non-negative"),
    (lambda s: s.update(lights=[{"type": "environment"}, {"type": "environment"}]), "lights", "at most one"),
    (lambda s: s.update(lights=[{"type": "environment", "lookup": "mitsuba"}]), "lights[0].lookup",
     "applies to an environment image"),
    (lambda s: s.update(lights=[{"type": "environment", "image": np.ones((2, 4, 3)), "lookup": "bilinear"}]),
     "lights[0].lookup", "valid: texel, mitsuba"),
    (lambda s: s.update(lights=[{"type": "environment", "image": np.ones((1, 4, 3)), "lookup": "mitsuba"}]),
     "lights[0].image", "at least 2 rows"),
    (lambda s: s.update(lights=[{"type": "environment", "image": np.ones((2, 4, 3)), "transform": {"scale": 2}}]),
     "lights[0].transform", "must be a rotation"),
    (lambda s: s.pop("camera"), "camera", "is required"),
])
def test_invalid_fields_are_reported_with_their_place(patch, where, message):
    data = base_scene()
    patch(data)
    text = error_of(data)
    assert text.startswith(where + ":"), text
    assert message in text, text


def test_the_camera_filter_is_a_box_unless_named_with_mitsubas_defaults():
    def loaded(**fields):
        return clrender.load_scene_dict(base_scene(camera={**camera(), **fields})).camera.filter

    assert loaded().type == "box"
    assert (loaded(filter={"type": "gaussian"}).type, loaded(filter={"type": "gaussian"}).stddev) == ("gaussian", 0.5)
    assert loaded(filter={"type": "gaussian", "stddev": 0.3}).stddev == 0.3
    assert loaded(filter={"type": "tent"}).radius == 1.0


def test_a_camera_is_a_pinhole_unless_given_an_aperture_focused_on_look_at():
    default = clrender.load_scene_dict(base_scene()).camera
    assert default.aperture_radius == 0 and np.isclose(default.focus_distance, 5.0)   # camera() looks from z = 5
    lens = clrender.load_scene_dict(base_scene(camera={**camera(), "aperture_radius": 0.1, "focus_distance": 3})).camera
    assert (lens.aperture_radius, lens.focus_distance) == (0.1, 3.0)


def test_missing_mesh_file_names_the_path_tried(tmp_path):
    data = base_scene(shapes=[{"type": "mesh", "file": "nowhere/bunny.obj", "material": "white"}])
    text = error_of(data, tmp_path)
    assert text.startswith("shapes[0].file: file not found")
    assert str(tmp_path / "nowhere" / "bunny.obj") in text


def test_malformed_mesh_file_is_reported(tmp_path):
    (tmp_path / "bad.obj").write_text("this is not an obj file\n")
    text = error_of(base_scene(shapes=[{"type": "mesh", "file": "bad.obj", "material": "white"}]), tmp_path)
    assert text.startswith("shapes[0].file:")


def test_invalid_json_reports_line_and_column(tmp_path):
    path = tmp_path / "scene.json"
    path.write_text('{\n  "camera": {,\n}')
    with pytest.raises(clrender.SceneError, match=r"line 2 column"):
        clrender.load_scene(path)


def test_mesh_files_load_through_trimesh(tmp_path):
    import trimesh

    trimesh.creation.box(extents=(2, 2, 2)).export(tmp_path / "cube.ply")
    trimesh.creation.icosphere(subdivisions=1).export(tmp_path / "ball.obj")
    trimesh.creation.box().export(tmp_path / "part.stl")
    trimesh.creation.box().export(tmp_path / "part.glb")
    shapes = [{"type": "mesh", "file": name, "material": "white", "transform": {"translate": [3 * i, 0, 0]}}
              for i, name in enumerate(["cube.ply", "ball.obj", "part.stl", "part.glb"])]
    scene = clrender.load_scene_dict(base_scene(shapes=shapes), base_dir=tmp_path)
    assert [len(s.mesh.faces) for s in scene.shapes] == [12, 80, 12, 12]
    lo, hi = scene.bounds()
    assert np.allclose(lo[0], -1) and hi[0] > 9


def test_transform_moves_and_mirrors_keep_normals_outward():
    data = base_scene(shapes=[{"type": "box", "material": "white",
                               "transform": {"scale": [-1, 2, 1], "translate": [5, 0, 0]}}])
    mesh = clrender.load_scene_dict(data).shapes[0].mesh
    corners = mesh.vertices[mesh.faces]
    normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    outward = corners.mean(axis=1) - mesh.vertices.mean(axis=0)
    assert np.all(np.sum(normals * outward, axis=1) > 0)
    assert np.allclose(mesh.vertices.mean(axis=0), [5, 0, 0])


def test_features_follow_what_the_scene_contains():
    cornell_box = clrender.load_scene("scenes/cornell_box.json")
    assert scene_features(cornell_box) == {
        "ENVIRONMENT": 0, "MEDIA": 0, "TOON": 0, "DIELECTRIC": 0, "GRID_MEDIA": 0, "AOVS": 0, "TEXTURES": 0,
        "LANES": 1}
    assert scene_features(cornell_box, sample_aovs=True)["AOVS"] == 1   # asked by the render, not the scene
    with_env = clrender.load_scene_dict(base_scene(lights=[{"type": "environment", "radiance": 1}]))
    assert scene_features(with_env)["ENVIRONMENT"] == 1
    black_env = clrender.load_scene_dict(base_scene(lights=[{"type": "environment", "radiance": 1, "scale": 0}]))
    assert scene_features(black_env)["ENVIRONMENT"] == 0   # no emitter to read
    with_sun = clrender.load_scene_dict(base_scene(lights=[{"type": "directional", "direction": [0, -1, 0],
                                                           "irradiance": 3}]))
    assert scene_features(with_sun) == {"ENVIRONMENT": 0, "MEDIA": 0, "TOON": 0, "DIELECTRIC": 0,
                                         "GRID_MEDIA": 0, "AOVS": 0, "TEXTURES": 0, "LANES": 1}
    glass = [{"name": "glass", "type": "dielectric", "ior": 1.5}]
    unused_glass = clrender.load_scene_dict(base_scene(materials=base_scene()["materials"] + glass))
    assert scene_features(unused_glass)["DIELECTRIC"] == 0
    used_glass = base_scene(materials=base_scene()["materials"] + glass)
    used_glass["shapes"][0]["material"] = "glass"
    assert scene_features(clrender.load_scene_dict(used_glass))["DIELECTRIC"] == 1
    mirror = base_scene(materials=base_scene()["materials"] + [{"name": "m", "type": "conductor"}])
    mirror["shapes"][0]["material"] = "m"
    assert scene_features(clrender.load_scene_dict(mirror))["DIELECTRIC"] == 1
    checks = [{"name": "c", "type": "checkerboard"}]
    unused_texture = base_scene(materials=base_scene()["materials"] + [
        {"name": "t", "type": "diffuse", "albedo": {"texture": "c"}}], textures=checks)
    assert scene_features(clrender.load_scene_dict(unused_texture))["TEXTURES"] == 0
    unused_texture["shapes"][0]["material"] = "t"
    assert scene_features(clrender.load_scene_dict(unused_texture))["TEXTURES"] == 1


def test_degenerate_triangles_are_dropped_and_counted(tmp_path):
    path = tmp_path / "degenerate.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nf 1 2 3\nf 1 2 4\nf 1 1 1\n")
    scene = clrender.load_scene_dict(base_scene(shapes=[{"type": "mesh", "file": "degenerate.obj",
                                                         "material": "white"}]), base_dir=tmp_path)
    arrays = build_scene_arrays(scene)
    assert len(arrays.info) == 1 and arrays.degenerate_triangles == 2


@pytest.mark.parametrize("entry,message", [(float("nan"), "must be finite, got nan"),
                                           (1e39, "is beyond the float32 range"), (10**400, "is too large"),
                                           (True, "must be a 4x4 affine matrix")])
def test_a_transform_matrix_entry_is_checked_where_it_stands(entry, message):
    rows = [[2, 0, 0, 1], [0, 2, 0, 0], [0, 0, 2, entry], [0, 0, 0, 1]]
    text = error_of(base_scene(shapes=[{"type": "box", "material": "white", "transform": {"matrix": rows}}]))
    assert text.startswith("shapes[0].transform.matrix: ") and message in text


def test_a_transform_matrix_of_integers_and_floats_is_read_as_floats():
    rows = [[2, 0, 0, 1], [0, 2.5, 0, 0], [0, 0, 2, -3], [0, 0, 0, 1]]
    scene = clrender.load_scene_dict(base_scene(shapes=[{"type": "box", "material": "white",
                                                         "transform": {"matrix": rows}}]))
    lo, hi = scene.shapes[0].mesh.vertices.min(axis=0), scene.shapes[0].mesh.vertices.max(axis=0)
    assert np.allclose(lo, [-1, -2.5, -5]) and np.allclose(hi, [3, 2.5, -1])


def test_scene_file_round_trip(tmp_path):
    path = tmp_path / "scene.json"
    path.write_text(json.dumps(base_scene()))
    assert clrender.load_scene(path).path == path


@pytest.mark.parametrize("bad,message", [(np.nan, "must be finite in float32"), (np.inf, "must be finite in float32"),
                                         (-np.inf, "must be finite in float32"), (-1.0, "must be non-negative")])
@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_an_environment_image_must_be_finite_and_non_negative(bad, message, dtype):
    # One bad texel among many (float32 images are checked by their min and max).
    image = np.ones((4, 8, 3), dtype)
    image[2, 5, 1] = bad
    text = error_of(base_scene(lights=[{"type": "environment", "image": image}]))
    assert "lights[0].image" in text and message in text


def test_a_black_environment_image_is_no_light():
    scene = clrender.load_scene_dict(base_scene(lights=[{"type": "environment", "image": np.zeros((4, 8, 3), np.float32)}]))
    assert active_environment(scene) is None
    scene.environment.image[3, 7, 2] = 1e-30
    assert active_environment(scene) is scene.environment


def test_texture_and_environment_files_decode_on_the_prefetch_workers(tmp_path, monkeypatch):
    # load_scene_dict starts each image file a scene names on image_prefetch's workers; the
    # readers take those results (the same pixels) instead of decoding the file again.
    from clrender import image

    texels = np.arange(2 * 3 * 3, dtype=np.uint8).reshape(2, 3, 3)
    sky = np.full((4, 8, 3), 0.25, np.float32)
    image.save_image(texels, tmp_path / "texels.png")
    image.save_image(sky, tmp_path / "sky.exr")
    reads = []   # (thread, file) of each decode (load_image decodes through load_texture_image)
    decode = image.load_texture_image
    monkeypatch.setattr(image, "load_texture_image",
                        lambda path, *a, **k: reads.append((threading.current_thread().name, path.name)) or decode(path, *a, **k))
    data = base_scene(textures=[{"name": "t", "type": "bitmap", "file": "texels.png", "raw": True}],
                      lights=[{"type": "environment", "file": "sky.exr"}])
    data["materials"][0]["albedo"] = {"texture": "t"}
    scene = clrender.load_scene_dict(data, base_dir=tmp_path)
    assert sorted(file for _, file in reads) == ["sky.exr", "texels.png"], reads
    assert all(thread.startswith("image-read") for thread, _ in reads), reads
    assert np.array_equal(scene.textures[0].pixels, decode(tmp_path / "texels.png", raw=True).pixels)
    np.testing.assert_allclose(scene.environment.image, sky, rtol=1e-3)
