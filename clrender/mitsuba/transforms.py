"""`<transform>`: 4x4 matrices, composed as Mitsuba composes them.

| operation | |
|---|---|
| `<translate x y z>` / `value` | translation |
| `<scale x y z>` / `value` | scale per axis (one value: uniform) |
| `<rotate x y z angle>` | `angle` degrees counter-clockwise about the axis (used as given: Rodrigues' formula) |
| `<matrix value>` | 9 (linear) or 16 numbers, row by row; the last row must be 0 0 0 1 |
| `<lookat origin target up>` | Mitsuba's look_at (up 0 1 0 by default; up 0 0 0 an axis perpendicular to the view, as Mitsuba picks it) |
"""
import numpy as np

from .values import parse_float, parse_numbers, parse_triple, parse_xyz
from .xml import attribute


def parse_transform(element):
    """The 4x4 matrix of a <transform>: its operations in document order, each applied after
    (left-multiplied onto) the ones before, as in Mitsuba."""
    matrix = np.eye(4)
    for op in element.children:
        if op.tag == "translate":
            step = np.eye(4)
            step[:3, 3] = parse_xyz(op, 0.0)
        elif op.tag == "scale":
            step = np.diag([*parse_xyz(op, 1.0), 1.0])
        elif op.tag == "rotate":
            step = _rotation(op)
        elif op.tag == "matrix":
            values = parse_numbers(op)
            if len(values) == 9:
                step = np.eye(4)
                step[:3, :3] = np.reshape(values, (3, 3))
            elif len(values) == 16:
                step = np.reshape(values, (4, 4))
                if np.any(step[3] != [0, 0, 0, 1]):
                    raise op.error("projective matrices are not supported: the last row must be 0 0 0 1")
            else:
                raise op.error(f"a matrix has 9 or 16 numbers, got {len(values)}")
        elif op.tag == "lookat":
            step = _look_at(op)
        else:
            raise op.error(f"unknown transform operation <{op.tag}>")
        matrix = step @ matrix
    if not np.all(np.isfinite(matrix)):
        raise element.error("the transform is not finite")
    return matrix


def _rotation(op):
    """Rotation by `angle` degrees (counter-clockwise, right-handed) about the axis (x, y, z).
    Like Mitsuba, the axis is used as given: one that is not of unit length also scales and
    shears (Rodrigues' formula with that vector)."""
    if "angle" not in op.attrs:
        raise op.error("<rotate> needs an angle (degrees)")
    axis = parse_xyz(op, 0.0)
    if not np.any(axis):
        raise op.error("<rotate> needs a non-zero axis")
    x, y, z = axis
    angle = np.radians(parse_float(op, op.attrs["angle"]))
    c, s = np.cos(angle), np.sin(angle)
    k = np.array([[0, -z, y], [z, 0, -x], [-y, x, 0]])
    m = np.eye(4)
    m[:3, :3] = c * np.eye(3) + s * k + (1 - c) * np.outer([x, y, z], [x, y, z])
    return m


def _look_at(op):
    """Mitsuba's look_at: columns (left, up, direction, origin), left = up x direction. An up of
    (0, 0, 0) is, as Mitsuba's parser takes it, the first axis of coordinate_system(direction)."""
    origin = parse_triple(op, attribute(op, "origin"))
    target = parse_triple(op, attribute(op, "target"))
    up = parse_triple(op, op.attrs.get("up", "0 1 0"))
    direction = target - origin
    if np.linalg.norm(direction) == 0:
        raise op.error("origin and target coincide")
    direction /= np.linalg.norm(direction)
    if not np.any(up):
        up = _first_basis_axis(direction)
    left = np.cross(up, direction)
    if np.linalg.norm(left) < 1e-12:
        raise op.error("up is parallel to the viewing direction")
    left /= np.linalg.norm(left)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = left, np.cross(direction, left), direction, origin
    return m


def _first_basis_axis(n):
    """Mitsuba's coordinate_system(n)[0] (Duff et al. 2017)."""
    sign = np.copysign(1.0, n[2])
    a = -1.0 / (sign + n[2])
    return np.array([1.0 + sign * n[0] * n[0] * a, sign * n[0] * n[1] * a, -sign * n[0]])


def rotation_scale(matrix):
    """s when the linear part of `matrix` is s times a rotation (s > 0), else None."""
    linear = matrix[:3, :3]
    gram = linear.T @ linear
    scale2 = np.trace(gram) / 3
    if scale2 <= 0 or np.linalg.det(linear) <= 0 or not np.allclose(gram, scale2 * np.eye(3), rtol=0, atol=1e-6 * scale2):
        return None
    return float(np.sqrt(scale2))


# How far the linear part L of a sensor's to_world may be from a rotation, as max |L L^T - I|:
# Mitsuba's own bound (Transform::has_scale; its perspective camera refuses more). Matrices written
# with 6 significant digits (Bitterli's scenes) are 1e-6 to 2e-5 from a rotation.
ROTATION_TOLERANCE = 1e-3


def rotation_error(matrix):
    """max |L L^T - I| of the linear part L of `matrix`: 0 for a rotation (and for a mirror)."""
    linear = matrix[:3, :3]
    return float(np.max(np.abs(linear @ linear.T - np.eye(3))))


def is_rigid(matrix):
    """Whether the linear part of `matrix` is a rotation (up to float rounding)."""
    scale = rotation_scale(matrix)
    return scale is not None and abs(scale - 1.0) < 1e-5


def matrix_rows(matrix):
    return [[float(v) for v in row] for row in matrix]
