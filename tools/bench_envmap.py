"""Set-up cost of an environment map: `clrender info` (load, sampling tables, BVH) of a scene
whose only heavy part is a W x H lat-long map, timed whole in fresh processes, with the
process's peak memory. Three scenes: a Mitsuba envmap turned about y (the usual case), one
tilted (z up), and a JSON environment (the texel lookup).

    python tools/bench_envmap.py [--map sky.exr | --size 2048 1024] [--runs 5] [--roots DIR ...]

`--roots`: checkouts of clrender to compare (default: this one), e.g. an older commit unpacked
with `git archive COMMIT | tar -x -C /tmp/old`; rounds interleave them, so their ratios hold on
a loaded machine.
"""
import argparse
import json
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
from clrender.bench import interleaved, markdown_table, median, run_process, spread  # noqa: E402

# Runs the CLI in this process and prints its peak resident memory (KiB) last.
PROBE = """
import resource, runpy, sys
sys.path.insert(0, {root!r})
sys.argv = ["clrender", "info", {scene!r}]
try:
    runpy.run_module("clrender.cli", run_name="__main__")
except SystemExit:
    pass
print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)
"""

SENSOR = ('<sensor type="perspective"><transform name="to_world"><lookat origin="0, 0, 5" target="0, 0, 0"/>'
          '</transform><film type="hdrfilm"><integer name="width" value="64"/><integer name="height" value="48"/>'
          '<rfilter type="box"/></film></sensor>')


def sky(width, height):
    """A smooth sky with a small bright sun, float32 RGB."""
    import numpy as np

    v = (np.arange(height) + 0.5) / height
    u = (np.arange(width) + 0.5) / width
    image = (0.2 + 0.8 * np.cos(v * np.pi).clip(0))[:, None, None] * np.array([0.6, 0.8, 1.0]) \
        * (1 + 0.1 * np.sin(8 * np.pi * u))[None, :, None]
    image[height // 4:height // 4 + 3, width // 3:width // 3 + 3] = [4000.0, 3000.0, 2000.0]
    return image.astype(np.float32)


def write_scenes(folder, map_path):
    scenes = {}
    for name, rotation in (("envmap about y", '<rotate y="1" angle="30"/>'),
                           ("envmap z up", '<rotate x="1" angle="-90"/><rotate y="1" angle="30"/>')):
        path = folder / f"{name.replace(' ', '_')}.xml"
        path.write_text(f'<scene version="3.0.0">{SENSOR}<emitter type="envmap"><string name="filename" '
                        f'value="{map_path}"/><transform name="to_world">{rotation}</transform></emitter>'
                        '<shape type="sphere"/></scene>')
        scenes[name] = path
    path = folder / "json_environment.json"
    path.write_text(json.dumps({"camera": {"position": [0, 0, 5], "look_at": [0, 0, 0], "resolution": [64, 48]},
                                "materials": [{"name": "grey", "type": "diffuse"}],
                                "shapes": [{"type": "sphere", "material": "grey"}],
                                "lights": [{"type": "environment", "file": str(map_path)}]}))
    scenes["JSON environment"] = path
    return scenes


def measure(root, scene):
    run = run_process([sys.executable, "-c", PROBE.format(root=str(root), scene=str(scene))])
    return run.wall_seconds, int(run.stdout.split()[-1]) / 1024


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--map", type=Path, help="a lat-long image (default: a generated sky)")
    parser.add_argument("--size", type=int, nargs=2, default=(2048, 1024), metavar=("W", "H"))
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--roots", type=Path, nargs="+", default=[ROOT])
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        folder = Path(folder)
        map_path = args.map.resolve() if args.map else folder / "sky.exr"
        if not args.map:
            import clrender

            clrender.save_image(sky(*args.size), map_path)
        scenes = write_scenes(folder, map_path)
        measures = {(root, name): (lambda root=root, scene=scene: measure(root, scene))
                    for name, scene in scenes.items() for root in args.roots}
        runs = interleaved(measures, rounds=args.runs)
    rows = []
    for (root, name), results in runs.items():
        seconds, memory = [r[0] for r in results], [r[1] for r in results]
        rows.append([name, str(root), spread(seconds), f"{median(memory):.0f}"])
    print(f"`clrender info` of a {map_path.name if args.map else 'generated'} "
          f"{args.size[0] if not args.map else ''} map, {args.runs} runs:")
    print(markdown_table(["scene", "checkout", "wall s, median (min-max)", "peak MiB"], rows))


if __name__ == "__main__":
    main()
