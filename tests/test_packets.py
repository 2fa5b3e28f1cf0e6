"""Camera paths in packets (LANES 8: kernels/integrator_packets.cl, kernels/path_packets.h): they
trace the megakernel's paths, so the images agree with it to float rounding; features.py gives
them only the scenes they cover; launch splits, bands and tiles leave their images unchanged.

The two kernels run the same random numbers through the same functions (kernels/lanes.h), in a
different order of float operations: a path may take another turn where a rounding difference
flips a comparison, so a few pixels of a render differ. Everything else agrees to 1e-4.
"""
import copy
import json
from pathlib import Path

import numpy as np
import pytest

import clrender
from clrender.features import scene_features
from clrender.scene import Filter

SCENES = Path(__file__).resolve().parent.parent / "scenes"
# At most this fraction of the pixels may differ by more than RTOL: measured 0-2e-5 on the
# benchmark scenes at 32 spp; a broken lane (a wrong mask, a missed select) changes most pixels.
MAX_DIFFERING = 0.01
RTOL = 1e-4
# The direct integrator's samples end at their first surface, leaving few comparisons for
# rounding to flip: 0 pixels differed in every case below on PoCL and Intel's runtime at 8 spp;
# a smooth lane that keeps a number it should give back changes 0.6-0.8 % (the glass's pixels).
DIRECT_MAX_DIFFERING = 0.0025


def example(name, resolution=(40, 32), **render):
    one_sided = name.startswith("one_sided_")   # Mitsuba's diffuse: black seen from behind
    mirrors = name.startswith("mirror_")        # the blocks smooth conductors: copper, a tinted mirror
    rough = name.startswith("rough_mirror_")    # the blocks rough conductors, as Mitsuba's scenes have them:
    # gold (Beckmann, separable masking) and a tinted GGX one, one-sided, no energy compensation
    bulbs = name.startswith("bulbs_")           # two emitting spheres beside the ceiling's light
    frosted = name.startswith("frosted_")       # the glass rough: Beckmann, separable, uncompensated
    lit = name.startswith("lit_")               # point and spot lights in the room, a directional one
    plastic = name.startswith("plastic_")       # back wall, floor, tall block, sphere: plastic, textured
    masked = name.startswith("masked_")         # the blocks masks: by a checkerboard and a bitmap of opacity
    sky = next((kind for kind in ("skymap", "skytexels", "sky")   # an environment
                if name.startswith(f"{kind}_") or f"_{kind}_" in name), None)
    base = name
    for prefix in ("one_sided_", "rough_mirror_", "mirror_", "bulbs_", "frosted_", "lit_", "plastic_", "masked_",
                   "sky_", "skymap_", "skytexels_"):
        base = base.removeprefix(prefix)
    data = json.loads((SCENES / f"{base}.json").read_text())
    if one_sided:
        for material in data["materials"]:
            if material["type"] == "diffuse":
                material["two_sided"] = False
    if mirrors:
        data["materials"] += [{"name": "copper", "type": "conductor", "material": "Cu"},
                              {"name": "mirror", "type": "conductor", "tint": [0.9, 0.8, 0.6]}]
        for shape in data["shapes"]:
            if shape["name"] in ("short_block", "tall_block"):
                shape["material"] = "copper" if shape["name"] == "tall_block" else "mirror"
    if rough:
        data["materials"] += [{"name": "gold", "type": "conductor", "material": "Au", "roughness": 0.3,
                               "distribution": "beckmann", "masking": "separable", "energy_compensation": False,
                               "two_sided": False},
                              {"name": "brass", "type": "conductor", "tint": [0.9, 0.7, 0.5], "roughness": 0.15,
                               "energy_compensation": False, "two_sided": False}]
        for shape in data["shapes"]:
            if shape["name"] in ("short_block", "tall_block"):
                shape["material"] = "gold" if shape["name"] == "tall_block" else "brass"
    if plastic:
        rng = np.random.default_rng(3)
        data["textures"] = [{"name": "checks", "type": "checkerboard", "to_uv": [[5, 0, 0], [0, 5, 0.3]]},
                            {"name": "grain", "type": "bitmap", "wrap": "mirror", "to_uv": [[2, 0, -0.5], [0, 3, 0]],
                             "image": rng.integers(0, 256, (6, 9, 3), dtype=np.uint8)}]
        # Mitsuba's plastic (a smooth coat: its mirror is a delta lobe) and roughplastic (coat
        # tables), one-sided, as Mitsuba's are.
        data["materials"] += [{"name": "varnish", "type": "plastic", "diffuse": {"texture": "checks"},
                               "two_sided": False},
                              {"name": "lacquer", "type": "plastic", "alpha": 0.1, "distribution": "ggx",
                               "nonlinear": True, "diffuse": {"texture": "grain"}, "two_sided": False},
                              {"name": "parquet", "type": "diffuse", "albedo": {"texture": "grain"}},
                              {"name": "sky", "type": "emissive", "radiance": [0.2, 0.25, 0.3]}]
        roles = {"back": "varnish", "floor": "varnish", "tall_block": "lacquer", "short_block": "parquet",
                 "glass_sphere": "varnish"}   # the checkerboard at a sphere's uv
        for shape in data["shapes"]:
            shape["material"] = roles.get(shape["name"], shape["material"])
        # Around the open box, emitting inwards: the back wall mirrors it (the mirror's
        # emission weighted as a delta lobe's).
        data["shapes"].append({"name": "sky", "type": "sphere", "material": "sky", "center": [0.0, 1.0, 0.0],
                               "radius": 12.0, "flip_normals": True})
    if masked:
        # The tall block lets 0.1 or 0.7 of the light through by a checkerboard, the short one
        # through a bitmap of opacities (0 to 1, linear: some texels stop nothing, some all),
        # and the back wall through 0.25 everywhere, onto an emitting sky sphere behind it, or
        # the environment where there is one.
        rng = np.random.default_rng(11)
        data["textures"] = [{"name": "opacity_checks", "type": "checkerboard", "color0": 0.9, "color1": 0.3,
                             "to_uv": [[3, 0, 0], [0, 4, 0.2]]},
                            {"name": "opacity_noise", "type": "bitmap", "raw": True,
                             "image": rng.uniform(0, 1, (7, 5, 1)).astype(np.float32)}]
        data["materials"] += [{"name": "lace", "type": "diffuse", "albedo": [0.7, 0.6, 0.4],
                               "opacity": {"texture": "opacity_checks"}},
                              {"name": "gauze", "type": "diffuse", "albedo": [0.3, 0.5, 0.6],
                               "opacity": {"texture": "opacity_noise"}},
                              {"name": "net", "type": "diffuse", "albedo": [0.6, 0.6, 0.6], "opacity": 0.75}]
        roles = {"tall_block": "lace", "short_block": "gauze", "back": "net"}
        for shape in data["shapes"]:
            shape["material"] = roles.get(shape["name"], shape["material"])
            if shape["name"] in ("tall_block", "short_block"):
                # Seen through, a block's bottom face lies on the floor, where rounding decides
                # which of the two a ray meets (as the prism below): lifted by a hair.
                shape["transform"]["translate"][1] += 1e-3
        if not sky:
            data["materials"].append({"name": "sky", "type": "emissive", "radiance": [0.2, 0.25, 0.3]})
            data["shapes"].append({"name": "sky", "type": "sphere", "material": "sky", "center": [0.0, 1.0, 0.0],
                                   "radius": 12.0, "flip_normals": True})
    if frosted:
        for material in data["materials"]:
            if material["type"] == "dielectric":
                material.update(roughness=0.15, distribution="beckmann", masking="separable", energy_compensation=False)
    if lit:
        data["lights"] = [{"type": "point", "position": [0.4, 1.5, 0.5], "intensity": [0.8, 0.7, 0.5]},
                          # its beam's edge (the falloff's transition) crosses the floor in view
                          {"type": "spot", "position": [-0.3, 1.8, 0.2], "direction": [0.2, -1.0, 0.1],
                           "intensity": 3.0, "cutoff_angle": 35, "beam_width": 20},
                          {"type": "directional", "direction": [0.1, -0.4, -1.0], "irradiance": [0.6, 0.7, 0.9]}]
    if bulbs:
        data["materials"] += [{"name": "bulb", "type": "emissive", "radiance": [8.0, 6.0, 3.0]},
                              {"name": "sky", "type": "emissive", "radiance": [0.2, 0.25, 0.3]}]
        data["shapes"] += [{"name": "bulb", "type": "sphere", "material": "bulb", "center": [-0.5, 0.5, 0.3],
                            "radius": 0.12},
                           # flipped: emitting inwards, onto the room and the camera inside it
                           {"name": "sky", "type": "sphere", "material": "sky", "center": [0.0, 1.0, 0.0],
                            "radius": 12.0, "flip_normals": True}]
    if sky == "sky":   # constant, beside the emitting triangle
        data["lights"] = [{"type": "environment", "radiance": [0.3, 0.4, 0.5]}]
    elif sky:   # a lat-long image with a bright sun (sampled by luminance), turned, by either lookup
        rng = np.random.default_rng(7)
        image = rng.uniform(0.05, 0.6, (16, 32, 3)).astype(np.float32)
        image[4:6, 9:12] = [40.0, 36.0, 30.0]
        data["lights"] = [{"type": "environment", "image": image, "lookup": "mitsuba" if sky == "skymap" else "texel",
                           "transform": {"rotate": [0, 35, 0]}}]
    data["camera"]["resolution"] = list(resolution)
    # The prism stands on the floor: where two surfaces coincide, rounding decides which one a
    # ray meets, and the two kernels round differently (2 % of the pixels differed at 8 spp).
    # Lifted by a hair, as tools/peers.py lifts it.
    for shape in data["shapes"]:
        if shape["name"] == "prism":
            shape["transform"] = {"translate": [0, 1e-3, 0]}
    data["render"] = {**data.get("render", {}), **render}
    return clrender.load_scene_dict(data, base_dir=SCENES)


def differing(a, b):
    """Fraction of pixels whose colour differs by more than RTOL (relative, 1e-6 absolute)."""
    return float(np.mean(~np.all(np.isclose(a[..., :3], b[..., :3], rtol=RTOL, atol=1e-6), axis=-1)))


def both(scene, device, spp=8, **settings):
    """The RenderResults of the megakernel and of the packets, same seed."""
    results = []
    for packets in (False, True):
        renderer = clrender.Renderer(copy.deepcopy(scene), device, packets=packets, **settings)
        assert renderer.features["LANES"] == (8 if packets else 1)
        results.append(renderer.render(spp=spp, seed=5))
    return results


@pytest.mark.parametrize("name", ["cornell_box", "tir_prism", "cornell_glass", "one_sided_cornell_box",
                                  "mirror_cornell_box", "rough_mirror_cornell_box", "bulbs_cornell_box",
                                  "frosted_cornell_glass", "frosted_tir_prism", "lit_cornell_glass",
                                  "plastic_cornell_box", "plastic_cornell_glass", "masked_cornell_box",
                                  "masked_cornell_glass", "masked_skymap_cornell_glass", "sky_cornell_box",
                                  "skymap_cornell_glass", "frosted_skytexels_cornell_glass"])
@pytest.mark.parametrize("sampler", ["sobol", "independent"])
def test_packets_trace_the_megakernel_paths(device, name, sampler):
    # Diffuse walls and an emitting triangle; a glass prism (total internal reflection); an
    # analytic glass sphere; copper and tinted mirror blocks; rough gold and brass blocks; two
    # emitting spheres, one flipped around the scene (sampled by area, from inside); the sphere
    # and the prism of frosted glass (rough: reflection and refraction, from both sides); a point,
    # a spot and a directional light beside the emitting triangle; a smooth plastic back wall and
    # floor mirroring an emitting sky and a rough plastic block, coloured by a checkerboard and an
    # 8-bit bitmap, as is the diffuse short block; a constant environment beside the emitting
    # triangle, and environment images (a sun among noise, turned) looked up as Mitsuba does
    # and texel by texel, seen through the box's open front, the glass and frosted glass; masks
    # (opacity from a checkerboard, a bitmap and a constant) that paths and shadow rays cross,
    # also before the environment and through glass. The
    # independent sampler checks that a smooth lane gives back the number its lobe choice does not
    # take, and that a rough lane draws the lobe number it does not use (path_packets.h).
    mega, packets = both(example(name), device, sampler=sampler)
    assert mega.discarded_samples == packets.discarded_samples == 0
    assert differing(mega.image, packets.image) <= MAX_DIFFERING


@pytest.mark.parametrize("name, samples", [
    ("lit_cornell_glass", (1, 1)), ("bulbs_cornell_box", (2, 3)), ("rough_mirror_cornell_box", (3, 1)),
    ("plastic_cornell_glass", (1, 2)), ("frosted_skytexels_cornell_glass", (2, 2)), ("mirror_cornell_box", (0, 2)),
    ("sky_cornell_box", (1, 0)), ("skymap_cornell_glass", (1, 1))])
@pytest.mark.parametrize("sampler", ["sobol", "independent"])
def test_packets_take_the_direct_integrators_samples(device, name, samples, sampler):
    # kernels/direct_packets.h against direct.h: light samples at the first surface (none at a
    # delta one, which gives their numbers back) and BSDF samples finding emitting triangles,
    # spheres and the environment (constant, and an image seen through smooth glass, whose lobe
    # choice needs the right number) through smooth, rough and plastic lobes, each weighed against
    # the other technique's count; point, spot and directional lights; with one technique alone.
    # The independent sampler checks the numbers given back, which its 2D draws take two of.
    emitter_samples, bsdf_samples = samples
    scene = example(name, integrator="direct", emitter_samples=emitter_samples, bsdf_samples=bsdf_samples)
    assert scene_features(scene, packets=True)["LANES"] == 8
    mega, packets = both(scene, device, sampler=sampler)
    assert mega.discarded_samples == packets.discarded_samples == 0
    assert differing(mega.image, packets.image) <= DIRECT_MAX_DIFFERING
    # Not the path tracer's image: the same paths would agree with it.
    path = clrender.Renderer(example(name), device, packets=True, sampler=sampler).render(spp=8, seed=5)
    assert differing(path.image, packets.image) > 0.5


def test_packets_record_the_direct_integrators_aovs(device):
    aovs = ("albedo", "normal", "emission", "variance")
    scene = example("skymap_cornell_glass", integrator="direct", emitter_samples=1, bsdf_samples=1)
    results = [clrender.Renderer(copy.deepcopy(scene), device, packets=packets).render(spp=4, seed=5, aovs=aovs)
               for packets in (False, True)]
    for name in aovs:
        assert differing(results[0].aovs[name], results[1].aovs[name]) <= DIRECT_MAX_DIFFERING, name
    hidden = both(example("skymap_cornell_glass", integrator="direct", hide_environment=True), device)
    assert differing(hidden[0].image, hidden[1].image) <= DIRECT_MAX_DIFFERING
    assert hidden[1].image.sum() < results[1].image.sum()


def assert_a_tile_from_column_3_keeps_the_bits(scene, device):
    """A 40 x 32 scene's per-pixel sums (3 spp, packets) the same bits whole and in a tile from
    column 3, whose packets group other pixels."""
    renderer = clrender.Renderer(scene, device, packets=True)
    assert renderer.features["LANES"] == 8
    whole = renderer.accumulate(clrender.Accumulation.start((0, 0, 40, 32)), 3, seed=5).sums.reshape(32, 40, 4)
    tile = renderer.accumulate(clrender.Accumulation.start((3, 0, 37, 32)), 3, seed=5).sums.reshape(32, 37, 4)
    assert np.array_equal(tile, whole[:, 3:])


# The glass sphere of cornell_glass as it is, and as a coarse mesh with interpolated normals:
# near its silhouettes a lane's refraction about the shading normal would leave through the facet,
# and sample_dielectric_delta refracts that lane about the facet's normal, which must leave the
# other lanes' refractions as they are (refract writes every lane that can refract).
GLASS_SPHERES = {"analytic": {}, "smooth-normal-mesh": {"mesh": True, "subdivisions": 1, "smooth": True}}


@pytest.mark.parametrize("glass", list(GLASS_SPHERES))
@pytest.mark.parametrize("integrator", ["path", "direct"])
def test_camera_hits_do_not_depend_on_which_pixels_share_a_packet(device, integrator, glass):
    # A packet's camera rays are walked together (kernels/bvh_packets.h), and so are the shadow
    # rays from their hits (the path tracer's where no surface is a mask, as in this scene); a
    # tile starting at another column groups other pixels into packets, and each pixel's sums
    # must stay the same bits. The tall block twice over in other colours (coincident triangles:
    # equal distances, which the lowest slot wins whatever the walk's order; shadows cast by
    # three blocks) and the glass sphere, traced whole and as a tile from column 3.
    data = json.loads((SCENES / "cornell_glass.json").read_text())
    data.setdefault("render", {})["integrator"] = integrator
    sphere = next(shape for shape in data["shapes"] if shape["name"] == "glass_sphere")
    sphere.update(GLASS_SPHERES[glass])
    data["materials"] += [{"name": "red_twin", "type": "diffuse", "albedo": [0.8, 0.1, 0.1]},
                          {"name": "blue_twin", "type": "diffuse", "albedo": [0.1, 0.1, 0.8]}]
    tall = next(shape for shape in data["shapes"] if shape["name"] == "tall_block")
    data["shapes"] += [dict(tall, name=f"{colour}_twin", material=f"{colour}_twin") for colour in ("red", "blue")]
    data["camera"]["resolution"] = [40, 32]
    scene = clrender.load_scene_dict(data, base_dir=SCENES)
    assert_a_tile_from_column_3_keeps_the_bits(scene, device)


@pytest.mark.parametrize("name", ["plastic_cornell_glass", "mirror_cornell_box", "rough_mirror_cornell_box",
                                  "frosted_skytexels_cornell_glass", "lit_cornell_glass", "bulbs_cornell_box",
                                  "masked_cornell_box"])
def test_paths_do_not_depend_on_which_pixels_share_a_packet(device, name):
    # Nothing a lane computes may depend on its packet-mates, whatever materials and lights the
    # packet mixes (a helper that writes all lanes' outputs is called into a variable of its
    # own and selected where it applies).
    assert_a_tile_from_column_3_keeps_the_bits(example(name), device)


def test_packets_cover_tiles_that_are_not_a_multiple_of_eight_wide(device):
    # 29 columns: the last work-item of each row has 5 lanes in the image and 3 outside, which
    # must neither trace nor write.
    scene = example("cornell_box", resolution=(29, 13))
    mega, packets = both(scene, device)
    assert differing(mega.image, packets.image) <= MAX_DIFFERING
    assert mega.image.shape == packets.image.shape == (13, 29, 3)


def test_packet_images_do_not_depend_on_how_samples_are_launched(device):
    scene = example("tir_prism", resolution=(21, 30))
    whole = clrender.Renderer(copy.deepcopy(scene), device, packets=True).render(spp=6, seed=2)
    # One sample per launch, and bands of 4 rows (4 x 4 work-groups: the last band overruns).
    banded = clrender.Renderer(copy.deepcopy(scene), device, packets=True, local_size=(4, 4),
                               pass_seconds=1e-9).render(spp=6, seed=2)
    single = clrender.Renderer(copy.deepcopy(scene), device, packets=True).render(spp=6, seed=2, samples_per_pass=1)
    assert np.array_equal(whole.image, banded.image)
    assert np.array_equal(whole.image, single.image)


def test_packets_write_the_pixel_centre_record(device):
    mega_aovs = clrender.Renderer(example("cornell_glass"), device, packets=False).render(
        spp=1, seed=5, aovs=("depth", "object_id")).aovs
    packet_aovs = clrender.Renderer(example("cornell_glass"), device, packets=True).render(
        spp=1, seed=5, aovs=("depth", "object_id")).aovs
    assert np.array_equal(mega_aovs["object_id"], packet_aovs["object_id"])
    assert np.allclose(mega_aovs["depth"], packet_aovs["depth"], rtol=1e-5, atol=1e-6)


def test_packets_see_the_environment_as_the_megakernel(device):
    # Escaping rays' AOVs (the environment's radiance as emission, its albedo), and camera rays
    # that do not see a hidden environment while it still lights the scene.
    aovs = ("albedo", "normal", "emission", "variance")
    results = [clrender.Renderer(example("skymap_cornell_glass"), device, packets=packets).render(spp=4, seed=5,
                                                                                                 aovs=aovs)
               for packets in (False, True)]
    for name in aovs:
        assert differing(results[0].aovs[name], results[1].aovs[name]) <= MAX_DIFFERING, name
    hidden = both(example("skymap_cornell_glass", hide_environment=True), device)
    assert differing(hidden[0].image, hidden[1].image) <= MAX_DIFFERING
    assert hidden[1].image.sum() < results[1].image.sum()


def test_packets_accumulate_the_megakernels_sample_aovs(device):
    # The AOVs of the first non-delta vertex (behind the glass sphere: refracted and reflected
    # surfaces), the emission seen directly, the colour's variance; the colour itself is the
    # colour-only render's, as the megakernel's is.
    aovs = ("albedo", "normal", "emission", "variance")
    results = [clrender.Renderer(example("cornell_glass"), device, packets=packets).render(spp=4, seed=5, aovs=aovs)
               for packets in (False, True)]
    for name in aovs:
        assert differing(results[0].aovs[name], results[1].aovs[name]) <= MAX_DIFFERING, name
    colour_only = clrender.Renderer(example("cornell_glass"), device, packets=True).render(spp=4, seed=5)
    assert np.array_equal(results[1].image, colour_only.image)


@pytest.mark.parametrize("pixel_filter", [Filter("gaussian"), Filter("tent", radius=1.5)], ids=["gaussian", "tent"])
def test_packets_filter_as_the_megakernel(device, pixel_filter):
    # Offsets and weights per lane (kernels/filter.h), truncated at the image's edges (29
    # columns: the last work-item's lanes overhang the right edge), the sample AOVs weighted
    # as the colour is.
    scene = example("cornell_glass", resolution=(29, 13))
    scene.camera.filter = pixel_filter
    aovs = ("albedo", "normal", "emission", "variance")
    mega, packets = both(scene, device, spp=4)
    assert differing(mega.image, packets.image) <= MAX_DIFFERING
    results = [clrender.Renderer(copy.deepcopy(scene), device, packets=p).render(spp=4, seed=5, aovs=aovs)
               for p in (False, True)]
    for name in aovs:
        assert differing(results[0].aovs[name], results[1].aovs[name]) <= MAX_DIFFERING, name


def test_packets_are_used_only_where_they_cover_the_scene():
    def lanes(scene, **options):
        return scene_features(scene, packets=True, **options)["LANES"]

    assert lanes(example("cornell_box")) == 8
    assert lanes(example("cornell_glass")) == 8
    assert lanes(example("mirror_cornell_box")) == 8
    assert lanes(example("rough_mirror_cornell_box")) == 8
    assert lanes(example("bulbs_cornell_box")) == 8
    assert lanes(example("frosted_cornell_glass")) == 8
    assert lanes(example("lit_cornell_glass")) == 8
    assert lanes(example("plastic_cornell_box")) == 8
    assert lanes(example("masked_cornell_box")) == lanes(example("masked_skymap_cornell_glass")) == 8
    assert lanes(example("sky_cornell_box")) == lanes(example("skymap_cornell_glass")) == 8
    assert scene_features(example("cornell_box"), packets=False)["LANES"] == 1
    assert lanes(example("cornell_box"), sample_aovs=True) == 8
    for name in ("rough_glass", "smoke_cornell_box", "toon_cornell_box", "cloud_low_sun", "fog_beam"):
        assert lanes(example(name)) == 1, name
    assert lanes(example("lit_cornell_glass", integrator="direct")) == 8
    # The direct integrator's camera rays cross masks as the path tracer's do not.
    assert lanes(example("masked_cornell_box", integrator="direct")) == 1

    def variant(change):
        data = json.loads((SCENES / "cornell_box.json").read_text())
        change(data)
        return clrender.load_scene_dict(data, base_dir=SCENES)

    def rough_conductor(data):   # energy compensation (the default): its tables are not in the packets
        data["materials"][0] = {"name": "white", "type": "conductor", "roughness": 0.3}

    def textured_roughness(data):   # a texture on a parameter other than the colour
        data["textures"] = [{"name": "t", "type": "checkerboard"}]
        data["materials"][0] = {"name": "white", "type": "plastic", "alpha": {"texture": "t"}}

    def textured_emission(data):
        data["textures"] = [{"name": "t", "type": "checkerboard"}]
        light = next(m for m in data["materials"] if m["type"] == "emissive")
        light["radiance"] = {"texture": "t"}

    def bumps(data):
        data["textures"] = [{"name": "t", "type": "checkerboard"}]
        data["materials"][0]["bump"] = {"texture": "t"}

    def back_material(data):
        data["materials"].append({"name": "back", "type": "diffuse"})
        data["materials"][0]["back"] = "back"

    for change in (rough_conductor, textured_roughness, textured_emission, bumps, back_material):
        assert lanes(variant(change)) == 1, change.__name__
