"""Command line: render, info, devices.

Exit codes (docs/errors.md): 0 success, 2 bad arguments, 3 bad scene, 4 device problem, 5 file
I/O, 128 + signal when interrupted (SIGINT 130, SIGHUP 129, SIGTERM 143: a render in progress
saves its partial image first), 1 only for a bug in clrender (with its traceback).
Imports are deferred so that a signal during start-up is handled like any other.
"""
import argparse
import contextlib
import signal
import sys
import threading
import warnings
from pathlib import Path

from .errors import ArgumentError, ClrenderError, Interrupted


def main(argv=None):
    try:
        with _plain_warnings(), _interrupt_on_termination():
            args = _parser().parse_args(argv)
            return args.run(args)
    except ClrenderError as e:
        print(f"clrender: error: {e}", file=sys.stderr)
        return e.exit_code
    except KeyboardInterrupt as e:
        print("clrender: interrupted", file=sys.stderr)
        return 128 + getattr(e, "signal", signal.SIGINT)


@contextlib.contextmanager
def _interrupt_on_termination():
    """SIGTERM and SIGHUP raise Interrupted, a KeyboardInterrupt: they stop a render as Ctrl-C
    does (the launch in flight finishes, the partial image is saved) instead of killing it."""
    def interrupt(signum, frame):
        raise Interrupted(signum)

    if threading.current_thread() is not threading.main_thread():   # only it receives signals
        yield
        return
    previous = {signum: signal.signal(signum, interrupt) for signum in (signal.SIGTERM, signal.SIGHUP)}
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)


@contextlib.contextmanager
def _plain_warnings():
    """Warnings (e.g. a rebuilt kernel cache entry) as one `clrender: warning:` line."""
    def show(message, category, filename, lineno, file=None, line=None):
        print(f"clrender: warning: {message}", file=sys.stderr)

    with warnings.catch_warnings():
        warnings.showwarning = show
        yield


def _parser():
    parser = argparse.ArgumentParser(prog="clrender", description="OpenCL path tracer")
    commands = parser.add_subparsers(dest="command", required=True)

    render = commands.add_parser("render", help="render a scene to an image")
    render.add_argument("scene", type=Path)
    render.add_argument("-o", "--output", type=Path, required=True,
                        help="output image: .exr (linear float) or .png/.jpg/.tif (sRGB)")
    render.add_argument("--spp", type=_setting("spp"), help="samples per pixel (default: the scene's)")
    render.add_argument("--time", type=_setting("time_limit"), metavar="SECONDS",
                        help="render for this long (kernel time); with --spp, whichever comes first")
    render.add_argument("--seed", type=_setting("seed"), help="random seed (default: the scene's)")
    render.add_argument("--max-depth", type=_setting("max_depth"), help="longest path (default: the scene's)")
    render.add_argument("--device", help="device index, 'cpu', 'gpu' or a name part (default: $CLRENDER_DEVICE, else a GPU, else the CPU)")
    render.add_argument("--exposure", type=_setting("exposure"), default=0.0,
                        help="exposure in stops for 8-bit outputs")
    render.add_argument("--quiet", action="store_true", help="no progress bar")
    render.add_argument("--volume-method", choices=("null", "raymarch"),
                        help="grid media: null-scattering path integral (unbiased) or ray marching "
                             "(biased preview) (default: the scene's, else null)")
    render.add_argument("--step", type=_setting("step"), help="ray-marching step in scene units (default: the scene's)")
    render.add_argument("--raymarch-multiple-scattering", action=argparse.BooleanOptionalAction, default=None,
                        help="ray marching: continue paths from a scattering point (default: the scene's, else off)")
    render.set_defaults(run=_render)

    info = commands.add_parser("info", help="print scene statistics and the kernel features it needs")
    info.add_argument("scene", type=Path)
    info.set_defaults(run=_info)

    devices = commands.add_parser("devices", help="list OpenCL platforms and devices")
    devices.set_defaults(run=_devices)
    return parser


def _setting(name):
    """An argparse type for a render setting, bounded as in the scene and the API (limits.py)."""
    from . import limits

    integer = limits.SETTINGS[name][0]

    def parse(text):
        try:
            value = int(text) if integer else float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"must be {'an integer' if integer else 'a number'}, "
                                             f"got {limits.show(text)}") from None
        try:
            return limits.setting(name, value)
        except ArgumentError as e:
            raise argparse.ArgumentTypeError(e.message) from None
    return parse


def _render(args):
    from tqdm import tqdm

    from .image import check_output_path, save_image
    from .render import Renderer, RenderInterrupted
    from .scene import load_scene

    check_output_path(args.output, "--output")
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
        status = 128 + interrupted.signal
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
    print(f"triangles:  {len(arrays.triangles)}"
          + (f" ({arrays.degenerate_triangles} degenerate dropped)" if arrays.degenerate_triangles else ""))
    print(f"bvh:        {len(arrays.nodes)} nodes, depth {arrays.bvh_depth}")
    print(f"emitters:   {len(arrays.emitters)} ({len(scene.lights)} lights + emissive triangles)")
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
            f"{int((high == 0).sum())}/{high.size} empty majorant blocks of {grid.block}^3, "
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
