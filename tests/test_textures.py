"""Textures: the kernel's lookups against the numpy reference (clrender/textures.py), material
parameters resolved from them, and renders whose pixels are a texture's values.

Lookups are compared at float32 rounding (the kernel reduces repeating coordinates into one
period before scaling, the reference does not). Renders use max_depth 1 (emission seen
directly), so a pixel is the mean of the texture over the points its samples hit: exactly a
texel's value where every sample lands in one texel of a nearest-filtered texture."""
import numpy as np
import pyopencl as cl
import pytest

import clrender
from clrender import layout, textures
from clrender.device import kernel_dir
from conftest import build_test_kernels, camera


@pytest.fixture(scope="module")
def program(context):
    return build_test_kernels(context, TEXTURES=1)


def test_srgb_table_header_is_generated_from_the_reference():
    assert (kernel_dir() / "textures" / "srgb8.h").read_text() == textures.srgb8_header()
    table = textures.srgb8_table()
    assert table[0] == 0 and table[255] == 1 and np.all(np.diff(table) > 0)


def kernel_lookup(context, queue, program, texture_list, index, uv):
    records, texels = textures.texture_arrays(texture_list)
    uv = np.ascontiguousarray(uv, np.float32).reshape(-1, 2)
    out = np.empty((len(uv), 4), np.float32)
    mf = cl.mem_flags
    buffers = [cl.Buffer(context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=a) for a in (records, texels, uv)]
    out_buffer = cl.Buffer(context, mf.WRITE_ONLY, out.nbytes)
    cl.Kernel(program, "eval_texture_values")(queue, (len(uv),), None, buffers[0], buffers[1], np.int32(index), buffers[2],
                                out_buffer)
    cl.enqueue_copy(queue, out, out_buffer)
    return out[:, :3], out[:, 3]


def random_image(rng, height, width, channels, dtype):
    if dtype == np.uint8:
        return rng.integers(0, 256, (height, width, channels), dtype=np.uint8)
    return rng.uniform(0, 4, (height, width, channels)).astype(np.float32)


def sample_points(rng, texture):
    """uv spread over several periods (negative too), and the texel centres of the first one."""
    spread = rng.uniform(-2.3, 3.1, (4000, 2))
    if texture.pixels is None:
        return spread
    height, width = texture.pixels.shape[:2]
    i, j = np.meshgrid((np.arange(width) + 0.5) / width, (np.arange(height) + 0.5) / height)
    return np.concatenate([spread, np.stack([i.ravel(), j.ravel()], axis=1)])


def away_from_texel_edges(texture, uv, margin=1e-3):
    """Points whose nearest-filter texel cannot change with float32 rounding."""
    st = uv @ texture.to_uv[:, :2].T + texture.to_uv[:, 2]
    height, width = texture.pixels.shape[:2]
    scaled = st * [width, height]
    return np.all(np.abs(scaled - np.round(scaled)) > margin * np.array([width, height]), axis=1)


BITMAPS = [  # (channels, dtype, srgb)
    (3, np.uint8, True), (3, np.uint8, False), (1, np.uint8, True), (4, np.uint8, True),
    (1, np.float32, False), (3, np.float32, False), (4, np.float32, False)]


@pytest.mark.parametrize("channels,dtype,srgb", BITMAPS,
                         ids=lambda v: v.__name__ if isinstance(v, type) else str(v))
@pytest.mark.parametrize("filter_", textures.FILTERS)
@pytest.mark.parametrize("wrap", textures.WRAPS)
def test_bitmap_lookup_matches_the_reference(context, queue, program, channels, dtype, srgb, filter_, wrap):
    rng = np.random.default_rng(channels * 7 + srgb)
    # Another texture first, so this one's texels start at an offset (float ones: aligned).
    first = textures.Texture("first", "bitmap", pixels=random_image(rng, 3, 5, 3, np.uint8), srgb=True)
    texture = textures.Texture("t", "bitmap", pixels=random_image(rng, 7, 11, channels, dtype), srgb=srgb,
                               filter=filter_, wrap=wrap, to_uv=np.array([[1.5, 0.2, 0.1], [-0.3, 0.8, 0.25]]))
    uv = sample_points(rng, texture)
    rgb, number = kernel_lookup(context, queue, program, [first, texture], 1, uv)
    expected = textures.lookup(texture, uv)
    expected_number = textures.lookup_number(texture, uv)
    keep = away_from_texel_edges(texture, uv) if filter_ == "nearest" else np.ones(len(uv), bool)
    assert keep.sum() > 3000
    np.testing.assert_allclose(rgb[keep], expected[keep], rtol=2e-5, atol=2e-5)
    np.testing.assert_allclose(number[keep], expected_number[keep], rtol=2e-5, atol=2e-5)


def kernel_gradient(context, queue, program, texture_list, index, uv):
    records, texels = textures.texture_arrays(texture_list)
    uv = np.ascontiguousarray(uv, np.float32).reshape(-1, 2)
    out = np.empty((len(uv), 2), np.float32)
    mf = cl.mem_flags
    buffers = [cl.Buffer(context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=a) for a in (records, texels, uv)]
    out_buffer = cl.Buffer(context, mf.WRITE_ONLY, out.nbytes)
    cl.Kernel(program, "texture_gradient_values")(queue, (len(uv),), None, buffers[0], buffers[1], np.int32(index),
                                                  buffers[2], out_buffer)
    cl.enqueue_copy(queue, out, out_buffer)
    return out


@pytest.mark.parametrize("channels,dtype,srgb", BITMAPS[:5], ids=lambda v: v.__name__ if isinstance(v, type) else str(v))
@pytest.mark.parametrize("wrap", textures.WRAPS)
def test_bitmap_gradient_matches_the_reference(context, queue, program, channels, dtype, srgb, wrap):
    rng = np.random.default_rng(channels * 5 + srgb)
    first = textures.Texture("first", "bitmap", pixels=random_image(rng, 3, 5, 3, np.uint8), srgb=True)
    texture = textures.Texture("t", "bitmap", pixels=random_image(rng, 7, 11, channels, dtype), srgb=srgb,
                               wrap=wrap, to_uv=np.array([[1.5, 0.2, 0.1], [-0.3, 0.8, 0.25]]))
    uv = sample_points(rng, texture)
    # Off texel centres, where the one-sided derivative may take either side after rounding.
    st = uv @ texture.to_uv[:, :2].T + texture.to_uv[:, 2]
    centred = st * [11, 7] - 0.5
    keep = np.all(np.abs(centred - np.round(centred)) > 1e-3, axis=1)
    gradient = kernel_gradient(context, queue, program, [first, texture], 1, uv)
    expected = textures.lookup_number_gradient(texture, uv)
    scale = np.abs(expected).max()
    np.testing.assert_allclose(gradient[keep], expected[keep], rtol=1e-4, atol=1e-5 * scale)


def test_gradient_is_the_derivative_of_the_lookup():
    # Central differences of lookup_number inside the cells (square texture, diagonal to_uv:
    # where Mitsuba's order of the resolution and to_uv factors is the chain rule), and 0 for
    # piecewise constant textures.
    rng = np.random.default_rng(8)
    texture = textures.Texture("t", "bitmap", pixels=random_image(rng, 6, 6, 3, np.uint8), srgb=True,
                               to_uv=np.array([[2.0, 0.0, 0.3], [0.0, -1.5, 0.1]]))
    uv = rng.uniform(-1, 2, (500, 2))
    centred = (uv @ texture.to_uv[:, :2].T + texture.to_uv[:, 2]) * 6 - 0.5
    uv = uv[np.all(np.abs(centred - np.round(centred)) > 1e-4, axis=1)]   # not across a cell's edge
    h = 1e-6
    central = np.stack([(textures.lookup_number(texture, uv + d) - textures.lookup_number(texture, uv - d)) / (2 * h)
                        for d in (np.array([h, 0]), np.array([0, h]))], axis=1)
    assert len(uv) > 450
    np.testing.assert_allclose(textures.lookup_number_gradient(texture, uv), central, rtol=1e-5, atol=1e-6)
    for flat in (textures.Texture("c", "checkerboard"), textures.Texture("n", "bitmap", pixels=texture.pixels,
                                                                          filter="nearest")):
        assert np.all(textures.lookup_number_gradient(flat, uv) == 0)


@pytest.mark.parametrize("channels, dtype, srgb", [(3, np.uint8, True), (1, np.uint8, True), (4, np.uint8, False),
                                                   (3, np.float32, False)])
def test_bitmap_mean_is_the_float32_mean_of_its_linear_texels(channels, dtype, srgb, tmp_path, monkeypatch):
    # Texture.mean decodes block by block: the bits of numpy's mean over the decoded image (its
    # running float32 sum), on images of more texels than a block and not a multiple of one.
    monkeypatch.setenv("CLRENDER_CACHE_DIR", str(tmp_path))   # computed, not read from an earlier run
    rng = np.random.default_rng(9)
    height = 2 * textures._MEAN_BLOCK // 97 + 3
    texture = textures.Texture("t", "bitmap", pixels=random_image(rng, height, 97, channels, dtype), srgb=srgb)
    whole = textures._as_rgb(textures._linear(texture.pixels, srgb)).reshape(-1, 3).mean(axis=0)
    assert texture.mean().dtype == whole.dtype
    np.testing.assert_array_equal(texture.mean(), whole)


def test_bitmap_mean_is_kept_until_the_pixels_are_replaced():
    # Texture.mean remembers its value (build_scene_arrays computes it beside the BVH build);
    # new pixels, or another encoding, give a new mean.
    texture = textures.Texture("t", "bitmap", pixels=np.zeros((2, 3, 3), np.uint8), srgb=True)
    assert np.all(texture.mean() == 0) and texture.mean() is texture.mean()
    texture.pixels = np.full((2, 3, 3), 128, np.uint8)
    np.testing.assert_allclose(texture.mean(), textures.srgb8_table()[128], rtol=1e-6)
    texture.srgb = False
    np.testing.assert_allclose(texture.mean(), 128 / 255, rtol=1e-6)


def test_a_bitmap_mean_is_computed_once_per_image(tmp_path, monkeypatch):
    # Later processes (here: other Texture objects of the same texels) read it from the disk
    # cache, the bits computed; other texels or another encoding are computed.
    monkeypatch.setenv("CLRENDER_CACHE_DIR", str(tmp_path))
    computed = []
    compute = textures.Texture._bitmap_mean
    monkeypatch.setattr(textures.Texture, "_bitmap_mean", lambda self: computed.append(1) or compute(self))
    pixels = random_image(np.random.default_rng(4), 40, 30, 3, np.uint8)
    first = textures.Texture("a", "bitmap", pixels=pixels, srgb=True).mean()
    again = textures.Texture("b", "bitmap", pixels=pixels.copy(), srgb=True).mean()
    assert len(computed) == 1 and again.dtype == first.dtype and np.array_equal(again, first)
    textures.Texture("c", "bitmap", pixels=pixels, srgb=False).mean()
    other = pixels.copy()
    other[0, 0, 0] ^= 1
    textures.Texture("d", "bitmap", pixels=other, srgb=True).mean()
    assert len(computed) == 3


def test_bitmap_values_are_mitsubas_conventions():
    # Row 0 at v = 0; bilinear weights between texel centres; sRGB decoded before filtering.
    pixels = np.array([[[0], [255]], [[255], [255]]], np.uint8)
    texture = textures.Texture("t", "bitmap", pixels=pixels, srgb=True, wrap="clamp")
    values = textures.lookup(texture, np.array([[0.25, 0.25], [0.5, 0.25], [0.75, 0.75]]))[:, 0]
    np.testing.assert_allclose(values, [0.0, 0.5, 1.0])
    grey = textures.Texture("g", "bitmap", pixels=np.array([[[10], [200]]], np.uint8), srgb=True)
    # Mitsuba 3.9's bitmap (scalar_rgb) gives 0.290308 halfway between these two texels.
    assert textures.lookup_number(grey, np.array([[0.5, 0.5]]))[0] == pytest.approx(0.290308, abs=1e-6)


@pytest.mark.parametrize("to_uv", [np.eye(3)[:2], np.array([[3.0, 0.0, 0.25], [0.0, 2.0, -0.1]])])
def test_checkerboard_lookup_matches_the_reference(context, queue, program, to_uv):
    rng = np.random.default_rng(5)
    texture = textures.Texture("c", "checkerboard", to_uv=to_uv, color0=np.array([0.9, 0.5, 0.1]),
                               color1=np.array([0.05, 0.2, 0.7]))
    uv = rng.uniform(-2, 2, (4000, 2))
    st = uv @ to_uv[:, :2].T + to_uv[:, 2]
    frac = st - np.floor(st)
    keep = np.all(np.abs(frac - 0.5) > 1e-4, axis=1) & np.all(np.abs(frac) > 1e-4, axis=1)
    rgb, number = kernel_lookup(context, queue, program, [texture], 0, uv)
    np.testing.assert_allclose(rgb[keep], textures.lookup(texture, uv)[keep], rtol=1e-6)
    np.testing.assert_allclose(number[keep], textures.lookup_number(texture, uv)[keep], rtol=1e-5)


def test_checkerboard_numbers_are_mitsubas_eval_1():
    # Mitsuba 3.9's checkerboard eval_1 (a texture driving a number: roughness, metallic...)
    # swaps the colours against eval and takes a constant colour's channel mean: values read
    # from Mitsuba (scalar_rgb) at the centres of the four checks of the unit square.
    texture = textures.Texture("c", "checkerboard", color0=np.array([0.9, 0.5, 0.1]), color1=np.array([0.05, 0.2, 0.7]))
    uv = np.array([[0.25, 0.25], [0.75, 0.25], [0.3, 0.8], [0.9, 0.9]])
    np.testing.assert_allclose(textures.lookup(texture, uv)[:, 0], [0.9, 0.05, 0.05, 0.9])
    np.testing.assert_allclose(textures.lookup_number(texture, uv), [0.3166667, 0.5, 0.5, 0.3166667], rtol=1e-6)


def test_resolved_material_takes_colours_and_numbers_from_its_textures(context, queue, program):
    rng = np.random.default_rng(2)
    colour = textures.Texture("c", "bitmap", pixels=random_image(rng, 4, 4, 3, np.uint8), srgb=True)
    number = textures.Texture("n", "bitmap", pixels=random_image(rng, 5, 3, 3, np.float32))
    records, texels = textures.texture_arrays([colour, number])
    material = np.zeros(1, layout.MATERIAL)
    layout.clear_texture_references(material)
    material["slot"][0, :, :3] = np.arange(3 * layout.MATERIAL_SLOTS).reshape(-1, 3)
    material["emission"][0, :3] = 7.0
    layout.set_field(material, layout.MATERIAL_FIELDS, "ior", 1.33)
    layout.set_texture_reference(material, "color", 0)
    layout.set_texture_reference(material, "alpha", 1)
    layout.set_texture_reference(material, "emission", 1)
    uv = rng.uniform(0, 1, (64, 2)).astype(np.float32)
    stride = layout.MATERIAL_SLOTS + 1
    out = np.empty((len(uv) * stride, 4), np.float32)
    mf = cl.mem_flags
    buffers = [cl.Buffer(context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=a) for a in (material, records, texels, uv)]
    out_buffer = cl.Buffer(context, mf.WRITE_ONLY, out.nbytes)
    cl.Kernel(program, "resolve_material_values")(queue, (len(uv),), None, *buffers, out_buffer)
    cl.enqueue_copy(queue, out, out_buffer)
    out = out.reshape(len(uv), stride, 4)
    np.testing.assert_allclose(out[:, 0, :3], textures.lookup(colour, uv), rtol=2e-5, atol=1e-6)
    np.testing.assert_allclose(out[:, 1, 0], textures.lookup_number(number, uv), rtol=2e-5)
    np.testing.assert_array_equal(out[:, 1, 1:3], np.broadcast_to(material["slot"][0, 1, 1:3], (len(uv), 2)))
    np.testing.assert_allclose(out[:, layout.MATERIAL_SLOTS, :3], textures.lookup(number, uv), rtol=2e-5)
    untouched = [k for k in range(layout.MATERIAL_SLOTS) if k not in (0, 1)]
    np.testing.assert_array_equal(out[:, untouched], np.broadcast_to(material["slot"][0, untouched], (len(uv), len(untouched), 4)))
    assert out[0, 2, 0] == np.float32(1.33)


# ----- renders -----------------------------------------------------------------------------------
def emitting_scene(shape, texture, resolution=(48, 48), view=None):
    return clrender.load_scene_dict({
        "camera": view or camera(position=(0, 0, 4), look_at=(0, 0, 0), fov=40, resolution=resolution),
        "textures": [texture],
        "materials": [{"name": "glow", "type": "emissive", "radiance": {"texture": texture["name"]}}],
        "shapes": [{**shape, "material": "glow"}],
        "render": {"max_depth": 1},
    })


def compare_interior(image, scene, texture_at):
    """Pixels whose whole footprint (a 5 x 5 grid over the pixel, edges included) sees one value
    of `texture_at(origin, directions)` ((..., 3); NaN where nothing is hit) show exactly it."""
    width, height = scene.camera.resolution
    values = []
    for fy in np.linspace(0, 1, 5):
        for fx in np.linspace(0, 1, 5):
            x, y = np.meshgrid(np.arange(width) + fx, np.arange(height) + fy)
            values.append(texture_at(scene.camera.position, scene.camera.pixel_directions(x, y)))
    values = np.stack(values)
    interior = np.all(values == values[:1], axis=(0, 3)) & ~np.isnan(values[0, ..., 0])
    assert interior.sum() > 200
    np.testing.assert_allclose(image[interior], values[0][interior], rtol=1e-6)


def test_textured_emission_on_a_sphere_follows_mitsubas_sphere_uv(device):
    # A checkerboard of 8 x 4 checks on a rotated sphere: pixels whose samples all hit one check
    # show exactly its colour, at the uv Mitsuba's sphere gives.
    checks = {"name": "checks", "type": "checkerboard", "color0": [2.0, 1.0, 0.5], "color1": [0.1, 0.3, 0.9],
              "to_uv": [[4.0, 0.0, 0.0], [0.0, 2.0, 0.0]]}
    shape = {"type": "sphere", "radius": 1.2, "center": [0.1, -0.1, 0.0],
             "transform": {"rotate": [70, 20, 0]}}
    scene = emitting_scene(shape, checks)
    image = clrender.Renderer(scene, device).render(spp=16, seed=1).image
    sphere = scene.shapes[0].mesh

    def texture_at(origin, directions):
        to_centre = origin - sphere.center
        b = directions @ to_centre
        c = to_centre @ to_centre - sphere.radius ** 2
        t = -b - np.sqrt(np.maximum(b * b - c, 0))
        points = origin + t[..., None] * directions
        q = (points - sphere.center) / sphere.radius @ sphere.rotation
        uv = np.stack([np.mod(np.arctan2(q[..., 1], q[..., 0]), 2 * np.pi) / (2 * np.pi),
                       np.arccos(np.clip(q[..., 2], -1, 1)) / np.pi], axis=-1)
        return np.where((b * b - c > 0)[..., None], textures.lookup(scene.textures[0], uv), np.nan)

    compare_interior(image, scene, texture_at)


def test_textured_emission_on_a_mesh_without_uv_uses_barycentrics(device, tmp_path):
    # A mesh without texture coordinates has Mitsuba's uv = (b1, b2) of each triangle.
    (tmp_path / "tri.obj").write_text("v -1.5 -1.5 0\nv 1.5 -1.5 0\nv -1.5 1.5 0\nf 1 2 3\n")
    rng = np.random.default_rng(4)
    image_texture = {"name": "img", "type": "bitmap", "filter": "nearest",
                     "image": rng.integers(0, 256, (6, 6, 3), dtype=np.uint8)}
    scene = emitting_scene({"type": "mesh", "file": str(tmp_path / "tri.obj")}, image_texture)
    image = clrender.Renderer(scene, device).render(spp=16, seed=2).image

    def texture_at(origin, directions):
        points = origin + (-origin[2] / directions[..., 2])[..., None] * directions
        uv = (points[..., :2] + 1.5) / 3.0       # b1 along +x, b2 along +y
        inside = (uv.sum(axis=-1) < 1) & np.all(uv > 0, axis=-1)
        return np.where(inside[..., None], textures.lookup(scene.textures[0], uv), np.nan)

    compare_interior(image, scene, texture_at)


def test_textured_emitter_lights_by_its_texture(device, tmp_path):
    # Next-event estimation must see the texture too: a diffuse floor lit by an emitting triangle
    # whose (barycentric) uv show black for b1 < 0.5 and white beyond gets the light of that
    # quarter of the triangle only, as a constant emitter covering just that quarter gives it.
    (tmp_path / "lamp.obj").write_text("v -1 1 -1\nv 1 1 -1\nv -1 1 1\nf 1 2 3\n")
    (tmp_path / "quarter.obj").write_text("v 0 1 -1\nv 1 1 -1\nv 0 1 0\nf 1 2 3\n")

    def render(lamp_file, radiance, seed):
        scene = clrender.load_scene_dict({
            "camera": camera(position=(0, 0.3, 3), look_at=(0, 0, 0), fov=20, resolution=(24, 24)),
            "textures": [{"name": "half", "type": "bitmap", "filter": "nearest", "raw": True,
                          "image": np.array([[[0], [255]]], np.uint8)}],
            "materials": [{"name": "floor", "type": "diffuse", "albedo": [0.8] * 3},
                          {"name": "lamp", "type": "emissive", "radiance": radiance}],
            "shapes": [{"type": "rectangle", "material": "floor", "transform": {"rotate": [-90, 0, 0], "scale": 2}},
                       {"type": "mesh", "file": str(tmp_path / lamp_file), "material": "lamp"}],
            "render": {"max_depth": 2},
        })
        return clrender.Renderer(scene, device).render(spp=256, seed=seed).image

    textured = render("lamp.obj", {"texture": "half"}, 5)
    constant = render("quarter.obj", 1.0, 6)
    difference = (textured - constant)[..., 0].ravel()
    standard_error = difference.std(ddof=1) / np.sqrt(difference.size)
    assert abs(difference.mean()) < 5 * standard_error
    # Sharp enough to tell: the whole triangle would give about 4x the light of its quarter.
    assert standard_error < 0.05 * constant[..., 0].mean()


def test_texture_errors_name_their_place():
    base = {"camera": camera(), "materials": [], "shapes": []}
    cases = [
        ({"textures": [{"name": "t", "type": "bitmap"}]}, "textures[0]", "either a `file` or an `image`"),
        ({"textures": [{"name": "t", "type": "marble"}]}, "textures[0].type", "unknown value"),
        ({"textures": [{"name": "t", "type": "checkerboard", "to_uv": [[1, 0], [0, 1]]}]}, "textures[0].to_uv",
         "2 rows of 3 numbers"),
        ({"textures": [{"name": "t", "type": "bitmap", "image": np.zeros((2, 2, 2))}]}, "textures[0].image", "C in 1, 3, 4"),
        ({"materials": [{"name": "m", "type": "diffuse", "albedo": {"texture": "nope"}}]}, "materials[0].albedo.texture",
         "unknown texture 'nope'"),
        ({"textures": [{"name": "t", "type": "checkerboard"}],
          "materials": [{"name": "m", "type": "conductor", "alpha": {"texture": "t"}, "energy_compensation": True}]},
         "materials[0].energy_compensation", "constant roughness"),
        ({"textures": [{"name": "t", "type": "checkerboard"}, {"name": "t", "type": "checkerboard"}]},
         "textures[1].name", "duplicate name"),
    ]
    for fields, where, message in cases:
        with pytest.raises(clrender.SceneError) as error:
            clrender.load_scene_dict({**base, **fields})
        assert error.value.where == where and message in error.value.message, (where, str(error.value))


def test_scenes_without_textures_carry_no_texture_data(device):
    scene = clrender.load_scene("scenes/cornell_box.json")
    renderer = clrender.Renderer(scene, device)
    assert renderer.features["TEXTURES"] == 0
    assert renderer.arrays.uvs.shape == (1, 2) and renderer.arrays.texels.size == 1
