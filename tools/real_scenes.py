"""Real Mitsuba 3 scenes for tools/peers.py (--real-scenes) and tools/variance.py: each scene's XML
as shipped, in an edited copy whose only changes are the film's size and the sampler's type (and,
for tools/variance.py, the film's reconstruction filter), rendered by both renderers from the same
files; and the timed processes, which time their phases.

The copy is a mirror of the scene's folder in the cache: every file a symbolic link to the
original except the XML files holding a <film> or a <sampler>, written with the edit, so every
relative path (includes, meshes, textures, <path> folders) resolves as it does beside the
original. Research integrators a scene names as its default (SOURCES.md: Bitterli's scenes as
edited by a path-guiding lab) are replaced with `-D integrator=path`, as SOURCES.md says.
"""
import importlib
import json
import os
import re
import time
from pathlib import Path

# Mitsuba 3's own integrators: a scene whose default integrator is none of these gets `path`.
MITSUBA_INTEGRATORS = {"path", "volpath", "volpathmis", "direct", "aov", "moment", "ptracer", "prb", "prb_basic",
                       "prbvolpath", "direct_projective", "prb_projective", "stokes", "depth"}
_DEFAULT_INTEGRATOR = re.compile(r"""<default\s+name=["']integrator["']\s+value=["']([^"']*)["']""")
_INCLUDE = re.compile(r"""<include\s+filename=["']([^"']*)["']""")
_FILM = re.compile(r"<film\b.*?</film>", re.S)
_SAMPLER_TYPE = re.compile(r"""(<sampler\s+type=)(["'])[^"']*\2""")
_RFILTER = re.compile(r"<rfilter\b[^>]*/>|<rfilter\b[^>]*>.*?</rfilter>", re.S)


def scene_files(paths):
    """The scene XML files of `paths`: files as given; a scene's folder gives the XML files no
    other XML there includes; a folder of scenes with its SOURCES.md (../shared/real-scenes), those
    of each scene's folder (its `xml-only/` folder, scenes without their assets, left out)."""
    found = []
    for path in map(Path, paths):
        if path.is_file():
            found.append(path.resolve())
            continue
        many = (path / "SOURCES.md").is_file()
        for folder in sorted(p for p in path.iterdir() if p.is_dir() and p.name != "xml-only") if many else [path]:
            xmls = sorted(folder.rglob("*.xml"))
            # Includes resolve against the including file or the scene's folders: matched by ending.
            included = {name for x in xmls for name in _INCLUDE.findall(x.read_text())}
            found += [x.resolve() for x in xmls if not any(x.as_posix().endswith("/" + n) for n in included)]
    return found


def scene_name(xml):
    """A short name: the scene's folder (see _scene_root)."""
    return _scene_root(xml).name


def parameters(xml):
    """The -D parameters both renderers get: `integrator=path` where the scene's default
    integrator (any of its <default name="integrator">) is not one of Mitsuba's."""
    names = _DEFAULT_INTEGRATOR.findall(xml.read_text())
    return {"integrator": "path"} if any(n not in MITSUBA_INTEGRATORS for n in names) else {}


def film_size(resolution, longest):
    """The film (width, height): the longer side `longest` (or the scene's, if smaller), the
    aspect kept to the nearest multiple of 8 pixels (peers.py compares 8 x 8 blocks)."""
    width, height = resolution
    scale = min(1.0, longest / max(width, height))
    return tuple(max(8, 8 * round(side * scale / 8)) for side in (width, height))


def sized_scenes(paths, longest):
    """name -> clrender Scene of each real scene in `paths` (scene_files), loaded from its XML as
    shipped (with `parameters`), its film's longer side `longest` (film_size): the scenes as
    tools/peers.py renders them, for benchmarks that run clrender alone in one process."""
    import warnings
    from dataclasses import replace

    import clrender

    scenes = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for xml in scene_files(paths):
            scene = clrender.load_scene(xml, parameters(xml))
            size = film_size(scene.camera.resolution, longest)
            scenes[scene_name(xml)] = replace(scene, camera=replace(scene.camera, resolution=size))
    return scenes


def mirror(xml, folder, size, sampler, rfilter=None):
    """The scene file `xml` mirrored into `folder` (see the module's docstring) with its film
    `size` (width, height) and every sampler of type `sampler`; with `rfilter` (a filter type), every
    film's reconstruction filter becomes one of that type with its default parameters (a film
    without one, whose filter is Mitsuba's default gaussian, gets it too). Returns the mirrored
    XML's path."""
    root = _scene_root(xml)
    for source in root.rglob("*"):
        target = folder / source.relative_to(root)
        if source.is_dir():
            target.mkdir(parents=True, exist_ok=True)
            continue
        target.parent.mkdir(parents=True, exist_ok=True)
        text = source.read_text(errors="replace") if source.suffix == ".xml" else None
        if text is not None and ("<film" in text or "<sampler" in text):
            edited = _edit(text, size, sampler, rfilter)
            if not target.is_file() or target.is_symlink() or target.read_text() != edited:
                target.unlink(missing_ok=True)
                target.write_text(edited)
        elif not target.is_symlink():
            target.unlink(missing_ok=True)
            target.symlink_to(source)
    return folder / xml.relative_to(root)


def _scene_root(xml):
    """The folder mirrored for `xml`: the topmost folder holding it that is a scene's own (the
    one below a folder with SOURCES.md, else the file's folder)."""
    for parent in xml.parents:
        if (parent.parent / "SOURCES.md").is_file():
            return parent
    return xml.parent


def _edit(text, size, sampler, rfilter=None):
    def film(match):
        block = match.group(0)
        for name, value in zip(("width", "height"), size):
            block = re.sub(rf"""(<integer\s+name=["']{name}["']\s+value=)(["'])[^"']*\2""",
                           rf"\g<1>\g<2>{value}\g<2>", block)
        if rfilter is not None:
            block = _RFILTER.sub("", block).replace("</film>", f'<rfilter type="{rfilter}"/></film>')
        return block
    return _SAMPLER_TYPE.sub(rf"\g<1>\g<2>{sampler}\g<2>", _FILM.sub(film, text))


# ---------------------------------------------------------------------------------------------
# The timed processes: phases in seconds, written beside the image
# ---------------------------------------------------------------------------------------------
class Phases:
    """Wall seconds of named phases of one process, in order; `cpu` the CPU seconds since the
    process began (all threads) at the end of the image the parent times."""

    def __init__(self):
        self.seconds = {}

    def time(self, name, function):
        start = time.perf_counter()
        result = function()
        self.seconds[name] = self.seconds.get(name, 0.0) + time.perf_counter() - start
        return result

    def write(self, out):
        Path(out).with_suffix(".phases.json").write_text(json.dumps(self.seconds))


def cpu_seconds():
    times = os.times()
    return times.user + times.system


def child_clrender(xml, params, spp, seed, batches, out, sampler, warmup=False):
    """Load, set up (arrays and BVH, kernel build, upload) and render the images of seeds seed,
    seed + 1, ... (`batches` of them, written to `out`); a single image is followed by a render of
    another seed, whose time is rendering alone. `warmup`: see _render_all."""
    import warnings

    import clrender
    render_module = importlib.import_module("clrender.render")

    phases = Phases()
    # The set-up's parts, timed where Renderer calls them.
    for name, label in (("build_scene_arrays", "arrays + BVH"), ("build_program", "kernel build")):
        function = getattr(render_module, name)
        setattr(render_module, name, lambda *a, _f=function, _l=label, **k: phases.time(_l, lambda: _f(*a, **k)))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        scene = phases.time("load", lambda: clrender.load_scene(xml, params))
    renderer = phases.time("set-up", lambda: clrender.Renderer(scene, sampler=sampler))
    _render_all(lambda s: renderer.render(spp=spp, seed=s).image, seed, batches, out, phases, warmup)


def child_mitsuba(xml, params, spp, seed, batches, out, variant, warmup=False):
    """The same with Mitsuba: load_file (parse, meshes, textures, BVH), the first render (its
    JIT: tracing, compilation or the kernel cache), the second (rendering alone)."""
    import mitsuba as mi
    import numpy as np

    mi.set_variant(variant)
    phases = Phases()
    scene = phases.time("load", lambda: mi.load_file(str(xml), **params))
    _render_all(lambda s: np.asarray(mi.render(scene, spp=spp, seed=s), np.float32), seed, batches, out, phases,
                warmup)


def _render_all(render, seed, batches, out, phases, warmup=False):
    """The images written to `out`, each one's seconds beside them (`.seconds.json`), and the
    phases. With `warmup` (--timing render), an untimed render of seed 0 first (kernel builds,
    Mitsuba's JIT); without, a single image is followed by the next seed's render as `again`
    (wall) and `again cpu`, which the parent takes off the process."""
    import numpy as np

    if warmup:
        phases.time("warm-up", lambda: render(0))
    images, seconds = [], []
    for b in range(batches):
        start = time.perf_counter()
        images.append(render(seed + b)[..., :3])
        seconds.append(time.perf_counter() - start)
    phases.seconds["render"] = sum(seconds)
    np.save(out, np.stack(images).astype(np.float32))
    Path(out).with_suffix(".seconds.json").write_text(json.dumps(seconds))
    if batches == 1 and not warmup:
        before = cpu_seconds()
        phases.time("again", lambda: render(seed + 1))
        phases.seconds["again cpu"] = cpu_seconds() - before
    phases.write(out)
