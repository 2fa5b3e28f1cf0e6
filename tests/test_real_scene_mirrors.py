"""tools/real_scenes.py, which tools/peers.py --real-scenes renders: the edited copy of a real
scene changes the film's size and the sampler's type and nothing else, every other file is the
original (a link), and the scene files of a folder are the XML files nothing includes."""
import importlib.util
from pathlib import Path

import pytest

spec = importlib.util.spec_from_file_location("real_scenes", Path(__file__).parent.parent / "tools" / "real_scenes.py")
real_scenes = importlib.util.module_from_spec(spec)
spec.loader.exec_module(real_scenes)

SCENE = """<scene version="3.0.0">
    <default name="integrator" value="path_guiding_integrator"/>
    <include filename="include/walls.xml"/>
    <sensor type="perspective">
        <sampler type='independent'><integer name="sample_count" value="64"/></sampler>
        <film type="hdrfilm">
            <integer name="width" value="$resx"/>
            <integer name='height' value="720"/>
        </film>
    </sensor>
    <texture type="bitmap"><integer name="width" value="7"/></texture>
</scene>
"""


@pytest.fixture
def scenes(tmp_path):
    (tmp_path / "SOURCES.md").write_text("sources")
    room = tmp_path / "room"
    (room / "include").mkdir(parents=True)
    (room / "scene.xml").write_text(SCENE)
    (room / "include" / "walls.xml").write_text('<scene version="3.0.0"><shape type="obj"/></scene>')
    (room / "mesh.obj").write_text("v 0 0 0")
    (tmp_path / "xml-only" / "absent").mkdir(parents=True)
    (tmp_path / "xml-only" / "absent" / "scene.xml").write_text(SCENE)
    return tmp_path


def test_the_scene_files_are_those_nothing_includes(scenes):
    assert real_scenes.scene_files([scenes]) == [(scenes / "room" / "scene.xml").resolve()]
    assert real_scenes.scene_files([scenes / "room"]) == [(scenes / "room" / "scene.xml").resolve()]
    assert real_scenes.scene_name(scenes / "room" / "scene.xml") == "room"


def test_research_integrators_become_path(scenes):
    assert real_scenes.parameters(scenes / "room" / "scene.xml") == {"integrator": "path"}
    (scenes / "room" / "scene.xml").write_text(SCENE.replace("path_guiding_integrator", "volpath"))
    assert real_scenes.parameters(scenes / "room" / "scene.xml") == {}


@pytest.mark.parametrize("resolution,size", [((1280, 720), (128, 72)), ((720, 1280), (72, 128)),
                                             ((683, 512), (128, 96)), ((48, 48), (48, 48))])
def test_the_film_keeps_its_aspect_in_multiples_of_8(resolution, size):
    assert real_scenes.film_size(resolution, 128) == size


def test_the_mirror_edits_the_film_and_sampler_only(scenes, tmp_path_factory):
    out = tmp_path_factory.mktemp("mirror")
    xml = real_scenes.mirror(scenes / "room" / "scene.xml", out, (128, 72), "ldsampler")
    assert xml == out / "scene.xml"
    expected = (SCENE.replace('value="$resx"', 'value="128"').replace("value=\"720\"", 'value="72"')
                .replace("type='independent'", "type='ldsampler'"))
    assert xml.read_text() == expected   # the texture's width stays 7
    assert (out / "mesh.obj").is_symlink() and (out / "mesh.obj").resolve() == (scenes / "room" / "mesh.obj").resolve()
    assert (out / "include" / "walls.xml").is_symlink()
    again = real_scenes.mirror(scenes / "room" / "scene.xml", out, (64, 40), "independent")
    assert 'value="64"' in again.read_text() and "type='independent'" in again.read_text()


@pytest.mark.parametrize("rfilter", ['<rfilter type="tent" />',
                                     '<rfilter type="gaussian">\n<float name="stddev" value="0.3"/>\n</rfilter>', ""])
def test_the_mirror_can_replace_the_reconstruction_filter(scenes, tmp_path_factory, rfilter):
    """tools/variance.py renders both renderers with the same filter: one given in the film, in
    either form, is replaced, and a film without one (Mitsuba's default gaussian) gets it."""
    scene = scenes / "room" / "scene.xml"
    scene.write_text(SCENE.replace("</film>", rfilter + "</film>"))
    xml = real_scenes.mirror(scene, tmp_path_factory.mktemp("mirror"), (64, 36), "independent", rfilter="box")
    text = xml.read_text()
    assert text.count("<rfilter") == 1 and '<rfilter type="box"/></film>' in text
    assert 'value="64"' in text and 'value="36"' in text and "stddev" not in text


@pytest.mark.parametrize("warmup", [False, True])
def test_timed_renders_take_their_seeds_in_order_after_an_untimed_warm_up(tmp_path, warmup):
    """The children of peers.py: with a warm-up (--timing render), seed 0 renders first, untimed,
    then each image of the seeds asked for has its own seconds; without, a single image is
    followed by the next seed's, timed as rendering alone (`again`)."""
    import json

    import numpy as np

    seeds = []

    def render(seed):
        seeds.append(seed)
        return np.full((2, 3, 4), seed, np.float32)

    out = tmp_path / "images.npy"
    phases = real_scenes.Phases()
    real_scenes._render_all(render, 5, 3 if warmup else 1, out, phases, warmup)
    images, seconds = np.load(out), json.loads(out.with_suffix(".seconds.json").read_text())
    assert seeds == ([0, 5, 6, 7] if warmup else [5, 6])
    assert images.shape == ((3, 2, 3, 3) if warmup else (1, 2, 3, 3))
    assert [image[0, 0, 0] for image in images] == ([5, 6, 7] if warmup else [5])
    assert len(seconds) == len(images) and all(s >= 0 for s in seconds)
    written = json.loads(out.with_suffix(".phases.json").read_text())
    assert ("warm-up" in written) == warmup and ("again" in written) != warmup
