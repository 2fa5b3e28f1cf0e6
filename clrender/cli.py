"""Command line: render, info, view, devices.

Exit codes (docs/errors.md): 0 success, 2 bad arguments, 3 bad scene, 4 device problem, 5 file
I/O, 128 + signal when interrupted (SIGINT 130, SIGHUP 129, SIGTERM 143: a render in progress
saves its partial image first), 1 only for a bug in clrender (with its traceback).
Several scenes render as a batch; --workers/--scheduler render on a Dask cluster (distributed.py).
Imports are deferred so that a signal during start-up is handled like any other; numpy and
pyopencl are imported first with signals held (signals.py).
"""
import argparse
import contextlib
import signal
import string
import sys
import threading
import warnings
from pathlib import Path

from .errors import ArgumentError, ClrenderError, Interrupted
from .signals import signals_held


def main(argv=None):
    """The command line `argv` (None: the process's own, which then exits with the code
    returned: once interrupted, it ignores later signals until then)."""
    with _plain_warnings(), _interrupt_on_termination(exiting=argv is None):
        try:
            with signals_held():
                import numpy  # noqa: F401
                import pyopencl  # noqa: F401
            args = _parser().parse_args(argv)
            return args.run(args)
        except ClrenderError as e:
            print(f"clrender: error: {e}", file=sys.stderr)
            return e.exit_code
        except KeyboardInterrupt as e:
            print("clrender: interrupted", file=sys.stderr)
            return 128 + getattr(e, "signal", signal.SIGINT)


@contextlib.contextmanager
def _interrupt_on_termination(exiting=False):
    """SIGINT, SIGTERM and SIGHUP raise Interrupted, a KeyboardInterrupt: they stop a render
    (the launch in flight finishes, the partial image is saved) instead of killing it. The first
    one only: the later ones are ignored, so that two quick signals still save the partial image
    (SIGKILL stops at once), and, when the process is `exiting` after the block, until it has
    exited (a second SIGTERM would otherwise kill it with the default action as it exits). A
    signal ignored when clrender started (SIGHUP under nohup, SIGINT in a background job) stays
    ignored."""
    interrupted = []

    def interrupt(signum, frame):
        for handled in previous:   # not SIG_IGN: a signal already pending would raise OSError
            signal.signal(handled, ignore)
        interrupted.append(signum)
        raise Interrupted(signum)

    def ignore(signum, frame):
        pass

    if threading.current_thread() is not threading.main_thread():   # only it receives signals
        yield
        return
    previous = {signum: signal.signal(signum, interrupt) for signum in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)
                if signal.getsignal(signum) is not signal.SIG_IGN}
    try:
        yield
    finally:
        for signum, handler in previous.items():   # Python's exit resets Python handlers, not SIG_IGN
            signal.signal(signum, signal.SIG_IGN if exiting and interrupted else handler)


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

    render = commands.add_parser("render", help="render scenes to images")
    render.add_argument("scene", type=Path, nargs="+", help="scene file(s); several render as a batch")
    render.add_argument("-o", "--output", required=True,
                        help="output image: .exr (linear float) or .png/.jpg/.tif (sRGB); for several "
                             "scenes a folder (out/ writes out/STEM.exr) or a pattern with {stem} "
                             "and/or {index} (out/frame_{index:04d}.png)")
    render.add_argument("--spp", type=_setting("spp"), help="samples per pixel (default: the scene's)")
    render.add_argument("--time", type=_setting("time_limit"), metavar="SECONDS",
                        help="render for this long (kernel time); with --spp, whichever comes first")
    render.add_argument("--seed", type=_setting("seed"), help="random seed (default: the scene's)")
    render.add_argument("--max-depth", type=_setting("max_depth"), help="longest path (default: the scene's)")
    render.add_argument("--device", help="device index, 'cpu', 'gpu', or a part of a platform or device name, e.g. 'pocl', 'intel' (default: $CLRENDER_DEVICE, else a GPU, else the CPU)")
    render.add_argument("--exposure", type=_setting("exposure"), default=0.0,
                        help="exposure in stops for 8-bit outputs")
    render.add_argument("--quiet", action="store_true", help="no progress bar")
    render.add_argument("--volume-method", choices=("null", "raymarch"),
                        help="grid media: null-scattering path integral (unbiased) or ray marching "
                             "(biased preview) (default: the scene's, else null)")
    render.add_argument("--sampler", choices=("sobol", "independent"),
                        help="random numbers of camera paths: Owen-scrambled Sobol or independent "
                             "(default: the scene's, else sobol)")
    render.add_argument("--step", type=_setting("step"),
                        help="ray marching: longest step in voxels, also scaling the optical depth per step "
                             "(default: the scene's, else 2)")
    render.add_argument("--raymarch-multiple-scattering", action=argparse.BooleanOptionalAction, default=None,
                        help="ray marching: continue paths from a scattering point; --no-... renders single "
                             "scattering (default: the scene's, else on)")
    render.add_argument("--aov", default="", metavar="NAMES",
                        help="auxiliary outputs, comma-separated: albedo, normal, emission, variance, depth, object_id "
                             "(EXR: layers of the output file; 8-bit formats: files NAME.LAYER.png; default: the "
                             "scene's render.aovs, e.g. those of a Mitsuba moment or aov integrator)")
    render.add_argument("--denoise", action="store_true",
                        help="denoise with Intel Open Image Denoise (needs pyoidn: pip install 'clrender[denoise]')")
    render.add_argument("--denoise-prefilter", action="store_true",
                        help="with --denoise, denoise the albedo and normal guides first (slower; see docs/denoising.md)")
    render.add_argument("--denoise-keep-emission", action="store_true",
                        help="with --denoise, leave emitters and the environment seen directly out of the denoiser "
                             "(exact emitters, raw anti-aliasing noise at their edges; see docs/denoising.md)")
    render.add_argument("--keep-noisy", action="store_true",
                        help="with --denoise, also write the image before denoising (EXR layer 'noisy' or NAME.noisy.png)")
    _add_parameter_option(render)
    cluster = render.add_argument_group("distributed rendering (docs/distributed.md)").add_mutually_exclusive_group()
    cluster.add_argument("--workers", type=_setting("workers"), metavar="N",
                         help="render on a local Dask cluster of N worker processes")
    cluster.add_argument("--scheduler", metavar="ADDRESS", help="render on the Dask cluster at tcp://HOST:PORT")
    render.add_argument("--tiles", type=_setting("tiles"), help="with a cluster: image strips (default: 4 per worker thread)")
    render.add_argument("--chunk-seconds", type=_setting("chunk_seconds"), default=3.0,
                        help="with a cluster: kernel time per chunk of samples (default: 3)")
    render.add_argument("--connect-timeout", type=_setting("connect_timeout"), metavar="SECONDS",
                        help="with --scheduler: time to reach the scheduler, and for a first worker to join "
                             "(default: 30)")
    render.add_argument("--chunk-timeout", type=_setting("chunk_timeout"), metavar="SECONDS",
                        help="with a cluster: the render fails when no chunk finishes for this long (default: 600)")
    render.set_defaults(run=_render)

    info = commands.add_parser("info", help="print scene statistics and the kernel features it needs")
    info.add_argument("scene", type=Path, nargs="?", help="a scene (optional with --kernel)")
    info.add_argument("--kernel", action="store_true",
                      help="the render kernel's private memory per work-item, preferred work-group multiple "
                           "and one-sample launch time on the device: for the scene, or without a scene for "
                           "every feature combination (docs/portability.md)")
    info.add_argument("--device", help="device for --kernel (as for render)")
    info.add_argument("--resolution", type=_image_side, nargs=2, metavar=("W", "H"),
                      help="--kernel without a scene: image size of the combinations' scenes (default 256 256)")
    info.add_argument("--no-launch", action="store_true", help="--kernel: leave out the launch timing")
    _add_parameter_option(info)
    info.set_defaults(run=_info)

    view = commands.add_parser("view", help="watch a scene converge in the browser (docs/viewer.md)")
    view.add_argument("scene", type=Path, help="a scene file (JSON or Mitsuba XML)")
    view.add_argument("-o", "--output", help="where 'save' writes: PATH.exr (linear, with the AOVs as layers) and "
                                             "PATH.png (as shown) (default: STEM.exr and STEM.png next to the scene)")
    view.add_argument("--spp", type=_setting("spp"), help="samples per pixel to render to (default: the scene's)")
    view.add_argument("--device", help="device (as for render)")
    view.add_argument("--port", type=_port, default=0, help="port to listen on (default: any free port)")
    view.add_argument("--host", default="127.0.0.1",
                      help="address to listen on (default 127.0.0.1: this machine only; the URL's token is "
                           "needed from anywhere)")
    view.add_argument("--no-browser", action="store_true", help="print the URL, open no browser")
    _add_parameter_option(view)
    view.set_defaults(run=_view)

    devices = commands.add_parser("devices", help="list OpenCL platforms and devices")
    devices.set_defaults(run=_devices)
    return parser


def _add_parameter_option(parser):
    parser.add_argument("-D", dest="parameters", action="append", default=[], metavar="NAME=VALUE",
                        type=_parameter, help="Mitsuba XML scenes: set parameter $NAME (overrides its <default>)")


def _parameter(text):
    from .mitsuba import PARAMETER_NAME

    name, sep, value = text.partition("=")
    if not sep or not name:
        raise argparse.ArgumentTypeError(f"expected NAME=VALUE, got {text!r}")
    if not PARAMETER_NAME.fullmatch(name):
        raise argparse.ArgumentTypeError(f"{name!r} is not a parameter name (letters, digits and _, "
                                         "not starting with a digit)")
    return name, value


def _parameters(args):
    """The -D parameters as a dict: each given once, and only for Mitsuba XML scenes."""
    parameters = {}
    for name, value in args.parameters:
        if name in parameters:
            raise ArgumentError("-D", f"{name} given twice")
        parameters[name] = value
    scenes = args.scene if isinstance(args.scene, list) else [args.scene]
    not_xml = [path for path in scenes if path.suffix.lower() != ".xml"]
    if parameters and not_xml:
        raise ArgumentError("-D", f"parameters apply to Mitsuba XML scenes only, not to {not_xml[0]}")
    return parameters


def _load_scene(path, parameters, plan=None):
    """The scene file, JSON or Mitsuba 3 XML (-D parameters; its warnings printed), and for XML
    the translation notes that `info` shows (None for JSON). With the run's output `plan`, an
    output that is one of the files the scene reads (an include, a mesh, a texture) is an
    ArgumentError."""
    from .files import recording_inputs
    from .loader import read_scene_file

    with recording_inputs() as inputs:
        loaded = read_scene_file(path, parameters)
    clashes = sorted(plan[key] for key in inputs & (plan or {}).keys() if plan[key][0] != SCENE_FILE)
    if clashes:
        what, output = clashes[0]
        raise ArgumentError("--output", f"{what} ({output}) would replace a file {path} reads")
    for warning in loaded.warnings:
        print(f"clrender: warning: {warning}", file=sys.stderr)
    return loaded.scene, loaded.notes


def _port(text):
    if not text.isdigit() or int(text) > 65535:
        raise argparse.ArgumentTypeError(f"must be a port number from 0 (any free port) to 65535, got {text!r}")
    return int(text)


def _image_side(text):
    from . import limits

    try:
        return limits.number(int(text), "", low=1, high=limits.MAX_RESOLUTION, integer=True)
    except ValueError as e:   # int() or the limit
        raise argparse.ArgumentTypeError(getattr(e, "message", f"must be an integer, got {limits.show(text)}")) from None


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
    """Every argument and output path is checked before the first scene renders."""
    from .aovs import parse_aovs

    aovs = parse_aovs(args.aov, source="--aov") if args.aov else None   # None: each scene's render.aovs
    for flag in ("keep_noisy", "denoise_prefilter", "denoise_keep_emission"):
        if getattr(args, flag) and not args.denoise:
            raise ArgumentError(f"--{flag.replace('_', '-')}", "only with --denoise")
    parameters = _parameters(args)
    layers = (aovs or ()) + (("noisy",) if args.keep_noisy else ())
    plan = _output_plan(args.scene)   # the run's files, for the scenes' own AOVs as they load
    outputs = _output_paths(args.output, args.scene, layers, plan)
    _check_scene_files(args.scene)
    if args.scheduler == "":
        raise ArgumentError("--scheduler", "is empty; expected tcp://HOST:PORT")
    cluster = "--workers" if args.workers else "--scheduler" if args.scheduler is not None else None
    if cluster:
        if args.time is not None:
            raise ArgumentError("--time", f"is not supported with {cluster}: chunks are sized in samples")
        from .distributed import require_dask

        require_dask(cluster)
        if args.denoise:
            from .denoise import check_denoiser

            check_denoiser("--denoise")
        return _render_distributed(args, outputs, parameters, aovs, plan)
    if args.tiles is not None:
        raise ArgumentError("--tiles", "only with --workers or --scheduler")
    if args.denoise:
        from .denoise import check_denoiser

        check_denoiser("--denoise")
    for scene_path, output in zip(args.scene, outputs):
        status = _render_local(args, scene_path, output, aovs, parameters, plan)
        if status:
            return status
    return 0


def _view(args):
    """Serve the live view until the last page closes (exit 0) or a signal (128 + signal)."""
    from .view import view
    from .view.output import output_paths

    parameters = _parameters(args)
    _check_scene_files([args.scene])
    scene, _ = _load_scene(args.scene, parameters)
    output_paths(args.output, scene, "--output")
    view(scene, args.spp, args.output, args.device, args.host, args.port, open_browser=not args.no_browser, block=True)
    return 0


def _check_scene_files(paths):
    """Each scene file is a regular file before a batch starts (its contents are read when it
    renders; a named pipe would block the read)."""
    from .errors import SceneError
    from .files import describe, not_a_file

    for path in paths:
        if not_a_file(path) is not None:
            raise SceneError("", describe(path, "scene file"))


def _output_paths(output, scene_paths, layers=(), plan=None):
    """The image path of each scene, each checked (image.check_output_path; with 8-bit formats,
    the files of the `layers` too): `output` itself for one scene; a folder (a path ending in /,
    or for several scenes an existing folder) holds STEM.exr; a pattern names {stem} (the scene
    file's name without its suffix) and/or {index} (its position, from 0; format specs allowed:
    {index:04d}). One scene and an existing folder without the / is an error, not a guess. Each
    file is planned in `plan` (_output_plan; the scenes' own AOVs are planned as they load)."""
    from .image import check_output_path

    is_folder = output.endswith(("/", "\\")) or (len(scene_paths) > 1 and Path(output).is_dir())
    if "{" in output or is_folder:
        pattern = str(Path(output) / "{stem}.exr") if is_folder else output
        try:
            fields = {field for _, field, _, _ in string.Formatter().parse(pattern) if field is not None}
            if not fields <= {"stem", "index"}:   # no {0}, {stem.attribute}, {index[0]}
                raise ValueError(f"unknown field {{{sorted(fields - {'stem', 'index'})[0]}}}")
            paths = [Path(pattern.format(stem=p.stem, index=i)) for i, p in enumerate(scene_paths)]
        except (KeyError, IndexError, ValueError) as e:
            raise ArgumentError("--output", f"bad pattern {output!r} ({e}); use {{stem}} and {{index}}") from None
    elif len(scene_paths) > 1:
        raise ArgumentError("--output", f"{len(scene_paths)} scenes need a folder (out/) or a pattern "
                                        "with {stem} or {index} (out/{stem}.exr), got " + repr(output))
    else:
        paths = [Path(output)]
    plan = _output_plan(scene_paths) if plan is None else plan
    for scene_path, path in zip(scene_paths, paths):
        _plan_output(plan, path, f"the image of {scene_path}")
        check_output_path(path, "--output")
        _check_layer_paths(path, layers, plan, scene_path)
    return paths


SCENE_FILE = "the scene file"


def _output_plan(scene_paths):
    """The files of a run so far (identity -> (what it is, its path)), to plan its outputs in:
    the scene files, which no output may replace."""
    from .files import file_identity

    return {file_identity(path): (SCENE_FILE, path) for path in scene_paths}


def _plan_output(plan, path, what):
    """Add the output `path` (`what` it is) to `plan`; ArgumentError if it is an input or another
    output of the run: a run replaces only files the user named as its outputs, each once."""
    from .files import file_identity

    key = file_identity(path)
    if key in plan:
        clash, clash_path = plan[key]
        raise ArgumentError("--output", f"{what} ({path}) would replace the scene file {clash_path}" if clash == SCENE_FILE
                            else f"{clash} and {what} would both write {path}; name them apart (e.g. {{index}})")
    plan[key] = (what, path)


def _check_layer_paths(path, layers, plan, scene_path):
    """With an 8-bit format, the files NAME.LAYER.png of the `layers` can be written and are
    planned in `plan` (not an input, not another output)."""
    from .image import LDR_SUFFIXES, check_output_path, layer_path

    if path.suffix.lower() in LDR_SUFFIXES:
        for name in layers:
            _plan_output(plan, layer_path(path, name), f"the {name} layer of {scene_path}")
            check_output_path(layer_path(path, name), "--output")


def _render_local(args, scene_path, output, aovs, parameters, plan):
    from .image import save_image
    from .render import Renderer, RenderInterrupted

    scene, _ = _load_scene(scene_path, parameters, plan)
    if aovs is None:
        aovs = scene.render.aovs
        _check_layer_paths(output, aovs, plan, scene_path)
    renderer = Renderer(scene, args.device, volume_method=args.volume_method, step=args.step,
                        raymarch_multiple_scattering=args.raymarch_multiple_scattering, sampler=args.sampler)
    for note in renderer.notes:
        print(f"clrender: note: {note}", file=sys.stderr)
    try:
        result = renderer.render(spp=args.spp, seed=args.seed, max_depth=args.max_depth, progress=not args.quiet,
                                 time_limit=args.time, aovs=aovs, denoise=args.denoise,
                                 denoise_prefilter=args.denoise_prefilter,
                                 denoise_keep_emission=args.denoise_keep_emission)
        status = 0
    except RenderInterrupted as interrupted:
        result = interrupted.result
        status = 128 + interrupted.signal
    save_image(result.image, output, exposure=args.exposure, layers=_layers(args, aovs, result))
    _report(output, result, renderer.device.name.strip(), status)
    return status


def _render_distributed(args, outputs, parameters, aovs, plan):
    """Render the scenes on a Dask cluster; each image is written as soon as it is complete, and
    on Ctrl-C (SIGTERM, SIGHUP) the scenes in flight are written as far as they got."""
    from tqdm import tqdm

    from .distributed import dask_client, render_many
    from .image import save_image
    from .render import RenderInterrupted

    batch = len(args.scene) > 1
    # One scene: loaded now for its spp (the bar's unit). A batch: loaded as the cluster takes
    # them on, so a long sequence is never in memory at once.
    scenes = (_load_scene(path, parameters, plan)[0] for path in args.scene)
    scenes = scenes if batch else list(scenes)
    spp = None if batch else args.spp or scenes[0].render.spp
    if aovs is None:   # a batch renders the AOVs of --aov only: one request for every scene
        aovs = () if batch else scenes[0].render.aovs
        _check_layer_paths(outputs[0], aovs, plan, args.scene[0])
    with dask_client(args.workers, args.scheduler, args.connect_timeout) as client:
        where = f"{len(client.scheduler_info()['workers'])} Dask workers"
        bar = tqdm(total=len(args.scene) if batch else spp, unit="scene" if batch else "spp",
                   disable=args.quiet, file=sys.stderr, dynamic_ncols=True,
                   bar_format="{l_bar}{bar}| {n:.1f}/{total_fmt} {unit} [{elapsed}<{remaining}, "
                              + where + "]")

        def progress(done, total, seconds):
            bar.update((done if batch else done * spp) - bar.n)

        results = render_many(scenes, client, args.spp, args.seed, args.max_depth, args.device,
                              args.volume_method, args.step, args.raymarch_multiple_scattering,
                              args.tiles, args.chunk_seconds, progress=progress, aovs=aovs,
                              denoise=args.denoise, denoise_prefilter=args.denoise_prefilter,
                              denoise_keep_emission=args.denoise_keep_emission, sampler=args.sampler,
                              chunk_timeout=args.chunk_timeout)
        saving = []
        try:
            for index, result in results:
                saving = [(index, result)]
                save_image(result.image, outputs[index], exposure=args.exposure, layers=_layers(args, aovs, result))
                _report(outputs[index], result, where, 0, bar)
                saving = []
            bar.close()
            return 0
        except KeyboardInterrupt as interrupted:
            partial = interrupted.result if isinstance(interrupted, RenderInterrupted) else _stop(results, interrupted)
            status = 128 + getattr(interrupted, "signal", signal.SIGINT)
            bar.close()
            for index, result in saving:   # complete, but its write was interrupted
                save_image(result.image, outputs[index], exposure=args.exposure, layers=_layers(args, aovs, result))
                _report(outputs[index], result, where, 0)
            for index, result in partial:
                save_image(result.image, outputs[index], exposure=args.exposure, layers=_layers(args, aovs, result))
                _report(outputs[index], result, where, status)
            if not saving and not partial:
                print("interrupted before any chunk finished: nothing saved", file=sys.stderr)
            return status


def _stop(results, interrupt):
    """The partial results of a render_many generator interrupted (by `interrupt`) outside it."""
    from .render import RenderInterrupted

    try:
        results.throw(interrupt)
    except RenderInterrupted as interrupted:
        return interrupted.result
    except (StopIteration, KeyboardInterrupt):
        pass
    return []


def _layers(args, aovs, result):
    """The extra layers to write beside the image: the AOVs asked for, the noisy image."""
    layers = {name: result.aovs[name] for name in aovs}
    if args.keep_noisy:
        layers["noisy"] = result.noisy_image
    return layers


def _report(output, result, where, status, bar=None):
    line = (f"{output}: {result.samples} spp in {result.seconds:.2f} s, "
            f"{result.samples_per_second / 1e6:.2f} M samples/s on {where}"
            + (f", {result.discarded_samples} non-finite samples discarded" if result.discarded_samples else "")
            + (f", denoised in {result.denoise_seconds:.2f} s" if result.noisy_image is not None else "")
            + (" (interrupted: partial image saved)" if status else ""))
    if bar is not None:
        bar.write(line, file=sys.stderr)
    else:
        print(line, file=sys.stderr)


def _info(args):
    from .arrays import build_scene_arrays
    from .features import describe, scene_features
    from .origins import errors_at_source

    for flag, given in (("--device", args.device), ("--no-launch", args.no_launch), ("--resolution", args.resolution)):
        if given and not args.kernel:
            raise ArgumentError(flag, "only with --kernel")
    if args.scene is None:
        if not args.kernel:
            raise ArgumentError("scene", "info needs a scene (or --kernel for every feature combination)")
        return _kernel_table(args)
    if args.resolution:
        raise ArgumentError("--resolution", "only without a scene (the scene gives its image size)")
    scene, notes = _load_scene(args.scene, _parameters(args))
    with errors_at_source(scene):
        arrays = build_scene_arrays(scene)
    lo, hi = scene.bounds()
    width, height = scene.camera.resolution
    print(f"scene:      {args.scene}")
    for index, note in enumerate(notes or []):
        print(f"{'mitsuba:' if index == 0 else '':<12}{note}")
    settings = scene.render
    integrator = (f"direct integrator, {settings.emitter_samples} emitter and {settings.bsdf_samples} BSDF samples"
                  if settings.integrator == "direct" else f"max depth {settings.max_depth}")
    print(f"image:      {width} x {height}, {settings.spp} spp, {integrator}"
          + (", emitters hidden from the camera" if settings.hide_emitters else "")
          + (f", AOVs {', '.join(settings.aovs)}" if settings.aovs else ""))
    print(f"materials:  {len(scene.materials)} ({', '.join(m.name for m in scene.materials)})")
    print(f"shapes:     {len(scene.shapes)}")
    print(f"triangles:  {len(arrays.info) - arrays.sphere_count}"
          + (f" ({arrays.degenerate_triangles} degenerate dropped)" if arrays.degenerate_triangles else "")
          + (f", spheres: {arrays.sphere_count}" if arrays.sphere_count else ""))
    print(f"bvh:        {len(arrays.nodes)} nodes, depth {arrays.bvh_depth}")
    print(f"emitters:   {len(arrays.emitters)} ({len(scene.lights)} lights + emissive triangles and spheres)")
    for medium in scene.media:
        print(f"medium:     {medium.name}: {_describe_medium(medium)}")
    if any(m.type == "grid" for m in scene.media):
        r = scene.render
        print(f"volumes:    method {r.volume_method}" + (
            f", step {r.step:g} voxels, multiple scattering {'on' if r.raymarch_multiple_scattering else 'off'}"
            if r.volume_method == "raymarch" else ""))
    print(f"bounds:     min {_fmt(lo)}  max {_fmt(hi)}")
    print(f"features:   {describe(scene_features(scene))}")
    o = scene.outlines
    print("outlines:   " + (f"width {o.width:g} px, depth threshold {o.depth_threshold:g}, "
                            f"crease angle {o.crease_angle:g} deg" if o.enabled else "off"))
    if args.kernel:
        from .device import device_errors
        from .kernel_info import scene_figures
        from .render import Renderer

        renderer = Renderer(scene, args.device)
        with device_errors():
            figures = scene_figures(renderer, launch=not args.no_launch)
        print(f"device:     {renderer.device.name.strip()} [{renderer.device.platform.name.strip()}]")
        print(f"kernel:     {figures.private_bytes} bytes private memory per work-item, work-group "
              f"multiple {figures.preferred_multiple}, at most {figures.max_work_group}")
        if figures.launch_seconds is not None:
            print(f"launch:     {figures.launch_seconds:.3f} s for one sample per pixel "
                  f"(the renderer's shortest launch; longer ones aim at 0.25 s)")
    return 0


def _kernel_table(args):
    from . import limits
    from .device import choose_device, device_errors

    device = choose_device(args.device)
    width, height = args.resolution or (256, 256)
    try:
        limits.check_image_fits((width, height), device)
    except ValueError as e:
        raise ArgumentError("--resolution", e.message) from None
    with device_errors():
        _print_kernel_table(device, width, height, args.no_launch)
    return 0


def _print_kernel_table(device, width, height, no_launch):
    import pyopencl as cl

    from .features import all_feature_combinations, describe
    from .kernel_info import combination_launch_seconds, kernel_figures

    context = cl.Context([device])
    print(f"device: {device.name.strip()} [{device.platform.name.strip()}, {device.driver_version.strip()}]")
    launch = "" if no_launch else f"  1-spp launch at {width}x{height}"
    print(f"{'features':<66} {'private B':>9} {'multiple':>8} {'max wg':>6}{launch}")
    for features in all_feature_combinations():
        f = kernel_figures(context, features)
        if not no_launch:
            f.launch_seconds = combination_launch_seconds(device, features, (width, height))
        seconds = "" if f.launch_seconds is None else f"  {f.launch_seconds:10.4f} s"
        print(f"{describe(features):<66} {f.private_bytes:>9} {f.preferred_multiple:>8} {f.max_work_group:>6}{seconds}",
              flush=True)


def _describe_medium(medium):
    coefficients = f"sigma_a {_fmt(medium.sigma_a)}, sigma_s {_fmt(medium.sigma_s)}, g {medium.g:g}"
    if medium.albedo_grid is not None:
        nz, ny, nx, channels = medium.albedo_grid.shape
        coefficients = (f"sigma_t {_fmt(medium.sigma_t)} split by a {nx}x{ny}x{nz} albedo grid of {channels} "
                        f"channel{'s' if channels > 1 else ''}, g {medium.g:g}")
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
    print("(* = default; choose with --device INDEX|cpu|gpu|NAME (platform or device) or CLRENDER_DEVICE)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
