"""Grid media in the scene format: files (.npy, .npz, Mitsuba .vol), generators, validation
errors that name their place, the volume-method settings, the kernel features, and the CLI."""
import json
import os
import subprocess
import sys

import numpy as np
import pytest

import clrender
from clrender import grids
from clrender.arrays import build_scene_arrays
from clrender.features import all_feature_combinations, scene_features
from conftest import camera

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def grid_scene(density, medium=None, top_level=True, **render):
    medium = {"name": "cloud", "type": "grid", "sigma_t": 2.0, "albedo": 0.9, "density": density, **(medium or {})}
    data = {"camera": camera(resolution=(8, 8)), "media": [medium],
            "materials": [{"name": "boundary", "type": "interface"}],
            "shapes": [], "lights": [{"type": "environment", "radiance": 1.0}]}
    if top_level:
        data["medium"] = "cloud"
    if render:
        data["render"] = render
    return data


def error_of(data, base_dir="."):
    with pytest.raises(clrender.SceneError) as error:
        clrender.load_scene_dict(data, base_dir=base_dir)
    return str(error.value)


def test_npy_npz_and_vol_files_load_the_same_grid(tmp_path):
    density = grids.noise_cloud((12, 10, 8), seed=1)
    np.save(tmp_path / "a.npy", density)
    np.savez(tmp_path / "b.npz", density=density, other=np.zeros(3))
    np.savez(tmp_path / "c.npz", density.astype(np.float64))   # the only array, any real dtype
    grids.write_vol(tmp_path / "d.vol", density, bbox=((0, 0, 0), (2, 2, 2)))
    for name in ("a.npy", "b.npz", "c.npz", "d.vol"):
        scene = clrender.load_scene_dict(grid_scene({"file": name}), base_dir=tmp_path)
        grid = scene.media[0].grid
        assert grid.density.dtype == np.float32 and grid.resolution == (12, 10, 8)
        assert np.array_equal(grid.density, density), name
    # .vol layout: x fastest, then y, z, after a 48-byte header.
    raw = (tmp_path / "d.vol").read_bytes()
    assert raw[:3] == b"VOL" and raw[3] == 3 and len(raw) == 48 + 4 * density.size
    assert np.frombuffer(raw[48:52], "<f4")[0] == density[0, 0, 0]
    assert np.frombuffer(raw[52:56], "<f4")[0] == density[0, 0, 1]


@pytest.mark.parametrize("patch,where,message", [
    (lambda d: d["media"][0]["density"].update(procedural="fluffy"), "media[0].density.procedural", "valid: noise_cloud"),
    (lambda d: d["media"][0]["density"].update(resolution=[0, 4, 4]), "media[0].density.resolution", "1..1024"),
    (lambda d: d["media"][0]["density"].update(resolution=[4, 4]), "media[0].density.resolution", "[nx, ny, nz]"),
    (lambda d: d["media"][0]["density"].update(value=-1.0), "media[0].density.value", ">= 0"),
    (lambda d: d["media"][0]["density"].update(seed=3), "media[0].density.seed", "unknown field"),
    (lambda d: d["media"][0]["density"].update(file="x.npy"), "media[0].density", "either a `file` or a `procedural`"),
    (lambda d: d["media"][0].update(density=5), "media[0].density", "must be an object"),
    (lambda d: d["media"][0].pop("density"), "media[0].density", "is required"),
    (lambda d: d["media"][0].update(type="cloudy"), "media[0].type", "valid: homogeneous, grid"),
    (lambda d: d["media"][0].update(majorant_block=0), "media[0].majorant_block", ">= 1"),
    (lambda d: d["media"][0].update(transform={"scale": [1, 0, 1]}), "media[0].transform", "singular"),
    (lambda d: d["media"][0].update(type="homogeneous"), "media[0].density", "unknown field"),
    (lambda d: d.update(render={"volume_method": "magic"}), "render.volume_method", "valid: null, raymarch"),
    (lambda d: d.update(render={"step": 0}), "render.step", "must be >= 0.001"),
    (lambda d: d.update(render={"raymarch_multiple_scattering": 1}), "render.raymarch_multiple_scattering", "true or false"),
])
def test_invalid_grid_fields_are_reported_with_their_place(patch, where, message):
    data = grid_scene({"procedural": "constant", "resolution": [4, 4, 4]})
    patch(data)
    text = error_of(data)
    assert text.startswith(where + ":"), text
    assert message in text, text


@pytest.mark.parametrize("bad", [np.nan, np.inf, -0.5])
def test_non_finite_or_negative_densities_are_rejected(tmp_path, bad):
    density = np.ones((4, 4, 4), np.float32)
    density[1, 2, 3] = bad
    np.save(tmp_path / "bad.npy", density)
    assert error_of(grid_scene({"file": "bad.npy"}), tmp_path) == "media[0].density: must be finite and non-negative"


def test_malformed_grid_files_are_reported(tmp_path):
    np.save(tmp_path / "flat.npy", np.ones((4, 4)))
    np.savez(tmp_path / "many.npz", a=np.ones((2, 2, 2)), b=np.ones((2, 2, 2)))
    (tmp_path / "junk.vol").write_bytes(b"NOTAVOLFILE" * 10)
    grids.write_vol(tmp_path / "short.vol", np.ones((2, 2, 2)))
    (tmp_path / "short.vol").write_bytes((tmp_path / "short.vol").read_bytes()[:-4])
    cases = {
        "flat.npy": "media[0].density: must be a 3D array",
        "many.npz": "none named 'density'",
        "junk.vol": "not a Mitsuba .vol file",
        "short.vol": "does not match 2 x 2 x 2",
        "missing.npy": "file not found",
        "cloud.txt": "unsupported grid format '.txt'",
    }
    for name, message in cases.items():
        text = error_of(grid_scene({"file": name}), tmp_path)
        assert message in text, text
        assert text.startswith("media[0].density"), text


def test_albedo_grids_load_from_vol_npy_and_npz(tmp_path):
    albedo = np.random.default_rng(2).uniform(0, 1, (3, 4, 5, 3)).astype(np.float32)
    grids.write_vol(tmp_path / "rgb.vol", albedo)
    grids.write_vol(tmp_path / "grey.vol", albedo[..., 0])
    np.save(tmp_path / "rgb.npy", albedo)
    np.savez(tmp_path / "grey.npz", albedo=albedo[..., 0], other=np.ones(2))
    for name, expected in (("rgb.vol", albedo), ("grey.vol", albedo[..., :1]), ("rgb.npy", albedo),
                           ("grey.npz", albedo[..., :1])):
        data = grid_scene({"procedural": "constant", "resolution": [2, 2, 2]}, {"albedo_grid": {"file": name}})
        data["media"][0].pop("albedo")
        medium = clrender.load_scene_dict(data, base_dir=tmp_path).media[0]
        assert np.array_equal(medium.albedo_grid, expected), name
        assert np.allclose(medium.sigma_s, 2.0) and np.all(medium.sigma_a == 0)


def test_invalid_albedo_grids_are_reported(tmp_path):
    grids.write_vol(tmp_path / "bright.vol", np.full((2, 2, 2, 3), 1.5))
    grids.write_vol(tmp_path / "two.vol", np.ones((2, 2, 2, 2)))
    np.save(tmp_path / "flat.npy", np.ones((4, 4)))
    density = {"procedural": "constant", "resolution": [2, 2, 2]}

    def error(medium, pop_albedo=True):
        data = grid_scene(density, medium)
        if pop_albedo:
            data["media"][0].pop("albedo")
        return error_of(data, tmp_path)

    assert error({"albedo_grid": {"file": "bright.vol"}}) == (
        f"media[0].albedo_grid.file: cannot load grid {tmp_path / 'bright.vol'}: albedos must be in [0, 1], the largest is 1.5")
    assert "this .vol has 2 channels, expected 1 or 3" in error({"albedo_grid": {"file": "two.vol"}})
    assert "must be a (z, y, x) or (z, y, x, 3) array" in error({"albedo_grid": {"file": "flat.npy"}})
    assert error({"albedo_grid": {"file": "none.vol"}}).startswith("media[0].albedo_grid.file: file not found")
    assert error({"albedo_grid": {"file": "bright.vol"}}, pop_albedo=False) == (
        "media[0].albedo_grid: replaces `albedo`: give `sigma_t` only (the albedo grid splits it)")
    homogeneous = {"name": "fog", "sigma_t": 1.0, "albedo_grid": {"file": "bright.vol"}}
    assert error_of({"camera": camera(), "media": [homogeneous]}, tmp_path) == (
        "media[0].albedo_grid: only a grid medium takes an albedo grid")


def test_a_grid_medium_must_be_placed_where_it_can_be_seen():
    data = grid_scene({"procedural": "constant", "resolution": [2, 2, 2]}, top_level=False)
    assert "used nowhere" in error_of(data) and error_of(data).startswith("media[0]:")
    # As the interior of a box far from the grid's unit cube: it could never be seen.
    data["shapes"] = [{"type": "box", "material": "boundary", "interior": "cloud",
                       "transform": {"translate": [10, 0, 0]}}]
    assert "lies outside every shape" in error_of(data)
    data["shapes"][0]["transform"] = {"scale": 0.5, "translate": [0.5, 0.5, 0.5]}   # overlapping: fine
    assert clrender.load_scene_dict(data).media[0].type == "grid"


def test_features_follow_the_volume_method_and_combinations_stay_valid():
    scene = clrender.load_scene_dict(grid_scene({"procedural": "constant", "resolution": [2, 2, 2]}))
    assert scene_features(scene)["GRID_MEDIA"] == 1 and scene_features(scene)["MEDIA"] == 1
    assert scene_features(scene, "raymarch")["GRID_MEDIA"] == 2
    marched = clrender.load_scene_dict(grid_scene({"procedural": "constant", "resolution": [2, 2, 2]},
                                                  volume_method="raymarch", step=0.1))
    assert scene_features(marched)["GRID_MEDIA"] == 2 and scene_features(marched, "null")["GRID_MEDIA"] == 1
    assert scene_features(clrender.load_scene("scenes/smoke_cornell_box.json"))["GRID_MEDIA"] == 0
    with pytest.raises(ValueError, match="unknown volume method"):
        scene_features(scene, "magic")
    for step in (0.0, -1.0, 1e-4, float("nan")):
        with pytest.raises(clrender.ArgumentError, match="^step: must be"):
            clrender.Renderer(scene, step=step)
    combinations = list(all_feature_combinations())
    assert all(c["MEDIA"] == 1 for c in combinations if c["GRID_MEDIA"])
    # Kept small: every one is compiled by test_compile.py (AOVS and TEXTURES doubled it twice;
    # packets add the 24 of ENVIRONMENT x DIELECTRIC x AOVS x TEXTURES without media or toon).
    assert len(combinations) == 2 * 96 + 24
    assert all(not (c["MEDIA"] or c["TOON"]) for c in combinations if c["LANES"] > 1)


def test_medium_records_point_into_the_shared_buffers():
    data = grid_scene({"procedural": "sphere_falloff", "resolution": [10, 6, 4]},
                      medium={"majorant_block": 4, "transform": {"scale": [2, 3, 4], "translate": [1, 2, 3]}})
    data["media"] = [{"name": "fog", "sigma_a": 0.1}, data["media"][0],
                     {"name": "second", "type": "grid", "sigma_a": 1.0,
                      "density": {"procedural": "constant", "resolution": [3, 3, 3]}}]
    data["shapes"] = [{"type": "box", "material": "boundary", "interior": "second", "exterior": "fog"}]
    scene = clrender.load_scene_dict(data)
    arrays = build_scene_arrays(scene)
    fog, cloud, second = arrays.media
    assert fog["grid"][0] == 0 and cloud["grid"][0] == 1 and second["grid"][0] == 1
    assert tuple(cloud["resolution"][:3]) == (10, 6, 4) and tuple(cloud["majorant_resolution"][:3]) == (3, 2, 1)
    assert cloud["grid"][1] == 0 and second["grid"][1] == 240 and cloud["grid"][3] == 4
    assert second["grid"][2] == 6 and len(arrays.majorant_data) == 2 * (6 + 1)
    assert np.array_equal(arrays.grid_data[:240], scene.media[1].grid.density.ravel())
    # world -> voxel: the grid's corners map to (0, 0, 0) and (nx, ny, nz).
    to_voxel = cloud["to_voxel"]
    assert np.allclose(to_voxel @ [1, 2, 3, 1], 0, atol=1e-5) and np.allclose(to_voxel @ [3, 5, 7, 1], [10, 6, 4])


def run_cli(*args):
    return subprocess.run([sys.executable, "-m", "clrender.cli", *args], capture_output=True, text=True,
                          cwd=REPO, timeout=300)


def test_cli_chooses_the_volume_method(tmp_path):
    data = grid_scene({"procedural": "noise_cloud", "resolution": [8, 8, 8]},
                      medium={"transform": {"scale": 2, "translate": [-1, -1, -1]}})
    path = tmp_path / "cloud.json"
    path.write_text(json.dumps(data))
    info = run_cli("info", str(path))
    assert info.returncode == 0, info.stderr
    assert "grid_media=null" in info.stdout and "grid 8x8x8 (noise_cloud 8x8x8)" in info.stdout
    for extra in ([], ["--volume-method", "raymarch", "--step", "2", "--no-raymarch-multiple-scattering"]):
        out = tmp_path / "cloud.exr"
        result = run_cli("render", str(path), "-o", str(out), "--spp", "2", "--quiet", *extra)
        assert result.returncode == 0, result.stderr
        image = clrender.load_image(out)
        assert np.all(np.isfinite(image)) and image.min() < 0.99   # the cloud is visible
        assert "note:" not in result.stderr
    # A medium too dense for marching's step refinement is reported, not silently capped.
    data["media"][0]["sigma_t"] = 1e4
    path.write_text(json.dumps(data))
    dense = run_cli("render", str(path), "-o", str(out), "--spp", "1", "--quiet", "--volume-method", "raymarch")
    assert dense.returncode == 0 and "note: ray marching: medium 'cloud'" in dense.stderr, dense.stderr
    bad = run_cli("render", str(path), "-o", str(tmp_path / "x.exr"), "--volume-method", "magic")
    assert bad.returncode != 0 and "invalid choice" in bad.stderr
    bad = run_cli("render", str(path), "-o", str(tmp_path / "x.exr"), "--step", "-1")
    assert bad.returncode == 2 and "--step: must be >= 0.001" in bad.stderr


def test_example_grid_scenes_load():
    for name in ("cloud_cornell_box", "cloud_low_sun", "smoke_plume"):
        scene = clrender.load_scene(f"scenes/{name}.json")
        assert scene_features(scene)["GRID_MEDIA"] == 1
        assert any(m.type == "grid" for m in scene.media)
