"""Build scenes/toon_character.obj: a small bean-shaped character from trimesh primitives.

    python tools/make_toon_character.py [output.obj]

Body, head, arms and legs are one mesh (one object id), so its inner outlines (an arm in front
of the body, the chin over the chest) come from depth jumps and creases, not from object ids.
Eyes, nose and hat are separate shapes in scenes/toon_character.json. Units: metres-ish, the
character stands on y = 0, faces +z, about 1.9 tall.
"""
import sys
from pathlib import Path

import numpy as np
import trimesh


def _capsule(start, end, radius, sections=20):
    """A capsule from `start` to `end` (trimesh builds it along +z, centred at the origin)."""
    start, end = np.asarray(start, float), np.asarray(end, float)
    axis = end - start
    length = np.linalg.norm(axis)
    mesh = trimesh.creation.capsule(height=length, radius=radius, count=[sections, sections])
    rotation = trimesh.geometry.align_vectors([0, 0, 1], axis / length)
    mesh.apply_transform(rotation)
    mesh.apply_translation((start + end) / 2)
    return mesh


def _ellipsoid(center, radii, subdivisions=3):
    mesh = trimesh.creation.icosphere(subdivisions=subdivisions, radius=1.0)
    mesh.apply_scale(radii)
    mesh.apply_translation(center)
    return mesh


def character():
    parts = [
        _ellipsoid([0, 0.78, 0], [0.42, 0.48, 0.36]),                # body
        _ellipsoid([0, 1.42, 0.02], [0.36, 0.33, 0.33]),              # head
        _capsule([-0.40, 1.02, 0.02], [-0.62, 0.62, 0.30], 0.09),     # left arm, reaching forward
        _capsule([0.40, 1.02, 0.0], [0.70, 1.30, -0.02], 0.09),       # right arm, waving
        _capsule([-0.17, 0.38, 0.0], [-0.19, 0.08, 0.04], 0.12),      # legs
        _capsule([0.17, 0.38, 0.0], [0.19, 0.08, 0.04], 0.12),
        _ellipsoid([-0.19, 0.05, 0.10], [0.14, 0.06, 0.20], 2),       # feet
        _ellipsoid([0.19, 0.05, 0.10], [0.14, 0.06, 0.20], 2),
    ]
    return trimesh.util.concatenate(parts)


def main(argv):
    output = Path(argv[1]) if len(argv) > 1 else Path(__file__).resolve().parent.parent / "scenes" / "toon_character.obj"
    mesh = character()
    output.write_text(trimesh.exchange.obj.export_obj(mesh, include_normals=False, digits=5))
    print(f"{output}: {len(mesh.faces)} triangles")


if __name__ == "__main__":
    main(sys.argv)
