"""Real Mitsuba 3 scenes written by others (../shared/real-scenes beside the checkout, SOURCES.md
there; skipped where they are absent, as in CI): what clrender refused though Mitsuba reads it
(issue 23) now loads as Mitsuba loads it. About 10 s on 2 cores (the staircase's 775 meshes).
"""
import re
import warnings
import xml.etree.ElementTree as ET

import pytest

import clrender
from clrender.arrays import SkippedShapeWarning, build_scene_arrays
from clrender.mitsuba import MitsubaXmlError, read_scene
from clrender.mitsuba.xml import Files, check_version, expand, parse_xml
from conftest import real_scene


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
    assert arrays.degenerate_triangles >= 20 and len(arrays.triangles) > 100000


def test_textured_principled_sphere_renders_as_in_mitsuba(tmp_path, device):
    # Mitsuba's test scene of a principled BSDF whose anisotropic, metallic, clearcoat and sheen
    # come from checkerboards (a 32k-triangle OBJ sphere with uv; an environment map, an area and
    # a point light; max_depth 2). Its `moment` integrator (the nested `path`'s image plus second
    # moments) is unwrapped to the nested `path`, which is the image both renderers compare
    # (clrender has no `moment`). Compared as tests/test_mitsuba_parity.py compares images.
    mi = pytest.importorskip("mitsuba")
    mi.set_variant("scalar_rgb")
    from test_mitsuba_parity import assert_same_image, render_both
    folder = real_scene("test-textured-principled/tests/scenes/bsdf_spheres")
    scene = (folder / "test_texturedprincipled1_path.xml").read_text()
    (tmp_path / "scene.xml").write_text(scene.replace('"../../../common"', f'"{folder.parents[2] / "common"}"'))
    fragment = (folder / "fragments/single_sphere.xml").read_text()
    (tmp_path / "fragments").mkdir()
    (tmp_path / "fragments/single_sphere.xml").write_text(
        re.sub(r'<integrator type="moment">\s*(<integrator.*?</integrator>)\s*</integrator>', r"\1", fragment, flags=re.S))
    ours, mitsuba = render_both(tmp_path / "scene.xml", device, spp=32)
    assert_same_image(ours, mitsuba)
