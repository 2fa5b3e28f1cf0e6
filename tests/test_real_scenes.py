"""Real Mitsuba 3 scenes written by others (../shared/real-scenes beside the checkout, SOURCES.md
there; skipped where they are absent, as in CI): what clrender refused though Mitsuba reads it
(issue 23) now loads as Mitsuba loads it. The XML-only scenes load with stand-ins for their
absent assets (tests/stand_ins.py). The 15 complete scenes render as Mitsuba 3.9 renders them
(issues 22 and 23; skipped without Mitsuba). About 20 s on 2 cores (the staircase's 775 meshes,
the Lego's 439), and 2 minutes for the renders (warm kernel caches).
"""
import re
import warnings
import xml.etree.ElementTree as ET

import pytest
from scipy import stats

import clrender
from clrender.arrays import SkippedShapeWarning, build_scene_arrays
from clrender.cli import main
from clrender.features import scene_features
from clrender.mitsuba import MitsubaXmlError, read_scene
from clrender.mitsuba.xml import Files, check_version, expand, parse_xml
from conftest import real_scene, use_mitsuba_llvm
from small_copies import small_copy
from stand_ins import copy_with_stand_ins


@pytest.mark.parametrize("scene", ["tutorials-cbox/cbox.xml", "mitsuba-cbox/cbox.xml"])
def test_cornell_boxes_with_a_focus_distance_load(scene):
    # Mitsuba's tutorial Cornell box and its test data's: perspective sensors with focus_distance.
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", clrender.MitsubaXmlWarning)   # filters, spectra, clipping
        loaded = clrender.load_scene(real_scene(scene))
    assert len(loaded.shapes) >= 7 and loaded.camera.fov > 0


@pytest.mark.parametrize("scene", [
    "bitterli-staircase/scene_gt.xml", "bitterli-veach-bidir/scene.xml", "bitterli-living-room/scene_v3.xml",
    "xml-only/bitterli-teapot/scene_v3.xml", "xml-only/bitterli-veach-ajar/scene_v3.xml",
    "xml-only/bitterli-kitchen/scene.xml", "xml-only/bitterli-bathroom2/scene.xml",
    "xml-only/bitterli-bedroom/scene.xml", "xml-only/nppm-classroom/scene_v3.xml"])
def test_six_digit_camera_matrices_are_rotations_enough(tmp_path, scene):
    # Their cameras' to_world are 1e-6 to 2e-5 from a rotation: the sensor reads without even a
    # warning (read here with the file's defaults and a ball: the rest is not the sensor's).
    text = real_scene(scene).read_text()
    defaults = "".join(re.findall(r"<default [^>]*/>", text))
    sensor = re.search(r"<sensor .*?</sensor>", text, re.S).group(0)
    (tmp_path / "camera.xml").write_text(f'<scene version="3.0.0">{defaults}{sensor}<shape type="sphere"/></scene>')
    translation = read_scene(tmp_path / "camera.xml")
    assert "camera" in translation.scene
    assert not [w for w in translation.warnings if "<sensor" in w and "rotation" in w]


@pytest.mark.parametrize("scene,version,first", [
    ("test-hetero-volume/tests/scenes/participating_media/test_hetero_sigmat_volpath.xml", "2.0.0",
     [("emitter", "envmap"), ("integrator", "moment"), ("sensor", "perspective"), ("shape", "obj"),
      ("medium", "heterogeneous"), ("shape", "obj"), ("shape", "obj")]),
    ("docs-medium-sss-bunny/docs/scenes/medium_homogeneous_sss.xml", "2.1.0",
     [("bsdf", "roughdielectric"), ("medium", "homogeneous"), ("shape", "ply"), ("integrator", "volpath"),
      ("sensor", "perspective"), ("emitter", "envmap"), ("texture", "checkerboard")]),
])
def test_version_2_scenes_read(scene, version, first):
    # Mitsuba's own test and documentation scenes of version 2.x (and their includes) read; the
    # first refusal, if any, is a plugin clrender lacks, not the version.
    path = real_scene(scene)
    root = parse_xml(path)
    assert root.attrs["version"] == version
    check_version(root)
    elements = expand(root, {}, Files(path.parent.resolve()))
    assert [(e.tag, e.attrs.get("type")) for e in elements][:len(first)] == first
    try:
        clrender.load_scene(path)
    except MitsubaXmlError as error:
        assert "version" not in error.message


@pytest.mark.parametrize("scene,integrator,aovs", [
    ("tutorials-simple-teapot/simple.xml", "direct", ()),
    ("test-hetero-volume/tests/scenes/participating_media/test_hetero_sigmat_volpath.xml", "path", ("variance",)),
    ("test-homo-dielectric-envmap/tests/scenes/participating_media/test_homo_dielectric_envmap_volpath.xml", "path",
     ("variance",)),
])
def test_scenes_of_mitsubas_direct_and_moment_integrators_load(scene, integrator, aovs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", clrender.MitsubaXmlWarning)   # clipping planes, envmap resampling
        loaded = clrender.load_scene(real_scene(scene), parameters={"res": "8"} if "tests/" in scene else {})
    assert (loaded.render.integrator, loaded.render.aovs) == (integrator, aovs)


def test_staircase_meshes_without_area_are_skipped_with_a_warning(tmp_path):
    # 20 of the staircase's 775 meshes are lines (their corners collinear): Mitsuba loads them
    # and never hits them; clrender skips them, naming each. Read here without the BSDFs.
    path = real_scene("bitterli-staircase/scene_gt.xml")
    root = ET.parse(path).getroot()
    for element in list(root):
        if element.tag == "bsdf":
            root.remove(element)
        for child in list(element) if element.tag == "shape" else []:
            if child.tag in ("bsdf", "ref"):
                element.remove(child)
    root.insert(0, ET.Element("path", value=str(path.parent)))
    ET.ElementTree(root).write(tmp_path / "geometry.xml")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = clrender.load_scene(tmp_path / "geometry.xml", parameters={"resx": "8", "resy": "8"})
        arrays = build_scene_arrays(scene)
    skipped = [str(w.message) for w in caught if w.category is SkippedShapeWarning]
    assert len(scene.shapes) == 775 and len(skipped) == 20
    assert all(re.match(r"geometry\.xml:\d+ <shape type='obj'>: no triangle of 'WoodStairs_\d+' has an area", w)
               for w in skipped)
    assert arrays.degenerate_triangles >= 20 and len(arrays.info) > 100000


def test_staircase_loads_with_its_roughplastics():
    # Its six roughplastics (two-sided, GGX, nonlinear, four with wood textures) were the first
    # refusal (issue 22); Mitsuba's parameters reach the plastic materials.
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        scene = clrender.load_scene(real_scene("bitterli-staircase/scene_gt.xml"), parameters={"resx": "8", "resy": "8"})
    plastics = [m for m in scene.materials if m.type == "plastic"]
    assert len(plastics) == 6
    assert all(m.distribution == "ggx" and m.nonlinear and m.two_sided and m.ior == 1.5 and m.exterior_ior == 1
               for m in plastics)
    assert sum("color" in m.textures for m in plastics) == 4


# XML-only scenes with stand-ins: `clrender info` accepts each, or stops where Mitsuba would
# ============================================================================================
def info(capsys, path, parameters):
    """(exit code, error line) of `clrender info path -D name=value ...`."""
    code = main(["info", str(path)] + [arg for name, value in parameters.items() for arg in ("-D", f"{name}={value}")])
    errors = [line for line in capsys.readouterr().err.splitlines() if line.startswith("clrender: error:")]
    return code, errors[0] if errors else ""


def assert_accepted(code, error):
    assert code == 0, error


# scene: its -D parameters. The research scenes default to their own integrator plugin:
# Mitsuba, too, loads them only with -D integrator=path (SOURCES.md).
XML_ONLY = {
    "bitterli-bedroom/scene.xml": {},
    "bitterli-dining-room/scene_v3_lowerfov.xml": {},
    "bitterli-teapot/scene_v3.xml": {"integrator": "path"},
    "bitterli-veach-ajar/scene_v3.xml": {},
    "nppm-classroom/scene_v3.xml": {},   # ptracer
    "nppm-water-caustic-glossy/scene.xml": {},   # ptracer, hide_emitters
    "tutorials-lego/scene.xml": {},
}
# Their integrator is a research plugin around Mitsuba's `aov` (and `path`): it stops Mitsuba
# and clrender alike, whatever -D says.
RESEARCH_WRAPPED = ["bitterli-bathroom2/scene.xml", "bitterli-kitchen/scene.xml"]


@pytest.mark.parametrize("scene", list(XML_ONLY))
def test_xml_only_scene_is_accepted_with_stand_ins(tmp_path, capsys, scene):
    parameters = XML_ONLY[scene]
    copy = copy_with_stand_ins(real_scene(f"xml-only/{scene}"), tmp_path, parameters)
    assert_accepted(*info(capsys, copy, parameters))


@pytest.mark.parametrize("scene", list(RESEARCH_WRAPPED))
def test_a_research_integrator_stops_the_scene_as_it_stops_mitsuba(tmp_path, capsys, scene):
    copy = copy_with_stand_ins(real_scene(f"xml-only/{scene}"), tmp_path, {})
    code, error = info(capsys, copy, {"integrator": "path"})
    assert code == 3
    assert re.fullmatch(r"clrender: error: scene\.xml:7 <integrator type='statistical_integrator'>: unsupported "
                        r"integrator 'statistical_integrator' \(supported: .*\); Mitsuba too renders it only with a "
                        r"plugin of that name", error), error


@pytest.mark.parametrize("scene", RESEARCH_WRAPPED)
def test_a_research_scene_without_its_integrator_is_accepted(tmp_path, capsys, scene):
    # The statistical_integrator element replaced by the aov integrator it wraps.
    copy = copy_with_stand_ins(real_scene(f"xml-only/{scene}"), tmp_path, {})
    text, count = re.subn(r'<integrator type="statistical_integrator">\s*(<integrator type="aov">.*?</integrator>'
                          r'\s*</integrator>)\s*</integrator>', r"\1", copy.read_text(), flags=re.S)
    assert count == 1
    copy.write_text(text)
    assert_accepted(*info(capsys, copy, {"integrator": "path"}))


def bsdf_block(path, opening):
    """The BSDF element of a real scene that starts with `opening`, its files named absolutely."""
    text = path.read_text()
    start = text.index(opening)
    depth, index = 0, start
    for match in re.finditer(r"<(/?)bsdf\b[^>]*?(/?)>", text[start:]):
        depth += -1 if match.group(1) else (0 if match.group(2) else 1)
        if depth == 0:
            index = start + match.end()
            break
    return re.sub(r'value="textures/', f'value="{path.parent}/textures/', text[start:index])


def test_the_living_rooms_leaves_are_masked_by_their_bitmap(tmp_path):
    # Bitterli's LeavesBSDF: mask (opacity textures/leaf_mask.png) around twosided(diffuse with
    # textures/leaf.png), on a rectangle.
    block = bsdf_block(real_scene("bitterli-living-room/scene_v3.xml"), '<bsdf type="mask" id="LeavesBSDF">')
    (tmp_path / "leaf.xml").write_text(f'<scene version="3.0.0"><sensor type="perspective"/>{block}'
                                       '<shape type="rectangle"><ref id="LeavesBSDF"/></shape></scene>')
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", clrender.MitsubaXmlWarning)   # the default film
        scene = clrender.load_scene(tmp_path / "leaf.xml")
    (leaf,) = scene.materials
    assert leaf.type == "diffuse" and leaf.two_sided
    assert [scene.textures[leaf.textures[f]].source.split("/")[-1] for f in ("opacity", "color")] == ["leaf_mask.png", "leaf.png"]
    assert scene_features(scene)["TEXTURES"] == 1


def test_the_staircases_bump_map_wraps_a_bsdf_its_shapes_reference_by_its_inner_id(tmp_path):
    # Bitterli's converted scenes give the id to the BSDF inside the bumpmap, and shapes
    # reference that id: they get the inner twosided, without bumps, in Mitsuba (checked with
    # Mitsuba 3.9.1) and in clrender; the bumpmap itself is never used.
    block = bsdf_block(real_scene("bitterli-staircase/scene_gt.xml"), '<bsdf type="bumpmap">\n\t\t<texture name="map" type="bitmap">\n\t\t\t<string name="filename" value="textures/BrushedAluminium.jpg" />')
    (tmp_path / "bump.xml").write_text(f'<scene version="3.0.0"><sensor type="perspective"/>{block}'
                                       '<shape type="rectangle"><ref id="BrushedAluminiumBSDF"/></shape></scene>')
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", clrender.MitsubaXmlWarning)
        (aluminium,) = clrender.load_scene(tmp_path / "bump.xml").materials
    assert aluminium.type == "conductor" and aluminium.two_sided and aluminium.bump_map == -1


# Parity with Mitsuba 3.9 (issues 22 and 23)
# ============================================================================================
# Each complete scene, its film made small (its aspect kept) in a copy whose other files are
# links (tests/small_copies.py), rendered RENDERS times by both renderers at the same spp with
# different seeds, compared as tests/test_mitsuba_parity.py compares splatted images: z per 4 x 4
# block and channel, and of the whole image, from the renders' block means. The renders are few and these scenes' noise is far from
# Gaussian (caustics, small bright lights), so the limit on |z| is Student's t for Welch's
# smallest degrees of freedom (RENDERS - 1), Bonferroni-corrected over the z values of each
# comparison for a false alarm of FALSE_ALARM per scene (about 6.2 for the 4 x 4 blocks of
# 64 x 36, 4.1 for the whole image). Mitsuba renders with llvm_ad_rgb: scalar_rgb splats
# with a gaussian tabulated in 31 steps per radius, whose mass beyond 1.5 pixels is 1.2 times
# the exact filter's (seen at mitsuba-cbox's dark edges, z 5), where llvm_ad_rgb evaluates the
# filter, as clrender does (docs/mitsuba-xml.md). Seeds are fixed, so outcomes are deterministic.
RENDERS, FALSE_ALARM = 24, 1e-3

# scene folder: (scene file, film width and height, spp, -D parameters). The research scenes
# default to their repository's integrator plugin; SOURCES.md says to render them with path.
PARITY = {
    "bitterli-cornell-box": ("scene_v3.xml", (32, 32), 64, {}),
    "bitterli-living-room": ("scene_v3.xml", (64, 36), 8, {}),
    "bitterli-staircase": ("scene_gt.xml", (36, 64), 8, {}),
    "bitterli-veach-bidir": ("scene.xml", (32, 32), 32, {"integrator": "path"}),
    "bitterli-veach-mis": ("scene.xml", (64, 36), 64, {"integrator": "path"}),
    "docs-medium-sss-bunny": ("docs/scenes/medium_homogeneous_sss.xml", (32, 24), 8, {}),
    "docs-veach-mis-direct": ("docs/scenes/integrator_direct_both.xml", (48, 32), 32, {}),
    "mitsuba-cbox": ("cbox.xml", (32, 32), 64, {}),
    "mitsuba-matpreview": ("matpreview.xml", (32, 24), 16, {}),
    "ppg-torus": ("scene.xml", (32, 24), 64, {"integrator": "path"}),
    "test-hetero-volume": ("tests/scenes/participating_media/test_hetero_sigmat_volpath.xml", (32, 32), 16, {}),
    "test-homo-dielectric-envmap": ("tests/scenes/participating_media/test_homo_dielectric_envmap_volpath.xml",
                                    (32, 32), 16, {}),
    "test-textured-principled": ("tests/scenes/bsdf_spheres/test_texturedprincipled1_path.xml", (32, 32), 32, {}),
    "tutorials-cbox": ("cbox.xml", (32, 32), 64, {}),
    "tutorials-simple-teapot": ("simple.xml", (32, 32), 16, {}),
}
# Mitsuba's spp as a multiple of ours, where our estimator has a lighter tail than Mitsuba's: a
# z-test needs each renderer's mean of RENDERS renders near Gaussian, and ppg-torus's caustics
# through the glass block reach Mitsuba's path tracer in under 5 % of its 64-spp renders of a
# 4 x 4 block (the block's mean 0.32, its median render 0.21), so 24 renders often hold none;
# ours, with the caustic guide (clrender/guide.py), finds them in most renders. Over 1,000
# renders of each, 11 of 41 draws of 24 at 64 spp failed the comparison below, none of 10 with
# Mitsuba at 256 spp (the worst |z| per draw 2.7 in the median).
MITSUBA_SPP_FACTOR = {"ppg-torus": 4}


@pytest.fixture(scope="module")
def mitsuba_llvm():
    """Mitsuba with its llvm_ad_rgb variant, and tests/test_mitsuba_parity.py's comparison."""
    pytest.importorskip("mitsuba")
    use_mitsuba_llvm()
    import test_mitsuba_parity
    return test_mitsuba_parity


def z_limit(count):
    """The |z| that `count` z values, each from RENDERS renders per renderer, all stay below
    with probability 1 - FALSE_ALARM (two-sided, Bonferroni)."""
    return stats.t.isf(FALSE_ALARM / (2 * count), RENDERS - 1)


@pytest.mark.parametrize("scene", sorted(PARITY))
def test_real_scene_renders_as_in_mitsuba(tmp_path, device, mitsuba_llvm, scene):
    file, (width, height), spp, parameters = PARITY[scene]
    path = small_copy(real_scene(scene), file, tmp_path / scene, width, height)
    ours, mitsuba = mitsuba_llvm.render_both(path, device, spp=spp, renders=RENDERS,
                                             mitsuba_spp=spp * MITSUBA_SPP_FACTOR.get(scene, 1), **parameters)
    # Both splat with the scenes' gaussian and tent filters: neighbouring pixels share samples.
    mitsuba_llvm.assert_same_image(ours, mitsuba, z_limit, independent_pixels=False)


@pytest.mark.parametrize("scene", ["tutorials-cbox/cbox.xml", "mitsuba-cbox/cbox.xml",
                                   "bitterli-cornell-box/scene_v3.xml"])
def test_the_packet_integrator_renders_the_cornell_boxes(scene):
    # Diffuse walls, smooth glass and mirrors (tutorials-cbox's conductor), triangle emitters:
    # the scenes the packet integrator covers (features.packets_cover) render in packets on CPUs.
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", clrender.MitsubaXmlWarning)
        loaded = clrender.load_scene(real_scene(scene))
    assert scene_features(loaded, packets=True)["LANES"] == 8
