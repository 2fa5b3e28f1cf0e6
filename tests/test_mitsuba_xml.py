"""The Mitsuba 3 XML reader on small files written here (no Mitsuba needed): every supported
element, the translation it gives, and every error, which must name the file, line and element.
About 15 s on 2 cores (two tiny renders, the rest is parsing)."""
import json
import subprocess
import sys

import numpy as np
import pytest
import trimesh

import clrender
from clrender import cie, grids, layout, limits, meshes, mitsuba
from clrender.arrays import build_scene_arrays
from clrender.mitsuba import MitsubaXmlError, MitsubaXmlWarning
from mitsuba_envmap import mitsuba_envmap_lookup

SENSOR = """<sensor type="perspective">
        <float name="fov" value="40"/>
        <transform name="to_world"><lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="6"/>
            <rfilter type="box"/></film>
    </sensor>"""


def write(folder, body, sensor=SENSOR, name="scene.xml", version="3.0.0"):
    path = folder / name
    path.write_text(f'<?xml version="1.0"?>\n<scene version="{version}">\n    {sensor}\n{body}\n</scene>\n')
    return path


def translate(folder, body, sensor=SENSOR, parameters=None):
    """(scene dict, warnings) of a scene with the default sensor and `body`."""
    translation = mitsuba.read_scene(write(folder, body, sensor), parameters)
    return translation.scene, translation.warnings


def error_of(folder, body, sensor=SENSOR, parameters=None):
    with pytest.raises(MitsubaXmlError) as error:
        clrender.load_scene(write(folder, body, sensor), parameters=parameters)
    return str(error.value)


def line_of(body, text):
    """The line of `text` in the file `write` makes from `body` (the sensor takes lines 3-8)."""
    lines = f'<?xml version="1.0"?>\n<scene version="3.0.0">\n    {SENSOR}\n{body}\n'.splitlines()
    return next(i + 1 for i, line in enumerate(lines) if text in line)


# ============================================================================================
# Structure: defaults, parameters, includes, references, paths
# ============================================================================================
def test_defaults_and_parameters_substitute_everywhere(tmp_path):
    body = """<default name="r" value="0.25"/><default name="kind" value="diffuse"/>
    <shape type="sphere"><float name="radius" value="$r"/><bsdf type="$kind"><rgb name="reflectance" value="$r, 0.5, $r"/></bsdf></shape>"""
    scene, _ = translate(tmp_path, body)
    assert scene["shapes"][0]["radius"] == 0.25 and scene["materials"][0]["albedo"] == [0.25, 0.5, 0.25]
    scene, _ = translate(tmp_path, body, parameters={"r": "0.5"})   # like Mitsuba's -D
    assert scene["shapes"][0]["radius"] == 0.5


def test_undefined_parameter_is_an_error(tmp_path):
    body = '<shape type="sphere"><float name="radius" value="$radius"/></shape>'
    message = error_of(tmp_path, body)
    assert f"scene.xml:{line_of(body, '$radius')} <float name='radius'>" in message
    assert "undefined parameter $radius" in message


def test_include_resolves_against_the_including_file(tmp_path):
    (tmp_path / "parts").mkdir()
    (tmp_path / "parts" / "ball.obj").write_text(trimesh.creation.icosphere(1).export(file_type="obj"))
    (tmp_path / "parts" / "objects.xml").write_text("""<scene version="3.0.0">
        <bsdf type="diffuse" id="grey"/>
        <shape type="obj"><string name="filename" value="ball.obj"/><ref id="grey"/></shape>
    </scene>""")
    scene, _ = translate(tmp_path, '<include filename="parts/objects.xml"/>')
    assert scene["shapes"][0]["file"] == str((tmp_path / "parts" / "ball.obj").resolve())
    assert clrender.load_scene(tmp_path / "scene.xml").shapes[0].mesh.faces.shape == (80, 3)


def test_include_cycles_and_missing_includes_are_errors(tmp_path):
    (tmp_path / "loop.xml").write_text('<scene version="3.0.0"><include filename="loop.xml"/></scene>')
    assert "nested deeper than 16" in error_of(tmp_path, '<include filename="loop.xml"/>')
    assert "file not found: nothing.xml" in error_of(tmp_path, '<include filename="nothing.xml"/>')


def test_path_element_adds_a_search_folder(tmp_path):
    (tmp_path / "meshes").mkdir()
    (tmp_path / "meshes" / "box.ply").write_bytes(trimesh.creation.box().export(file_type="ply"))
    scene, _ = translate(tmp_path, '<path value="meshes"/><shape type="ply"><string name="filename" value="box.ply"/></shape>')
    assert scene["shapes"][0]["file"].endswith("meshes/box.ply")


def test_references_share_one_material_and_one_medium(tmp_path):
    body = """<integrator type="volpath"/><bsdf type="null" id="glass"/>
    <medium type="homogeneous" id="fog"><float name="sigma_t" value="0.5"/></medium>
    <shape type="sphere"><ref id="glass"/><ref name="interior" id="fog"/></shape>
    <shape type="cube"><ref id="glass"/><ref name="interior" id="fog"/></shape>"""
    scene, _ = translate(tmp_path, body)
    assert len(scene["materials"]) == 1 and len(scene["media"]) == 1
    assert scene["shapes"][0]["material"] == scene["shapes"][1]["material"] == "glass"
    # Given on one side only, the other side is vacuum (as in Mitsuba).
    assert scene["shapes"][0]["interior"] == "fog" and scene["shapes"][0]["exterior"] is None


@pytest.mark.parametrize("body,message", [
    ('<shape type="sphere"><ref id="nope"/></shape>', "unknown id 'nope'"),
    ('<bsdf type="diffuse" id="a"/><bsdf type="diffuse" id="a"/>', "duplicate id 'a' (first at line"),
    ('<shape type="sphere"><float name="radius" value="1"/><float name="radius" value="2"/></shape>', "given twice"),
    ('<shape type="sphere"><float value="1"/></shape>', "a property needs a name"),
    ('<shape type="sphere"><colour name="x" value="1"/></shape>', "unexpected element <colour>"),
    ('<rgb name="x" value="1"/>', "unexpected element <rgb> in <scene>"),
    ('<film type="hdrfilm"/>', "a top-level <film> must have an id"),
    ('<shape type="sphere"><float name="radius" value="big"/></shape>', "not a list of numbers: 'big'"),
    ('<shape type="sphere"><boolean name="flip_normals" value="yes"/></shape>', "not a boolean"),
    ('<shape type="sphere"><float name="sharpness" value="2"/></shape>', "parameter 'sharpness' of"),
    ('<shape type="sphere"><string name="radius" value="2"/></shape>', "must be <float> or <integer>, got <string>"),
    ('<shape type="sphere"><bsdf type="dielectric"><texture type="checkerboard" name="int_ior"/></bsdf></shape>',
     "got <texture> type 'checkerboard' (not supported here)"),
    ('<shape type="sphere"><bsdf type="diffuse"><texture type="bitmap" name="reflectance"/></bsdf></shape>',
     "parameter 'filename' is required"),
    ('<shape type="sphere"><bsdf type="diffuse"><texture type="marble" name="reflectance"/></bsdf></shape>',
     "unsupported texture 'marble'"),
    ('<shape type="sphere"><sampler type="independent"/></shape>', "<sampler> inside"),
])
def test_structural_errors_name_file_line_and_element(tmp_path, body, message):
    text = error_of(tmp_path, body)
    assert message in text
    assert text.startswith("scene.xml:")


def test_malformed_xml_and_versions(tmp_path):
    (tmp_path / "bad.xml").write_text('<scene version="3.0.0">\n<shape type="sphere">\n</scene>')
    with pytest.raises(MitsubaXmlError, match=r"bad.xml:3: malformed XML: mismatched tag"):
        clrender.load_scene(tmp_path / "bad.xml")
    for version in ("0.6.0", "1.0.0", "4.0.0"):
        with pytest.raises(MitsubaXmlError, match=rf"scene version {version}: only versions 2.x and 3.x"):
            clrender.load_scene(write(tmp_path, "", version=version))
    (tmp_path / "noversion.xml").write_text("<scene/>")
    with pytest.raises(MitsubaXmlError, match="needs a version attribute"):
        clrender.load_scene(tmp_path / "noversion.xml")
    (tmp_path / "notscene.xml").write_text('<bsdf version="3.0.0" type="diffuse"/>')
    with pytest.raises(MitsubaXmlError, match="root element must be <scene>"):
        clrender.load_scene(tmp_path / "notscene.xml")
    with pytest.raises(MitsubaXmlError, match="scene file not found"):
        clrender.load_scene(tmp_path / "missing.xml")


def test_version_2_scenes_read_as_mitsuba_3_reads_them(tmp_path):
    # Mitsuba 3 reads 2.x files unchanged (it upgrades only older ones), also when included.
    (tmp_path / "ball.xml").write_text('<scene version="2.1.0"><shape type="sphere"/></scene>')
    body = '<include filename="ball.xml"/>'
    assert translate(tmp_path, body)[0] == mitsuba.read_scene(write(tmp_path, body, version="2.0.0")).scene
    assert clrender.load_scene(write(tmp_path, body, version="2.0.0")).shapes[0].mesh.radius == 1.0


def test_validation_errors_point_at_the_xml_element(tmp_path):
    # The dict's checks (here albedo <= 1) report the element the value came from.
    body = '<shape type="sphere">\n<bsdf type="diffuse"><rgb name="reflectance" value="1.5, 0, 0"/></bsdf></shape>'
    message = error_of(tmp_path, body)
    assert f"scene.xml:{line_of(body, 'reflectance')} <bsdf type='diffuse'>" in message
    assert "must be <= 1 per channel" in message and "materials[0].albedo" in message


def test_errors_found_at_upload_point_at_the_xml_element(tmp_path, context):
    # A rectangle 1e30 times smaller than the scene has no area in float32: found when the
    # scene's arrays are built (Renderer, `clrender info`), still named by the XML element.
    body = ('<shape type="rectangle"><transform name="to_world"><scale value="1e30"/></transform></shape>\n'
            '<shape type="sphere"/>')
    scene = clrender.load_scene(write(tmp_path, body))
    with pytest.raises(MitsubaXmlError) as error:
        clrender.Renderer(scene, context=context)
    assert error.value.where == f"scene.xml:{line_of(body, 'sphere')} <shape type='sphere'>"
    assert "degenerate at the scene's scale" in error.value.message and "(scene field shapes[1])" in error.value.message
    info = subprocess.run([sys.executable, "-m", "clrender.cli", "info", str(tmp_path / "scene.xml")],
                          capture_output=True, text=True)
    assert info.returncode == 3 and "scene.xml:" in info.stderr and "Traceback" not in info.stderr


def test_meshes_without_area_are_skipped_with_a_warning_at_the_xml_element(tmp_path):
    (tmp_path / "line.obj").write_text("v 0 0 0\nv 0 1 0\nv 0 2 0\nf 1 2 3\n")
    body = '<shape type="obj"><string name="filename" value="line.obj"/></shape>\n<shape type="sphere"/>'
    scene = clrender.load_scene(write(tmp_path, body))
    with pytest.warns(clrender.arrays.SkippedShapeWarning) as caught:
        build_scene_arrays(scene)
    line = line_of(body, "line.obj")
    assert [str(w.message) for w in caught] == [
        f"scene.xml:{line} <shape type='obj'>: no triangle of 'obj_line{line}' has an area (their corners "
        "are collinear or coincide): skipped, as it cannot be seen (scene field shapes[0])"]


# ============================================================================================
# integrator, sensor, film, sampler
# ============================================================================================
@pytest.mark.parametrize("integrator,expected", [
    ("", {"max_depth": limits.MAX_DEPTH, "rr_depth": 5}),
    ('<integrator type="path"/>', {"max_depth": limits.MAX_DEPTH, "rr_depth": 5}),
    ('<integrator type="path"><integer name="max_depth" value="3"/><integer name="rr_depth" value="2"/></integrator>',
     {"max_depth": 3, "rr_depth": 2}),
    # volpath starts roulette one vertex later than path for the same rr_depth.
    ('<integrator type="volpath"><integer name="max_depth" value="12"/></integrator>', {"max_depth": 12, "rr_depth": 6}),
    ('<integrator type="volpathmis"><integer name="rr_depth" value="0"/></integrator>', {"max_depth": limits.MAX_DEPTH, "rr_depth": 1}),
    ('<integrator type="path"><integer name="rr_depth" value="0"/></integrator>', {"max_depth": limits.MAX_DEPTH, "rr_depth": 1}),
    ('<integrator type="path"><boolean name="hide_emitters" value="true"/></integrator>',
     {"max_depth": limits.MAX_DEPTH, "rr_depth": 5, "hide_emitters": True}),
    ('<integrator type="direct"/>', {"integrator": "direct", "emitter_samples": 1, "bsdf_samples": 1}),
    ('<integrator type="direct"><integer name="shading_samples" value="3"/><integer name="bsdf_samples" value="0"/>'
     '<boolean name="hide_emitters" value="true"/></integrator>',
     {"integrator": "direct", "emitter_samples": 3, "bsdf_samples": 0, "hide_emitters": True}),
    ('<integrator type="moment"><integrator type="volpath"><integer name="max_depth" value="6"/></integrator>'
     '</integrator>', {"max_depth": 6, "rr_depth": 6, "aovs": ["variance"]}),
    ('<integrator type="aov"><string name="aovs" value="dd.y:depth, nn:sh_normal,gg:geo_normal"/>'
     '<integrator type="path" name="my_image"/></integrator>',
     {"max_depth": limits.MAX_DEPTH, "rr_depth": 5, "aovs": ["normal", "depth"]}),
    ('<integrator type="moment"><integrator type="aov"><string name="aovs" value="al:albedo,si:shape_index"/>'
     '<integrator type="direct"/></integrator></integrator>',
     {"integrator": "direct", "emitter_samples": 1, "bsdf_samples": 1, "aovs": ["albedo", "variance", "object_id"]}),
])
def test_integrators(tmp_path, integrator, expected):
    scene, _ = translate(tmp_path, integrator)
    assert {k: v for k, v in scene["render"].items() if k not in ("spp", "seed", "sampler")} == expected


def test_integrator_wrappers_note_their_aovs_and_warn_how_they_differ(tmp_path):
    body = ('<integrator type="aov"><string name="aovs" value="dd.y:depth"/><integrator type="path"/>'
            '</integrator>')
    translation = mitsuba.read_scene(write(tmp_path, body))
    assert translation.warnings == [
        f"scene.xml:{line_of(body, 'aov')} <integrator type='aov'>: AOV 'dd.y:depth' is written as clrender's "
        "'depth' layer: the planar depth (along the view axis) at the pixel centre, inf where nothing is hit; "
        "Mitsuba's is the distance along each ray, averaged, 0 there"]
    assert any("<integrator type='aov'> -> render.aovs: depth" in note for note in translation.notes)
    with pytest.warns(MitsubaXmlWarning, match="AOV 'dd.y:depth'"):
        assert clrender.load_scene(tmp_path / "scene.xml").render.aovs == ("depth",)


def test_ptracer_renders_by_path_tracing_with_a_warning(tmp_path):
    scene, warned = translate(tmp_path, '<integrator type="ptracer"><integer name="max_depth" value="6"/>'
                                        '<integer name="samples_per_pass" value="4"/></integrator>')
    assert scene["render"]["max_depth"] == 6 and scene["render"]["rr_depth"] == 5
    assert len(warned) == 1 and "rendered by path tracing" in warned[0] and "smooth mirrors and glass" in warned[0]


def test_hide_emitters_with_area_emitters_hides_the_shapes_from_camera_rays(tmp_path):
    scene, _ = translate(tmp_path, '<integrator type="path"><boolean name="hide_emitters" value="true"/></integrator>'
                                   '<shape type="rectangle"><emitter type="area"/></shape>')
    assert scene["render"]["hide_emitters"] is True
    assert clrender.load_scene(tmp_path / "scene.xml").render.hide_emitters


@pytest.mark.parametrize("integrator,message", [
    ('<integrator type="bdpt"/>', "unsupported integrator 'bdpt' (supported: path, volpath, volpathmis, ptracer, "
                                  "direct, moment, aov); Mitsuba too renders it only with a plugin of that name"),
    ('<integrator type="statistical_integrator"><integrator type="aov"><string name="aovs" value="a:albedo"/>'
     '<integrator type="path"/></integrator></integrator>', "<integrator type='statistical_integrator'>: unsupported"),
    ('<integrator type="moment"><integrator type="path_guiding_integrator"/></integrator>',
     "<integrator type='path_guiding_integrator'>: unsupported integrator"),
    ('<integrator type="direct"><integer name="emitter_samples" value="0"/><integer name="bsdf_samples" value="0"/>'
     '</integrator>', "emitter_samples and bsdf_samples are both 0"),
    ('<integrator type="direct"><integer name="shading_samples" value="-1"/></integrator>',
     "shading_samples must be in 0..1024, got -1"),
    ('<integrator type="direct"><integer name="max_depth" value="2"/></integrator>',
     "parameter 'max_depth' of scene.xml:9 <integrator type='direct'> is not supported"),
    ('<integrator type="aov"><string name="aovs" value="pp:position"/><integrator type="path"/></integrator>',
     "AOV 'pp:position': clrender writes the types albedo, sh_normal, geo_normal, depth, shape_index"),
    ('<integrator type="aov"><string name="aovs" value="depth"/><integrator type="path"/></integrator>',
     "AOV 'depth': clrender writes the types"),
    ('<integrator type="aov"><string name="aovs" value="d:depth"/></integrator>',
     "clrender renders the colour of one nested integrator, this aov integrator has 0"),
    ('<integrator type="moment"><integrator type="path"/><integrator type="volpath"/></integrator>',
     "this moment integrator has 2"),
    ('<integrator type="path"><integer name="max_depth" value="0"/></integrator>', "max_depth 0 renders a black image"),
    ('<integrator type="path"><integer name="max_depth" value="-3"/></integrator>', "max_depth must be -1"),
    ('<integrator type="path"><integer name="rr_depth" value="-1"/></integrator>', "rr_depth must be >= 0"),
    ('<integrator type="path"><float name="max_depth" value="2.5"/></integrator>', "must be <integer>"),
    ('<integrator type="path"><integer name="max_depth" valeu="2"/></integrator>',   # found by test_fuzz
     "<integer name='max_depth'>: missing attribute 'value'"),
    ('<integrator type="path"/><integrator type="path"/>', "only one <integrator>"),
])
def test_integrator_errors(tmp_path, integrator, message):
    assert message in error_of(tmp_path, integrator)


def sensor(fov="", to_world='<lookat origin="0, 0, 5" target="0, 0, 0"/>', film=None, sampler="", extra=""):
    film = film if film is not None else (
        '<film type="hdrfilm"><integer name="width" value="40"/><integer name="height" value="20"/><rfilter type="box"/></film>')
    return (f'<sensor type="perspective">{fov}<transform name="to_world">{to_world}</transform>'
            f'{film}{sampler}{extra}</sensor>')


@pytest.mark.parametrize("fov,expected_tan_half_y", [
    ('<float name="fov" value="60"/>', np.tan(np.radians(30)) / 2),                 # x axis: the default
    ('<float name="fov" value="60"/><string name="fov_axis" value="x"/>', np.tan(np.radians(30)) / 2),
    ('<float name="fov" value="60"/><string name="fov_axis" value="y"/>', np.tan(np.radians(30))),
    ('<float name="fov" value="60"/><string name="fov_axis" value="diagonal"/>', np.tan(np.radians(30)) / np.sqrt(5)),
    ('<float name="fov" value="60"/><string name="fov_axis" value="smaller"/>', np.tan(np.radians(30))),
    ('<float name="fov" value="60"/><string name="fov_axis" value="larger"/>', np.tan(np.radians(30)) / 2),
    ('<string name="focal_length" value="50mm"/>', np.hypot(36, 24) / 100 / np.sqrt(5)),
    ('', np.hypot(36, 24) / 100 / np.sqrt(5)),                                        # Mitsuba's default lens
])
def test_fov_axes_give_the_vertical_fov(tmp_path, fov, expected_tan_half_y):
    scene, _ = translate(tmp_path, "", sensor=sensor(fov))
    assert np.isclose(np.tan(np.radians(scene["camera"]["fov"]) / 2), expected_tan_half_y, rtol=1e-12)
    assert scene["camera"]["resolution"] == [40, 20]


def test_camera_frame_follows_to_world_in_document_order(tmp_path):
    # Mitsuba's camera looks along +z of its frame with +y up; a rotation then a translation.
    to_world = '<rotate y="1" angle="90"/><translate value="1, 2, 3"/>'
    camera = translate(tmp_path, "", sensor=sensor('<float name="fov" value="30"/>', to_world))[0]["camera"]
    assert np.allclose(camera["position"], [1, 2, 3])
    assert np.allclose(np.subtract(camera["look_at"], camera["position"]), [1, 0, 0])
    assert np.allclose(camera["up"], [0, 1, 0])
    assert camera["medium"] is None


def test_thinlens_is_a_camera_with_a_lens(tmp_path):
    thinlens = sensor('<float name="aperture_radius" value="0.2"/><float name="focus_distance" value="3"/>')
    camera = translate(tmp_path, "", sensor=thinlens.replace("perspective", "thinlens"))[0]["camera"]
    assert (camera["aperture_radius"], camera["focus_distance"]) == (0.2, 3.0)
    # Mitsuba's focus_distance defaults to the far_clip's value.
    thinlens = sensor('<float name="aperture_radius" value="0.2"/><float name="far_clip" value="50"/>')
    camera = translate(tmp_path, "", sensor=thinlens.replace("perspective", "thinlens"))[0]["camera"]
    assert camera["focus_distance"] == 50.0


@pytest.mark.parametrize("film,expected", [
    ('<film type="hdrfilm"/>', {"type": "gaussian", "stddev": 0.5}),   # Mitsuba's default
    ("", {"type": "gaussian", "stddev": 0.5}),                           # no film at all
    ('<film type="hdrfilm"><rfilter type="gaussian"><float name="stddev" value="0.8"/></rfilter></film>',
     {"type": "gaussian", "stddev": 0.8}),
    ('<film type="hdrfilm"><rfilter type="tent"/></film>', {"type": "tent", "radius": 1.0}),
    ('<film type="hdrfilm"><rfilter type="tent"><float name="radius" value="2"/></rfilter></film>',
     {"type": "tent", "radius": 2.0}),
    ('<film type="hdrfilm"><rfilter type="box"/></film>', {"type": "box"}),
])
def test_reconstruction_filters_are_the_cameras(tmp_path, film, expected):
    assert translate(tmp_path, "", sensor=sensor(film=film))[0]["camera"]["filter"] == expected


@pytest.mark.parametrize("sensor_xml,message", [
    ('<sensor type="orthographic"/>', "unsupported sensor 'orthographic' (supported: perspective, thinlens)"),
    (sensor().replace("perspective", "thinlens"), "a thinlens sensor needs an aperture_radius"),
    (sensor('<float name="aperture_radius" value="-1"/>').replace("perspective", "thinlens"),
     "aperture_radius must be >= 0 and focus_distance > 0, got -1 and 10000"),
    (sensor(to_world='<scale value="2"/>'), "must be a rotation and translation: it scales or shears"),
    (sensor(to_world='<scale x="-1"/>'), "must be a rotation and translation: it mirrors the image"),
    (sensor('<float name="fov" value="30"/><string name="focal_length" value="50mm"/>'), "either fov or focal_length"),
    (sensor('<string name="focal_length" value="wide"/>'), "focal_length must be like '50mm'"),
    (sensor('<string name="focal_length" value="1.2.3mm"/>'), "focal_length must be like '50mm'"),
    (sensor('<float name="fov" value="200"/>'), "fov must be in (0, 180)"),
    (sensor('<float name="fov" value="30"/><string name="fov_axis" value="z"/>'), "unknown fov_axis 'z'"),
    (sensor(extra='<float name="principal_point_offset_x" value="0.1"/>'), "principal_point_offset_x is not supported"),
    (sensor(film='<film type="specfilm"/>'), "unsupported film 'specfilm'"),
    (sensor(film='<film type="hdrfilm"><integer name="crop_width" value="4"/></film>'), "crop windows are not supported"),
    (sensor(sampler='<sampler type="fancy"/>'), "unsupported sampler 'fancy'"),
    (sensor(sampler='<sampler type="independent"><integer name="sample_count" value="0"/></sampler>'), "sample_count must be >= 1"),
    (sensor(film='<film type="hdrfilm"/><film type="hdrfilm"/>'), "at most one film"),
    (sensor(film='<film type="hdrfilm"><rfilter type="gaussian"><float name="stddev" value="5"/></rfilter></film>'),
     "stddev must be in [0.0025, 4] pixels, got 5"),
    (sensor(film='<film type="hdrfilm"><rfilter type="tent"><float name="width" value="5"/></rfilter></film>'),
     "parameter 'width' of scene.xml:3 <rfilter type='tent'> is not supported"),
    (sensor(film='<film type="hdrfilm"><integer name="height" value="0"/><rfilter type="box"/></film>'),
     "width and height must be >= 1"),
    (sensor(film='<film type="hdrfilm"><integer name="width" value="20000"/><rfilter type="box"/></film>'),
     "got [20000, 576] (scene field camera.resolution)"),
])
def test_sensor_errors(tmp_path, sensor_xml, message):
    assert message in error_of(tmp_path, "", sensor=sensor_xml)


def test_sensor_without_sensor_or_with_two_is_an_error(tmp_path):
    assert "scene.xml:2 <scene>: the scene has no <sensor>" in error_of(tmp_path, "", sensor="")
    assert "keep a single <sensor>" in error_of(tmp_path, SENSOR)


def test_sensor_warnings(tmp_path):
    _, warned = translate(tmp_path, "", sensor=sensor(film='<film type="hdrfilm"/>',
                                                      extra='<float name="near_clip" value="0.5"/>'))
    assert len(warned) == 1 and "near_clip 0.5 ignored" in warned[0]
    _, warned = translate(tmp_path, "", sensor=sensor(film='<film type="hdrfilm"><rfilter type="mitchell"/></film>'))
    assert any("reconstruction filter 'mitchell' approximated by clrender's box filter" in w for w in warned)
    _, warned = translate(tmp_path, "", sensor=sensor(film='<film type="hdrfilm"><boolean name="sample_border" '
                                                           'value="true"/></film>'))
    assert len(warned) == 1 and "sample_border: Mitsuba also samples outside the image" in warned[0]
    scene, warned = translate(tmp_path, "", sensor=sensor(film=""))
    assert scene["camera"]["resolution"] == [768, 576] and any("no <film>" in w for w in warned)
    _, warned = translate(tmp_path, "", sensor=sensor(extra='<float name="near_clip" value="0.01"/>'))
    assert warned == []


def linear_to_world(linear):
    """A sensor's to_world: `linear` (3x3) then a translation, as a 16-number <matrix>."""
    matrix = np.eye(4)
    matrix[:3, :3], matrix[:3, 3] = linear, [0.5, -1, 5]
    return f'<matrix value="{" ".join(f"{v:.17g}" for v in matrix.ravel())}"/>'


def shear(amount):
    linear = np.eye(3)
    linear[0, 1] = amount
    return linear


ROTATION = np.array([[0, 0, -1], [0, 1, 0], [1, 0, 0]])   # about y, looking down -x


@pytest.mark.parametrize("linear,corner_shift", [
    (ROTATION, None),
    (ROTATION @ np.diag([1.0004, 1, 1]), 0.2),        # |L L^T - I| 8e-4: within Mitsuba's 1e-3
    (ROTATION @ shear(9e-4), 0.45),
    (ROTATION @ np.diag([1.0001, 1, 1]), None),       # 0.05 pixels: no warning
    (ROTATION @ shear(2e-5) @ np.diag([1, 1.00001, 1]), None),   # as Bitterli's 6-digit matrices
])
def test_sensor_to_world_may_be_a_rotation_to_mitsubas_tolerance(tmp_path, linear, corner_shift):
    film = '<film type="hdrfilm"><integer name="width" value="1000"/><integer name="height" value="500"/><rfilter type="box"/></film>'
    scene, warned = translate(tmp_path, "", sensor=sensor('<float name="fov" value="40"/>', linear_to_world(linear), film))
    camera = scene["camera"]
    assert np.allclose(camera["position"], [0.5, -1, 5])
    forward = linear @ [0, 0, 1]
    assert np.allclose(np.subtract(camera["look_at"], camera["position"]), forward / np.linalg.norm(forward))
    assert np.allclose(camera["up"], linear @ [0, 1, 0])
    shifts = [w for w in warned if "rotation to" in w]
    if corner_shift is None:
        assert shifts == []
    else:   # the corners of a 1000-pixel-wide film move by 500 x the stretch or shear
        assert len(shifts) == 1 and f"pass {corner_shift:.2g} pixels from Mitsuba's" in shifts[0]


@pytest.mark.parametrize("linear,message", [
    (ROTATION @ np.diag([1.0006, 1, 1]), "it scales or shears (|L L^T - I| = 0.0012"),   # Mitsuba refuses it too
    (ROTATION @ shear(1.2e-3), "it scales or shears (|L L^T - I| = 0.0012"),
    (ROTATION @ shear(0.1), "it scales or shears"),
    (ROTATION @ np.diag([1, 1, -1]), "it mirrors the image"),    # Mitsuba renders it mirrored
])
def test_sensor_to_world_that_scales_shears_or_mirrors_is_an_error(tmp_path, linear, message):
    text = error_of(tmp_path, "", sensor=sensor('<float name="fov" value="40"/>', linear_to_world(linear)))
    assert "scene.xml:3 <sensor type='perspective'>: the sensor's to_world must be a rotation and translation" in text
    assert message in text


def test_focus_distance_is_accepted_on_a_pinhole_camera(tmp_path):
    with_focus = translate(tmp_path, "", sensor=sensor(extra='<float name="focus_distance" value="3"/>'))
    assert with_focus == translate(tmp_path, "", sensor=sensor())
    assert "must be <float> or <integer>" in error_of(
        tmp_path, "", sensor=sensor(extra='<string name="focus_distance" value="near"/>'))


@pytest.mark.parametrize("sampler,spp,seed,kind", [
    ("", 4, 0, "sobol"),
    ('<sampler type="independent"><integer name="sample_count" value="10"/><integer name="seed" value="7"/></sampler>', 10, 7,
     "sobol"),
    ('<sampler type="stratified"><integer name="sample_count" value="10"/></sampler>', 16, 0, "sobol"),
    ('<sampler type="multijitter"><integer name="sample_count" value="9"/></sampler>', 9, 0, "sobol"),
    ('<sampler type="ldsampler"><integer name="sample_count" value="10"/></sampler>', 16, 0, "sobol"),
    ('<sampler type="orthogonal"><integer name="sample_count" value="10"/></sampler>', 25, 0, "sobol"),
])
def test_samplers(tmp_path, sampler, spp, seed, kind):
    render = translate(tmp_path, "", sensor=sensor(sampler=sampler))[0]["render"]
    assert (render["spp"], render["seed"], render["sampler"]) == (spp, seed, kind)


# ============================================================================================
# BSDFs
# ============================================================================================
def material_of(folder, bsdf):
    scene, warned = translate(folder, f'<integrator type="volpath"/><shape type="sphere">{bsdf}</shape>')
    material = dict(scene["materials"][0])
    material.pop("name")
    return material, warned


@pytest.mark.parametrize("bsdf,expected", [
    ('', {"type": "diffuse", "albedo": [0.5] * 3, "two_sided": False}),
    ('<bsdf type="diffuse"/>', {"type": "diffuse", "albedo": [0.5] * 3, "two_sided": False}),
    ('<bsdf type="twosided"><bsdf type="diffuse"><float name="reflectance" value="0.2"/></bsdf></bsdf>',
     {"type": "diffuse", "albedo": [0.2] * 3, "two_sided": True}),
    ('<bsdf type="dielectric"/>', {"type": "dielectric", "ior": 1.5046, "exterior_ior": 1.000277, "tint": [1.0] * 3,
                                   "reflection_tint": [1.0] * 3}),
    ('<bsdf type="dielectric"><string name="int_ior" value="water"/><float name="ext_ior" value="1.1"/>'
     '<rgb name="specular_transmittance" value="0.5, 0.6, 0.7"/><float name="specular_reflectance" value="0.4"/></bsdf>',
     {"type": "dielectric", "ior": 1.333, "exterior_ior": 1.1, "tint": [0.5, 0.6, 0.7], "reflection_tint": [0.4] * 3}),
    ('<bsdf type="thindielectric"><string name="int_ior" value="bk7"/><string name="ext_ior" value="air"/></bsdf>',
     {"type": "thin_dielectric", "ior": 1.5046, "exterior_ior": 1.000277, "tint": [1.0] * 3,
      "reflection_tint": [1.0] * 3}),
    ('<bsdf type="roughdielectric"><string name="distribution" value="ggx"/><float name="alpha" value="0.09"/></bsdf>',
     {"type": "dielectric", "ior": 1.5046, "exterior_ior": 1.000277, "tint": [1.0] * 3, "roughness": 0.3,
      "reflection_tint": [1.0] * 3, "distribution": "ggx", "masking": "separable", "energy_compensation": False}),
    ('<bsdf type="roughdielectric"><string name="distribution" value="GGX"/><float name="alpha_u" value="0.04"/>'
     '<float name="alpha_v" value="0.04"/></bsdf>',
     {"type": "dielectric", "ior": 1.5046, "exterior_ior": 1.000277, "tint": [1.0] * 3, "roughness": 0.2,
      "reflection_tint": [1.0] * 3, "distribution": "ggx", "masking": "separable", "energy_compensation": False}),
    ('<bsdf type="roughdielectric"><boolean name="sample_visible" value="false"/></bsdf>',   # Mitsuba's defaults
     {"type": "dielectric", "ior": 1.5046, "exterior_ior": 1.000277, "tint": [1.0] * 3, "roughness": np.sqrt(0.1),
      "reflection_tint": [1.0] * 3, "distribution": "beckmann", "masking": "separable", "energy_compensation": False}),
    ('<bsdf type="conductor"/>', {"type": "conductor", "tint": [1.0] * 3, "two_sided": False}),
    ('<bsdf type="twosided"><bsdf type="roughconductor"><string name="distribution" value="ggx"/>'
     '<rgb name="specular_reflectance" value="0.5, 0.4, 0.3"/></bsdf></bsdf>',
     {"type": "conductor", "tint": [0.5, 0.4, 0.3], "two_sided": True, "roughness": np.sqrt(0.1),
      "distribution": "ggx", "masking": "separable", "energy_compensation": False}),
    ('<bsdf type="null"/>', {"type": "interface"}),
    ('<bsdf type="plastic"/>',   # Mitsuba's defaults: polypropylene in air
     {"type": "plastic", "two_sided": False, "ior": 1.49, "exterior_ior": 1.000277, "diffuse": [0.5] * 3,
      "specular": [1.0] * 3, "nonlinear": False}),
    ('<bsdf type="twosided"><bsdf type="plastic"><float name="int_ior" value="1.9"/><string name="ext_ior" '
     'value="water"/><rgb name="diffuse_reflectance" value="0.1, 0.2, 0.3"/><float name="specular_reflectance" '
     'value="0.5"/><boolean name="nonlinear" value="true"/></bsdf></bsdf>',
     {"type": "plastic", "two_sided": True, "ior": 1.9, "exterior_ior": 1.333, "diffuse": [0.1, 0.2, 0.3],
      "specular": [0.5] * 3, "nonlinear": True}),
    ('<bsdf type="roughplastic"/>',
     {"type": "plastic", "two_sided": False, "ior": 1.49, "exterior_ior": 1.000277, "diffuse": [0.5] * 3,
      "specular": [1.0] * 3, "nonlinear": False, "roughness": np.sqrt(0.1), "distribution": "beckmann"}),
    ('<bsdf type="twosided"><bsdf type="roughplastic"><string name="distribution" value="ggx"/>'
     '<float name="alpha" value="0.04"/><boolean name="sample_visible" value="false"/></bsdf></bsdf>',
     {"type": "plastic", "two_sided": True, "ior": 1.49, "exterior_ior": 1.000277, "diffuse": [0.5] * 3,
      "specular": [1.0] * 3, "nonlinear": False, "roughness": 0.2, "distribution": "ggx"}),
])
def test_bsdfs(tmp_path, bsdf, expected):
    material, warned = material_of(tmp_path, bsdf)
    assert material.keys() == expected.keys()
    for key, value in expected.items():
        assert np.allclose(material[key], value) if not isinstance(value, str) else material[key] == value, key
    assert warned == []


@pytest.mark.parametrize("bsdf,expected", [
    ('<bsdf type="conductor"><string name="material" value="Au"/><float name="specular_reflectance" value="0.5"/></bsdf>',
     {"material": "Au", "tint": [0.5] * 3}),
    ('<bsdf type="conductor"><rgb name="eta" value="0.2, 0.9, 1.1"/><rgb name="k" value="3.9, 2.4, 2.2"/></bsdf>',
     {"eta": [0.2, 0.9, 1.1], "k": [3.9, 2.4, 2.2], "tint": [1.0] * 3}),
    ('<bsdf type="conductor"><float name="eta" value="1.5"/></bsdf>', {"eta": [1.5] * 3, "k": [1.0] * 3, "tint": [1.0] * 3}),
    ('<bsdf type="roughconductor"><string name="material" value="none"/></bsdf>', {"tint": [1.0] * 3}),
])
def test_conductor_indices_translate_without_warnings(tmp_path, bsdf, expected):
    # Presets by name, explicit eta and k (Mitsuba's defaults 0 and 1), none: a perfect mirror.
    material, warned = material_of(tmp_path, bsdf)
    assert {key: material[key] for key in ("material", "eta", "k", "tint") if key in material} == expected
    assert warned == []


def test_conductor_with_a_textured_reflectance_keeps_its_index(tmp_path):
    material, _ = material_of(tmp_path, '<bsdf type="conductor"><string name="material" value="Cu"/>'
                                        '<texture type="checkerboard" name="specular_reflectance"/></bsdf>')
    assert material["material"] == "Cu" and "texture" in material["tint"]


@pytest.mark.parametrize("bsdf,message", [
    ('<bsdf type="hair"/>', "unsupported BSDF 'hair' (supported: diffuse, dielectric"),
    ('<bsdf type="plastic"><float name="int_ior" value="1.2"/><float name="ext_ior" value="1.2"/></bsdf>',
     "int_ior and ext_ior must differ"),
    ('<bsdf type="roughplastic"><texture type="checkerboard" name="alpha"/></bsdf>',
     "a textured alpha is not supported on roughplastic (Mitsuba takes a number)"),
    ('<bsdf type="roughplastic"><float name="alpha_u" value="0.1"/><float name="alpha_v" value="0.2"/></bsdf>',
     "anisotropic roughness"),
    ('<bsdf type="roughdielectric"><string name="distribution" value="phong"/></bsdf>',
     "unknown microfacet distribution 'phong' (known: ggx, beckmann)"),
    ('<bsdf type="roughconductor"><string name="distribution" value="ggx"/><float name="alpha_u" value="0.1"/>'
     '<float name="alpha_v" value="0.2"/></bsdf>', "anisotropic roughness"),
    ('<bsdf type="roughconductor"><string name="distribution" value="ggx"/><float name="alpha" value="1.5"/></bsdf>',
     "alpha must be in [0, 1]"),
    ('<bsdf type="roughconductor"><string name="distribution" value="ggx"/><float name="alpha" value="0.1"/>'
     '<float name="alpha_u" value="0.1"/></bsdf>', "either alpha or alpha_u"),
    ('<bsdf type="dielectric"><string name="int_ior" value="unobtainium"/></bsdf>', "unknown index of refraction"),
    ('<bsdf type="conductor"><string name="material" value="Xx"/></bsdf>', "unknown conductor material 'Xx'"),
    ('<bsdf type="conductor"><string name="material" value="Au"/><float name="eta" value="1"/></bsdf>',
     "either material or eta and k"),
    ('<bsdf type="twosided"><bsdf type="diffuse"/><bsdf type="diffuse"/><bsdf type="diffuse"/></bsdf>',
     "twosided needs 1 or 2 nested BSDFs, got 3"),
    ('<bsdf type="twosided"><bsdf type="dielectric"/></bsdf>', "a 'dielectric' inside twosided is not supported"),
    ('<bsdf type="diffuse"><rgb name="reflectance" value="1, 2"/></bsdf>', "expected 3 numbers (or 1)"),
    ('<bsdf type="diffuse"><spectrum name="reflectance" filename="x.spd"/></bsdf>', "no .spd files"),
    ('<bsdf type="diffuse"><spectrum name="reflectance" value="500:0.1, 400:0.2"/></bsdf>', "increasing wavelengths"),
    ('<bsdf type="diffuse"><spectrum name="reflectance" value="500-0.1"/></bsdf>', "not a list of numbers"),
    ('<bsdf type="diffuse"><spectrum name="reflectance" value="a:0.1, 600:0.2"/></bsdf>', "wavelength:value pairs"),
])
def test_bsdf_errors(tmp_path, bsdf, message):
    assert message in error_of(tmp_path, f'<shape type="sphere">{bsdf}</shape>')


def test_sampled_spectrum_becomes_rgb_with_a_warning(tmp_path):
    material, warned = material_of(tmp_path, '<bsdf type="diffuse"><spectrum name="reflectance" '
                                             'value="400:0.1, 500:0.5, 600:0.9, 700:0.2"/></bsdf>')
    assert np.allclose(material["albedo"], cie.spectrum_to_rgb([400, 500, 600, 700], [0.1, 0.5, 0.9, 0.2], False))
    assert "spectrum converted to RGB" in warned[0]
    material, warned = material_of(tmp_path, '<bsdf type="diffuse"><spectrum name="reflectance" value="0.3"/></bsdf>')
    assert material["albedo"] == [0.3] * 3 and warned == []


def test_spectrum_to_rgb_of_flat_and_white_spectra():
    assert np.allclose(cie.spectrum_to_rgb([360, 830], [0.5, 0.5], illuminant=False), 0.5, atol=2e-3)
    assert np.allclose(cie.equal_energy_rgb(), [1.205, 0.948, 0.909], atol=3e-3)


# ============================================================================================
# Shapes
# ============================================================================================
def test_shapes(tmp_path):
    (tmp_path / "ball.obj").write_text(trimesh.creation.icosphere(1).export(file_type="obj"))
    (tmp_path / "box.ply").write_bytes(trimesh.creation.box().export(file_type="ply"))
    body = """<shape type="rectangle" id="floor"><transform name="to_world"><scale value="3"/></transform></shape>
    <shape type="cube"><boolean name="flip_normals" value="true"/></shape>
    <shape type="sphere"><point name="center" x="1" y="2" z="3"/><float name="radius" value="0.5"/></shape>
    <shape type="disk"/>
    <shape type="obj"><string name="filename" value="ball.obj"/><boolean name="face_normals" value="true"/></shape>
    <shape type="ply"><string name="filename" value="box.ply"/></shape>"""
    shapes = translate(tmp_path, body)[0]["shapes"]
    assert [s["type"] for s in shapes] == ["rectangle", "box", "sphere", "disk", "mesh", "mesh"]
    assert shapes[0]["name"] == "floor" and shapes[0]["transform"]["matrix"][0][0] == 3
    assert shapes[1]["flip_normals"] is True
    assert shapes[2]["center"] == [1, 2, 3] and shapes[2]["radius"] == 0.5
    assert shapes[4]["smooth"] is False and shapes[5]["smooth"] is True
    scene = clrender.load_scene(tmp_path / "scene.xml")
    sphere = scene.shapes[2].mesh   # analytic
    assert isinstance(sphere, meshes.Sphere) and sphere.center.tolist() == [1, 2, 3] and sphere.radius == 0.5
    assert [len(s.mesh.faces) for i, s in enumerate(scene.shapes) if i != 2] == [2, 12, 128, 80, 12]


def test_sphere_to_world_applies_after_center_and_radius(tmp_path):
    # Mitsuba's sphere is to_world * translate(center) * scale(radius) applied to the unit sphere.
    body = """<shape type="sphere"><point name="center" x="1" y="0" z="0"/><float name="radius" value="0.5"/>
    <boolean name="flip_normals" value="true"/>
    <transform name="to_world"><scale value="2"/><rotate z="1" angle="90"/><translate x="0" y="0" z="3"/></transform>
    </shape>"""
    sphere = clrender.load_scene(write(tmp_path, body)).shapes[0].mesh
    assert isinstance(sphere, meshes.Sphere) and sphere.flipped
    np.testing.assert_allclose(sphere.center, [0, 2, 3], atol=1e-12)
    assert sphere.radius == pytest.approx(1.0)


def test_mesh_file_shapes_pass_their_options(tmp_path):
    from mesh_writers import write_serialized

    (tmp_path / "ball.obj").write_text(trimesh.creation.icosphere(1).export(file_type="obj"))
    (tmp_path / "box.ply").write_bytes(trimesh.creation.box().export(file_type="ply"))
    triangle = {"positions": [[0, 0, 0], [1, 0, 0], [0, 1, 0]], "faces": [[0, 1, 2]]}
    write_serialized(tmp_path / "parts.serialized", [triangle, dict(triangle, positions=[[0, 0, 0], [2, 0, 0], [0, 2, 0]])])
    body = """<shape type="obj"><string name="filename" value="ball.obj"/><boolean name="flip_tex_coords" value="false"/></shape>
    <shape type="ply"><string name="filename" value="box.ply"/><boolean name="flip_tex_coords" value="true"/></shape>
    <shape type="serialized"><string name="filename" value="parts.serialized"/><integer name="shape_index" value="1"/>
        <boolean name="face_normals" value="true"/><transform name="to_world"><translate z="1"/></transform></shape>
    <shape type="serialized"><string name="filename" value="parts.serialized"/></shape>"""
    shapes = translate(tmp_path, body)[0]["shapes"]
    assert shapes[0]["flip_tex_coords"] is False and shapes[1]["flip_tex_coords"] is True
    assert {k: shapes[2][k] for k in ("type", "smooth", "shape_index")} == {"type": "mesh", "smooth": False, "shape_index": 1}
    assert shapes[3]["shape_index"] == 0 and shapes[3]["smooth"] is True and "flip_tex_coords" not in shapes[3]
    scene = clrender.load_scene(tmp_path / "scene.xml")
    np.testing.assert_array_equal(scene.shapes[2].mesh.vertices, [[0, 0, 1], [2, 0, 1], [0, 2, 1]])
    np.testing.assert_array_equal(scene.shapes[3].mesh.vertices, [[0, 0, 0], [1, 0, 0], [0, 1, 0]])


@pytest.mark.parametrize("body,message", [
    ('<shape type="cylinder"/>', "unsupported shape 'cylinder' (supported: rectangle, cube, sphere, disk, obj, ply, serialized)"),
    ('<shape type="serialized"><string name="filename" value="parts.serialized"/>'
     '<boolean name="flip_tex_coords" value="true"/></shape>', "a serialized shape has no flip_tex_coords: Mitsuba 3 refuses it"),
    ('<shape type="serialized"><string name="filename" value="parts.serialized"/>'
     '<integer name="shape_index" value="2"/></shape>', "shape_index 2 is out of range: the file has 1 shape (0..0)"),
    ('<shape type="ply"><string name="filename" value="parts.serialized"/></shape>',
     "a 'ply' shape's file must end in .ply (clrender reads mesh files by their suffix), got 'parts.serialized'"),
    ('<shape type="obj"/>', "parameter 'filename' is required"),
    ('<shape type="obj"><string name="filename" value="none.obj"/></shape>', "file not found: none.obj"),
    ('<shape type="sphere"><transform name="to_world"><scale x="2"/></transform></shape>', "non-uniform scales on spheres"),
    ('<shape type="rectangle"><transform name="to_world"><scale value="0"/></transform></shape>', "singular"),
    ('<shape type="rectangle"><transform name="to_world"><matrix value="1 0 0 0 0 1 0 0 0 0 1 0 0 0 1 1"/>'
     '</transform></shape>', "projective matrices"),
    ('<shape type="rectangle"><transform name="to_world"><matrix value="1 2 3"/></transform></shape>', "9 or 16 numbers"),
    ('<shape type="rectangle"><transform name="to_world"><rotate x="1"/></transform></shape>', "needs an angle"),
    ('<shape type="rectangle"><transform name="to_world"><rotate angle="3"/></transform></shape>', "non-zero axis"),
    ('<shape type="rectangle"><transform name="to_world"><shear x="1"/></transform></shape>', "unknown transform operation"),
    ('<shape type="rectangle"><transform name="to_world"><lookat origin="1 1 1" target="1 1 1"/></transform></shape>',
     "origin and target coincide"),
    ('<shape type="rectangle"><transform name="to_world"><lookat origin="0 0 0" target="0 1 0"/></transform></shape>',
     "up is parallel"),
    ('<shape type="rectangle"><bsdf type="diffuse"/><bsdf type="diffuse"/></shape>', "at most one BSDF"),
    ('<shape type="rectangle"><emitter type="area"/><emitter type="area"/></shape>', "at most one emitter"),
    ('<shape type="rectangle"><emitter type="point"/></shape>', "only 'area' emitters can be attached"),
    ('<shape type="rectangle"><bsdf type="null"/><emitter type="area"/></shape>',
     "an area emitter on a 'null' BSDF is not supported"),
    ('<shape type="rectangle"><medium type="homogeneous"/></shape>', "<medium> inside"),
])
def test_shape_errors(tmp_path, body, message):
    from mesh_writers import write_serialized

    write_serialized(tmp_path / "parts.serialized", [{"positions": [[0, 0, 0], [1, 0, 0], [0, 1, 0]], "faces": [[0, 1, 2]]}])
    assert message in error_of(tmp_path, body)


def test_area_emitters(tmp_path):
    body = """<shape type="rectangle"><emitter type="area"><rgb name="radiance" value="1, 2, 3"/></emitter></shape>
    <shape type="disk"><bsdf type="diffuse"><float name="reflectance" value="0.3"/></bsdf><emitter type="area"/></shape>
    <shape type="sphere"><emitter type="area"><spectrum name="radiance" value="2"/></emitter></shape>"""
    scene, warned = translate(tmp_path, body)
    materials = {m["name"]: m for m in scene["materials"]}
    first, second, third = (materials[s["material"]] for s in scene["shapes"])
    assert first == {"name": "emitter", "type": "diffuse", "albedo": [0.0] * 3, "two_sided": False,
                     "emission": [1.0, 2.0, 3.0]}
    assert second["albedo"] == [0.3] * 3 and second["emission"] == [1.0] * 3
    # A uniform spectrum on an emitter is an equal-energy illuminant (as in Mitsuba's RGB modes).
    assert np.allclose(third["emission"], 2 * cie.equal_energy_rgb()) and "equal-energy illuminant" in warned[0]


# ============================================================================================
# Emitters
# ============================================================================================
def test_emitters(tmp_path):
    body = """<emitter type="point"><point name="position" value="1, 2, 3"/><float name="intensity" value="5"/></emitter>
    <emitter type="point"><transform name="to_world"><translate x="4"/></transform></emitter>
    <emitter type="directional"><vector name="direction" x="0" y="-1" z="0"/><rgb name="irradiance" value="1, 2, 3"/></emitter>
    <emitter type="directional"><transform name="to_world"><rotate x="1" angle="90"/></transform></emitter>
    <emitter type="constant"><rgb name="radiance" value="0.1, 0.2, 0.3"/></emitter>"""
    lights = translate(tmp_path, body)[0]["lights"]
    assert lights[0] == {"type": "point", "position": [1, 2, 3], "intensity": [5.0] * 3}
    assert lights[1]["position"] == [4, 0, 0] and lights[1]["intensity"] == [1.0] * 3
    assert lights[2] == {"type": "directional", "direction": [0, -1, 0], "irradiance": [1.0, 2.0, 3.0]}
    assert np.allclose(lights[3]["direction"], [0, -1, 0])   # +z turned by 90 degrees about x
    assert lights[4] == {"type": "environment", "radiance": [0.1, 0.2, 0.3]}


def test_spot_lights(tmp_path):
    # Mitsuba's defaults: at the origin shining along +z, cutoff 20 degrees, beam 3/4 of it;
    # to_world places and turns it (a uniform scale changes nothing).
    body = """<emitter type="spot"/>
    <emitter type="spot"><transform name="to_world"><rotate x="1" angle="90"/><scale value="2"/>
        <translate value="1, 2, 3"/></transform><rgb name="intensity" value="1, 2, 3"/>
        <float name="cutoff_angle" value="40"/><float name="beam_width" value="5"/></emitter>"""
    lights = translate(tmp_path, body)[0]["lights"]
    assert lights[0] == {"type": "spot", "position": [0, 0, 0], "direction": [0, 0, 1], "intensity": [1.0] * 3,
                         "cutoff_angle": 20.0, "beam_width": 15.0}
    assert np.allclose(lights[1]["position"], [1, 2, 3]) and np.allclose(lights[1]["direction"], [0, -1, 0])
    assert (lights[1]["intensity"], lights[1]["cutoff_angle"], lights[1]["beam_width"]) == ([1.0, 2.0, 3.0], 40.0, 5.0)


def test_envmap_keeps_its_image_and_mitsubas_lookup(tmp_path):
    """The map as read (no resampling, no warning), with its scale, Mitsuba's lookup and
    to_world's rotation (a translation dropped: directions only)."""
    image = np.random.default_rng(3).uniform(0.5, 2.0, (6, 10, 3)).astype(np.float32)
    clrender.save_image(image, tmp_path / "env.exr")
    turned = '<transform name="to_world"><rotate x="1" angle="90"/><translate x="5"/></transform>'
    for rotation in ("", turned):
        scene, warned = translate(tmp_path, '<emitter type="envmap"><string name="filename" value="env.exr"/>'
                                            f'<float name="scale" value="2"/>{rotation}</emitter>')
        light = scene["lights"][0]
        assert not warned and light["lookup"] == "mitsuba" and light["scale"] == 2.0
        assert np.array_equal(light["image"], clrender.load_image(tmp_path / "env.exr"))
        loaded = clrender.load_scene_dict(scene).environment
        assert np.array_equal(loaded.image, light["image"] * np.float32(2)) and loaded.lookup == "mitsuba"
        expected = meshes.transform_matrix(rotate=[90, 0, 0])[:3, :3] if rotation else np.eye(3)
        np.testing.assert_allclose(loaded.rotation, expected, atol=1e-12)


def test_envmap_lookup_convention():
    # Mitsuba's texel i is centred at u = (i + 0.5) / W, u = atan2(x, -z) / 2pi; rows at v = j / (H - 1).
    image = np.zeros((3, 4, 3))
    image[1, 2] = 1.0
    u, v = (2 + 0.5) / 4, 0.5
    phi, theta = 2 * np.pi * u, np.pi * v
    direction = np.array([[np.sin(phi) * np.sin(theta), np.cos(theta), -np.cos(phi) * np.sin(theta)]])
    assert np.allclose(mitsuba_envmap_lookup(image, direction), 1.0)
    assert np.allclose(mitsuba_envmap_lookup(image, direction * [[1, 1, -1]]), 0.0)


@pytest.mark.parametrize("body,message", [
    ('<emitter type="area"/>', "an area emitter belongs inside a <shape>"),
    ('<emitter type="sun"/>', "unsupported emitter 'sun' (supported: point, spot, directional, constant, envmap"),
    ('<emitter type="spot"><transform name="to_world"><scale x="2"/></transform></emitter>',
     "a spot's to_world must be a rotation, a uniform scale and a translation"),
    ('<emitter type="spot"><texture type="bitmap" name="texture"/></emitter>', "spot textures are not supported"),
    ('<emitter type="spot"><float name="cutoff_angle" value="190"/></emitter>', "must be <= 180, got 190"),
    ('<emitter type="point"><point name="position" value="1 2 3"/><transform name="to_world"/></emitter>',
     "either position or to_world"),
    ('<emitter type="directional"><vector name="direction" value="1 2 3"/><transform name="to_world"/></emitter>',
     "either direction or to_world"),
    ('<emitter type="constant"/><emitter type="constant"/>', "only one environment emitter"),
    ('<emitter type="envmap"/>', "parameter 'filename' is required"),
    ('<emitter type="envmap"><string name="filename" value="env.exr"/><transform name="to_world"><scale value="2"/>'
     '</transform></emitter>', "an envmap's to_world must be a rotation"),
    ('<emitter type="envmap"><string name="filename" value="env.exr"/><transform name="to_world"><scale x="2"/>'
     '</transform></emitter>', "an envmap's to_world must be a rotation"),
    ('<emitter type="directional"><vector name="direction" value="0 0 0"/></emitter>', "must be non-zero"),
])
def test_emitter_errors(tmp_path, body, message):
    clrender.save_image(np.ones((4, 8, 3), np.float32), tmp_path / "env.exr")
    assert message in error_of(tmp_path, body)


def test_hide_emitters_hides_the_environment(tmp_path):
    from clrender.render import hidden_from_camera

    translate(tmp_path, '<integrator type="path"><boolean name="hide_emitters" value="true"/>'
                        '</integrator><emitter type="constant"/>')
    settings = clrender.load_scene(tmp_path / "scene.xml").render
    assert hidden_from_camera(settings) == layout.HIDDEN_FROM_CAMERA["environment"] | layout.HIDDEN_FROM_CAMERA["emitting_shapes"]


# ============================================================================================
# Media
# ============================================================================================
def medium_scene(medium, integrator="volpath", shape_medium=True):
    where = ('<shape type="cube"><bsdf type="null"/>' + medium.replace("<medium ", '<medium name="interior" ', 1)
             + "</shape>") if shape_medium else ""
    return f'<integrator type="{integrator}"/>{where}'


@pytest.mark.parametrize("medium,expected", [
    ('<medium type="homogeneous"/>',
     {"sigma_t": [1.0] * 3, "albedo": [0.75] * 3, "scale": 1.0, "g": 0.0, "sample_emitters": True}),
    ('<medium type="homogeneous"><rgb name="sigma_t" value="1, 2, 3"/><float name="albedo" value="0.5"/>'
     '<float name="scale" value="4"/><phase type="hg"/><boolean name="sample_emitters" value="false"/></medium>',
     {"sigma_t": [1.0, 2.0, 3.0], "albedo": [0.5] * 3, "scale": 4.0, "g": 0.8, "sample_emitters": False}),
    ('<medium type="homogeneous"><float name="sigma_a" value="0.2"/><rgb name="sigma_s" value="1, 2, 3"/>'
     '<phase type="hg"><float name="g" value="-0.3"/></phase></medium>',
     {"sigma_a": [0.2] * 3, "sigma_s": [1.0, 2.0, 3.0], "scale": 1.0, "g": -0.3, "sample_emitters": True}),
    ('<medium type="heterogeneous"><volume type="constvolume" name="sigma_t"><float name="value" value="2"/></volume>'
     '<volume type="constvolume" name="albedo"><rgb name="value" value="0.1, 0.2, 0.3"/></volume></medium>',
     {"sigma_t": [2.0] * 3, "albedo": [0.1, 0.2, 0.3], "scale": 1.0, "g": 0.0, "sample_emitters": True}),
])
def test_homogeneous_media(tmp_path, medium, expected):
    scene, _ = translate(tmp_path, medium_scene(medium))
    medium = {k: v for k, v in scene["media"][0].items() if k != "name"}
    assert medium.keys() == expected.keys()
    for key, value in expected.items():
        assert np.allclose(medium[key], value), key


def test_grid_medium_from_a_vol_file(tmp_path):
    density = np.random.default_rng(4).uniform(0, 1, (3, 4, 5)).astype(np.float32)
    grids.write_vol(tmp_path / "smoke.vol", density, bbox=((1, 2, 3), (2, 4, 6)))
    volume = '<volume type="gridvolume" name="sigma_t"><string name="filename" value="smoke.vol"/>{}</volume>'
    medium = ('<medium type="heterogeneous">' + volume + '<float name="scale" value="3"/>'
              '<rgb name="albedo" value="0.9, 0.8, 0.7"/><phase type="isotropic"/></medium>')
    for placement, unit_to_world in [
            ('<transform name="to_world"><scale value="2"/><translate x="1"/></transform>',
             [[2, 0, 0, 1], [0, 2, 0, 0], [0, 0, 2, 0], [0, 0, 0, 1]]),
            ('<boolean name="use_grid_bbox" value="true"/>',   # the file's box [1, 2] x [2, 4] x [3, 6]
             [[1, 0, 0, 1], [0, 2, 0, 2], [0, 0, 3, 3], [0, 0, 0, 1]])]:
        # The medium around the camera (a shape's interior would have to cover the grid's box).
        medium_sensor = SENSOR.replace("</sensor>", medium.format(placement) + "</sensor>")
        scene, _ = translate(tmp_path, '<integrator type="volpath"/>', sensor=medium_sensor)
        grid_medium = scene["media"][0]
        assert grid_medium["type"] == "grid" and grid_medium["density"]["file"].endswith("smoke.vol")
        assert np.allclose(grid_medium["transform"]["matrix"], unit_to_world)
        assert (grid_medium["sigma_t"], grid_medium["scale"], grid_medium["g"]) == (1.0, 3.0, 0.0)
        loaded = clrender.load_scene(tmp_path / "scene.xml").media[0]
        assert np.array_equal(loaded.grid.density, density)
        assert np.allclose(loaded.sigma_s, 3 * np.array([0.9, 0.8, 0.7]))


def test_grid_albedo_from_a_vol_file(tmp_path):
    # An RGB albedo grid of its own resolution, placed as the density grid is (here by both files'
    # bounding boxes): the grid medium's albedo_grid; sigma_t splits by it in the kernel.
    box = ((1, 2, 3), (2, 4, 6))
    grids.write_vol(tmp_path / "smoke.vol", np.ones((3, 4, 5)), bbox=box)
    albedo = np.random.default_rng(5).uniform(0, 1, (2, 3, 2, 3)).astype(np.float32)
    grids.write_vol(tmp_path / "albedo.vol", albedo, bbox=box)
    bbox = '<boolean name="use_grid_bbox" value="true"/>'
    medium = (f'<medium type="heterogeneous"><volume type="gridvolume" name="sigma_t"><string name="filename" '
              f'value="smoke.vol"/>{bbox}</volume><volume type="gridvolume" name="albedo"><string name="filename" '
              f'value="albedo.vol"/>{bbox}</volume><float name="scale" value="2"/></medium>')
    scene, _ = translate(tmp_path, '<integrator type="volpath"/>', sensor=SENSOR.replace("</sensor>", medium + "</sensor>"))
    assert scene["media"][0]["albedo_grid"] == {"file": str((tmp_path / "albedo.vol").resolve())}
    assert "albedo" not in scene["media"][0]
    loaded = clrender.load_scene(tmp_path / "scene.xml").media[0]
    assert np.array_equal(loaded.albedo_grid, albedo)
    assert np.allclose(loaded.sigma_s, 2) and np.all(loaded.sigma_a == 0)


def test_a_volume_texture_as_albedo_is_its_value_at_the_origin(tmp_path):
    # Mitsuba 3.9 wraps a texture given as a medium's albedo in a constvolume that evaluates it at
    # a zeroed interaction (its render equals that constant's: tests/test_mitsuba_parity.py).
    values = np.zeros((2, 2, 2, 3), np.float32)
    values[..., 0] = [[[0.1, 0.3], [0.1, 0.3]], [[0.1, 0.3], [0.1, 0.3]]]   # red along x
    values[..., 1:] = 0.5
    grids.write_vol(tmp_path / "albedo.vol", values)
    texture = ('<texture type="volume" name="albedo"><volume type="gridvolume" name="volume"><string '
               'name="filename" value="albedo.vol"/><transform name="to_world"><scale value="4"/>'
               '<translate x="-1" y="-2" z="-2"/></transform></volume></texture>')
    scene, warned = translate(tmp_path, medium_scene(f'<medium type="homogeneous">{texture}</medium>'))
    # The origin is at unit x 0.25, the first sample's centre: 0.1.
    assert np.allclose(scene["media"][0]["albedo"], [0.1, 0.5, 0.5])
    assert len(warned) == 1 and "its value at the world origin, (0.1, 0.5, 0.5)" in warned[0]


@pytest.mark.parametrize("medium,message", [
    ('<medium type="sparse"/>', "unsupported medium 'sparse' (supported: homogeneous, heterogeneous)"),
    ('<medium type="homogeneous"><float name="sigma_a" value="1"/><float name="sigma_t" value="1"/></medium>',
     "either sigma_t and albedo, or sigma_a and sigma_s"),
    ('<medium type="homogeneous"><phase type="rayleigh"/></medium>', "unsupported phase function 'rayleigh'"),
    ('<medium type="homogeneous"><phase type="hg"/><phase type="hg"/></medium>', "one phase function"),
    ('<medium type="homogeneous"><float name="albedo" value="1.5"/></medium>', "must be <= 1 per channel"),
    ('<medium type="homogeneous"><volume type="gridvolume" name="sigma_t"><string name="filename" value="g.vol"/>'
     '</volume></medium>', "a grid sigma_t needs a heterogeneous medium"),
    ('<medium type="heterogeneous"><volume type="gridvolume" name="sigma_t"><string name="filename" value="g.vol"/>'
     '<string name="filter_type" value="nearest"/></volume></medium>', "only trilinear filtering"),
    ('<medium type="heterogeneous"><volume type="gridvolume" name="sigma_t"><string name="filename" value="g.vol"/>'
     '<string name="wrap_mode" value="repeat"/></volume></medium>', "only wrap_mode clamp"),
    ('<medium type="heterogeneous"><volume type="gridvolume" name="sigma_t"><string name="filename" value="g.vol"/>'
     '<float name="max_value" value="3"/></volume></medium>', "max_value is not supported"),
    ('<medium type="heterogeneous"><volume type="gridvolume" name="sigma_t"><string name="filename" value="g.vol"/>'
     '</volume><volume type="gridvolume" name="albedo"><string name="filename" value="g.vol"/>'
     '<transform name="to_world"><scale value="2"/></transform></volume></medium>',
     "the albedo grid must be placed as the sigma_t grid is"),
    ('<medium type="heterogeneous"><volume type="gridvolume" name="albedo"><string name="filename" value="g.vol"/>'
     '</volume></medium>', "a grid albedo needs a gridvolume sigma_t"),
    ('<medium type="heterogeneous"><texture type="checkerboard" name="albedo"/></medium>',
     "unsupported texture 'checkerboard' for a medium's albedo"),
    ('<medium type="heterogeneous"><volume type="gridvolume" name="sigma_t"><string name="filename" value="g.vol"/>'
     '</volume><volume type="gridvolume" name="albedo"><string name="filename" value="big.vol"/></volume></medium>',
     "albedos must be in [0, 1], the largest is 2"),
    ('<medium type="homogeneous"><float name="sigma_t" value="1"/><float name="sigma_a" value="1"/></medium>',
     "give either sigma_t and albedo, or sigma_a and sigma_s"),
    ('<medium type="heterogeneous"><volume type="gridvolume" name="sigma_t"><string name="filename" value="g.npy"/>'
     '</volume></medium>', "file not found: g.npy"),
    ('<medium type="heterogeneous"><volume type="grid3d" name="sigma_t"/></medium>', "unsupported volume 'grid3d'"),
])
def test_medium_errors(tmp_path, medium, message):
    grids.write_vol(tmp_path / "g.vol", np.ones((2, 2, 2)))
    grids.write_vol(tmp_path / "big.vol", np.full((2, 2, 2, 3), 2.0))
    assert message in error_of(tmp_path, medium_scene(medium))


def test_sensor_medium_surrounds_the_scene(tmp_path):
    medium = '<medium type="homogeneous" id="fog"><float name="sigma_t" value="0.1"/></medium>'
    fog_sensor = SENSOR.replace("</sensor>", '<ref id="fog"/></sensor>')
    scene, _ = translate(tmp_path, '<integrator type="volpath"/>' + medium + '<shape type="sphere"/>', sensor=fog_sensor)
    assert scene["medium"] == scene["camera"]["medium"] == "fog"
    assert "interior" not in scene["shapes"][0]


def test_path_integrator_ignores_media_with_a_warning(tmp_path):
    medium = '<medium type="homogeneous" id="fog"/>'
    fog_sensor = SENSOR.replace("</sensor>", '<ref id="fog"/></sensor>')
    scene, warned = translate(tmp_path, '<integrator type="path"/>' + medium +
                              '<shape type="sphere"><ref name="interior" id="fog"/></shape>', sensor=fog_sensor)
    assert scene["media"] == [] and scene["camera"]["medium"] is None and "interior" not in scene["shapes"][0]
    assert len(warned) == 2 and all("`path` integrator ignores media" in w for w in warned)
    assert "the null BSDF needs integrator volpath" in error_of(tmp_path, '<shape type="sphere"><bsdf type="null"/></shape>')


def test_shape_without_media_inside_a_medium_is_an_error(tmp_path):
    # Mitsuba keeps the smoke across the inner sphere's surface; clrender cannot say that.
    body = """<integrator type="volpath"/>
    <shape type="cube"><bsdf type="null"/><medium name="interior" type="homogeneous"/></shape>
    <shape type="sphere"><float name="radius" value="0.3"/><bsdf type="dielectric"/></shape>"""
    message = error_of(tmp_path, body)
    line = line_of(body, '<shape type="sphere">')
    assert f"scene.xml:{line} <shape type='sphere'>" in message
    assert "lies inside scene.xml:" in message and "give the shape interior and exterior explicitly" in message
    # Outside the medium's shape it is fine.
    clrender.load_scene(write(tmp_path, body.replace('<float name="radius" value="0.3"/>',
                                                     '<point name="center" x="3" y="0" z="0"/>')))
    # The same with the medium in a sphere (analytic) around a small cube.
    body = """<integrator type="volpath"/>
    <shape type="sphere"><float name="radius" value="2"/><bsdf type="null"/><medium name="interior" type="homogeneous"/></shape>
    <shape type="cube"><transform name="to_world"><scale value="0.3"/></transform><bsdf type="diffuse"/></shape>"""
    assert "give the shape interior and exterior explicitly" in error_of(tmp_path, body)
    clrender.load_scene(write(tmp_path, body.replace('<scale value="0.3"/>', '<translate x="5"/>')))


# ============================================================================================
# Rendering and the command line
# ============================================================================================
def test_cornell_box_xml_renders_the_json_cornell_box_bit_for_bit(device):
    xml = clrender.load_scene("scenes/cornell_box.xml", parameters={"resolution": 24})
    json_scene = clrender.load_scene("scenes/cornell_box.json")
    json_scene.camera.resolution = (24, 24)
    assert xml.render.__dict__ == json_scene.render.__dict__
    ours = clrender.Renderer(xml, device).render(spp=8, seed=5).image
    theirs = clrender.Renderer(json_scene, device).render(spp=8, seed=5).image
    assert np.array_equal(ours, theirs)


def test_xml_parameters_apply_to_xml_only(tmp_path):
    (tmp_path / "s.json").write_text(json.dumps({"camera": {"position": [0, 0, 1], "look_at": [0, 0, 0]}}))
    with pytest.raises(clrender.ArgumentError, match="parameters: apply to Mitsuba XML scenes only"):
        clrender.load_scene(tmp_path / "s.json", parameters={"spp": "2"})


def test_load_scene_emits_warnings(tmp_path):
    path = write(tmp_path, "", sensor=sensor(film='<film type="hdrfilm"><rfilter type="lanczos"/></film>'))
    with pytest.warns(MitsubaXmlWarning, match="approximated by clrender's box filter"):
        clrender.load_scene(path)


def run_cli(*args):
    return subprocess.run([sys.executable, "-m", "clrender.cli", *map(str, args)], capture_output=True, text=True)


def test_cli_info_shows_what_was_understood():
    result = run_cli("info", "scenes/cornell_box.xml", "-D", "resolution=32")
    assert result.returncode == 0, result.stderr
    assert "mitsuba:    cornell_box.xml:10 <integrator type='path'> -> render: max_depth 8, rr_depth 5" in result.stdout
    assert "camera: 32 x 32, vertical fov 39.3 deg" in result.stdout
    assert "<shape type='rectangle'> -> shapes[5]: rectangle, material 'emitter', emits (17, 12, 4)" in result.stdout


def test_cli_render_xml_with_parameters(tmp_path):
    result = run_cli("render", "scenes/cornell_box.xml", "-D", "resolution=8", "-D", "spp=2", "-o",
                     tmp_path / "cb.exr", "--quiet")
    assert result.returncode == 0, result.stderr
    assert clrender.load_image(tmp_path / "cb.exr").shape == (8, 8, 3)


def test_cli_errors_and_warnings(tmp_path):
    body = '<shape type="sphere"><bsdf type="hair"/></shape>'
    result = run_cli("info", write(tmp_path, body))
    assert result.returncode == 3 and "Traceback" not in result.stderr   # a bad scene (docs/errors.md)
    assert (f"clrender: error: scene.xml:{line_of(body, 'hair')} <bsdf type='hair'>: "
            "unsupported BSDF 'hair'") in result.stderr
    path = write(tmp_path, "", sensor=sensor(film='<film type="hdrfilm"><rfilter type="mitchell"/></film>'))
    result = run_cli("info", path)
    assert result.returncode == 0 and "clrender: warning: scene.xml:" in result.stderr
    result = run_cli("info", "scenes/cornell_box.xml", "-D", "spp")
    assert result.returncode == 2 and "expected NAME=VALUE" in result.stderr
