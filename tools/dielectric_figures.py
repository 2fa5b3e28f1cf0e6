"""Figures for the dielectric materials: the example scenes and two checks shown as numbers.

Usage: python tools/dielectric_figures.py [--out /tmp/dielectric] [--spp 256] [--scale 1.0]

Writes PNGs (sRGB) and EXRs (linear) of scenes/cornell_glass.json, rough_glass.json,
tir_prism.json and ior_sweep.json (--scale multiplies their resolution), a furnace image (glass
spheres, smooth and rough, in a uniform environment: they should vanish), and prints, for the
glass Cornell box scaled by 1e-3 and 1e3 and moved to 1e4 from the origin, the relative
difference of the mean image from the unmoved scene (independent seeds, so it includes noise).
"""
import argparse
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

import clrender  # noqa: E402
from clrender import meshes  # noqa: E402
from clrender.bench import timed  # noqa: E402

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
SCENES = ["cornell_glass", "rough_glass", "tir_prism", "ior_sweep"]


def render_scene(name, spp, scale, out, device):
    scene = clrender.load_scene(os.path.join(ROOT, "scenes", f"{name}.json"))
    width, height = scene.camera.resolution
    scene.camera.resolution = (max(1, round(width * scale)), max(1, round(height * scale)))
    seconds, result = timed(lambda: clrender.Renderer(scene, device).render(spp=spp, seed=1))
    clrender.save_image(result.image, os.path.join(out, f"{name}.png"))
    clrender.save_image(result.image, os.path.join(out, f"{name}.exr"))
    print(f"{name}: {scene.camera.resolution[0]}x{scene.camera.resolution[1]}, {spp} spp, "
          f"{seconds:.1f} s, {result.samples_per_second / 1e6:.2f} M samples/s, "
          f"discarded {result.discarded_samples}")


def furnace(spp, out, device):
    materials = [{"name": "smooth", "type": "dielectric", "ior": 1.5},
                 {"name": "rough", "type": "dielectric", "ior": 1.5, "roughness": 0.5},
                 {"name": "rough_metal", "type": "conductor", "roughness": 0.5}]
    scene = clrender.load_scene_dict({
        "camera": {"position": [0, 0, 7], "look_at": [0, 0, 0], "fov": 30, "resolution": [192, 64]},
        "materials": materials,
        "shapes": [{"type": "sphere", "material": m["name"], "center": [2.4 * (i - 1), 0, 0],
                    "radius": 1.0} for i, m in enumerate(materials)],
        "lights": [{"type": "environment", "radiance": 0.5}],
        "render": {"max_depth": 1024, "rr_depth": 8},
    })
    result = clrender.Renderer(scene, device).render(spp=spp, seed=1)
    clrender.save_image(result.image, os.path.join(out, "furnace.png"))
    image = result.image[..., 0]
    print(f"furnace (environment 0.5): pixel min {image.min():.4f} max {image.max():.4f} "
          f"mean {image.mean():.5f}, discarded {result.discarded_samples}")


def scale_check(spp, device):
    def moved(scale, offset):
        scene = clrender.load_scene(os.path.join(ROOT, "scenes", "cornell_glass.json"))
        scene.camera.resolution = (64, 64)
        return scene.transform(meshes.transform_matrix(translate=[offset] * 3, scale=[scale] * 3))

    reference = clrender.Renderer(moved(1.0, 0.0), device).render(spp=spp, seed=1).image
    for label, scale, offset in [("unmoved, other seed", 1.0, 0.0), ("x 1e-3", 1e-3, 0.0),
                                 ("x 1e3", 1e3, 0.0), ("+ 1e4", 1.0, 1e4)]:
        image = clrender.Renderer(moved(scale, offset), device).render(spp=spp, seed=2).image
        difference = (image - reference).mean(axis=2)
        z = abs(difference.mean()) / (difference.std(ddof=1) / np.sqrt(difference.size))
        print(f"glass Cornell box {label:20s}: mean relative difference "
              f"{image.mean() / reference.mean() - 1:+.4f} (z = {z:.2f}), black pixels "
              f"{int(np.sum(image.sum(axis=2) == 0))}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="/tmp/dielectric")
    parser.add_argument("--spp", type=int, default=256)
    parser.add_argument("--scale", type=float, default=1.0, help="resolution factor")
    parser.add_argument("--device", default=None)
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)
    device = clrender.choose_device(args.device)
    for name in SCENES:
        render_scene(name, args.spp, args.scale, args.out, device)
    furnace(args.spp, args.out, device)
    scale_check(args.spp, device)


if __name__ == "__main__":
    main()
