"""Command line: render, info, devices.

Exit codes: 0 success, 1 bad input or failed build, 130 interrupted (the partial image is saved).
"""
import argparse
import sys
from pathlib import Path

import numpy as np

from .errors import KernelBuildError, SceneError


def main(argv=None):
    parser = _parser()
    args = parser.parse_args(argv)
    try:
        return args.run(args)
    except (SceneError, KernelBuildError, ValueError, RuntimeError, OSError) as e:
        print(f"clrender: error: {e}", file=sys.stderr)
        return 1


def _parser():
    parser = argparse.ArgumentParser(prog="clrender", description="OpenCL path tracer")
    commands = parser.add_subparsers(dest="command", required=True)

    render = commands.add_parser("render", help="render a scene to an image")
    render.add_argument("scene", type=Path)
    render.add_argument("-o", "--output", type=Path, required=True,
                        help="output image: .exr (linear float) or .png/.jpg/.tif (sRGB)")
    render.add_argument("--spp", type=_positive_int, help="samples per pixel (default: the scene's)")
    render.add_argument("--time", type=float, metavar="SECONDS",
                        help="render for this long (kernel time); with --spp, whichever comes first")
    render.add_argument("--seed", type=_non_negative_int, help="random seed (default: the scene's)")
    render.add_argument("--max-depth", type=_positive_int, help="longest path (default: the scene's)")
    render.add_argument("--device", help="device index, 'cpu', 'gpu' or a name part (default: $CLRENDER_DEVICE, else a GPU, else the CPU)")
    render.add_argument("--exposure", type=float, default=0.0, help="exposure in stops for 8-bit outputs")
    render.add_argument("--quiet", action="store_true", help="no progress bar")
    render.add_argument("--volume-method", choices=("null", "raymarch"),
                        help="grid media: null-scattering path integral (unbiased) or ray marching "
                             "(biased preview) (default: the scene's, else null)")
    render.add_argument("--step", type=_positive_float, help="ray-marching step in scene units (default: the scene's)")
    render.add_argument("--raymarch-multiple-scattering", action=argparse.BooleanOptionalAction, default=None,
                        help="ray marching: continue paths from a scattering point (default: the scene's, else off)")
    render.set_defaults(run=_render)

    info = commands.add_parser("info", help="print scene statistics and the kernel features it needs")
    info.add_argument("scene", type=Path)
    info.set_defaults(run=_info)

    devices = commands.add_parser("devices", help="list OpenCL platforms and devices")
    devices.set_defaults(run=_devices)
    return parser


def _number_at_least(convert, low, strict=False):
    """An argparse type: `convert(text)`, finite and >= low (> low if strict)."""
    def parse(text):
        value = convert(text)
        if not (value > low if strict else value >= low) or value == float("inf"):
            bound = "a positive number" if strict and low == 0 else f">= {low}"
            raise argparse.ArgumentTypeError(f"must be {bound}, got {text}")
        return value
    return parse


_positive_int = _number_at_least(int, 1)
_non_negative_int = _number_at_least(int, 0)
_positive_float = _number_at_least(float, 0.0, strict=True)


def _render(args):
    from tqdm import tqdm

    from .image import LDR_SUFFIXES, save_image
    from .render import Renderer, RenderInterrupted
    from .scene import load_scene

    suffix = args.output.suffix.lower()
    if suffix != ".exr" and suffix not in LDR_SUFFIXES:
        raise ValueError(f"unsupported output format {suffix!r}; use .exr or one of {', '.join(LDR_SUFFIXES)}")
    scene = load_scene(args.scene)
    renderer = Renderer(scene, args.device, volume_method=args.volume_method, step=args.step,
                        raymarch_multiple_scattering=args.raymarch_multiple_scattering)
    spp = args.spp or (None if args.time else scene.render.spp)
    bar = tqdm(total=spp, unit="spp", disable=args.quiet, file=sys.stderr, dynamic_ncols=True)

    def progress(done, total, seconds):
        bar.update(done - bar.n)
        width, height = scene.camera.resolution
        bar.set_postfix_str(f"{done * width * height / max(seconds, 1e-9) / 1e6:.2f} M samples/s")

    try:
        result = renderer.render(spp=spp, seed=args.seed, max_depth=args.max_depth, progress=progress,
                                 time_limit=args.time)
        status = 0
    except RenderInterrupted as interrupted:
        result = interrupted.result
        status = 130
    bar.close()
    save_image(result.image, args.output, exposure=args.exposure)
    print(f"{args.output}: {result.samples} spp in {result.seconds:.2f} s, "
          f"{result.samples_per_second / 1e6:.2f} M samples/s on {renderer.device.name.strip()}"
          + (f", {result.discarded_samples} non-finite samples discarded" if result.discarded_samples else "")
          + (" (interrupted: partial image saved)" if status else ""), file=sys.stderr)
    return status


def _info(args):
    from .arrays import build_scene_arrays
    from .features import describe, scene_features
    from .scene import load_scene

    scene = load_scene(args.scene)
    arrays = build_scene_arrays(scene)
    lo, hi = scene.bounds()
    width, height = scene.camera.resolution
    print(f"scene:      {args.scene}")
    print(f"image:      {width} x {height}, {scene.render.spp} spp, max depth {scene.render.max_depth}")
    print(f"materials:  {len(scene.materials)} ({', '.join(m.name for m in scene.materials)})")
    print(f"shapes:     {len(scene.shapes)}")
    print(f"triangles:  {len(arrays.triangles) - arrays.spheres}"
          + (f" ({arrays.degenerate_triangles} degenerate dropped)" if arrays.degenerate_triangles else "")
          + (f", spheres: {arrays.spheres}" if arrays.spheres else ""))
    print(f"bvh:        {len(arrays.nodes)} nodes, depth {arrays.bvh_depth}")
    print(f"emitters:   {len(arrays.emitters)} ({len(scene.lights)} lights + emissive triangles and spheres)")
    for medium in scene.media:
        print(f"medium:     {medium.name}: {_describe_medium(medium)}")
    if any(m.type == "grid" for m in scene.media):
        r = scene.render
        print(f"volumes:    method {r.volume_method}" + (
            f", step {r.step:g}, multiple scattering {'on' if r.raymarch_multiple_scattering else 'off'}"
            if r.volume_method == "raymarch" else ""))
    print(f"bounds:     min {_fmt(lo)}  max {_fmt(hi)}")
    print(f"features:   {describe(scene_features(scene))}")
    o = scene.outlines
    print("outlines:   " + (f"width {o.width:g} px, depth threshold {o.depth_threshold:g}, "
                            f"crease angle {o.crease_angle:g} deg" if o.enabled else "off"))
    return 0


def _describe_medium(medium):
    coefficients = f"sigma_a {_fmt(medium.sigma_a)}, sigma_s {_fmt(medium.sigma_s)}, g {medium.g:g}"
    if medium.grid is None:
        return f"homogeneous, {coefficients}"
    grid = medium.grid
    high, _ = grid.majorants()
    nx, ny, nz = grid.resolution
    lo, hi = grid.world_bounds()
    return (f"grid {nx}x{ny}x{nz} ({grid.source}), density max {float(grid.density.max()):.4g}, "
            f"{np.count_nonzero(high == 0)}/{high.size} empty majorant blocks of {grid.block}^3, "
            f"box {_fmt(lo)}-{_fmt(hi)}, {coefficients} per unit density")


def _fmt(v):
    return "(" + ", ".join(f"{x:.4g}" for x in v) + ")"


def _devices(args):
    from .device import choose_device, list_devices

    default = choose_device()
    for index, platform, device in list_devices():
        mark = "*" if device.int_ptr == default.int_ptr else " "
        print(f"{mark} {index}: {device.name.strip()} [{platform.name.strip()}, "
              f"{device.version.strip()}, {device.max_compute_units} compute units]")
    print("(* = default; choose with --device INDEX|cpu|gpu|NAME or CLRENDER_DEVICE)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
