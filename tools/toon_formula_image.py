"""Render docs/images/toon_formula.png: the default toon material on a sphere lit by one
unit-strength sun (irradiance pi), with a plate casting a shadow on it; left alone, middle inside
an empty `interface` sphere (identical), right inside the same sphere filled with an absorbing
fog (sigma_a 0.6: the lit side darkens by the fog's transmittance).

    python tools/toon_formula_image.py [--device cpu] [-o docs/images/toon_formula.png]
"""
import argparse

import numpy as np

import clrender


def scene(fog_sigma=None):
    to_light = np.array([-0.8, 0.5, 0.33]) / np.linalg.norm([-0.8, 0.5, 0.33])
    plate = 2.2 * to_light + [0.15, -0.45, 0.0]
    data = {
        "camera": {"position": [0, 0, 5], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov": 26,
                   "resolution": [200, 200]},
        "materials": [{"name": "toon", "type": "toon", "color": [0.8, 0.45, 0.2]},
                      {"name": "black", "type": "diffuse", "albedo": [0, 0, 0]}],
        "shapes": [{"type": "sphere", "material": "toon", "radius": 1.0},
                   {"type": "rectangle", "material": "black",
                    "transform": {"scale": 0.35, "rotate": [0, 90, 0], "translate": plate.tolist()}}],
        "lights": [{"type": "directional", "direction": (-to_light).tolist(), "irradiance": np.pi}],
    }
    if fog_sigma is not None:
        data["media"] = [{"name": "fog", "sigma_a": fog_sigma, "sigma_s": 0.0}]
        data["materials"].append({"name": "boundary", "type": "interface"})
        data["shapes"].append({"type": "sphere", "material": "boundary", "radius": 1.5, "interior": "fog"})
    return clrender.load_scene_dict(data)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--device", default=None)
    parser.add_argument("-o", "--output", default="docs/images/toon_formula.png")
    args = parser.parse_args()
    device = clrender.choose_device(args.device)
    images = [clrender.Renderer(scene(sigma), device).render(spp=64, seed=0).image
              for sigma in (None, 0.0, 0.6)]
    gap = np.ones((images[0].shape[0], 3, 3), np.float32)
    clrender.save_image(np.concatenate([images[0], gap, images[1], gap, images[2]], axis=1), args.output)
    print(args.output)


if __name__ == "__main__":
    main()
