"""PROTOTYPE measurement (docs/performance.md, "Explicit ray packets"): the megakernel against
packet8.cl (8 paths per work-item in float8 lanes) on a benchmark scene folder of tools/peers.py,
same seeds, alternating in one process: kernel CPU seconds, and the two images compared.

    python tools/experiments/packets/bench_packets.py SCENE_FOLDER [--spp 64] [--seeds 1 2 3 4 5]

SCENE_FOLDER: e.g. ~/.cache/clrender/peers/cornell_box-<hash> (written by tools/peers.py).
"""
import argparse
import os
from pathlib import Path

import numpy as np
import pyopencl as cl

import clrender
from clrender import device, features
from clrender.arrays import build_scene_arrays
from clrender.bench import median
from clrender.render import render_params

HERE = Path(__file__).resolve().parent
SUPPORTED = {"AOVS": 0, "ENVIRONMENT": 0, "GRID_MEDIA": 0, "MEDIA": 0, "TOON": 0}


def cpu_seconds(function):
    before = os.times()
    result = function()
    after = os.times()
    return (after.user - before.user) + (after.system - before.system), result


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("folder", type=Path)
    parser.add_argument("--spp", type=int, default=64)
    parser.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3, 4, 5])
    args = parser.parse_args()
    scene = clrender.load_scene(args.folder / "scene.json")
    needed = features.scene_features(scene)
    if any(needed.get(name, 0) != value for name, value in SUPPORTED.items()):
        raise SystemExit(f"the prototype renders none of these: {needed}")
    width, height = scene.camera.resolution
    if width % 8:
        raise SystemExit("the prototype needs an image width that is a multiple of 8")
    renderer = clrender.Renderer(scene, sampler="sobol")
    context = cl.Context([clrender.choose_device()])
    queue = cl.CommandQueue(context)
    arrays = build_scene_arrays(scene)
    entry = os.path.relpath(HERE / "packet8.cl", device.kernel_dir())
    source = device.kernel_source(entry)
    options = f"{device.BUILD_OPTIONS} {device.define_options(needed)} -DLANES=8"
    program = cl.Program(context, source).build(options=options)
    kernel = cl.Kernel(program, "render_packet8")
    flags = cl.mem_flags
    buffers = [cl.Buffer(context, flags.READ_ONLY | flags.COPY_HOST_PTR, hostbuf=np.ascontiguousarray(x))
               for x in (arrays.nodes, arrays.triangles, arrays.shading, arrays.info, arrays.materials,
                         arrays.emitters, arrays.emitter_cdf.astype(np.float32))]
    settings = scene.render

    def packets(seed):
        sums = np.zeros((height * width, 4), np.float32)
        sums_buffer = cl.Buffer(context, flags.READ_WRITE | flags.COPY_HOST_PTR, hostbuf=sums)
        params = render_params(scene, arrays, 0, args.spp, settings.max_depth, settings.rr_depth, seed,
                               sampler="sobol")
        params_buffer = cl.Buffer(context, flags.READ_ONLY | flags.COPY_HOST_PTR, hostbuf=params)
        kernel(queue, (width // 8, height), None, params_buffer, *buffers, sums_buffer).wait()
        cl.enqueue_copy(queue, sums, sums_buffer)
        return sums.reshape(height, width, 4)[..., :3] / args.spp

    def megakernel(seed):
        return renderer.render(spp=args.spp, seed=seed).image[..., :3]

    packets(0), megakernel(0)   # builds, caches
    ratios = []
    print(f"{args.folder.name}: {args.spp} spp, {width} x {height}; kernel CPU seconds")
    for seed in args.seeds:
        packet_s, packet_image = cpu_seconds(lambda: packets(seed))
        mega_s, mega_image = cpu_seconds(lambda: megakernel(seed))
        equal = np.mean(np.all(np.isclose(packet_image, mega_image, rtol=1e-4, atol=1e-6), axis=-1))
        ratios.append(mega_s / packet_s)
        print(f"seed {seed}: megakernel {mega_s:.2f} s, packets {packet_s:.2f} s, x{ratios[-1]:.3f}; "
              f"pixels equal to 1e-4: {100 * equal:.2f} %; image means {mega_image.mean():.6f} {packet_image.mean():.6f}")
    print(f"median speed-up of the packets: x{median(ratios):.3f}")


if __name__ == "__main__":
    main()
