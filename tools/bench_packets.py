"""Camera paths in packets (LANES 8) against the megakernel (LANES 1) on the CPU: kernel CPU
seconds of the same renders, alternating in one process, and how many pixels differ.

    python tools/bench_packets.py [SCENE.json ...] [--real-scenes ../shared/real-scenes] [--size 128]
        [--spp 64] [--seeds 1 2 3 4 5]

Default scenes: the surface benchmark scenes of tools/peers.py (written by it under
~/.cache/clrender/peers), else the example Cornell box. Real scenes are sized as tools/peers.py
sizes them (the longer side --size).
"""
import argparse
import glob
import os
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
sys.path.insert(0, str(Path(__file__).resolve().parent))
import clrender  # noqa: E402
import real_scenes  # noqa: E402
from clrender.bench import median  # noqa: E402
from clrender.features import describe  # noqa: E402

PEERS = Path.home() / ".cache" / "clrender" / "peers"


def cpu_seconds(function):
    before = os.times()
    result = function()
    after = os.times()
    return (after.user - before.user) + (after.system - before.system), result


def default_scenes():
    found = [sorted(glob.glob(str(PEERS / f"{name}-*" / "scene.json")), key=os.path.getmtime)[-1:]
             for name in ("cornell_box", "glass_sphere", "tir_prism")]
    return [path for paths in found for path in paths] or [str(Path(__file__).resolve().parent.parent / "scenes" / "cornell_box.json")]


def scenes(args):
    """name -> Scene or scene file of the scenes asked for."""
    found = {Path(path).parent.name or path: path for path in args.scenes}
    found.update(real_scenes.sized_scenes(args.real_scenes, args.size) if args.real_scenes else {})
    return found or {Path(path).parent.name or path: path for path in default_scenes()}


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("scenes", nargs="*")
    parser.add_argument("--spp", type=int, default=64)
    parser.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3, 4, 5])
    parser.add_argument("--real-scenes", nargs="+", type=Path)
    parser.add_argument("--size", type=int, default=128)
    args = parser.parse_args()
    for name, scene in scenes(args).items():
        renderers = {lanes: clrender.Renderer(scene, packets=lanes > 1) for lanes in (1, 8)}
        if renderers[8].features["LANES"] != 8:
            print(f"{name}: not covered by packets ({describe(renderers[8].features)})")
            continue
        for renderer in renderers.values():
            renderer.render(spp=1, seed=0)   # builds, caches
        ratios, differing = [], []
        for seed in args.seeds:
            mega_s, mega = cpu_seconds(lambda: renderers[1].render(spp=args.spp, seed=seed).image)
            packet_s, packets = cpu_seconds(lambda: renderers[8].render(spp=args.spp, seed=seed).image)
            ratios.append(mega_s / packet_s)
            differing.append(np.mean(~np.all(np.isclose(mega, packets, rtol=1e-4, atol=1e-6), axis=-1)))
        print(f"{name}: {args.spp} spp, speed-up of the packets x{median(ratios):.3f} "
              f"(per seed {min(ratios):.3f}-{max(ratios):.3f}); pixels differing by more than 1e-4: "
              f"{100 * max(differing):.3f} % at most")


if __name__ == "__main__":
    main()
