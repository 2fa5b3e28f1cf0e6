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
from clrender.features import scene_features
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
        warnings.simplefilter("ignore", clrender.MitsubaXmlWarning)   # eta/k approximated
        (aluminium,) = clrender.load_scene(tmp_path / "bump.xml").materials
    assert aluminium.type == "conductor" and aluminium.two_sided and aluminium.bump_map == -1
