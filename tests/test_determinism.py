"""Counter-based RNG: the image depends only on (scene, seed, spp), not on how it is launched."""
import importlib

import numpy as np
import pytest

import clrender
from clrender.scene import Filter

SCENE = "scenes/cornell_box.json"
# Each sample's offset and weight come from its own numbers (kernels/filter.h), and the filter's
# truncation at the image's edges from the full image, never the launch's tile.
FILTERS = pytest.mark.parametrize("pixel_filter", [Filter("box"), Filter("gaussian", stddev=0.7)],
                                  ids=["box", "gaussian"])


def small_cornell_box(pixel_filter=Filter()):
    scene = clrender.load_scene(SCENE)
    scene.camera.resolution = (40, 30)
    scene.camera.filter = pixel_filter
    return scene


@FILTERS
def test_split_into_launches_gives_identical_image(device, pixel_filter):
    renderer = clrender.Renderer(small_cornell_box(pixel_filter), device)
    whole = renderer.render(spp=12, seed=5, samples_per_pass=12)
    ones = renderer.render(spp=12, seed=5, samples_per_pass=1)
    uneven = renderer.render(spp=12, seed=5, samples_per_pass=5)
    assert whole.samples == ones.samples == uneven.samples == 12
    assert np.array_equal(whole.image, ones.image)
    assert np.array_equal(whole.image, uneven.image)


def test_launches_of_row_bands_give_identical_image(device, monkeypatch):
    # A launch longer than pass_seconds at one sample is split into bands of rows (GPU
    # watchdogs), and so is a render's first launch beyond FIRST_LAUNCH_PIXELS: here both at
    # once, the first launch 8 rows and every later one a band of one work-group row.
    monkeypatch.setattr(importlib.import_module("clrender.render"), "FIRST_LAUNCH_PIXELS", 40 * 8)
    scene = small_cornell_box()
    for local_size in (None, (4, 4)):   # 30 rows: the last band of 4 overruns the image by 2
        whole = clrender.Renderer(scene, device, local_size=local_size).render(spp=3, seed=4, samples_per_pass=3)
        launches = []
        banded_renderer = clrender.Renderer(scene, device, local_size=local_size, pass_seconds=1e-9)
        banded = banded_renderer.render(spp=3, seed=4, progress=lambda *a: launches.append(a))
        # Bands are whole work-group rows: of the size asked for, else of the renderer's own
        # (packets have 4 x 4 groups by default).
        rows = 1 if banded_renderer.local_size is None else banded_renderer.local_size[1]
        assert len(launches) == 4 + 2 * -(-30 // rows), local_size   # 8 rows in bands, then 2 samples
        done = [a[0] for a in launches]   # samples done, in fractions of a sample after each band
        assert done[:4] == [8 / 30, 16 / 30, 24 / 30, 1] and done == sorted(done) and done[-1] == 3
        assert banded.samples == 3 and np.array_equal(banded.image, whole.image), local_size
        assert np.array_equal(banded.aux["object_id"], whole.aux["object_id"])
        assert np.array_equal(banded.aux["depth"], whole.aux["depth"])


def test_work_group_size_does_not_change_the_image(device):
    scene = small_cornell_box()
    default = clrender.Renderer(scene, device).render(spp=4, seed=2).image
    for local_size in [(8, 8), (16, 2), (1, 1)]:
        image = clrender.Renderer(scene, device, local_size=local_size).render(spp=4, seed=2).image
        assert np.array_equal(default, image), local_size


def test_seed_changes_the_noise_but_not_the_expectation(device):
    renderer = clrender.Renderer(small_cornell_box(), device)
    a = renderer.render(spp=8, seed=1).image
    b = renderer.render(spp=8, seed=2).image
    assert not np.array_equal(a, b)
    # Means over the image agree within the noise of two independent renders.
    difference = (a - b).ravel()
    assert abs(difference.mean()) < 5 * difference.std() / np.sqrt(difference.size)


def test_time_limited_render_stops_after_the_limit(device):
    renderer = clrender.Renderer(small_cornell_box(), device, pass_seconds=0.05)
    result = renderer.render(time_limit=0.3, seed=3)
    assert result.seconds >= 0.3 and result.samples >= 1
    # The samples taken are the first ones of the fixed sequence: an spp render agrees exactly.
    assert np.array_equal(result.image, renderer.render(spp=result.samples, seed=3).image)


@FILTERS
def test_tiles_rendered_in_resumed_chunks_give_the_identical_image(device, pixel_filter):
    # What distributed rendering relies on (docs/distributed.md): a tile's pixels are keyed by
    # the full image, and Renderer.accumulate continues a tile's sums from any sample count.
    from clrender.distributed import merge_strips
    from clrender.render import image_result

    scene = small_cornell_box(pixel_filter)
    renderer = clrender.Renderer(scene, device)
    whole = renderer.render(spp=7, seed=5)
    strips = []
    for tile in [(0, 0, 40, 11), (0, 11, 40, 11), (0, 22, 40, 8)]:
        state = clrender.Accumulation.start(tile)
        for samples in (3, 1, 3):
            state = renderer.accumulate(state, samples, seed=5)
        strips.append(state)
    merged = image_result(scene, merge_strips(scene, strips))
    assert merged.samples == 7 and np.array_equal(merged.image, whole.image)
    assert np.array_equal(merged.aux["object_id"], whole.aux["object_id"])
