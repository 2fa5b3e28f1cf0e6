"""Distributed rendering on a LocalCluster of 2 worker processes (one thread each) gives exactly
the local render: any strips, any chunking, a worker killed mid-render, batches, the CLI."""
import logging
import os
import re
import shutil
import signal
import subprocess
import sys
import threading
import time
from contextlib import contextmanager

import numpy as np
import pytest

import clrender
from clrender import distributed
from clrender.cli import _output_paths, main
from clrender.render import RenderInterrupted
from conftest import TEST_DEVICE

pytest.importorskip("distributed", reason="dask[distributed] is not installed: pip install -e '.[distributed]'")


@pytest.fixture(scope="module")
def client():
    from distributed import Client, LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0",
                      silence_logs=logging.ERROR) as cluster, Client(cluster) as client:
        yield client


def small(path, resolution, **render):
    scene = clrender.load_scene(path)
    scene.camera.resolution = resolution
    for name, value in render.items():
        setattr(scene.render, name, value)
    return scene


def local(scene, spp, **options):
    return clrender.Renderer(scene, TEST_DEVICE, **options).render(spp=spp)


def assert_identical(result, expected):
    assert np.array_equal(result.image, expected.image)
    assert result.samples == expected.samples
    assert result.discarded_samples == expected.discarded_samples
    for name in ("depth", "normal", "object_id"):
        assert np.array_equal(result.aux[name], expected.aux[name]), name


def test_cornell_box_is_bit_identical_for_any_strips_and_chunks(client):
    scene = small("scenes/cornell_box.json", (40, 30), seed=4)
    expected = local(scene, 7)
    # Strips of 6 rows (chunks of 2 samples, then sized from the measured rate), of 1 and of 30.
    for tiles, samples_per_chunk in ((5, 2), (5, None), (30, 3), (1, 7)):
        result = distributed.render(scene, client, 7, device=TEST_DEVICE, tiles=tiles,
                                    samples_per_chunk=samples_per_chunk)
        assert_identical(result, expected)


def test_a_filtered_image_is_bit_identical(client):
    # The filter's truncation at the image's edges comes from the full image, not the strip.
    scene = small("scenes/cornell_box.json", (24, 20), seed=3)
    scene.camera.filter = clrender.scene.Filter("gaussian")
    result = distributed.render(scene, client, 3, device=TEST_DEVICE, tiles=5, samples_per_chunk=2)
    assert_identical(result, local(scene, 3))


@pytest.mark.parametrize("path", ["scenes/cloud_cornell_box.json", "scenes/cornell_glass.json"],
                         ids=["grid_cloud", "analytic_glass_spheres"])
def test_scene_is_bit_identical(client, path):
    scene = small(path, (24, 24), max_depth=8)
    result = distributed.render(scene, client, 3, device=TEST_DEVICE, tiles=4, samples_per_chunk=2)
    assert_identical(result, local(scene, 3))


def test_a_scene_the_kernel_sees_rescaled_is_bit_identical(client):
    """A scene of 2^40 units reaches the kernel scaled by a power of two (arrays.length_scale):
    strips and chunks do not change that, and depths come back in the scene's units."""
    scene = small("scenes/cornell_box.json", (20, 16), seed=2)
    reference = local(scene, 3)
    for shape in scene.shapes:
        shape.mesh.vertices = shape.mesh.vertices * 2.0**40
    scene.camera.position, scene.camera.look_at = scene.camera.position * 2.0**40, scene.camera.look_at * 2.0**40
    result = distributed.render(scene, client, 3, device=TEST_DEVICE, tiles=4, samples_per_chunk=2)
    assert_identical(result, local(scene, 3))
    assert np.array_equal(result.image, reference.image)
    assert np.array_equal(result.aux["depth"], reference.aux["depth"] * 2.0**40)


def test_outlines_and_a_mesh_file_the_workers_never_see(client, tmp_path):
    # The toon character: ink outlines from the aux buffers span strip boundaries; its mesh is
    # loaded on the client only (the file is gone before the render), shipped in the scene.
    for name in ("toon_character.json", "toon_character.obj"):
        shutil.copy(f"scenes/{name}", tmp_path / name)
    scene = small(tmp_path / "toon_character.json", (48, 40))
    (tmp_path / "toon_character.obj").unlink()
    expected = local(scene, 2)
    assert expected.outline_alpha is not None and expected.outline_alpha.max() > 0
    result = distributed.render(scene, client, 2, device=TEST_DEVICE, tiles=6, samples_per_chunk=1)
    assert_identical(result, expected)
    assert np.array_equal(result.outline_alpha, expected.outline_alpha)


def test_aovs_and_denoising_are_bit_identical(client):
    """The AOV sums travel with the colour in each strip's chain: every AOV, and the image the
    client denoises from them, are exactly the local render's."""
    pytest.importorskip("pyoidn", reason="pyoidn is not installed: pip install -e '.[denoise]'")
    scene = small("scenes/cornell_glass.json", (24, 20), seed=3)
    expected = clrender.Renderer(scene, TEST_DEVICE).render(spp=3, aovs=clrender.AOV_NAMES, denoise=True)
    result = distributed.render(scene, client, 3, device=TEST_DEVICE, tiles=3, samples_per_chunk=2,
                                aovs=clrender.AOV_NAMES, denoise=True)
    assert_identical(result, expected)
    assert np.array_equal(result.noisy_image, expected.noisy_image)
    assert sorted(result.aovs) == sorted(clrender.AOV_NAMES)
    for name in clrender.AOV_NAMES:
        assert np.array_equal(result.aovs[name], expected.aovs[name]), name


def test_the_sampler_is_chosen_as_in_a_local_render(client):
    scene = small("scenes/cornell_box.json", (16, 12), seed=2)
    independent = clrender.Renderer(scene, TEST_DEVICE, sampler="independent").render(spp=2)
    result = distributed.render(scene, client, 2, device=TEST_DEVICE, tiles=2, sampler="independent")
    assert_identical(result, independent)
    assert not np.array_equal(result.image, local(scene, 2).image)   # the scene's sampler: sobol
    with pytest.raises(clrender.ArgumentError, match="^sampler: unknown sampler 'halton'"):
        distributed.render(scene, client, 2, device=TEST_DEVICE, sampler="halton")


def test_batch_yields_every_scene_identical_to_its_local_render(client):
    scenes = [small("scenes/cornell_box.json", (24, 16), seed=seed) for seed in (1, 2)]
    scenes.append(small("scenes/toon_cornell_box.json", (20, 20)))
    results = dict(distributed.render_many(scenes, client, 3, device=TEST_DEVICE, samples_per_chunk=2))
    assert sorted(results) == [0, 1, 2]
    for index, scene in enumerate(scenes):
        assert_identical(results[index], local(scene, 3))
    # Each worker made one device context, and rendering the scenes again (new Renderers) builds
    # no program: a kernel variant is built (or loaded) once per worker process.
    def counts():
        return client.run(lambda: (len(distributed._contexts),
                                   sum(len(clrender.device._memory_cache(c)) for c in distributed._contexts.values())))

    before = counts()
    assert {contexts for contexts, _ in before.values()} == {1}
    for _ in distributed.render_many(scenes, client, 1, device=TEST_DEVICE, tiles=8):
        pass
    assert counts() == before


def test_interrupted_render_returns_each_strip_as_far_as_it_got(client):
    scene = small("scenes/cornell_box.json", (32, 24), seed=9)

    def interrupt(done, spp, seconds):
        if done >= 0.5 * spp:
            raise KeyboardInterrupt

    with pytest.raises(RenderInterrupted) as interrupted:
        distributed.render(scene, client, 12, device=TEST_DEVICE, tiles=4, samples_per_chunk=2,
                           progress=interrupt)
    partial = interrupted.value.result
    assert 0 <= partial.samples < 12
    # Every strip holds the first 0, 2, ... samples of the sequence, normalised by its own count:
    # each row equals that row of a local render of that many samples (or is black).
    renders = {0: np.zeros_like(partial.image), **{k: local(scene, k).image for k in range(2, 13, 2)}}
    counts = [next(k for k, image in renders.items() if np.array_equal(image[row], partial.image[row]))
              for row in range(24)]
    assert partial.samples == min(counts)
    assert all(len(set(counts[top:top + 6])) == 1 for top in range(0, 24, 6))   # strips of 6 rows


def test_an_interrupted_batch_leaves_scenes_without_a_finished_chunk_alone(client):
    """Interrupted after its first chunk: the scene of that chunk comes back as far as it got; the
    second scene in flight, none of whose chunks finished, does not (a 0-sample black image would
    replace its file; the local batch leaves later scenes alone too)."""
    scenes = [small("scenes/cornell_box.json", (16, 8), seed=seed) for seed in (1, 2)]

    def interrupt(done, frames, seconds):
        raise KeyboardInterrupt

    with pytest.raises(RenderInterrupted) as interrupted:
        for _ in distributed.render_many(scenes, client, 4, device=TEST_DEVICE, tiles=2, samples_per_chunk=1,
                                         progress=interrupt):
            pass
    assert len(interrupted.value.result) == 1


@contextmanager
def killing_busy_workers(client, when, again=False):
    """While the block runs: once the event `when` is set, SIGKILL the process of a worker that
    has a chunk assigned (with `again`, every 0.5 s). Yields the list of addresses killed."""
    killed, stop = [], threading.Event()

    def kill():
        when.wait()
        while not stop.is_set():
            busy = [address for address, keys in sorted(client.processing().items()) if keys]
            if busy:
                os.kill(client.run(os.getpid, workers=busy[:1])[busy[0]], signal.SIGKILL)
                killed.append(busy[0])
                if not again:
                    return
                stop.wait(0.5)
            else:
                stop.wait(0.001)

    thread = threading.Thread(target=kill, daemon=True)
    thread.start()
    try:
        yield killed
    finally:
        stop.set()
        when.set()
        thread.join()


def test_worker_killed_mid_render_changes_nothing(client):
    scene = small("scenes/cornell_box.json", (40, 30), seed=2)
    started = threading.Event()
    pids = set(client.run(os.getpid).values())
    with killing_busy_workers(client, started) as killed:
        result = distributed.render(scene, client, 160, device=TEST_DEVICE, tiles=5, samples_per_chunk=4,
                                    progress=lambda done, spp, seconds: done >= 0.3 * spp and started.set())
    assert len(killed) == 1   # before the render ended
    assert_identical(result, local(scene, 160))
    client.wait_for_workers(2)
    assert set(client.run(os.getpid).values()) != pids   # the nanny started a new worker process


def test_every_worker_killed_mid_render_changes_nothing(client):
    # The scattered scene dies with the workers that held it: the chunks that need it are
    # cancelled by the cluster, and the render scatters it again to the workers the nannies
    # start (as when a scene went to the one worker that had joined and that worker died).
    scene = small("scenes/cornell_box.json", (40, 30), seed=4)
    started, killed = threading.Event(), []

    def kill_all():
        started.wait()
        pids = client.run(os.getpid)
        for pid in pids.values():
            os.kill(pid, signal.SIGKILL)
        killed.extend(pids)

    thread = threading.Thread(target=kill_all, daemon=True)
    thread.start()
    try:
        result = distributed.render(scene, client, 160, device=TEST_DEVICE, tiles=5, samples_per_chunk=4,
                                    progress=lambda done, spp, seconds: done >= 0.3 * spp and started.set())
    finally:
        started.set()
        thread.join()
    assert len(killed) == 2
    assert_identical(result, local(scene, 160))
    client.wait_for_workers(2)


def test_chunk_whose_workers_keep_dying_is_an_error_naming_the_worker(client):
    scene = small("scenes/cornell_box.json", (40, 30))
    started = threading.Event()

    def allow_failures(count):
        client.run_on_scheduler(lambda dask_scheduler: setattr(dask_scheduler, "allowed_failures", count))

    allow_failures(0)   # the first death of a chunk's worker is its last
    try:
        with killing_busy_workers(client, started, again=True) as killed, \
                pytest.raises(distributed.DistributedRenderError, match="KilledWorker") as error:
            distributed.render(scene, client, 10 ** 5, device=TEST_DEVICE, tiles=5, samples_per_chunk=4,
                               progress=lambda *_: started.set())
    finally:
        allow_failures(3)
    assert any(address in str(error.value) for address in killed)


def test_chunk_failing_on_every_try_names_the_worker(client):
    scene = small("scenes/cornell_box.json", (8, 8))
    # The error of a local render (a bad --device: ArgumentError), on the worker that met it.
    with pytest.raises(clrender.ArgumentError, match=r"worker tcp://.*no OpenCL device matches"):
        distributed.render(scene, client, 1, device="no such device")


def test_strips_cover_the_image_once():
    for height, count in ((30, 8), (30, 100), (7, 1), (1, 3), (100, 7)):
        strips = distributed.horizontal_strips(11, height, count)
        rows = [row for _, top, _, n in strips for row in range(top, top + n)]
        assert rows == list(range(height)) and len({n for *_, n in strips[:-1]}) <= 1


def test_output_paths_for_batches(tmp_path):
    scenes = [tmp_path / "a" / "shot.json", tmp_path / "b" / "shot.json"]
    assert _output_paths(f"{tmp_path}/out/", scenes[:1]) == [tmp_path / "out" / "shot.exr"]
    assert _output_paths(str(tmp_path / "f_{index:03d}.png"), scenes) == [tmp_path / "f_000.png",
                                                                          tmp_path / "f_001.png"]
    for output, message in ((f"{tmp_path}/out/", "would both write"),
                            (str(tmp_path / "{stem}.png"), "would both write"),
                            (str(tmp_path / "one.exr"), "need a folder"),
                            (str(tmp_path / "{name}.exr"), "bad pattern"),
                            (str(tmp_path / "{index}.gif"), "unsupported image format")):
        with pytest.raises(clrender.ArgumentError, match=message):
            _output_paths(output, scenes)


def test_cli_renders_on_local_workers(tmp_path, capsys):
    path = tmp_path / "box.json"
    path.write_text(_scene_json("scenes/cornell_box.json", resolution=[16, 12], seed=1, spp=3))
    assert main(["render", str(path), "-o", str(tmp_path / "box.exr"), "--workers", "2", "--quiet",
                 "--device", TEST_DEVICE]) == 0
    image = clrender.load_image(tmp_path / "box.exr")
    assert np.array_equal(image, local(clrender.load_scene(path), 3).image)
    assert "on 2 Dask workers" in capsys.readouterr().err


def test_cli_writes_aov_layers_from_a_running_cluster(client, tmp_path):
    path = tmp_path / "box.json"
    path.write_text(_scene_json("scenes/cornell_box.json", resolution=[16, 12], seed=1, spp=2))
    assert main(["render", str(path), "-o", str(tmp_path / "box.exr"), "--aov", "albedo,depth",
                 "--scheduler", client.scheduler.address, "--quiet", "--device", TEST_DEVICE]) == 0
    layers = clrender.load_exr_layers(tmp_path / "box.exr")
    expected = clrender.Renderer(clrender.load_scene(path), TEST_DEVICE).render(spp=2, aovs=("albedo", "depth"))
    assert np.array_equal(layers[""], expected.image)
    assert np.array_equal(layers["albedo"], expected.aovs["albedo"])
    assert np.array_equal(layers["depth"].reshape(expected.aovs["depth"].shape), expected.aovs["depth"])


def test_cli_renders_a_batch_on_a_running_cluster(client, tmp_path):
    paths = []
    for seed in (1, 2, 3):
        paths.append(tmp_path / f"shot{seed}.json")
        paths[-1].write_text(_scene_json("scenes/cornell_box.json", resolution=[16, 12], seed=seed, spp=2))
    assert main(["render", *map(str, paths), "-o", str(tmp_path / "out" / "frame_{index:02d}.exr"),
                 "--scheduler", client.scheduler.address, "--quiet", "--device", TEST_DEVICE]) == 0
    for index, path in enumerate(paths):
        image = clrender.load_image(tmp_path / "out" / f"frame_{index:02d}.exr")
        assert np.array_equal(image, local(clrender.load_scene(path), 2).image)


@pytest.mark.parametrize("signum,group,times", [
    (signal.SIGINT, True, 1),    # a terminal's Ctrl-C goes to the whole process group: client and workers
    (signal.SIGHUP, True, 1),    # so does the hang-up of a closed terminal
    (signal.SIGTERM, False, 1),  # `kill PID`: the client alone
    (signal.SIGTERM, False, 2),  # twice, quickly: still saved (the second is ignored)
])
def test_ctrl_c_on_the_cli_writes_the_partial_image_without_tracebacks(tmp_path, client, signum, group, times):
    path = tmp_path / "box.json"
    path.write_text(_scene_json("scenes/cornell_box.json", resolution=[32, 24], spp=10 ** 6))
    # A cluster of the CLI's own (--workers) where its workers get the signal too; else the module's.
    cluster = ("--workers", "2") if group else ("--scheduler", client.scheduler.address)
    command = [sys.executable, "-m", "clrender.cli", "render", str(path), "-o", str(tmp_path / "box.exr"),
               *cluster, "--device", TEST_DEVICE, "--chunk-seconds", "0.2"]
    process = subprocess.Popen(command, stderr=subprocess.PIPE, start_new_session=True, text=True,
                               preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    seen = []
    reader = threading.Thread(target=lambda: seen.extend(iter(lambda: process.stderr.read(1), "")))
    reader.start()
    deadline = time.monotonic() + 120
    # Chunks are flowing: the bar counts samples (workers may still be building kernels when it
    # first shows 0).
    while not re.search(r"[1-9][\d.]*/1000000 spp \[", "".join(seen)) and time.monotonic() < deadline:
        time.sleep(0.1)
    for _ in range(times):
        (os.killpg if group else os.kill)(process.pid, signum)
        time.sleep(0.02)
    assert process.wait(timeout=60) == 128 + signum
    reader.join()
    err = "".join(seen)
    assert "interrupted: partial image saved" in err and "Traceback" not in err, err[-3000:]
    assert clrender.load_image(tmp_path / "box.exr").shape == (24, 32, 3)


def _scene_json(path, resolution, **render):
    import json

    data = json.loads(open(path).read())
    data["camera"]["resolution"] = resolution
    data.setdefault("render", {}).update(render)
    return json.dumps(data)
