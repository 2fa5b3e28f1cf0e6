"""clrender against Mitsuba 3 on the same XML files (Mitsuba's scalar_rgb variant, which needs
no LLVM; skipped when Mitsuba is not installed: `pip install -e '.[peers]'`).

Conventions that must match exactly are compared exactly: camera rays through pixel centres
and corners (fov axes, to_world), .vol voxel placement, the envmap lookup, conductor presets,
named IORs, spectra. Images are compared statistically: both renderers render RENDERS images
with different seeds; per pixel the mean and the variance of the mean come from those renders,
and per block of 4 x 4 pixels (and the whole image) z = (mean_clrender - mean_mitsuba) /
sqrt(var_clrender + var_mitsuba) must stay below Z_MAX = 4.5 (48 block values per scene: a
false alarm about 1 in 3000 for Gaussian statistics; seeds are fixed, so outcomes are
deterministic). Blocks where neither renderer varies must agree exactly.

Budget: about 30 s on 2 cores with warm kernel caches (Mitsuba's part about 10 s).
"""
import warnings
from pathlib import Path

import numpy as np
import pyopencl as cl
import pytest

import clrender
from clrender import cie, filters, grids, metrics, textures
from clrender.conductor_presets import CONDUCTOR_PRESETS
from clrender.arrays import build_scene_arrays
from clrender.mitsuba import IOR_PRESETS, MitsubaXmlWarning, read_scene
from clrender.render import render_params
from clrender.scene import Filter
from conftest import build_test_kernels, camera_rays, delta_light_values, use_mitsuba_llvm
from mitsuba_envmap import mitsuba_envmap_lookup
import mitsuba_scenes

try:
    import mitsuba as mi
except ImportError:
    pytest.skip("Mitsuba 3 is not installed (pip install -e '.[peers]')", allow_module_level=True)

RES, SPP, RENDERS, BLOCK, Z_MAX = 16, 128, 8, 4, 4.5


@pytest.fixture(scope="module", autouse=True)
def scalar_rgb():
    mi.set_variant("scalar_rgb")


@pytest.fixture
def mitsuba_llvm_variant():
    """Mitsuba's llvm_ad_rgb variant for one test (skipped where Debian's libLLVM 19 is missing),
    scalar_rgb again after it."""
    use_mitsuba_llvm()
    yield
    mi.set_variant("scalar_rgb")


def load_quietly(path, **parameters):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", MitsubaXmlWarning)
        return clrender.load_scene(path, parameters=parameters)


# ============================================================================================
# Images
# ============================================================================================
def render_both(path, device, spp=SPP, renders=RENDERS, sampler=None, mitsuba_spp=None, **parameters):
    """(clrender renders, Mitsuba renders), each (renders, height, width, 3), with Mitsuba's
    variant as set; `sampler` overrides clrender's (the scene's), `mitsuba_spp` Mitsuba's spp
    (default `spp`; the comparisons take each renderer's own variance across its renders)."""
    parameters = {"spp": str(spp), **{k: str(v) for k, v in parameters.items()}}
    theirs = mi.load_file(str(path), **parameters)
    # [..., :3]: a moment integrator adds its second moments as channels.
    mitsuba = np.array([np.array(mi.render(theirs, spp=mitsuba_spp or spp, seed=seed))[..., :3]
                        for seed in range(renders)])
    renderer = clrender.Renderer(load_quietly(path, **parameters), device, sampler=sampler)
    ours = np.array([renderer.render(spp=spp, seed=1000 + seed).image for seed in range(renders)])
    return ours, mitsuba


def block_z_scores(ours, mitsuba, block, independent_pixels=True):
    """z per block of pixels (block: an int for squares, or (rows, columns)) and channel. With
    `independent_pixels` (box filters: each sample counts in one pixel) a block's variance of the
    mean is the sum of its pixels' over the renders; otherwise (splatting: neighbours share
    samples, their noise is correlated) it is that of the renders' block means."""
    count, height, width, _ = ours.shape
    rows, columns = (block, block) if np.isscalar(block) else block
    shape = (count, height // rows, rows, width // columns, columns, 3)
    if independent_pixels:
        difference = ours.mean(0) - mitsuba.mean(0)
        variance = (ours.var(0, ddof=1) + mitsuba.var(0, ddof=1)) / count
        d = difference.reshape(shape[1:]).mean(axis=(1, 3))
        v = variance.reshape(shape[1:]).sum(axis=(1, 3)) / (rows * columns) ** 2
    else:
        ours_blocks, mitsuba_blocks = (images.reshape(shape).mean(axis=(2, 4)) for images in (ours, mitsuba))
        d = ours_blocks.mean(0) - mitsuba_blocks.mean(0)
        v = (ours_blocks.var(0, ddof=1) + mitsuba_blocks.var(0, ddof=1)) / count
    steady = v == 0
    assert np.all(d[steady] == 0), "blocks without noise differ"
    return np.where(steady, 0.0, d / np.sqrt(np.where(steady, 1.0, v)))


def assert_same_image(ours, mitsuba, z_max=Z_MAX, independent_pixels=True):
    """Blocks of BLOCK x BLOCK pixels and the whole image agree: |z| < z_max, a number or a
    function of the count of z values (blocks x channels); `independent_pixels` as for
    block_z_scores."""
    assert np.all(np.isfinite(ours))
    for block in (BLOCK, ours.shape[1:3]):
        z = block_z_scores(ours, mitsuba, block, independent_pixels)
        limit = z_max(z.size) if callable(z_max) else z_max
        assert np.abs(z).max() < limit, f"{block} blocks: max |z| {np.abs(z).max():.2f} (limit {limit:.2f})\n{z.round(1)}"


@pytest.mark.parametrize("name", sorted(mitsuba_scenes.SCENES))
def test_scene_renders_as_in_mitsuba(tmp_path, device, name):
    ours, mitsuba = render_both(mitsuba_scenes.write(tmp_path, name), device, res=RES)
    assert_same_image(ours, mitsuba)


def test_mitsuba_direct_counts_a_delta_light_emitter_samples_times(tmp_path, device):
    # Mitsuba 3.9's direct integrator weighs each light sample of a point light by 1, not
    # 1 / emitter_samples (docs/mitsuba-xml.md): with 3 samples the lit floor is 3 times
    # clrender's, which counts it once (as Mitsuba's own path integrator does).
    light = '<emitter type="point"><point name="position" x="0" y="2.5" z="2"/><rgb name="intensity" value="3"/></emitter>'
    path = tmp_path / "point.xml"
    path.write_text(mitsuba_scenes._scene(mitsuba_scenes.FLOOR + light, integrator="direct", origin="0 1 5", target="0 0 0",
                                          properties='<integer name="emitter_samples" value="3"/>'))
    ours, mitsuba = render_both(path, device, res=RES)
    assert ours.mean() > 0.005
    # Only pixel positions are random: the image means agree to 0.1 % (measured: 1e-4).
    assert np.allclose(mitsuba.mean(axis=(0, 1, 2)) / ours.mean(axis=(0, 1, 2)), 3.0, rtol=1e-3)


@pytest.mark.parametrize("max_depth", [2, 8])
def test_cornell_box_renders_as_in_mitsuba(device, max_depth):
    # max_depth 2 is direct lighting only in both: Mitsuba's depth convention.
    ours, mitsuba = render_both("scenes/cornell_box.xml", device, resolution=RES, max_depth=max_depth)
    assert_same_image(ours, mitsuba)


# Splatted images: neighbouring pixels share samples, so blocks are judged by the renders' block
# means, FILTER_RENDERS of them per renderer, against Student's t (Welch's smallest degrees of
# freedom, FILTER_RENDERS - 1) Bonferroni-corrected over the z values for a false alarm of
# FILTER_FALSE_ALARM per comparison.
FILTER_RENDERS, FILTER_FALSE_ALARM = 24, 1e-3


def splatted_z_limit(count):
    from scipy import stats
    return stats.t.isf(FILTER_FALSE_ALARM / (2 * count), FILTER_RENDERS - 1)


@pytest.mark.parametrize("rfilter", ["", '<rfilter type="tent"/>',
                                     '<rfilter type="gaussian"><float name="stddev" value="0.3"/></rfilter>'],
                         ids=["gaussian (Mitsuba's default)", "tent", "narrow gaussian"])
def test_pixel_filters_blur_edges_as_in_mitsuba(tmp_path, device, mitsuba_llvm_variant, rfilter):
    # At 16 x 16 the Cornell box is mostly edges: its box-filtered image differs from Mitsuba's
    # gaussian-filtered one by |z| 8 in some blocks; its edge blocks check the filter's
    # truncation at the image's edges. Both splat each sample into the pixels its filter
    # reaches. Against llvm_ad_rgb, which evaluates the filter: scalar_rgb splats with a filter
    # tabulated in 31 steps per radius (its gaussian's mass beyond 1.5 pixels 1.2 times the exact one's).
    path = tmp_path / "cornell_box.xml"
    path.write_text(Path("scenes/cornell_box.xml").read_text().replace('<rfilter type="box"/>', rfilter))
    ours, mitsuba = render_both(path, device, renders=FILTER_RENDERS, resolution=RES, max_depth=8)
    assert_same_image(ours, mitsuba, splatted_z_limit, independent_pixels=False)


def test_sun_and_sky_lit_paths_are_no_noisier_than_mitsubas(tmp_path, device):
    # Both renderers estimate the same image with the same path integrator, box filter and
    # independent sampler, so their per-pixel variances compare their estimators; under a directional light and a
    # constant sky (a diffuse floor and sphere seen through a thin pane) they differ only in how
    # next-event estimation picks the light (clrender/light_selection.py; Mitsuba: uniformly).
    # The sky's power counted whole (the flux into the scene's bounding sphere, 4 times what a
    # surface facing it receives) made clrender 1.38 +- 0.05 times as noisy; now 0.8 times.
    ours, mitsuba = render_both(mitsuba_scenes.write(tmp_path, "thin_pane"), device, res=RES, renders=2 * RENDERS,
                                sampler="independent")
    ratio, error = metrics.variance_ratio(ours, mitsuba)
    assert ratio < 1.0 + Z_MAX * error, f"variance ratio {ratio:.2f} +- {error:.2f}"


# ============================================================================================
# Exact conventions
# ============================================================================================
def sensor_xml(fov, size, to_world, sensor="perspective"):
    width, height = size
    return f"""<scene version="3.0.0">
    <sensor type="{sensor}">
        {fov}
        <transform name="to_world">{to_world}</transform>
        <film type="hdrfilm">
            <integer name="width" value="{width}"/>
            <integer name="height" value="{height}"/>
            <rfilter type="box"/>
        </film>
    </sensor>
</scene>"""


@pytest.mark.parametrize("fov", [
    '<float name="fov" value="50"/>',
    '<float name="fov" value="50"/><string name="fov_axis" value="y"/>',
    '<float name="fov" value="70"/><string name="fov_axis" value="diagonal"/>',
    '<float name="fov" value="40"/><string name="fov_axis" value="smaller"/>',
    '<float name="fov" value="40"/><string name="fov_axis" value="larger"/>',
    '<string name="focal_length" value="35mm"/>',
    '',   # Mitsuba's default: a 50 mm lens
])
@pytest.mark.parametrize("size", [(40, 24), (24, 40)])
def test_camera_rays_through_pixel_centres_and_corners_match(tmp_path, fov, size):
    to_world = """<lookat origin="1, 2, 5" target="0, 0.5, 0" up="0.1, 1, 0"/>
                  <rotate z="1" angle="12"/><translate value="0.3, -1, 2"/>"""
    path = tmp_path / "camera.xml"
    path.write_text(sensor_xml(fov, size, to_world))
    sensor = mi.load_file(str(path)).sensors()[0]
    camera = read_scene(path).scene["camera"]
    ours = clrender.load_scene_dict({"camera": camera}).camera
    width, height = size
    # Image positions in pixels: the corners, pixel centres and an edge; (0, 0) is the top left.
    x, y = np.meshgrid([0, 0.5, 1, 7.5, width / 2, width - 0.5, width],
                       [0, 0.5, 3.5, height / 2, height - 0.5, height])
    x, y = x.ravel(), y.ravel()
    directions = ours.pixel_directions(x, y)
    for px, py, d in zip(x, y, directions):
        ray, _ = sensor.sample_ray(0.0, 0.5, mi.Point2f(px / width, py / height), mi.Point2f(0.5, 0.5))
        assert np.allclose(np.array(ray.d), d, atol=2e-6), (px, py)
        # Mitsuba starts the ray on its near clip plane, on the same line from the eye.
        offset = np.array(ray.o) - ours.position
        assert np.allclose(offset, np.dot(offset, d) * d, atol=1e-5)


@pytest.mark.parametrize("size", [(40, 24), (24, 40)])
def test_thin_lens_rays_match(tmp_path, context, queue, size):
    # The same aperture point for the same lens sample (the concentric map in Mitsuba's
    # orientation) and the same point in focus.
    lens = ('<float name="fov" value="50"/><float name="aperture_radius" value="0.4"/>'
            '<float name="focus_distance" value="3.5"/>')
    to_world = '<lookat origin="1, 2, 5" target="0, 0.5, 0" up="0.1, 1, 0"/><translate value="0.3, -1, 2"/>'
    path = tmp_path / "camera.xml"
    path.write_text(sensor_xml(lens, size, to_world, sensor="thinlens"))
    sensor = mi.load_file(str(path)).sensors()[0]
    scene = clrender.load_scene_dict({"camera": read_scene(path).scene["camera"]})
    width, height = size
    rng = np.random.default_rng(3)
    samples = np.column_stack([rng.random(64) * width, rng.random(64) * height, rng.random((64, 2))])
    samples[:4, 2:] = [[0.5, 0.5], [0, 0.5], [1, 1], [0.5, 0]]   # the centre, the rim
    origins, directions = camera_rays(context, queue, scene, samples)
    for (x, y, u, v), origin, d in zip(samples, origins, directions):
        ray, _ = sensor.sample_ray(0.0, 0.5, mi.Point2f(x / width, y / height), mi.Point2f(u, v))
        assert np.allclose(np.array(ray.d), d, atol=2e-6), (x, y, u, v)
        # Mitsuba starts the ray on its near clip plane, on the same line.
        offset = np.array(ray.o) - origin
        assert np.allclose(offset, np.dot(offset, d) * d, atol=1e-5)


def test_spot_light_falloff_matches(tmp_path, context, queue):
    # A scaled, tilted spot with its own beam width: what reaches points around it, Mitsuba's
    # sample_direction (a delta: its weight is the arriving radiance) against the kernel's.
    spot = """<emitter type="spot">
        <transform name="to_world"><lookat origin="0.5, 2, -1" target="1, 0, 0.3"/><scale value="3"/></transform>
        <rgb name="intensity" value="3, 4, 5"/>
        <float name="cutoff_angle" value="40"/>
        <float name="beam_width" value="12"/>
    </emitter>"""
    (tmp_path / "spot.xml").write_text(spot.replace("<emitter", '<emitter version="3.0.0"', 1))
    theirs = mi.load_file(str(tmp_path / "spot.xml"))
    path = tmp_path / "scene.xml"
    path.write_text(sensor_xml("", (8, 8), '<lookat origin="0, 0, 5" target="0, 0, 0"/>').replace("</scene>", spot + "</scene>"))
    scene = load_quietly(path)
    # Points 1 to 5 away, up to 60 degrees off the axis: in the beam, in the falloff, beyond.
    rng = np.random.default_rng(6)
    axis = scene.lights[0].direction
    side = np.cross(axis, [0.0, 1.0, 0.0])
    side /= np.linalg.norm(side)
    angle, around = np.radians(rng.uniform(0, 60, 300)), rng.uniform(0, 2 * np.pi, 300)
    across = np.cos(around)[:, None] * side + np.sin(around)[:, None] * np.cross(axis, side)
    directions = np.cos(angle)[:, None] * axis + np.sin(angle)[:, None] * across
    points = scene.lights[0].position + rng.uniform(1, 5, (300, 1)) * directions
    ours, _ = delta_light_values(context, queue, scene, points)
    for point, value in zip(points, ours):
        interaction = mi.Interaction3f()
        interaction.p = mi.Point3f(*point)
        _, weight = theirs.sample_direction(interaction, mi.Point2f(0.5, 0.5))
        assert np.allclose(np.array(weight), value, rtol=2e-5, atol=1e-6), point


def stretch_or_shear(kind, amount):
    linear = np.eye(3)
    if kind == "stretch":
        linear[0, 0] += amount
    else:
        linear[0, 1] = amount
    return linear


@pytest.mark.parametrize("kind,amount,loads", [
    ("stretch", 4e-4, True), ("stretch", 6e-4, False),   # |L L^T - I| 8e-4 and 1.2e-3
    ("shear", 9e-4, True), ("shear", 1.2e-3, False)])
def test_camera_to_world_tolerance_and_corner_shift_are_mitsubas(tmp_path, kind, amount, loads):
    # Both load a to_world within 1e-3 of a rotation and refuse one beyond; where they load, the
    # warning's shift is the distance between Mitsuba's rays through the image's corners and ours.
    size = (1000, 600)   # wide enough for a warning (shifts of 0.2 and 0.45 pixels)
    matrix = np.eye(4)
    matrix[:3, :3] = [[0, 0, -1], [0, 1, 0], [1, 0, 0]] @ stretch_or_shear(kind, amount)
    to_world = f'<matrix value="{" ".join(f"{v:.17g}" for v in matrix.ravel())}"/>'
    path = tmp_path / "camera.xml"
    path.write_text(sensor_xml('<float name="fov" value="50"/>', size, to_world))
    try:
        sensor = mi.load_file(str(path)).sensors()[0]
    except RuntimeError as e:
        assert not loads and "Scale factors in the camera-to-world transformation" in str(e)
    else:
        assert loads
    if not loads:
        with pytest.raises(clrender.MitsubaXmlError, match="scales or shears"):
            read_scene(path)
        return
    translation = read_scene(path)
    ours = clrender.load_scene_dict({"camera": translation.scene["camera"]}).camera
    forward, right, up = ours.basis()
    width, height = size
    shifts = []
    for px, py in [(0, 0), (width, 0), (0, height), (width, height)]:
        ray, _ = sensor.sample_ray(0.0, 0.5, mi.Point2f(px / width, py / height), mi.Point2f(0.5, 0.5))
        d = np.array(ray.d) / np.dot(np.array(ray.d), forward)   # on our image plane
        x = (np.dot(d, right) / np.dot(right, right) + 1) / 2 * width
        y = (1 - np.dot(d, up) / np.dot(up, up)) / 2 * height
        shifts.append(np.hypot(x - px, y - py))
    warned = [w for w in translation.warnings if "rotation to" in w]
    assert len(warned) == 1 and f"pass {max(shifts):.2g} pixels from Mitsuba's" in warned[0]


@pytest.mark.parametrize("placement", ["to_world", "use_grid_bbox", "both"])
def test_vol_voxel_centres_map_as_in_mitsuba(tmp_path, placement):
    density = mitsuba_scenes.cloud_density((5, 4, 3))
    grids.write_vol(tmp_path / "g.vol", density, bbox=((-1, 0, 2), (1, 3, 2.5)))
    to_world = ("<transform name=\"to_world\"><scale x=\"2\" y=\"1\" z=\"3\"/><rotate y=\"1\" angle=\"30\"/>"
                "<translate value=\"1 2 3\"/></transform>") if placement != "use_grid_bbox" else ""
    bbox = '<boolean name="use_grid_bbox" value="true"/>' if placement != "to_world" else ""
    volume = f'<volume type="gridvolume" name="sigma_t"><string name="filename" value="g.vol"/>{to_world}{bbox}</volume>'
    (tmp_path / "v.xml").write_text(f'<volume version="3.0.0" type="gridvolume"><string name="filename" '
                                    f'value="{tmp_path / "g.vol"}"/>{to_world}{bbox}</volume>')
    theirs = mi.load_file(str(tmp_path / "v.xml"))
    path = tmp_path / "scene.xml"
    path.write_text(f"""<scene version="3.0.0"><integrator type="volpath"/>
        <sensor type="perspective"><medium type="heterogeneous">{volume}</medium></sensor></scene>""")
    grid = load_quietly(path).media[0].grid
    rng = np.random.default_rng(1)
    unit = rng.uniform(0.002, 0.998, (200, 3))
    world = unit @ grid.to_world[:3, :3].T + grid.to_world[:3, 3]
    expected = grids.trilinear(density, unit)
    for point, value in zip(world, expected):
        interaction = mi.Interaction3f()
        interaction.p = mi.Point3f(*point)
        assert abs(theirs.eval_1(interaction) - value) < 2e-5 * max(1.0, value), point


def environment_samples(context, queue, scene, count):
    """(directions, radiance, radiance looked up again from the direction) of `count`
    environment light samples drawn by the kernel (tests.cl sample_environment) in the world of
    `scene`: the sampler's lookup at the (u, v) it drew, and an escaped ray's."""
    arrays = build_scene_arrays(scene)
    mf = cl.mem_flags
    inputs = [cl.Buffer(context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=x)
              for x in (render_params(scene, arrays, 0, 1, 1, 1, 0), arrays.env_texels, arrays.env_cdf)]
    out, radiance, looked_up = (np.empty((count, 4), np.float32) for _ in range(3))
    outputs = [cl.Buffer(context, mf.WRITE_ONLY, a.nbytes) for a in (out, radiance, looked_up)]
    build_test_kernels(context, ENVIRONMENT=2).sample_environment(queue, (count,), None, *inputs, np.uint32(3), *outputs)
    for host, buffer in zip((out, radiance, looked_up), outputs):
        cl.enqueue_copy(queue, host, buffer)
    return out[:, :3], radiance[:, :3], looked_up[:, :3]


@pytest.mark.parametrize("suffix", [".exr", ".hdr"])
def test_envmap_lookup_matches_mitsuba_in_numpy_and_in_the_kernel(context, queue, tmp_path, suffix):
    image = mitsuba_scenes.sky_image(12, 7)
    image[3, 5] = (9.0, 0.1, 2.0)   # a sharp texel shows any misplacement
    path = tmp_path / f"sky{suffix}"
    write_float_image(image, path)
    image = clrender.load_image(path)   # Radiance HDR rounds to 8-bit mantissas: Mitsuba reads the same
    rotation = '<rotate y="1" angle="70"/><rotate x="1" angle="25"/>'
    xml = (f'<emitter version="3.0.0" type="envmap"><string name="filename" value="{path}"/>'
           f'<transform name="to_world">{rotation}</transform></emitter>')
    emitter = mi.load_string(xml)
    matrix = np.array(mi.traverse(emitter)["to_world"].matrix)

    def theirs(directions):
        values = []
        for d in directions:
            si = mi.SurfaceInteraction3f()
            si.wi = mi.Vector3f(*(-d))
            values.append(np.array(emitter.eval(si)))
        return np.array(values)

    rng = np.random.default_rng(2)
    directions = rng.normal(size=(300, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    assert np.allclose(mitsuba_envmap_lookup(image, directions @ matrix[:3, :3]), theirs(directions), rtol=1e-5, atol=1e-6)
    # The kernel's lookup "mitsuba" (kernels/lights.h) of the scene the XML reader makes, at the
    # directions its light sampling draws (many by the sharp texel): float32 angles.
    scene_file = tmp_path / "scene.xml"
    emitter_xml = xml.replace(' version="3.0.0"', "")
    scene_file.write_text(f'<scene version="3.0.0"><sensor type="perspective"/>{emitter_xml}</scene>')
    scene = load_quietly(scene_file)
    directions, sampled, looked_up = environment_samples(context, queue, scene, 300)
    for ours in (sampled, looked_up):
        np.testing.assert_allclose(ours, theirs(directions.astype(float)), rtol=1e-4, atol=1e-4)


@pytest.mark.parametrize("plugin", [{"type": "gaussian"}, {"type": "gaussian", "stddev": 1.3}, {"type": "tent"},
                                    {"type": "tent", "radius": 2.5}], ids=lambda p: str(p))
def test_pixel_filters_are_mitsubas(plugin):
    theirs = mi.load_dict(plugin)
    ours = Filter(**plugin)
    assert np.isclose(theirs.radius(), filters.radius(ours), rtol=1e-6)
    t = np.linspace(-1.2, 1.2, 241) * filters.radius(ours)
    # Mitsuba's gaussian evaluates exp with an approximation good to 4e-4 (of the peak, 1).
    np.testing.assert_allclose([theirs.eval(float(x)) for x in t], filters.evaluate(ours, t),
                               atol=5e-4 if ours.type == "gaussian" else 1e-6)


def write_float_image(image, path):
    """A float RGB image written with OpenImageIO (any format it writes: .exr, .hdr)."""
    import OpenImageIO as oiio

    output = oiio.ImageOutput.create(str(path))
    assert output.open(str(path), oiio.ImageSpec(image.shape[1], image.shape[0], 3, "float"))
    assert output.write_image(np.ascontiguousarray(image, dtype=np.float32))
    output.close()


def test_conductor_presets_are_mitsubas():
    # Every preset Mitsuba ships, with the RGB eta and k its conductor holds (float32: exact).
    folder = Path(mi.__file__).parent / "data" / "ior"
    assert sorted(CONDUCTOR_PRESETS) == sorted(p.name[:-len(".eta.spd")] for p in folder.glob("*.eta.spd"))
    for name, (eta, k) in CONDUCTOR_PRESETS.items():
        theirs = mi.traverse(mi.load_dict({"type": "conductor", "material": name}))
        assert np.array_equal(np.float32(eta), np.array(theirs["eta.value"], np.float32)), name
        assert np.array_equal(np.float32(k), np.array(theirs["k.value"], np.float32)), name


@pytest.mark.parametrize("material", [{"material": "Au"}, {"material": "AlSb"}, {"material": "none"},
                                      {"eta": [0.2, 0.92, 1.1], "k": [3.9, 2.45, 2.14]}])
def test_conductor_fresnel_is_mitsubas(device, material):
    # The weight of a smooth conductor's sample (specular_reflectance x Fresnel) at angles from
    # normal incidence to grazing, against Mitsuba's conductor (AlSb: Mitsuba's own is NaN at
    # normal incidence, where its red channel, eta = k = 0, divides 0 by 0; the limit is 1).
    from test_dielectric import Bsdf, direction
    from conftest import build_test_kernels
    import pyopencl as cl

    tint = [0.9, 0.8, 0.7]
    theirs_dict = {"type": "conductor", "specular_reflectance": {"type": "rgb", "value": tint}}
    ours_dict = {"type": "conductor", "tint": tint}
    if "eta" in material:
        theirs_dict.update(eta={"type": "rgb", "value": material["eta"]}, k={"type": "rgb", "value": material["k"]})
        ours_dict.update(material)
    else:
        theirs_dict["material"] = material["material"]
        if material["material"] != "none":
            ours_dict["material"] = material["material"]
    bsdf = mi.load_dict(theirs_dict)
    context = cl.Context([device])
    queue = cl.CommandQueue(context)
    ours = Bsdf(context, queue, build_test_kernels(context, DIELECTRIC=1), ours_dict)
    for cos in (1.0, 0.9, 0.6, 0.3, 0.1, 0.02):
        si = mi.SurfaceInteraction3f()
        si.wi = mi.Vector3f(*direction(cos))
        _, weight = bsdf.sample(mi.BSDFContext(), si, 0.5, mi.Point2f(0.5, 0.5))
        expected = np.array(weight)
        if material.get("material") == "AlSb" and cos == 1.0:
            expected[0] = tint[0]
        _, _, ours_weight, _, _ = ours.sample(direction(cos), 1)
        np.testing.assert_allclose(ours_weight[0], expected, rtol=2e-5, err_msg=str(cos))


@pytest.mark.parametrize("kind", ["roughconductor", "roughdielectric"])
@pytest.mark.parametrize("alpha", [0.2, 0.6])
def test_beckmann_directional_albedo_is_mitsubas(device, kind, alpha):
    # Single-scattering Beckmann lobes lose the light their microfacets shadow: their directional
    # albedo E(mu), the mean sample weight at cos(wo) = mu (the radiance 1/eta^2 of refraction
    # included in both), ours as read from XML (separable masking, no compensation) against
    # Mitsuba's, within 5 standard errors of the difference.
    from test_dielectric import Bsdf, direction
    from conftest import build_test_kernels
    import pyopencl as cl

    count = 20000
    theirs_bsdf = mi.load_dict({"type": kind, "distribution": "beckmann", "alpha": alpha, "int_ior": 1.5,
                                "ext_ior": 1.0} if kind == "roughdielectric" else
                               {"type": kind, "distribution": "beckmann", "alpha": alpha})
    context = cl.Context([device])
    ours_bsdf = Bsdf(context, cl.CommandQueue(context), build_test_kernels(context, DIELECTRIC=1),
                     {"type": "dielectric" if kind == "roughdielectric" else "conductor", "roughness": np.sqrt(alpha),
                      "distribution": "beckmann", "masking": "separable", "energy_compensation": False,
                      **({"ior": 1.5} if kind == "roughdielectric" else {})})
    rng = np.random.default_rng(12)
    for mu in (1.0, 0.7, 0.4, 0.15):
        si = mi.SurfaceInteraction3f()
        si.wi = mi.Vector3f(*direction(mu))
        theirs = np.empty(count)
        for i, u in enumerate(rng.uniform(size=(count, 3))):
            _, weight = theirs_bsdf.sample(mi.BSDFContext(), si, u[0], mi.Point2f(u[1], u[2]))
            theirs[i] = weight[0]
        _, pdf, weight, _, _ = ours_bsdf.sample(direction(mu), count, seed=21)
        ours = np.where(pdf > 0, weight[:, 0], 0.0)
        se = np.sqrt(ours.var() / count + theirs.var() / count)
        assert abs(ours.mean() - theirs.mean()) < 5 * se, (mu, ours.mean(), theirs.mean(), se)


def test_named_iors_are_mitsubas():
    for name, ior in IOR_PRESETS.items():
        bsdf = mi.load_dict({"type": "dielectric", "int_ior": name, "ext_ior": "vacuum"})
        assert np.isclose(mi.traverse(bsdf)["eta"], ior, rtol=1e-6), name


@pytest.mark.parametrize("spectrum", [[(400, 1), (500, 2), (600, 1), (700, 1)],
                                      [(380, 0.1), (450, 0.5), (560, 0.9), (620, 0.2), (780, 0.3)]])
@pytest.mark.parametrize("illuminant", [False, True])
def test_spectra_convert_as_in_mitsuba(spectrum, illuminant):
    wavelengths, values = zip(*spectrum)
    theirs = np.array(mi.spectrum_list_to_srgb(list(wavelengths), list(values), bounded=False, d65=not illuminant))
    ours = cie.spectrum_to_rgb(wavelengths, values, illuminant=illuminant)
    assert np.allclose(ours, theirs, rtol=3e-3, atol=1e-4)


def test_spectrum_values_reach_the_scene_as_in_mitsuba(tmp_path):
    # <spectrum> on a reflectance (D65-weighted, clamped), a uniform one on an emitter (an
    # equal-energy illuminant), a sampled one on an emitter (no D65), <float> on an emitter.
    (tmp_path / "s.xml").write_text("""<scene version="3.0.0"><sensor type="perspective"/>
        <shape type="sphere" id="a"><bsdf type="diffuse">
            <spectrum name="reflectance" value="400:0.1, 500:0.5, 600:0.9, 700:0.2"/></bsdf></shape>
        <emitter type="point" id="b"><spectrum name="intensity" value="3"/></emitter>
        <emitter type="directional" id="c"><spectrum name="irradiance" value="400:1, 500:2, 600:1, 700:1"/></emitter>
        <emitter type="constant" id="d"><float name="radiance" value="0.4"/></emitter>
    </scene>""")
    theirs = mi.traverse(mi.load_file(str(tmp_path / "s.xml")))
    scene = read_scene(tmp_path / "s.xml").scene
    ours = {"a.bsdf.reflectance.value": scene["materials"][0]["albedo"],
            "b.intensity.value": scene["lights"][0]["intensity"],
            "c.irradiance.value": scene["lights"][1]["irradiance"],
            "d.radiance.value": scene["lights"][2]["radiance"]}
    for key, value in ours.items():
        assert np.allclose(np.array(theirs[key]), value, rtol=3e-3), key


def test_transforms_compose_as_in_mitsuba(tmp_path):
    operations = """<translate x="1" y="-2"/><rotate value="1, 2, 3" angle="37"/><scale x="2" y="0.5" z="3"/>
        <matrix value="1 0.2 0 1  0 1 0 2  0.1 0 1 3  0 0 0 1"/><rotate z="1" angle="-20"/>
        <lookat origin="1, 1, 1" target="0, 0, 0" up="0, 0, 1"/><scale value="1.5"/>"""
    (tmp_path / "s.xml").write_text(f"""<scene version="3.0.0"><sensor type="perspective"/>
        <shape type="rectangle" id="r"><transform name="to_world">{operations}</transform></shape></scene>""")
    theirs = np.array(mi.traverse(mi.load_file(str(tmp_path / "s.xml")))["r.to_world"].matrix)
    ours = read_scene(tmp_path / "s.xml").scene["shapes"][0]["transform"]["matrix"]
    assert np.allclose(ours, theirs, atol=1e-5)


@pytest.mark.parametrize("target", ["1, 2, 0.5", "0, 0, 0.5", "0, -3, 0", "-2, 1, -0.3"])
def test_lookat_with_a_zero_up_is_mitsubas(tmp_path, target):
    # A real scene (nppm-classroom) aims a spot light so: Mitsuba then picks the up axis.
    (tmp_path / "s.xml").write_text(f"""<scene version="3.0.0"><sensor type="perspective"/>
        <shape type="rectangle" id="r"><transform name="to_world">
        <lookat origin="0, 1, 0" target="{target}" up="0, 0, 0"/></transform></shape></scene>""")
    theirs = np.array(mi.traverse(mi.load_file(str(tmp_path / "s.xml")))["r.to_world"].matrix)
    ours = read_scene(tmp_path / "s.xml").scene["shapes"][0]["transform"]["matrix"]
    assert np.allclose(ours, theirs, atol=1e-6)


@pytest.mark.parametrize("wrap", textures.WRAPS)
@pytest.mark.parametrize("channels,raw", [(1, True), (3, False), (1, False)])
def test_texture_gradients_are_mitsubas_eval_1_grad(wrap, channels, raw):
    # Bilinear bitmaps (8-bit, sRGB-decoded unless raw) under a turned, stretched to_uv on a
    # non-square image, where Mitsuba scales by the resolution after to_uv's transpose.
    rng = np.random.default_rng(channels + 2 * raw)
    pixels = rng.integers(0, 256, (4, 7, channels), dtype=np.uint8)
    to_uv = mi.ScalarTransform4f().translate([0.1, -0.2, 0]).rotate([0, 0, 1], 35).scale([1.7, 0.6, 1])
    bitmap = mi.Bitmap(pixels, mi.Bitmap.PixelFormat.Y if channels == 1 else mi.Bitmap.PixelFormat.RGB)
    bitmap.set_srgb_gamma(not raw)
    theirs = mi.load_dict({"type": "bitmap", "bitmap": bitmap, "raw": raw, "wrap_mode": wrap, "to_uv": to_uv})
    ours = textures.Texture("t", "bitmap", pixels=pixels, srgb=not raw, wrap=wrap,
                            to_uv=np.array(to_uv.matrix)[:2][:, [0, 1, 3]])
    uv = rng.uniform(-1.5, 2.5, (300, 2))
    si = mi.SurfaceInteraction3f()
    expected = []
    for point in uv:
        si.uv = mi.Point2f(*point)
        expected.append(np.array(theirs.eval_1_grad(si)))
    expected = np.array(expected)
    assert np.abs(expected).max() > 1
    np.testing.assert_allclose(textures.lookup_number_gradient(ours, uv), expected, rtol=1e-4,
                               atol=1e-5 * np.abs(expected).max())


def test_default_bsdfs_of_shapes_are_mitsubas(tmp_path):
    # No BSDF: diffuse 0.5; no BSDF but an area emitter: black.
    xml = """<scene version="3.0.0"><sensor type="perspective"/>
        <shape type="sphere"/>
        <shape type="sphere"><emitter type="area"/></shape>
    </scene>"""
    (tmp_path / "s.xml").write_text(xml)
    shapes = mi.load_file(str(tmp_path / "s.xml")).shapes()
    theirs = sorted(float(np.mean(mi.traverse(shape.bsdf())["reflectance.value"])) for shape in shapes)
    scene = read_scene(tmp_path / "s.xml").scene
    ours = sorted(float(np.mean(scene["materials"][i]["albedo"])) for i in (0, 1))
    assert theirs == ours == [0.0, 0.5]
