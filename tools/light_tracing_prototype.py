"""PROTOTYPE (branch light-tracing-prototype, not main): the path tracer leaving the caustics to
light paths (kernels/light_paths.h, .cl; `Renderer.light_path_every`) plus those light paths'
image, against the path tracer alone: image means, variance over seeds, times. The light paths'
records are splatted here with the scene's filter (box or tent) and summed in float64, not yet in
the renderer.

    python tools/light_tracing_prototype.py ../shared/real-scenes/bitterli-veach-bidir/scene.xml --size 128 --seeds 48 [--every 8] [--packets]
"""
import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import pyopencl as cl

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
import clrender  # noqa: E402
from clrender.device import build_program  # noqa: E402
from clrender.render import render_params  # noqa: E402


def splat(image, records, filter_type):
    """Add records (x, y, rgb) to `image` (padded by one pixel) with the box or the tent of radius 1."""
    x, y, v = records[:, 0], records[:, 1], records[:, 2:5]
    if filter_type == "box":
        np.add.at(image, (np.floor(y).astype(int) + 1, np.floor(x).astype(int) + 1), v)
        return
    i0, j0 = np.floor(x - 0.5).astype(int), np.floor(y - 0.5).astype(int)
    for di in (0, 1):
        for dj in (0, 1):
            i, j = i0 + di, j0 + dj
            w = np.maximum(0, 1 - np.abs(i + 0.5 - x)) * np.maximum(0, 1 - np.abs(j + 0.5 - y))
            np.add.at(image, (j + 1, i + 1), v * w[:, None])


def light_image(renderer, kernel, seed, spp, every, capacity=1 << 18):
    scene = renderer.scene
    width, height = scene.camera.resolution
    mf = cl.mem_flags
    params = render_params(scene, renderer.arrays, 0, spp, scene.render.max_depth, scene.render.rr_depth, seed,
                           light_path_every=every)
    params_buffer = cl.Buffer(renderer.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=params)
    while True:
        records = cl.Buffer(renderer.context, mf.READ_WRITE, capacity * 32)
        count = np.zeros(1, np.int32)
        count_buffer = cl.Buffer(renderer.context, mf.READ_WRITE | mf.COPY_HOST_PTR, hostbuf=count)
        kernel(renderer.queue, (width, height), None, params_buffer, *renderer._buffers, records, count_buffer,
               np.int32(capacity))
        cl.enqueue_copy(renderer.queue, count, count_buffer)
        if count[0] <= capacity:
            break
        capacity = int(count[0])
    out = np.empty((int(count[0]), 8), np.float32)
    if len(out):
        cl.enqueue_copy(renderer.queue, out, records)
    image = np.zeros((height + 2, width + 2, 3))
    splat(image, out[:, [0, 1, 4, 5, 6]].astype(np.float64), scene.camera.filter.type)
    light_paths_per_pixel = len(range(0, spp, every))
    return image[1:-1, 1:-1] / light_paths_per_pixel


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("scene", type=Path)
    parser.add_argument("--size", type=int, default=128)
    parser.add_argument("--seeds", type=int, default=16)
    parser.add_argument("--spp", type=int, default=64)
    parser.add_argument("--every", type=int, default=8, help="camera samples per light path")
    parser.add_argument("--packets", action="store_true")
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    scene = clrender.load_scene(args.scene, {"integrator": "path", "resx": str(args.size), "resy": str(args.size)})
    renderer = clrender.Renderer(scene, packets=args.packets)
    kernel = cl.Kernel(build_program(renderer.context, {**renderer.features, "LANES": 1}, entry="light_paths.cl"),
                       "light_paths")
    rows = {}
    for every in (0, args.every):
        renderer.light_path_every = every
        renderer.render(spp=4, seed=99)
        images, render_s, light_s = [], [], []
        for seed in range(1, args.seeds + 1):
            start = time.perf_counter()
            image = renderer.render(spp=args.spp, seed=seed).image.astype(np.float64)
            render_s.append(time.perf_counter() - start)
            if every:
                start = time.perf_counter()
                image = image + light_image(renderer, kernel, seed, args.spp, every)
                light_s.append(time.perf_counter() - start)
            images.append(image)
        images = np.stack(images)
        per_image = images.mean(axis=(1, 2, 3))
        variance = images.var(axis=0, ddof=1).mean(axis=-1)
        rows[every] = (per_image.mean(), per_image.std(ddof=1) / np.sqrt(len(per_image)), variance.mean(),
                       int((variance > 1).sum()), images.max(), np.median(render_s), np.median(light_s) if light_s else 0)
    print("every | image mean | +- | variance | pixels > 1 | max | render s | light paths s")
    for every, row in rows.items():
        print(every, *(f"{v:.5g}" for v in row))


if __name__ == "__main__":
    main()
