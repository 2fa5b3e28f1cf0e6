"""The integrators and camera settings beside path tracing (docs/scene-format.md, `render`): the
direct integrator (`render.integrator: "direct"`, kernels/direct.h), `render.hide_emitters`
(camera rays pass through emitting shapes) and the scene's own AOVs (`render.aovs`).

Exact cases compare exactly (a delta light and no environment: every sample of a pixel is the
same number); statistical ones require |mean - expected| < 5 standard errors (fixed seeds).
About 20 s on 2 cores (small kernel builds).
"""
import json
import subprocess
import sys

import numpy as np
import pytest

import clrender
from conftest import camera, z_bound


def direct(emitter_samples, bsdf_samples, **render):
    return {"integrator": "direct", "emitter_samples": emitter_samples, "bsdf_samples": bsdf_samples, **render}


def test_direct_with_one_sample_each_is_path_tracing_to_depth_2(device):
    # Mitsuba's direct integrator with 1 + 1 samples is its path tracer at max_depth 2: the same
    # random numbers in the same order, the same MIS weights, so the same image bit for bit.
    with open("scenes/cornell_box.json") as f:
        data = json.load(f)
    data["camera"]["resolution"] = [24, 24]
    images = [clrender.Renderer(clrender.load_scene_dict(dict(data, render=render), "scenes"), device,
                                packets=False).render(spp=8, seed=3).image
              for render in (direct(1, 1), {"max_depth": 2})]
    assert images[0].mean() > 0.05
    assert np.array_equal(images[0], images[1])


@pytest.mark.parametrize("emitter_samples,bsdf_samples", [(1, 0), (0, 1), (2, 3)])
def test_direct_lights_a_ball_in_a_furnace_exactly(device, emitter_samples, bsdf_samples):
    # A convex diffuse ball in a uniform environment sees all of it from every point: radiance
    # albedo x L however the light and BSDF samples share the work (MIS weights sum to 1).
    scene = clrender.load_scene_dict({
        "camera": camera(resolution=(24, 24), fov=14),   # the whole image inside the ball
        "materials": [{"name": "m", "type": "diffuse", "albedo": [0.5] * 3}],
        "shapes": [{"type": "sphere", "material": "m"}],
        "lights": [{"type": "environment", "radiance": 1.0}],
        "render": direct(emitter_samples, bsdf_samples),
    })
    image = clrender.Renderer(scene, device).render(spp=16, seed=5).image
    assert z_bound(image[..., 0], 0.5) < 5.0   # grey: one channel


def test_direct_counts_a_delta_light_once_per_shading_point(device):
    # A panel lit by a directional light of irradiance 1 shows albedo / pi whatever the number of
    # light samples (Mitsuba 3.9 would show it emitter_samples times brighter: docs/mitsuba-xml.md).
    scene = clrender.load_scene_dict({
        "camera": camera(fov=20, resolution=(8, 8)),
        "materials": [{"name": "m", "type": "diffuse", "albedo": [0.5] * 3}],
        "shapes": [{"type": "rectangle", "material": "m", "transform": {"scale": 3}}],
        "lights": [{"type": "directional", "direction": [0, 0, -1], "irradiance": 1.0}],
        "render": direct(3, 2),
    })
    image = clrender.Renderer(scene, device).render(spp=4, seed=1).image
    assert np.allclose(image, 0.5 / np.pi, rtol=1e-6, atol=0)


def test_path_depths_do_not_apply_to_the_direct_integrator(device):
    scene = clrender.load_scene_dict({"camera": camera(resolution=(4, 4)), "render": direct(1, 1)})
    for name in ("max_depth", "rr_depth"):
        with pytest.raises(clrender.ArgumentError, match=f"^{name}: does not apply to the direct integrator"):
            clrender.Renderer(scene, device).render(spp=1, **{name: 3})


@pytest.mark.parametrize("render,message", [
    (direct(0, 0), "render.emitter_samples: and bsdf_samples are both 0"),
    (direct(1025, 1), "render.emitter_samples: must be <= 1024"),
    ({"emitter_samples": 2}, "render.emitter_samples: unknown field"),   # only with the direct integrator
    ({"integrator": "bdpt"}, "render.integrator: unknown value 'bdpt'; valid: path, direct"),
    ({"aovs": ["albedo", "shadow"]}, "render.aovs: unknown AOV 'shadow'"),
    ({"aovs": "variance"}, "render.aovs: must be a list of AOV names"),
])
def test_render_setting_errors(render, message):
    scene = {"camera": camera(), "render": render}
    with pytest.raises(clrender.SceneError, match=message.replace("(", r"\(").replace(")", r"\)")):
        clrender.load_scene_dict(scene)


@pytest.mark.parametrize("extra,message", [
    ({"media": [{"name": "fog", "sigma_t": 0.1, "albedo": 0.5}], "medium": "fog"}, "'direct' renders no media"),
    ({"materials": [{"name": "ink", "type": "toon"}]}, "'direct' does not render toon materials"),
])
def test_direct_refuses_media_and_toon(extra, message):
    with pytest.raises(clrender.SceneError, match=f"render.integrator: {message}"):
        clrender.load_scene_dict({"camera": camera(), "render": direct(1, 1), **extra})


def emitter_before_a_lit_panel(hide):
    """An emitting square (facing the camera, radiance 5) 1 in front of a diffuse panel lit by a
    directional light at 45 degrees, whose shadow of the square falls 1 to the side."""
    return clrender.load_scene_dict({
        "camera": camera(fov=20, resolution=(16, 16)),
        "materials": [{"name": "panel", "type": "diffuse", "albedo": [0.5] * 3},
                      {"name": "light", "type": "emissive", "radiance": 5.0}],
        "shapes": [{"type": "rectangle", "material": "panel", "transform": {"scale": 4}},
                   {"type": "rectangle", "material": "light", "transform": {"scale": 0.4, "translate": [0, 0, 1]}}],
        "lights": [{"type": "directional", "direction": [-1, 0, -1], "irradiance": 1.0}],
        "render": {"max_depth": 4, "hide_emitters": hide},
    })


def test_hide_emitters_lets_camera_rays_through_emitting_shapes(device):
    # Mitsuba 3.9's hide_emitters: the camera sees the panel behind the emitter, lit as it is
    # (albedo / pi x E cos 45 deg; noisy only because the light sampler also picks the emitter,
    # which faces away from the panel).
    centre = (slice(6, 10), slice(6, 10))   # pixels wholly inside the emitter's outline
    shown = clrender.Renderer(emitter_before_a_lit_panel(False), device).render(spp=64, seed=1).image
    hidden = clrender.Renderer(emitter_before_a_lit_panel(True), device).render(spp=64, seed=1).image
    assert np.allclose(shown[centre], 5.0)
    assert z_bound(hidden[centre][..., 0], 0.5 / np.pi * np.sqrt(0.5)) < 5.0   # grey: one channel
    outside = np.ones((16, 16), bool)
    outside[3:13, 3:13] = False   # beyond the emitter's outline the images are the same
    assert np.array_equal(shown[outside], hidden[outside])


def test_scene_aovs_are_rendered_unless_others_are_asked_for(device):
    scene = emitter_before_a_lit_panel(False)
    scene.render.aovs = ("variance", "depth")
    renderer = clrender.Renderer(scene, device)
    assert sorted(renderer.render(spp=2).aovs) == ["depth", "variance"]
    assert sorted(renderer.render(spp=2, aovs=("albedo",)).aovs) == ["albedo"]


def test_a_moment_integrator_writes_the_variance_layer(tmp_path):
    # Mitsuba's moment integrator (its second moment) becomes clrender's variance AOV, written
    # by `clrender render` as a layer of the EXR.
    (tmp_path / "moment.xml").write_text("""<scene version="3.0.0">
        <integrator type="moment"><integrator type="path"><integer name="max_depth" value="3"/></integrator></integrator>
        <sensor type="perspective">
            <transform name="to_world"><lookat origin="0, 0, 4" target="0, 0, 0" up="0, 1, 0"/></transform>
            <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/>
                <rfilter type="box"/></film>
            <sampler type="independent"><integer name="sample_count" value="4"/></sampler>
        </sensor>
        <shape type="sphere"><bsdf type="diffuse"/></shape>
        <emitter type="constant"/>
    </scene>""")
    result = subprocess.run([sys.executable, "-m", "clrender.cli", "render", str(tmp_path / "moment.xml"),
                             "-o", str(tmp_path / "out.exr"), "--quiet"], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    layers = clrender.load_exr_layers(tmp_path / "out.exr")
    assert sorted(layers) == ["", "variance"]
    assert layers["variance"].shape == (8, 8, 3) and np.all(layers["variance"] >= 0)
    assert layers["variance"].max() > 0   # the sphere's pixels are noisy at 4 spp
