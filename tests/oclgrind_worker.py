"""Runs cases on the Oclgrind device, in a process of its own (started by tests/test_oclgrind.py).

Oclgrind writes its diagnostics to this process's stderr; each case is framed there by marker
lines, so the caller can tell which case printed what. Cases arrive as a JSON list on stdin:
  {"kind": "combination", "features": {...}}  render the feature combination's scene
                                             (clrender/feature_scenes.py)
  {"kind": "scene", "path": "scenes/x.json"}   render an example scene, shrunk
  {"kind": "test_kernels", "features": {...}}  every kernel of tests.cl that these features
                                             compile, on a few work-items
  {"kind": "canary"}                           a kernel with deliberate errors
Renders fill the energy tables of rough materials on the device (the table kernel), run two
launches of one sample (the second reads the first's accumulator) and use local size 4 x 4 for
example scenes, so images whose size is no multiple of 4 exercise the out-of-range guard.
"""
import json
import sys
import time
import warnings
from dataclasses import replace

import numpy as np
import pyopencl as cl

import clrender
from clrender import filters, guide, layout, textures, wide_bvh
from clrender.aovs import SAMPLE_AOVS
from clrender.arrays import _material_array, build_scene_arrays
from clrender.bvh import build_bvh
from clrender.device import build_program
from clrender.energy import fill_albedo_tables
from clrender.feature_scenes import feature_scene
from clrender.features import FEATURE_VALUES, scene_features
from clrender.render import render_params
from clrender.triangle_blocks import triangle_blocks
from test_layout import ORDER as STRUCT_ORDER

MARK = "@@oclgrind-case"
# The caustic guide's photons (guide_photons.cl, in every render of a scene with a directional
# light and glossy glass) under the simulator: its paths, not the guide's quality, are the point.
guide.PHOTONS = 256
RESOLUTION = (8, 8)
mf = cl.mem_flags


def render(scene, device, method=None, local_size=None, launches=2, aovs=(), banded=False, **settings):
    """`launches` samples, one per launch (a later one adds to the accumulator of the earlier);
    `aovs`: the AOVs to accumulate (the AOVS feature when sample-level ones are named); `banded`:
    the samples after the first in bands of one work-group row, launches offset to their row;
    with `sample_items=True` among the settings, the samples in one launch of sample items."""
    renderer = clrender.Renderer(scene, device, local_size=local_size, volume_method=method,
                                 **settings, **({"pass_seconds": 1e-9} if banded else {}))
    depth = {} if scene.render.integrator == "direct" else {"max_depth": min(scene.render.max_depth, 4)}
    per_pass = None if banded else launches if settings.get("sample_items") else 1
    result = renderer.render(spp=launches, samples_per_pass=per_pass, seed=1, aovs=aovs, **depth)
    return {"discarded": result.discarded_samples, "finite": bool(np.all(np.isfinite(result.image)))}


def add(a, b):
    return {"discarded": a["discarded"] + b["discarded"], "finite": a["finite"] and b["finite"]}


def run_combination(case, device):
    features = case["features"]
    scene, method = feature_scene(features, RESOLUTION)
    packets = features["LANES"] > 1
    info = render(scene, device, method, aovs=SAMPLE_AOVS if features["AOVS"] else (), packets=packets)
    # Run-time switches, on a quarter of the pixels: ray marching's other next-event path (one
    # light sample per segment instead of per step), hero-only free-flight sampling, an albedo
    # grid, emitters hidden from the camera, the direct integrator (surfaces only), the pixel
    # filter by importance sampling instead of splatting, and sample items (both filter methods).
    small, _ = feature_scene(features, (4, 4))
    info = add(info, render(replace(small, render=replace(small.render, filter_method="importance")), device, method,
                            launches=1))
    if method == "raymarch":
        info = add(info, render(small, device, method, launches=1, raymarch_multiple_scattering=True))
    if features["MEDIA"]:
        info = add(info, render(small, device, method, launches=1, spectral_mis=False))
    if features["GRID_MEDIA"]:
        info = add(info, render(with_albedo_grid(small), device, method, launches=1,
                                aovs=SAMPLE_AOVS if features["AOVS"] else ()))
    if features["DIELECTRIC"] and not (features["MEDIA"] or features["TOON"]):
        # Light paths (clrender/light_paths.py) need a pinhole: the scene's thin lens closed.
        pinhole, _ = feature_scene(features, (4, 4))
        pinhole.camera.aperture_radius = 0.0
        info = add(info, render(pinhole, device, method, launches=1, packets=packets))
    if not packets:
        sample_aovs = SAMPLE_AOVS if features["AOVS"] else ()   # their records summed by sum_samples
        info = add(info, render(small, device, method, launches=2, aovs=sample_aovs, sample_items=True))
        info = add(info, render(replace(small, render=replace(small.render, filter_method="importance")), device,
                                method, launches=2, aovs=sample_aovs, sample_items=True))
        small.render = replace(small.render, hide_emitters=True)
        info = add(info, render(small, device, method, launches=1))
    if not (packets or features["MEDIA"] or features["TOON"]):
        small.render = replace(small.render, integrator="direct", emitter_samples=2, bsdf_samples=3)
        info = add(info, render(small, device, launches=1))
    if packets:
        # The direct integrator in packets (kernels/direct_packets.h), which take no masks.
        small.render = replace(small.render, integrator="direct", emitter_samples=2, bsdf_samples=3)
        for material in small.materials:
            material.opacity = 1.0
            material.textures.pop("opacity", None)
        assert scene_features(small, packets=True)["LANES"] == features["LANES"]
        info = add(info, render(small, device, launches=1, packets=True))
    return info


def with_albedo_grid(scene):
    """`scene` with an RGB albedo grid (another resolution than the density's) in its grid medium."""
    cloud = next(medium for medium in scene.media if medium.grid is not None)
    cloud.albedo_grid = np.random.default_rng(5).uniform(0.2, 1.0, (3, 2, 4, 3)).astype(np.float32)
    cloud.sigma_a, cloud.sigma_s = np.zeros(3), cloud.sigma_t
    return scene


def run_scene(case, device):
    scene = clrender.load_scene(case["path"])
    width, height = scene.camera.resolution
    scene.camera.resolution = (8, max(1, round(8 * height / width)))
    return render(scene, device, local_size=(4, 4), banded=True)


# ----- tests.cl, on a few work-items --------------------------------------------------------
def upload(context, array):
    return cl.Buffer(context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=np.ascontiguousarray(array))


def outputs(context, *shapes):
    return [cl.Buffer(context, mf.WRITE_ONLY, int(np.prod(shape)) * 4) for shape in shapes]


def float4(rows):
    rows = np.atleast_2d(np.asarray(rows, np.float32))
    return np.c_[rows, np.zeros((len(rows), 4 - rows.shape[1]), np.float32)]


def small_scene(features):
    scene, _ = feature_scene(features, RESOLUTION)
    return scene, build_scene_arrays(scene)


def run_test_kernels(case, device):
    features = {name: values[0] for name, values in FEATURE_VALUES.items()}
    features.update(case["features"])
    context = cl.Context([device])
    queue = cl.CommandQueue(context)
    program = build_program(context, features, entry="tests.cl")
    kernel = lambda name: cl.Kernel(program, name)
    rng = np.random.default_rng(1)
    n = 4
    structs = [cl.Buffer(context, mf.READ_WRITE, layout.STRUCTS[name].itemsize) for name in STRUCT_ORDER]
    kernel("struct_layout")(queue, (1,), None, *structs, *outputs(context, 256))

    v0 = rng.uniform(-1, 1, (6, 3))
    v1, v2 = v0 + rng.normal(0, 0.5, (6, 3)), v0 + rng.normal(0, 0.5, (6, 3))
    tree = build_bvh(v0, v1, v2)
    nodes, _ = wide_bvh.collapse(tree)
    origins, directions = float4(rng.uniform(-3, 3, (n, 3))), float4(-rng.uniform(-3, 3, (n, 3)))
    directions[:, :3] /= np.linalg.norm(directions[:, :3], axis=1, keepdims=True)
    nodes, blocks = triangle_blocks(nodes, v0, v1, v2, tree.prim_order)
    kernel("trace_rays")(queue, (n,), None, upload(context, nodes), upload(context, blocks),
                         upload(context, np.zeros(1, layout.SPHERE)),
                         upload(context, origins), upload(context, directions), *outputs(context, n, n, n))
    for routine, g in ((0, 0.0), (1, 0.0), (2, 0.7), (2, -0.99)):
        kernel("sample_directions")(queue, (n,), None, np.int32(routine), np.float32(g), np.uint32(3),
                                    *outputs(context, (n, 4)))

    scene, arrays = small_scene({**features, "DIELECTRIC": 1, "MEDIA": 0, "GRID_MEDIA": 0})
    wo = float4([[0.3, 0.1, 0.9], [0.6, 0.0, 0.8], [0.1, -0.2, -0.97], [0.99, 0.0, 0.14]])
    wo[:, :3] /= np.linalg.norm(wo[:, :3], axis=1, keepdims=True)
    if features["DIELECTRIC"]:
        fill_albedo_tables(queue, arrays)
    albedo = upload(context, arrays.specular_albedo if arrays.specular_albedo.size else np.zeros(1, np.float32))
    names = [m.name for m in scene.materials]
    kinds = ["white"]
    if features["DIELECTRIC"]:
        kinds += ["glass", "rough_glass", "rough_mirror", "mirror", "pane", "plastic", "rough_plastic", "principled"]
    for name in kinds:
        material = upload(context, arrays.materials[names.index(name):names.index(name) + 1])
        for front in (0, 1):
            ns = np.float32([0.05, 0.0, 1.0, 0.0])
            kernel("sample_bsdf_values")(queue, (n,), None, material, albedo, np.int32(front), ns,
                                         upload(context, wo), np.uint32(5), *outputs(context, (n, 4), (n, 4)))
            kernel("eval_bsdf_values")(queue, (n,), None, material, albedo, np.int32(front), ns,
                                       upload(context, wo), upload(context, wo[::-1] * [1, 1, -1, 1]),
                                       *outputs(context, (n, 4)))
    # Diffuse sampling with a caustic guide (kernels/guide.h): one cell of two lobes, points in
    # and out of it.
    params = render_params(scene, arrays, 0, 1, 4, 2, 0)
    params["guide_grid"], params["guide_cells"], params["guide_cone"] = (0, 0, 0, 1), (1, 1, 1, 1), (0.25, 0.99, 30, 0)
    lobes = np.zeros(layout.GUIDE_LOBES, layout.GUIDE_LOBE)
    lobes["direction"] = [[0, 0, 1, 0.7], [1, 0, 0, 1], [0, 0, 0, 1], [0, 0, 0, 1]]
    kernel("sample_diffuse_values")(queue, (n,), None, upload(context, params), upload(context, lobes),
                                    upload(context, float4([[0.5, 0.5, 0.5], [1.5, 0.5, 0.5], [0.2, 0.9, 0.1],
                                                            [-1e30, 0, 0]])),
                                    upload(context, wo), np.uint32(2), *outputs(context, (n, 4), (n, 4)))
    if features["DIELECTRIC"]:
        kernel("fresnel_refract_values")(queue, (n,), None, upload(context, np.float32([[0.9, 1.5], [0.1, 1.5],
                                                                                        [0.3, 0.7], [1.0, 1.0]])),
                                         *outputs(context, (n, 4)))
        u = rng.uniform(0, 1, (n, 2)).astype(np.float32)
        for distribution in layout.MICROFACET_DISTRIBUTIONS.values():
            for masking in layout.MASKINGS.values():
                kernel("microfacet_values")(queue, (n,), None, np.float32(0.2), np.int32(distribution),
                                            np.int32(masking), upload(context, wo), upload(context, wo),
                                            upload(context, wo[::-1]), *outputs(context, (n, 4)))
            kernel("sample_vndf_values")(queue, (n,), None, np.float32(0.2), np.int32(distribution),
                                         upload(context, wo), upload(context, u), *outputs(context, (n, 4)))

    scene, arrays = small_scene(features)
    leave = float4([[0.2, 0.0, 1.0], [0.0, 0.3, -1.0], [1.0, 0.0, 0.001], [0.0, 0.0, -1.0]])
    cam_origins = float4(np.tile(scene.camera.position, (n, 1)))
    cam_dirs = float4(np.array([[0.0, -0.3, -1.0], [0.1, -0.2, -1.0], [-0.2, -0.25, -1.0], [0.3, -0.4, -1.0]]))
    cam_dirs[:, :3] /= np.linalg.norm(cam_dirs[:, :3], axis=1, keepdims=True)
    kernel("spawn_from_hits")(queue, (n,), None, *(upload(context, a) for a in
                              (arrays.nodes, arrays.blocks, arrays.spheres, arrays.shading, arrays.info, arrays.uvs, cam_origins,
                               cam_dirs, leave)),
                              *outputs(context, (n, 4)))
    params = upload(context, render_params(scene, arrays, 0, 1, 4, 2, 0))
    # The pixel filter at an image edge, thin-lens camera rays, the spot light (feature_scenes.py).
    kernel("filter_samples")(queue, (n,), None, upload(context, filters.filter_record(scene.camera.filter)),
                             np.int32(0), np.int32(3), np.uint32(2), *outputs(context, (n, 2)))
    kernel("camera_rays")(queue, (n,), None, params, upload(context, float4(rng.uniform(0, 8, (n, 4)) / [1, 1, 8, 8])),
                          *outputs(context, (2 * n, 4)))
    spot = arrays.first_light + [light.type for light in scene.lights].index("spot")
    kernel("delta_light_values")(queue, (n,), None, upload(context, arrays.emitters[spot:spot + 1]),
                                 upload(context, float4(rng.uniform(-1, 1, (n, 3)))), *outputs(context, (n, 4)))
    if features["ENVIRONMENT"] == layout.ENVIRONMENT_MODES["image"]:
        for lookup in layout.ENVIRONMENT_LOOKUPS:   # the scene's is Mitsuba's; the texel one too
            scene.environment.lookup = lookup
            env = build_scene_arrays(scene)
            kernel("sample_environment")(queue, (n,), None, upload(context, render_params(scene, env, 0, 1, 4, 2, 0)),
                                         upload(context, env.env_texels), upload(context, env.env_cdf), np.uint32(9),
                                         *outputs(context, (n, 4), (n, 4), (n, 4)))
    if features["GRID_MEDIA"]:
        media = [upload(context, a) for a in (arrays.media, arrays.grid_data, arrays.majorant_data)]
        cloud = [m.name for m in scene.media].index("cloud")
        points = float4(rng.uniform(-1.5, 1.5, (n, 3)))
        points[:, 3] = cloud   # grid_lookup reads grid media only; the fog is walked below
        kernel("grid_lookup")(queue, (n,), None, params, *media, upload(context, points), *outputs(context, (n, 4)))
        kernel("majorant_walk")(queue, (n,), None, params, *media, np.int32(cloud), upload(context, cam_origins), upload(context, cam_dirs),
                                np.float32(10.0), np.int32(8), np.int32(2), np.uint32(1),
                                *outputs(context, (n, 8, 4), n, (n, 2)))
        for medium in (cloud, 0):
            args = (params, *media, np.int32(medium), cam_origins[0], cam_dirs[0], np.float32(8.0), np.uint32(2),
                    np.int32(1))
            kernel("transmittance_estimates")(queue, (n,), None, *args, *outputs(context, (n, 4)))
            # Delta tracking serves grid media only (homogeneous media are sampled analytically).
            if features["GRID_MEDIA"] == layout.VOLUME_METHODS["null"] and medium == cloud:
                kernel("delta_pass_estimates")(queue, (n,), None, *args, *outputs(context, (n, 4)))
        albedo = build_scene_arrays(with_albedo_grid(scene))
        albedo_media = [upload(context, a) for a in (albedo.media, albedo.grid_data, albedo.majorant_data)]
        kernel("grid_lookup")(queue, (n,), None, params, *albedo_media, upload(context, points),
                              *outputs(context, (n, 4)))
    if features["TEXTURES"]:
        run_texture_kernels(context, queue, kernel, rng)
    queue.finish()
    return {}


def run_texture_kernels(context, queue, kernel, rng):
    """Lookups and gradients of every texel encoding, filter and wrap mode, far outside [0, 1]
    too (the texel indices they wrap stay in the buffer), a material resolved from textures, and
    a diffuse BSDF under a bump map and a normal map, seen from both sides."""
    texture_list = [textures.Texture("checks", "checkerboard")]
    for encoding, pixels in (("srgb8", rng.integers(0, 256, (3, 5, 3), dtype=np.uint8)),
                             ("linear8", rng.integers(0, 256, (4, 2, 1), dtype=np.uint8)),
                             ("float32", rng.uniform(0, 2, (2, 3, 4)).astype(np.float32))):
        for filter_ in textures.FILTERS:
            for wrap in textures.WRAPS:
                texture_list.append(textures.Texture(f"{encoding}-{filter_}-{wrap}", "bitmap", pixels=pixels,
                                                     srgb=encoding == "srgb8", filter=filter_, wrap=wrap))
    records, texels = textures.texture_arrays(texture_list)
    uv = rng.uniform(-40, 40, (4, 2)).astype(np.float32)
    uv[0] = (0.0, 1.0)   # the image's edges exactly
    for index in range(len(texture_list)):
        kernel("eval_texture_values")(queue, (len(uv),), None, upload(context, records), upload(context, texels),
                                      np.int32(index), upload(context, uv), *outputs(context, (len(uv), 4)))
        kernel("texture_gradient_values")(queue, (len(uv),), None, upload(context, records), upload(context, texels),
                                          np.int32(index), upload(context, uv), *outputs(context, (len(uv), 2)))
    frames = np.zeros((len(uv), 5, 4), np.float32)
    frames[:, 0, :2], frames[:, 0, 2] = uv, [1, 0, 1, 0]
    frames[:, 1, :3] = frames[:, 2, :3] = [0, 0, 1]
    frames[:, 3, :3], frames[:, 4, :3] = [2, 0, 0.3], [0, 1.5, 0]
    directions = float4([[0.3, 0.1, 0.9], [0.6, 0.0, -0.8], [0.1, -0.2, 0.97], [0.99, 0.0, 0.14]])
    for field, index in (("bump", 2), ("normal", 3)):
        bent = clrender.scene.Material("m", "diffuse", bump_map=index if field == "bump" else -1,
                                       normal_map=index if field == "normal" else -1)
        kernel("shading_map_values")(queue, (len(uv),), None, upload(context, _material_array([bent])),
                                     upload(context, records), upload(context, texels), upload(context, frames),
                                     upload(context, directions), upload(context, directions[::-1]),
                                     *outputs(context, (len(uv), 4), (len(uv), 4)))
    material = np.zeros(1, layout.MATERIAL)
    layout.clear_texture_references(material)
    layout.set_texture_reference(material, "color", 1)
    layout.set_texture_reference(material, "alpha", 5)
    kernel("resolve_material_values")(queue, (len(uv),), None, upload(context, material), upload(context, records),
                                      upload(context, texels), upload(context, uv),
                                      *outputs(context, (len(uv) * (layout.MATERIAL_SLOTS + 1), 4)))


CANARY = """
__kernel void canary(__global float* out, int n) {
    int i = get_global_id(0);
    float x;
    if (out[i] > 0.0f) x = 1.0f;      // out holds zeros: x stays uninitialised
    if (x > 0.5f) out[i] = 2.0f;      // control flow on an uninitialised value
    out[i] += out[i + n];             // a read beyond the buffer
}
"""


def run_canary(case, device):
    """Deliberate errors: tests/test_oclgrind.py checks that Oclgrind reports them."""
    context = cl.Context([device])
    queue = cl.CommandQueue(context)
    program = cl.Program(context, CANARY).build()
    buffer = upload(context, np.zeros(4, np.float32))
    program.canary(queue, (4,), None, buffer, np.int32(4))
    queue.finish()
    return {}


RUNNERS = {"combination": run_combination, "scene": run_scene, "test_kernels": run_test_kernels,
           "canary": run_canary}


def main():
    warnings.simplefilter("ignore")   # pyopencl's compiler-output notes: not diagnostics
    cases = json.load(sys.stdin)
    device = clrender.choose_device("oclgrind")
    for case in cases:
        key = json.dumps(case, sort_keys=True)
        print(f"{MARK} begin {key}", file=sys.stderr, flush=True)
        start = time.perf_counter()
        info = RUNNERS[case["kind"]](case, device)
        print(f"{MARK} end {key}", file=sys.stderr, flush=True)
        print(json.dumps({"case": key, "seconds": time.perf_counter() - start, **info}), flush=True)


if __name__ == "__main__":
    main()
