"""Start-up of the real Mitsuba scenes, this checkout against another: whole-process seconds and
the phases real_scenes.child_clrender times (load, arrays + BVH, kernel build, the rest of the
set-up, the first render), median of interleaved rounds in fresh processes, caches warm (one
warm-up round).

    python tools/startup_real_scenes.py --baseline CHECKOUT SCENE_FOLDER... [--runs 3] [--spp 4]
                                        [--cache DIR]

The scenes are mirrored as tools/peers.py --real-scenes mirrors them (the film's longer side 128
pixels, the 48 x 48 test scenes at their size). The whole-process column leaves out the second
render each process makes (as peers.py). CHECKOUT: e.g. `git archive BASE | tar -x -C DIR`.
"""
import argparse
import json
import sys
import tempfile
import warnings
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path[:0] = [str(ROOT), str(ROOT / "tools")]
import real_scenes  # noqa: E402
from clrender.bench import interleaved, markdown_table, median, run_process  # noqa: E402

CHILD = """
import json, sys
sys.path[:0] = [{root!r}, {root!r} + "/tools"]
import real_scenes
real_scenes.child_clrender(__import__("pathlib").Path({xml!r}), {params!r}, {spp}, 1, 1, {out!r}, "independent")
"""
PHASES = ("load", "arrays + BVH", "kernel build", "upload etc.", "render")


def mirrored(xml, cache):
    import clrender

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        resolution = clrender.load_scene(xml, real_scenes.parameters(xml)).camera.resolution
    size = real_scenes.film_size(resolution, 128)
    return real_scenes.mirror(xml, Path(cache) / f"{real_scenes.scene_name(xml)}-{size[0]}x{size[1]}", size,
                              "independent")


def measure(root, xml, params, spp, out):
    """Whole-process seconds (less the second render) and the phases of one process."""
    run = run_process([sys.executable, "-c", CHILD.format(root=str(root), xml=str(xml), params=params, spp=spp,
                                                          out=str(out))])
    phases = json.loads(Path(out).with_suffix(".phases.json").read_text())
    phases["upload etc."] = phases["set-up"] - phases.get("arrays + BVH", 0) - phases.get("kernel build", 0)
    return {"whole": run.wall_seconds - phases["again"], **phases}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenes", nargs="+")
    parser.add_argument("--baseline", required=True)
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--spp", type=int, default=4)
    parser.add_argument("--cache", default=str(Path(tempfile.gettempdir()) / "clrender-startup-real"))
    args = parser.parse_args()
    checkouts = {"before": Path(args.baseline).resolve(), "after": ROOT}
    rows = []
    for xml in real_scenes.scene_files(args.scenes):
        mirror, params = mirrored(xml, args.cache), real_scenes.parameters(xml)
        out = Path(args.cache) / "image.npy"
        runs = interleaved({name: (lambda r=root: measure(r, mirror, params, args.spp, out))
                            for name, root in checkouts.items()}, rounds=args.runs)
        cells = [real_scenes.scene_name(xml)]
        for column in ("whole",) + PHASES:
            cells.append(" / ".join(f"{median([r.get(column, 0.0) for r in runs[name]]):.2f}" for name in checkouts))
        rows.append(cells)
        print(" | ".join(cells), flush=True)
    print(markdown_table(["scene (before / after s)", "whole process", *PHASES], rows))


if __name__ == "__main__":
    main()
