"""Camera moves of the viewer: orbit around the target, pan, dolly, reset. Each returns a new
scene.Camera (dataclasses.replace: its resolution, field of view and any other field kept), which
the render loop hands to Renderer.set_camera; `move` reads one message of the page."""
import dataclasses
import math

import numpy as np

from .. import limits
from ..errors import ArgumentError

# An orbit stops this many degrees short of looking along the up axis, where the image's right
# axis (view direction x up) is undefined.
POLE_MARGIN_DEGREES = 1.0
# A dolly keeps the distance to the target within these factors of the scene's own camera's.
DOLLY_RANGE = (1e-3, 1e3)
MOVES = ("orbit", "pan", "zoom", "reset")   # the message types `move` reads
# Bounds of one message's values: a drag turns, pans or zooms a bounded amount.
MAX_TURN = 2 * math.pi       # radians
MAX_PAN = 10.0               # image widths or heights
ZOOM_RANGE = (0.01, 100.0)   # distance factor


def _unit(v):
    return v / np.linalg.norm(v)


def _perpendicular(axis):
    """A unit vector perpendicular to the unit `axis`."""
    other = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 0.0, 1.0])
    return _unit(np.cross(axis, other))


def orbit(camera, yaw, pitch):
    """`camera` turned around its target at the same distance: by `yaw` radians about its up
    axis (counter-clockwise seen from above) and `pitch` radians of elevation (positive: higher),
    the elevation kept POLE_MARGIN_DEGREES short of the up axis."""
    up = _unit(np.asarray(camera.up, float))
    offset = np.asarray(camera.position, float) - camera.look_at
    distance = np.linalg.norm(offset)
    direction = offset / distance
    elevation = math.asin(float(np.clip(direction @ up, -1.0, 1.0)))
    horizontal = direction - (direction @ up) * up
    horizontal = _unit(horizontal) if np.linalg.norm(horizontal) > 1e-9 else _perpendicular(up)
    horizontal = horizontal * math.cos(yaw) + np.cross(up, horizontal) * math.sin(yaw)
    limit = math.radians(90.0 - POLE_MARGIN_DEGREES)
    elevation = min(max(elevation + pitch, -limit), limit)
    direction = horizontal * math.cos(elevation) + up * math.sin(elevation)
    return dataclasses.replace(camera, position=camera.look_at + distance * direction)


def pan(camera, dx, dy):
    """`camera` and its target moved in the image plane so that the scene at the target's
    distance follows a drag of `dx` image widths to the right and `dy` image heights down."""
    _, right, up = camera.basis()   # at unit distance, forward +- right and +- up span the image
    distance = np.linalg.norm(np.asarray(camera.position, float) - camera.look_at)
    shift = 2.0 * distance * (-dx * right + dy * up)
    return dataclasses.replace(camera, position=camera.position + shift, look_at=camera.look_at + shift)


def dolly(camera, factor):
    """`camera` moved along its view direction to `factor` times its distance from the target."""
    return dataclasses.replace(camera, position=camera.look_at + factor * (camera.position - camera.look_at))


def move(camera, home, message):
    """The camera after one message of the page: {"type": "orbit", "yaw", "pitch"} (radians),
    {"type": "pan", "dx", "dy"} (image widths and heights), {"type": "zoom", "factor"} (of the
    distance to the target, which stays within DOLLY_RANGE of `home`'s), {"type": "reset"}
    (`home`, the scene's camera). A bad value raises ArgumentError naming the field."""
    kind = message.get("type")
    if kind == "reset":
        return home
    if kind == "orbit":
        return orbit(camera, _value(message, "yaw", MAX_TURN), _value(message, "pitch", MAX_TURN))
    if kind == "pan":
        return pan(camera, _value(message, "dx", MAX_PAN), _value(message, "dy", MAX_PAN))
    if kind == "zoom":
        factor = limits.number(message.get("factor"), "zoom.factor", low=ZOOM_RANGE[0], high=ZOOM_RANGE[1])
        home_distance = np.linalg.norm(np.asarray(home.position, float) - home.look_at)
        distance = np.linalg.norm(np.asarray(camera.position, float) - camera.look_at)
        low, high = (home_distance * bound for bound in DOLLY_RANGE)
        return dolly(camera, min(max(distance * factor, low), high) / distance)
    raise ArgumentError("type", f"unknown camera move {limits.show(kind)}; valid: {', '.join(MOVES)}")


def _value(message, name, bound):
    return limits.number(message.get(name), f"{message['type']}.{name}", low=-bound, high=bound)


def describe(camera):
    """The camera as the scene format writes it (position, look_at, up, fov): the page shows it,
    to be copied into a scene file."""
    return {"position": [round(float(v), 6) for v in camera.position],
            "look_at": [round(float(v), 6) for v in camera.look_at],
            "up": [round(float(v), 6) for v in camera.up],
            "fov": round(float(camera.fov), 6)}
