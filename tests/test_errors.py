"""Hostile input: every failure a user can cause is a clrender error naming its place, the CLI
exits with the code of its class (docs/errors.md), nothing is silently wrong, no traceback.

Each test reproduces a failure found by probing the renderer as a hostile new user (issue 12).
CLI cases run in-process through `cli.main` where a fresh process adds nothing; signals, start-up,
missing drivers and crashing caches need their own process."""
import importlib.util
import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import clrender
from clrender import cli, grids
from clrender.errors import ArgumentError, DeviceError, FileError, SceneError
from conftest import TEST_DEVICE

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
EXIT_ARGUMENTS, EXIT_SCENE, EXIT_DEVICE, EXIT_FILE = 2, 3, 4, 5


def tiny_scene(**render):
    """The Cornell box at 4 x 4 pixels."""
    with open(os.path.join(REPO, "scenes", "cornell_box.json")) as f:
        data = json.load(f)
    data["camera"]["resolution"] = [4, 4]
    data["render"].update(spp=1, **render)
    return data


def write_scene(tmp_path, data, name="scene.json"):
    path = tmp_path / name
    path.write_text(json.dumps(data))
    return path


def run_cli(*args):
    """(exit code, stderr) of `clrender ARGS` run in this process; a traceback fails the test."""
    import contextlib
    import io

    stderr = io.StringIO()
    with contextlib.redirect_stderr(stderr), contextlib.redirect_stdout(io.StringIO()):
        try:
            code = cli.main([str(a) for a in args])
        except SystemExit as e:   # argparse's own errors
            code = e.code
    return code, stderr.getvalue()


def run_process(*args, env=None, **kwargs):
    return subprocess.run([sys.executable, "-m", "clrender.cli", *map(str, args)], capture_output=True,
                          text=True, cwd=REPO, timeout=300, env={**os.environ, **(env or {})}, **kwargs)


# ---------------------------------------------------------------------------------------------
# Numbers the device cannot hold
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("patch,where", [
    (lambda s: s["render"].update(rr_depth=10**12), "render.rr_depth"),
    (lambda s: s["render"].update(seed=2**32), "render.seed"),
    (lambda s: s["render"].update(spp=2**40), "render.spp"),
    (lambda s: s["camera"].update(fov=int("9" * 400)), "camera.fov"),
    (lambda s: s["camera"].update(position=[0, 1, 10**400]), "camera.position"),
    (lambda s: s["materials"][3].update(radiance=1e39), "materials[3].radiance"),
    (lambda s: s["materials"][0].update(albedo=[0.5, 1e-50, 0.5]), None),   # underflows to 0: fine
    (lambda s: s["shapes"][0]["transform"].update(scale=1e39), "shapes[0].transform.scale"),
    (lambda s: s.update(materials=s["materials"] + [{"name": "g", "type": "dielectric", "ior": 1e39}]),
     "materials[4].ior"),
    (lambda s: s.update(media=[{"name": "m", "sigma_t": 1e39, "albedo": 0.5}], medium="m"), "media[0].sigma_t"),
    (lambda s: s.update(media=[{"name": "m", "sigma_t": 1e38, "albedo": 0.5, "scale": 1e38}], medium="m"),
     "media[0]"),
    (lambda s: s.update(lights=[{"type": "point", "position": [0, 1, 1], "intensity": [1, 1e300, 1]}]),
     "lights[0].intensity"),
])
def test_numbers_beyond_int32_or_float32_are_scene_errors(patch, where):
    data = tiny_scene()
    patch(data)
    if where is None:
        clrender.load_scene_dict(data)
        return
    with pytest.raises(SceneError) as error:
        clrender.load_scene_dict(data)
    assert str(error.value).startswith(where), error.value
    assert error.value.where.startswith(where)


def test_full_uint32_seed_renders():
    scene = clrender.load_scene_dict(tiny_scene(seed=2**32 - 1))
    assert np.all(np.isfinite(clrender.render(scene, device=TEST_DEVICE, max_depth=2)))


@pytest.mark.parametrize("flag,value", [
    ("--seed", 2**32), ("--seed", -1), ("--max-depth", 99999999999), ("--max-depth", 1000000000),
    ("--spp", 2**31), ("--spp", 0), ("--time", -5), ("--time", 0), ("--time", "nan"), ("--time", "inf"),
    ("--exposure", "1e308"), ("--exposure", "nan"), ("--step", "1e39"), ("--step", "1e-50"),
])
def test_out_of_range_flags_exit_2_before_rendering(tmp_path, flag, value):
    scene = write_scene(tmp_path, tiny_scene())
    out = tmp_path / "out.png"
    code, stderr = run_cli("render", scene, "-o", out, "--quiet", flag, value)
    assert code == EXIT_ARGUMENTS, stderr
    assert flag in stderr and "Traceback" not in stderr
    assert not out.exists()


def test_largest_seed_flag_renders(tmp_path):
    scene = write_scene(tmp_path, tiny_scene())
    code, stderr = run_cli("render", scene, "-o", tmp_path / "o.png", "--quiet",
                           "--seed", 2**32 - 1)
    assert code == 0, stderr


@pytest.mark.parametrize("kwargs,where", [
    ({"spp": 0}, "spp"), ({"spp": -1}, "spp"), ({"spp": 1.5}, "spp"), ({"spp": True}, "spp"),
    ({"seed": -1}, "seed"), ({"seed": 2**32}, "seed"), ({"max_depth": 0}, "max_depth"),
    ({"max_depth": 8193}, "max_depth"), ({"volume_method": "fast"}, "volume_method"),
    ({"step": float("nan")}, "step"), ({"step": -1.0}, "step"), ({"device": "no-such-device"}, "device"),
])
def test_api_arguments_are_checked(kwargs, where):
    scene = clrender.load_scene_dict(tiny_scene())
    with pytest.raises(ArgumentError) as error:
        clrender.render(scene, **{"device": TEST_DEVICE, **kwargs})
    assert error.value.where == where and str(error.value).startswith(where)


@pytest.mark.parametrize("kwargs,where", [
    ({"rr_depth": 0}, "rr_depth"), ({"time_limit": 0}, "time_limit"), ({"time_limit": float("nan")}, "time_limit"),
    ({"samples_per_pass": 0}, "samples_per_pass"),
])
def test_renderer_arguments_are_checked(kwargs, where):
    renderer = clrender.Renderer(clrender.load_scene_dict(tiny_scene()), TEST_DEVICE)
    with pytest.raises(ArgumentError) as error:
        renderer.render(**kwargs)
    assert error.value.where == where


@pytest.mark.parametrize("kwargs,where", [
    ({"aovs": ("albedo", "shadow")}, "aovs"), ({"aovs": 3}, "aovs"),
])
def test_aov_arguments_are_checked(kwargs, where):
    renderer = clrender.Renderer(clrender.load_scene_dict(tiny_scene()), TEST_DEVICE)
    with pytest.raises(ArgumentError) as error:
        renderer.render(**kwargs)
    assert error.value.where == where


def test_accumulate_keeps_the_limits_of_a_render():
    """Renderer.accumulate (distributed rendering's step) is bounded as render is: per-pixel
    counts stay within 2^24 across resumed chunks, and the tile lies in the image."""
    renderer = clrender.Renderer(clrender.load_scene_dict(tiny_scene()), TEST_DEVICE)
    whole = clrender.Accumulation.start((0, 0, 4, 4))
    done = renderer.accumulate(whole, 2)
    for state, samples, where in ((whole, 0, "samples"), (whole, 2**24 + 1, "samples"), (done, 2**24 - 1, "samples"),
                                  (clrender.Accumulation.start((2, 2, 4, 4)), 1, "state.tile"),
                                  ("sums", 1, "state")):
        with pytest.raises(ArgumentError) as error:
            renderer.accumulate(state, samples)
        assert error.value.where == where
    with pytest.raises(ArgumentError, match="^max_depth"):
        renderer.accumulate(done, 1, max_depth=10**9)
    assert renderer.accumulate(done, 2**24 - 2, time_limit=1e-9).samples == 3   # at the limit: allowed


def test_render_accepts_a_dict_or_a_path_and_rejects_other_things(tmp_path):
    data = tiny_scene()
    from_dict = clrender.render(data, spp=1, device=TEST_DEVICE)
    from_path = clrender.render(write_scene(tmp_path, data), spp=1, device=TEST_DEVICE)
    assert np.array_equal(from_dict, from_path)
    with pytest.raises(ArgumentError, match="scene"):
        clrender.render(42, device=TEST_DEVICE)
    with pytest.raises(SceneError):
        clrender.render({"camera": {}}, device=TEST_DEVICE)


def test_progress_is_a_bar_nothing_or_a_callable(capfd):
    data = tiny_scene()
    quiet = clrender.render(data, spp=2, device=TEST_DEVICE, progress=False)
    assert capfd.readouterr().err == ""
    shown = clrender.render(data, spp=2, device=TEST_DEVICE, progress=True)   # the command line's bar
    assert re.search(r"2/2 .*M samples/s", capfd.readouterr().err) and np.array_equal(quiet, shown)
    calls = []
    clrender.Renderer(data, TEST_DEVICE).render(spp=2, progress=lambda *args: calls.append(args))
    assert calls[-1][:2] == (2, 2)
    with pytest.raises(ArgumentError, match="^progress: must be True, False, None or a callable, got 'yes'"):
        clrender.render(data, spp=2, device=TEST_DEVICE, progress="yes")


def test_a_render_result_prints_as_a_summary():
    result = clrender.Renderer(tiny_scene(), TEST_DEVICE).render(spp=2, aovs=("albedo", "depth"))
    assert re.fullmatch(r"RenderResult\(4 x 4, 2 spp, \S+ s, \S+ M samples/s, aovs: albedo, depth\)", repr(result))


# ---------------------------------------------------------------------------------------------
# Scene files
# ---------------------------------------------------------------------------------------------
def test_a_directory_is_not_a_scene(tmp_path):
    with pytest.raises(SceneError, match="is a directory"):
        clrender.load_scene(tmp_path)
    code, stderr = run_cli("info", tmp_path)
    assert code == EXIT_SCENE and str(tmp_path) in stderr


@pytest.mark.parametrize("encoding,message", [("utf-16", "UTF-16"), ("latin-1", "not UTF-8")])
def test_scene_files_in_other_encodings_are_named(tmp_path, encoding, message):
    data = tiny_scene()
    data["materials"][0]["name"] = "wei\u00df"
    path = tmp_path / "scene.json"
    path.write_bytes(json.dumps(data, ensure_ascii=False).encode(encoding))
    with pytest.raises(SceneError) as error:
        clrender.load_scene(path)
    assert str(path) in str(error.value) and message in str(error.value)


def test_a_utf8_byte_order_mark_is_accepted(tmp_path):
    path = tmp_path / "scene.json"
    path.write_bytes(b"\xef\xbb\xbf" + json.dumps(tiny_scene()).encode())
    assert clrender.load_scene(path).camera.resolution == (4, 4)


def test_deeply_nested_json_is_an_error_with_the_file_name(tmp_path):
    path = tmp_path / "deep.json"
    path.write_text('{"camera": ' + "[" * 100000 + "]" * 100000 + "}")
    with pytest.raises(SceneError) as error:
        clrender.load_scene(path)
    assert str(path) in str(error.value) and "nested" in str(error.value)


def test_duplicate_keys_are_errors_naming_the_key(tmp_path):
    text = json.dumps(tiny_scene())
    duplicated = text.replace('"camera": {', '"camera": {"fov": 10, "fov": 20, ', 1)
    path = tmp_path / "dup.json"
    path.write_text(duplicated)
    with pytest.raises(SceneError) as error:
        clrender.load_scene(path)
    assert error.value.where == "camera.fov" and "duplicate key" in str(error.value)
    path.write_text(text[:-1] + ', "camera": {"position": [0, 0, 1], "look_at": [0, 0, 0]}}')
    with pytest.raises(SceneError) as error:
        clrender.load_scene(path)
    assert error.value.where == "camera"


def test_obj_vertices_must_be_finite(tmp_path):
    (tmp_path / "nan.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 nan 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\n")
    data = tiny_scene()
    data["shapes"].append({"type": "mesh", "file": "nan.obj", "material": "white"})
    with pytest.raises(SceneError) as error:
        clrender.load_scene_dict(data, base_dir=tmp_path)
    assert error.value.where == f"shapes[{len(data['shapes']) - 1}].file"
    assert "vertex 3" in str(error.value) and "finite" in str(error.value)


def test_obj_faces_must_reference_existing_vertices(tmp_path):
    (tmp_path / "far.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 9\n")
    data = tiny_scene()
    data["shapes"] = [{"type": "mesh", "file": "far.obj", "material": "white"}]
    with pytest.raises(SceneError, match=r"shapes\[0\].file"):
        clrender.load_scene_dict(data, base_dir=tmp_path)


def test_smooth_meshes_need_no_scipy_and_match_trimesh_normals():
    """trimesh computes vertex normals with scipy's sparse matrices and prints a traceback when
    scipy is missing; clrender computes them itself."""
    code = ("import sys; sys.modules['scipy'] = None\n"
            "import clrender\n"
            "scene = clrender.load_scene('scenes/toon_character.json')\n"
            "print(sum(s.mesh.normals is not None for s in scene.shapes))\n")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=REPO, timeout=120)
    assert result.returncode == 0 and result.stderr == "", result.stderr
    assert int(result.stdout) >= 1

    import trimesh

    from clrender.meshes import vertex_normals
    mesh = trimesh.load(os.path.join(REPO, "scenes", "toon_character.obj"), force="mesh", process=False)
    ours = vertex_normals(np.asarray(mesh.vertices), np.asarray(mesh.faces))
    np.testing.assert_allclose(ours, mesh.vertex_normals, atol=1e-9)


def test_procedural_grids_are_sized_before_allocation(monkeypatch):
    def allocate(*args, **kwargs):
        raise AssertionError("the generator ran")

    monkeypatch.setattr(grids, "PROCEDURAL", {name: (allocate, options)
                                              for name, (_, options) in grids.PROCEDURAL.items()})
    for name in ("noise_cloud", "constant"):
        data = tiny_scene()
        data["media"] = [{"name": "c", "type": "grid", "sigma_t": 1, "albedo": 0.5,
                          "density": {"procedural": name, "resolution": [1024, 1024, 1024]}}]
        data["medium"] = "c"
        with pytest.raises(SceneError) as error:
            clrender.load_scene_dict(data)
        assert error.value.where == "media[0].density.resolution" and "voxels" in str(error.value)


def test_images_too_large_for_the_device_are_refused_before_allocation(device):
    data = tiny_scene()
    data["camera"]["resolution"] = [16384, 16384]
    scene = clrender.load_scene_dict(data)
    limit = device.max_mem_alloc_size
    if 16384 * 16384 * 16 <= limit:
        pytest.skip(f"the device allocates {limit} bytes at once")
    with pytest.raises(SceneError) as error:
        clrender.Renderer(scene, device)
    assert error.value.where == "camera.resolution"


# ---------------------------------------------------------------------------------------------
# Scale: degeneracy is judged relative to the scene's own size
# ---------------------------------------------------------------------------------------------
def scaled_cornell(factor):
    data = tiny_scene()
    data["camera"]["resolution"] = [8, 8]
    for key in ("position", "look_at"):
        data["camera"][key] = [x * factor for x in data["camera"][key]]
    for shape in data["shapes"]:
        transform = shape.setdefault("transform", {})
        transform["scale"] = np.multiply(transform.get("scale", 1), factor).tolist()
        transform["translate"] = [x * factor for x in transform.get("translate", [0, 0, 0])]
    return data


@pytest.mark.parametrize("factor", [2.0**-66, 2.0**-33, 2.0**33, 2.0**66])
def test_a_scene_scaled_by_a_power_of_two_renders_the_identical_image(factor):
    """The kernel's float32 arithmetic would overflow or underflow (black images at 1e12, NaN
    at 1e-12); it sees every scene at an ordinary size instead, scaled by a power of two, which
    is exact. Depths come back in the scene's units."""
    reference = clrender.Renderer(scaled_cornell(1.0), TEST_DEVICE).render(spp=4, seed=3, aovs=clrender.AOV_NAMES)
    scaled = clrender.Renderer(scaled_cornell(factor), TEST_DEVICE).render(spp=4, seed=3, aovs=clrender.AOV_NAMES)
    assert np.array_equal(scaled.image, reference.image) and scaled.discarded_samples == 0
    assert np.array_equal(scaled.aux["depth"], reference.aux["depth"] * factor)
    for name in clrender.AOV_NAMES:   # the depth AOV in scene units too; the others do not scale
        assert np.array_equal(scaled.aovs[name], reference.aovs[name] * (factor if name == "depth" else 1)), name


def scaled_media(factor, kind, method):
    """The Cornell box inside a medium (homogeneous fog or a procedural grid), everything scaled
    by `factor`: lengths times it, extinction coefficients (per unit length) divided by it."""
    data = scaled_cornell(factor)
    if kind == "fog":
        medium = {"name": "m", "sigma_t": 0.4 / factor, "albedo": 0.7}
    else:
        medium = {"name": "m", "type": "grid", "sigma_t": 3 / factor, "albedo": 0.9,
                  "density": {"procedural": "sphere_falloff", "resolution": [8, 8, 8]},
                  "transform": {"scale": factor, "translate": [-0.5 * factor, 0.5 * factor, -0.5 * factor]}}
    data.update(media=[medium], medium="m")
    data["render"].update(volume_method=method, step=1.5)   # voxels: independent of the scale
    return data


@pytest.mark.parametrize("factor", [2.0**-33, 2.0**33])
@pytest.mark.parametrize("kind,method", [("fog", "null"), ("grid", "null"), ("grid", "raymarch")])
def test_media_scaled_by_a_power_of_two_render_the_identical_image(factor, kind, method):
    """Media coefficients and grid transforms follow the kernel's scale."""
    reference = clrender.Renderer(scaled_media(1.0, kind, method), TEST_DEVICE).render(spp=2, seed=5)
    scaled = clrender.Renderer(scaled_media(factor, kind, method), TEST_DEVICE).render(spp=2, seed=5)
    assert reference.image.mean() > 0.01
    assert np.array_equal(scaled.image, reference.image) and scaled.discarded_samples == 0


@pytest.mark.parametrize("factor", [1e-20, 1e20])
def test_a_scene_scaled_by_any_factor_renders_as_the_original(factor):
    """Only the rounding of the scaled coordinates (float64 to float32, one ulp of a vertex)
    differs. A path bouncing near the box's corners, where distances are small, magnifies that
    rounding several hundred times: over seeds 1-60 a pixel of these 4-spp images differed by
    up to 5.4e-5 of its value, so 1e-4; a scale bug (lengths in absolute units, underflow)
    changes pixels by far more, or makes them black or NaN."""
    reference = clrender.render(scaled_cornell(1.0), spp=4, seed=3, device=TEST_DEVICE)
    scaled = clrender.render(scaled_cornell(factor), spp=4, seed=3, device=TEST_DEVICE)
    np.testing.assert_allclose(scaled, reference, rtol=1e-4, atol=1e-6)


def test_transforms_are_singular_relative_to_their_own_scale():
    data = tiny_scene()
    data["shapes"][0]["transform"]["scale"] = [1e-10, 1e-10, 1e-10]
    clrender.load_scene_dict(data)                                  # tiny but invertible
    data["shapes"][0]["transform"]["scale"] = [1e10, 1e10, 1e-10]
    with pytest.raises(SceneError, match="singular") as error:      # flattened by 1e-20
        clrender.load_scene_dict(data)
    assert error.value.where == "shapes[0].transform"


@pytest.mark.parametrize("tessellated", [False, True])
def test_a_shape_with_no_area_left_at_the_scenes_scale_is_an_error(tessellated):
    # An analytic sphere whose radius has no square in float32, or an icosphere none of whose
    # triangles has an area.
    data = tiny_scene()
    data["shapes"].append({"type": "sphere", "material": "white", "radius": 1e-30, "mesh": tessellated})
    with pytest.raises(SceneError) as error:
        clrender.Renderer(clrender.load_scene_dict(data), TEST_DEVICE)
    assert error.value.where == f"shapes[{len(data['shapes']) - 1}]" and "degenerate" in str(error.value)


@pytest.mark.parametrize("obj", [
    "v 0 0 0\nv 0 1 0\nv 0 2 0\nv 0 3 0\nf 1 2 3\nf 2 3 4\n",   # a line, as 20 of Bitterli's staircase's
    "v 1 1 1\nv 1 1 1\nv 1 1 1\nf 1 2 3\n",                      # a point
])
def test_a_mesh_without_area_of_its_own_is_skipped_with_a_warning(tmp_path, obj):
    # Mitsuba loads such a mesh and never hits it: clrender skips it, and says so (the CLI's
    # info and render print the warning). A shape with area that loses it at the scene's
    # scale stays an error (above).
    (tmp_path / "line.obj").write_text(obj)
    data = tiny_scene()
    data["shapes"].append({"type": "mesh", "file": "line.obj", "material": "white", "name": "wire"})
    index = len(data["shapes"]) - 1
    with pytest.warns(clrender.arrays.SkippedShapeWarning,
                      match=rf"shapes\[{index}\]: no triangle of 'wire' has an area .*: skipped"):
        image = clrender.render(clrender.load_scene_dict(data, base_dir=tmp_path), device=TEST_DEVICE)
    del data["shapes"][index]
    assert np.array_equal(image, clrender.render(data, device=TEST_DEVICE))
    code, stderr = run_cli("info", write_scene(tmp_path, dict(data, shapes=data["shapes"] + [
        {"type": "mesh", "file": str(tmp_path / "line.obj"), "material": "white", "name": "wire"}])))
    assert code == 0 and f"clrender: warning: shapes[{index}]: no triangle of 'wire' has an area" in stderr


# ---------------------------------------------------------------------------------------------
# Output paths: checked before rendering
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("make_output,code,message", [
    (lambda tmp: tmp / "adir.png", EXIT_FILE, "is a directory"),
    (lambda tmp: tmp / "afile" / "out.png", EXIT_FILE, "not a directory"),
    (lambda tmp: "/proc/clrender-out.png", EXIT_FILE, "cannot write"),
    (lambda tmp: tmp / "out.gif", EXIT_ARGUMENTS, "unsupported"),
    (lambda tmp: tmp / "out", EXIT_ARGUMENTS, "no image format suffix"),
])
def test_output_path_problems_are_found_before_rendering(tmp_path, monkeypatch, make_output, code, message):
    (tmp_path / "adir.png").mkdir()
    (tmp_path / "afile").write_text("")
    scene = write_scene(tmp_path, tiny_scene())
    monkeypatch.setattr(clrender.Renderer, "__init__", lambda *a, **k: pytest.fail("rendering started"))
    result, stderr = run_cli("render", scene, "-o", make_output(tmp_path), "--quiet")
    assert result == code and message in stderr, stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["adir.png", "afile", "scene.json"]


@pytest.mark.parametrize("output,extra,message", [
    ("{stem}.png", (), "b.png: it is a directory"),                 # the second scene's output
    ("{stem}.png", ("--aov", "albedo"), "a.albedo.png: it is a directory"),   # a side file of an AOV
    ("out.png", (), "2 scenes need a folder"),
    ("{stem}{0}.png", (), "bad pattern"),
    ("{stem.upper}.png", (), "bad pattern"),
    ("same.png", ("--workers", "2"), "2 scenes need a folder"),
])
def test_every_output_of_a_batch_is_checked_before_rendering(tmp_path, monkeypatch, output, extra, message):
    (tmp_path / "b.png").mkdir()
    (tmp_path / "a.albedo.png").mkdir()
    scenes = [write_scene(tmp_path, tiny_scene(), name) for name in ("a.json", "b.json")]
    monkeypatch.setattr(clrender.Renderer, "__init__", lambda *a, **k: pytest.fail("rendering started"))
    code, stderr = run_cli("render", *scenes, "-o", tmp_path / output, "--quiet", *extra)
    assert code in (EXIT_ARGUMENTS, EXIT_FILE) and message in stderr, stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.albedo.png", "a.json", "b.json", "b.png"]


@pytest.mark.parametrize("scene,args,message", [
    ("json", ("-D", "spp=2"), "-D: parameters apply to Mitsuba XML scenes only"),
    ("xml", ("-D", "spp=2", "-D", "spp=3"), "-D: spp given twice"),
    ("xml", ("-D", "1x=2"), "'1x' is not a parameter name"),
    ("json", ("--tiles", "2"), "--tiles: only with --workers or --scheduler"),
    ("json", ("--workers", "2", "--aov", "shadow"), "--aov: unknown AOV 'shadow'"),
    ("json", ("--workers", "2", "--time", "1"), "--time: is not supported with --workers"),
    ("json", ("--scheduler", "tcp://localhost:1", "--time", "1"), "--time: is not supported with --scheduler"),
    ("json", ("--workers", "0"), "--workers: must be >= 1"),
    ("json", ("--chunk-seconds", "inf"), "--chunk-seconds: must be finite"),
    pytest.param("json", ("--scheduler", "nowhere"), "scheduler: missing port number",
                 marks=pytest.mark.skipif(importlib.util.find_spec("distributed") is None,
                                          reason="Dask parses the address (without it: the next test)")),
    ("json", ("--aov", "albedo,shadow"), "--aov: unknown AOV 'shadow'"),
    ("json", ("--denoise-keep-emission",), "--denoise-keep-emission: only with --denoise"),
])
def test_flags_of_batches_clusters_aovs_and_xml_are_checked_before_rendering(tmp_path, monkeypatch, scene, args,
                                                                             message):
    path = write_scene(tmp_path, tiny_scene()) if scene == "json" else os.path.join(REPO, "scenes", "cornell_box.xml")
    monkeypatch.setattr(clrender.Renderer, "__init__", lambda *a, **k: pytest.fail("rendering started"))
    code, stderr = run_cli("render", path, "-o", tmp_path / "o.png", "--quiet", *args)
    assert code == EXIT_ARGUMENTS and message in stderr, stderr
    assert not (tmp_path / "o.png").exists()


@pytest.mark.parametrize("module,flag,message", [
    ("pyoidn", "--denoise", "--denoise: denoising needs Intel Open Image Denoise: pip install 'clrender[denoise]'"),
    ("distributed", "--workers", "--workers: distributed rendering needs Dask: pip install 'clrender[distributed]'"),
])
def test_a_missing_optional_extra_is_an_argument_error_before_rendering(tmp_path, monkeypatch, module, flag,
                                                                         message):
    monkeypatch.setitem(sys.modules, module, None)   # `import module` now raises ImportError
    monkeypatch.setattr(clrender.Renderer, "__init__", lambda *a, **k: pytest.fail("rendering started"))
    extra = ("2",) if flag == "--workers" else ()
    code, stderr = run_cli("render", write_scene(tmp_path, tiny_scene()), "-o", tmp_path / "o.png", flag, *extra)
    assert code == EXIT_ARGUMENTS and message in stderr, stderr
    assert issubclass(clrender.DenoiserUnavailable, clrender.MissingDependency)
    assert issubclass(clrender.MissingDependency, clrender.ArgumentError)


@pytest.mark.parametrize("args,message", [
    (("info",), "scene: info needs a scene (or --kernel"),
    (("info", "SCENE", "--no-launch"), "--no-launch: only with --kernel"),
    (("info", "SCENE", "--device", "cpu"), "--device: only with --kernel"),
    (("info", "--kernel", "--resolution", "0", "8"), "argument --resolution: must be >= 1, got 0"),
    (("info", "--kernel", "--resolution", "8", "x"), "must be an integer, got 'x'"),
    (("info", "SCENE", "--kernel", "--resolution", "8", "8"), "--resolution: only without a scene"),
    (("info", "--kernel", "--device", "no-such-device"), "device: no OpenCL device matches 'no-such-device'"),
])
def test_info_flags_are_checked_before_any_kernel_runs(tmp_path, monkeypatch, args, message):
    scene = write_scene(tmp_path, tiny_scene())
    monkeypatch.setattr(clrender.Renderer, "__init__", lambda *a, **k: pytest.fail("a kernel ran"))
    code, stderr = run_cli(*[scene if a == "SCENE" else a for a in args])
    assert code == EXIT_ARGUMENTS and message in stderr, stderr


def test_info_kernel_resolution_must_fit_the_device(device, monkeypatch):
    from clrender import limits

    try:
        limits.check_image_fits((limits.MAX_RESOLUTION,) * 2, device)
        pytest.skip(f"{device.name} holds the largest image")
    except SceneError:
        pass
    monkeypatch.setattr(clrender.Renderer, "__init__", lambda *a, **k: pytest.fail("a kernel ran"))
    code, stderr = run_cli("info", "--kernel", "--resolution", limits.MAX_RESOLUTION, limits.MAX_RESOLUTION)
    assert code == EXIT_ARGUMENTS and "--resolution: 16384 x 16384 pixels need" in stderr, stderr


def test_a_device_from_the_environment_is_named_as_such(monkeypatch):
    monkeypatch.setenv("CLRENDER_DEVICE", "no-such-device")
    with pytest.raises(ArgumentError) as error:
        clrender.choose_device()
    assert error.value.where == "CLRENDER_DEVICE"
    code, stderr = run_cli("devices")
    assert code == EXIT_ARGUMENTS and "CLRENDER_DEVICE: no OpenCL device matches" in stderr, stderr


def test_missing_output_folders_are_made(tmp_path):
    scene = write_scene(tmp_path, tiny_scene())
    out = tmp_path / "new" / "deeper" / "out.exr"
    assert run_cli("render", scene, "-o", out, "--quiet")[0] == 0
    assert clrender.load_image(out).shape == (4, 4, 3)


def test_save_image_errors_are_file_errors(tmp_path):
    (tmp_path / "adir.exr").mkdir()
    with pytest.raises(FileError, match="is a directory"):
        clrender.save_image(np.zeros((2, 2, 3)), tmp_path / "adir.exr")
    with pytest.raises(ArgumentError, match="exposure"):
        clrender.save_image(np.zeros((2, 2, 3)), tmp_path / "a.png", exposure=1e308)
    with pytest.raises(FileError, match="not found"):
        clrender.load_image(tmp_path / "missing.exr")


# ---------------------------------------------------------------------------------------------
# Devices and the kernel cache
# ---------------------------------------------------------------------------------------------
def test_no_opencl_driver_gives_the_friendly_message(tmp_path):
    env = {"OCL_ICD_VENDORS": str(tmp_path), "OCL_ICD_FILENAMES": ""}
    for args in (("devices",), ("render", "scenes/cornell_box.json", "-o", tmp_path / "o.png")):
        result = run_process(*args, env=env)
        assert result.returncode == EXIT_DEVICE, result.stderr
        assert "no OpenCL" in result.stderr and "Traceback" not in result.stderr


CACHED_BUILD = """
import warnings, pyopencl as cl, clrender
from clrender.device import build_program
from clrender.features import FEATURE_VALUES
warnings.simplefilter("always")
context = cl.Context([clrender.choose_device()])
program = build_program(context, {name: values[0] for name, values in FEATURE_VALUES.items()}, entry="tests.cl")
print(len(program.get_info(cl.program_info.KERNEL_NAMES)) > 0)
"""


@pytest.mark.parametrize("damage", ["truncate", "flip", "empty"])
def test_damaged_kernel_cache_entries_are_rebuilt_with_a_warning(tmp_path, damage):
    env = {**os.environ, "CLRENDER_CACHE_DIR": str(tmp_path)}

    def build():
        return subprocess.run([sys.executable, "-c", CACHED_BUILD], capture_output=True, text=True,
                              cwd=REPO, env=env, timeout=300)

    first = build()
    assert first.returncode == 0 and first.stdout.strip() == "True", first.stderr
    (entry,) = [p for p in tmp_path.iterdir() if not p.name.startswith(".")]
    data = entry.read_bytes()
    if damage == "truncate":
        entry.write_bytes(data[: len(data) // 2])
    elif damage == "flip":
        entry.write_bytes(data[:-100] + bytes([data[-100] ^ 0xFF]) + data[-99:])
    else:
        entry.write_bytes(b"")
    second = build()
    assert second.returncode == 0 and second.stdout.strip() == "True", second.stderr
    assert "kernel cache" in second.stderr and "rebuil" in second.stderr
    assert entry.read_bytes() == data       # the entry was rewritten whole
    third = build()
    assert third.returncode == 0 and "kernel cache" not in third.stderr


# ---------------------------------------------------------------------------------------------
# Exit codes, signals and start-up
# ---------------------------------------------------------------------------------------------
def test_each_error_class_has_its_exit_code(tmp_path):
    scene = write_scene(tmp_path, tiny_scene())
    bad = write_scene(tmp_path, {"camera": {}}, "bad.json")
    assert run_cli("render", bad, "-o", tmp_path / "o.png")[0] == EXIT_SCENE
    assert run_cli("render", scene, "-o", tmp_path / "o.png", "--device", "no-such-device")[0] == EXIT_ARGUMENTS
    assert run_cli("render", scene, "-o", tmp_path / "o.png", "--spp", "x")[0] == EXIT_ARGUMENTS
    assert run_cli("info", tmp_path / "missing.json")[0] == EXIT_SCENE
    for error, code in ((ArgumentError("x", "y"), 2), (SceneError("x", "y"), 3), (DeviceError("x"), 4),
                        (FileError("x"), 5)):
        assert isinstance(error, clrender.ClrenderError) and error.exit_code == code


def start_render(tmp_path, out, *extra):
    process = subprocess.Popen([sys.executable, "-m", "clrender.cli", "render", "scenes/cornell_box.json",
                                "-o", str(out), "--spp", "100000", *extra], cwd=REPO,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 120
    seen = ""
    while "spp" not in seen and time.time() < deadline:  # wait until the progress bar moves
        seen += process.stderr.read(1)
    return process


@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGHUP])
def test_sigterm_and_sighup_save_the_partial_image(tmp_path, signum):
    out = tmp_path / "partial.exr"
    process = start_render(tmp_path, out)
    time.sleep(0.5)
    process.send_signal(signum)
    _, stderr = process.communicate(timeout=120)
    assert process.returncode == 128 + signum, stderr
    assert "partial image saved" in stderr and "Traceback" not in stderr
    image = clrender.load_image(out)
    assert np.all(np.isfinite(image)) and image.mean() > 0.05


def loaded(process, libraries):
    try:
        return any(name in Path(f"/proc/{process.pid}/maps").read_text() for name in libraries)
    except OSError:   # it has exited
        return False


# Libraries whose loading marks a stage: numpy is first loaded inside clrender's main (with
# signals held: numpy turns a Ctrl-C during its import into an ImportError with a traceback, which
# this test caught about once in 40 runs before; Python's own start-up, site and .pth files, loads
# none, and a Ctrl-C there is Python's); the OpenCL drivers are loaded when the platforms are
# listed, after the scene is loaded and before the context, the scene's arrays and the kernel
# build (cold caches: PoCL's too; Intel's runtime builds this scene in well under a second).
STAGES = {"loading": ("_multiarray_umath",), "building": ("libpocl", "libintelocl", "liboclgrind", "libnvidia-opencl")}


@pytest.mark.parametrize("stage", sorted(STAGES))
def test_an_interrupt_during_start_up_exits_cleanly(tmp_path, stage):
    out = tmp_path / "o.png"
    env = {**os.environ, "CLRENDER_CACHE_DIR": str(tmp_path / "cache"), "POCL_CACHE_DIR": str(tmp_path / "pocl")}
    process = subprocess.Popen([sys.executable, "-m", "clrender.cli", "render", "scenes/cornell_box.json",
                                "-o", str(out), "--spp", "1"], cwd=REPO, env=env,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 60
    while not loaded(process, STAGES[stage]) and process.poll() is None and time.time() < deadline:
        time.sleep(0.002)
    process.send_signal(signal.SIGINT)
    _, stderr = process.communicate(timeout=120)
    assert "Traceback" not in stderr, stderr
    assert process.returncode == 130 and "interrupted" in stderr, stderr
    assert not out.exists()
