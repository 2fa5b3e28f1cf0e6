"""Sample items (clrender/sample_items.py): a render pass over (pixel, sample) gives the bits of
the per-pixel loop, whatever the filter, the split into passes, bands and tiles."""
import importlib
from dataclasses import replace

import numpy as np
import pyopencl as cl
import pytest

import clrender
from clrender import layout, sample_items, splatting
from clrender.distributed import merge_strips
from clrender.errors import ArgumentError
from clrender.features import scene_features
from clrender.render import Accumulation, image_result
from clrender.scene import Filter

# Box: records of radiance summed per pixel; gaussian: splatting's records, summed and gathered;
# importance: a gaussian drawn per pixel, no splatting.
FILTERS = {"box": (Filter("box"), "splat"), "gaussian": (Filter("gaussian", stddev=0.5), "splat"),
           "importance": (Filter("gaussian", stddev=0.5), "importance")}


def cornell_box(name, resolution=(24, 18)):
    scene = clrender.load_scene("scenes/cornell_glass.json")
    pixel_filter, method = FILTERS[name]
    camera = replace(scene.camera, resolution=resolution, filter=pixel_filter)
    return replace(scene, camera=camera, render=replace(scene.render, filter_method=method, max_depth=6))


def renderers(scene, device):
    """(per pixel, sample items) renderers of `scene`, the megakernel both."""
    return (clrender.Renderer(scene, device, packets=False, sample_items=False),
            clrender.Renderer(scene, device, sample_items=True))


def assert_same_result(a, b):
    assert a.samples == b.samples and a.discarded_samples == b.discarded_samples
    assert np.array_equal(a.image, b.image)
    for name in ("depth", "normal", "object_id"):
        assert np.array_equal(a.aux[name], b.aux[name]), name


@pytest.mark.parametrize("name", list(FILTERS))
def test_sample_items_give_the_per_pixel_image(device, name):
    per_pixel, items = renderers(cornell_box(name), device)
    expected = per_pixel.render(spp=9, seed=4)
    # One pass of all samples, uneven passes (a last pass of one sample runs as a plain pass),
    # and the adaptive launches.
    for passes in (9, 4, None):
        assert_same_result(expected, items.render(spp=9, seed=4, samples_per_pass=passes))
    assert not np.array_equal(expected.image, items.render(spp=9, seed=5).image)


def test_sample_items_in_bands_of_rows(device, monkeypatch):
    # The first launch 6 rows, later ones bands of one work-group row, as for GPU watchdogs.
    monkeypatch.setattr(importlib.import_module("clrender.render"), "FIRST_LAUNCH_PIXELS", 24 * 6)
    scene = cornell_box("gaussian")
    expected = clrender.Renderer(scene, device, packets=False, sample_items=False).render(spp=5, seed=2)
    launches = []
    banded = clrender.Renderer(scene, device, sample_items=True, pass_seconds=1e-9, local_size=(4, 4))
    result = banded.render(spp=5, seed=2, progress=lambda *a: launches.append(a))
    assert len(launches) > 5   # bands were taken
    assert_same_result(expected, result)


@pytest.mark.parametrize("name", ["box", "gaussian"])
def test_sample_items_accumulate_strips_as_one_render(device, name):
    scene = cornell_box(name)
    per_pixel, items = renderers(scene, device)
    expected = per_pixel.render(spp=7, seed=3)
    width, height = scene.camera.resolution
    states = []
    for top in range(0, height, 5):
        state = Accumulation.start((0, top, width, min(5, height - top)))
        for samples in (4, 3):
            state = items.accumulate(state, samples, seed=3, samples_per_pass=samples)
        states.append(state)
    merged = image_result(scene, merge_strips(scene, states))
    assert_same_result(expected, merged)
    # The unfiltered sums too (sum_samples), not only the image.
    whole = per_pixel.accumulate(Accumulation.start((0, 0, width, height)), 7, seed=3)
    assert np.array_equal(merge_strips(scene, states).sums, whole.sums)


@pytest.mark.parametrize("name", list(FILTERS))
def test_sample_items_accumulate_the_sample_aovs(device, name, monkeypatch):
    # Each sample's AOVs are records beside its radiance, summed in sample order with the
    # colour's deviations: the loop's bits, in passes of several samples and of one.
    per_pixel, items = renderers(cornell_box(name), device)
    sums = []
    monkeypatch.setattr(sample_items.SampleSums, "__call__",
                        lambda self, *a, _call=sample_items.SampleSums.__call__: sums.append(len(a)) or _call(self, *a))
    names = ["albedo", "normal", "emission", "variance"]
    expected = per_pixel.render(spp=5, seed=1, aovs=names)
    for passes in (5, 3, 1):
        result = items.render(spp=5, seed=1, samples_per_pass=passes, aovs=names)
        assert_same_result(expected, result)
        for aov in names:
            assert np.array_equal(expected.aovs[aov], result.aovs[aov]), (passes, aov)
    # The passes of several samples summed their AOV records (7 arguments: 5 and the two AOV buffers).
    assert sums == [7, 7, 7]
    assert np.any(expected.aovs["variance"] > 0) and np.any(expected.aovs["albedo"] > 0)


@pytest.mark.parametrize("name", ["gaussian", "importance"])
def test_sample_items_keep_their_records_within_the_budget(device, name, monkeypatch):
    # The AOV records (64 bytes per pixel and sample) limit a pass to what the budget holds: two
    # samples, or one, which makes the passes plain ones (no records, no sums).
    scene = cornell_box(name)
    per_pixel, items = renderers(scene, device)
    names = ["albedo", "variance"]
    expected = per_pixel.render(spp=5, seed=2, aovs=names)
    reach = splatting.reach(scene.camera.filter) if splatting.splats(scene) else 0
    traced = (24 + 2 * reach) * (18 + 2 * reach)   # the pixels traced: the image and the filter's reach
    sums = []
    monkeypatch.setattr(sample_items.SampleSums, "__call__",
                        lambda self, *a, _call=sample_items.SampleSums.__call__: sums.append(len(a)) or _call(self, *a))
    for samples_per_pass, calls in ((2, [7, 7]), (1, [])):
        sums.clear()
        monkeypatch.setattr(splatting, "RECORDS_BUDGET", samples_per_pass * layout.AOV_SUMS.itemsize * traced)
        result = items.render(spp=5, seed=2, samples_per_pass=5, aovs=names)
        assert_same_result(expected, result)
        for aov in names:
            assert np.array_equal(expected.aovs[aov], result.aovs[aov]), (samples_per_pass, aov)
        assert sums == calls


def test_sample_items_are_for_the_megakernel_on_gpus(device):
    scene = cornell_box("box")
    features = scene_features(scene, packets=True)

    class Device:
        def __init__(self, kind):
            self.type = kind

    assert sample_items.wanted(Device(cl.device_type.GPU), {**features, "LANES": 1})
    assert not sample_items.wanted(Device(cl.device_type.CPU), {**features, "LANES": 1})
    assert not sample_items.wanted(Device(cl.device_type.GPU), {**features, "LANES": 8})
    with pytest.raises(ArgumentError, match="sample_items"):
        clrender.Renderer(scene, device, packets=True, sample_items=True)
