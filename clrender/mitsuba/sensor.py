"""Sensors: the camera, with its film and sampler (film.py, sampler.py).

| plugin | parameter (Mitsuba's default) | clrender |
|---|---|---|
| `perspective` | `fov` + `fov_axis` (x, y, diagonal, smaller, larger; x) | `camera.fov`, the vertical field of view |
| | `focal_length` (50mm, 35 mm film's diagonal, when neither is given) | the same, from the diagonal fov |
| | `to_world`: a rotation (to within ROTATION_TOLERANCE, as Mitsuba) and translation | `camera.position`, `look_at` (+z), `up` (+y); a mirror is an error |
| | `near_clip` (0.01), `far_clip` (10000) | not clipped: other values are a warning |
| | nested `film`, `sampler` | `camera.resolution`, `filter`; `render.spp`, `seed`, `sampler` |
| | nested `medium` | `camera.medium` and the scene's `medium` |
| | accepted | `shutter_open`, `shutter_close` (no effect on a static scene), `focus_distance` (a pinhole camera is sharp at every distance: Mitsuba ignores it too) |
| | errors | non-zero `principal_point_offset_x`, `principal_point_offset_y` |
| `thinlens` | everything `perspective` takes, and | |
| | `aperture_radius` (required) | `camera.aperture_radius` |
| | `focus_distance` (far_clip's value) | `camera.focus_distance` |
"""
import re

import numpy as np

from .film import read_film
from .medium import read_medium
from .sampler import read_sampler
from .transforms import ROTATION_TOLERANCE, rotation_error

DEFAULT_NEAR_CLIP, DEFAULT_FAR_CLIP = 0.01, 10000.0
# A to_world that is a rotation only to within ROTATION_TOLERANCE moves the image's corners by up
# to this many pixels from Mitsuba's before a warning says so (Bitterli's 6-digit matrices: 0.007).
MAX_CORNER_SHIFT = 0.1


def read_sensor(plugin, reader):
    """perspective, thinlens: the camera (position, look_at, up, vertical fov, lens), film and sampler."""
    if plugin.type not in ("perspective", "thinlens"):
        raise plugin.error(f"unsupported sensor '{plugin.type}' (supported: perspective, thinlens)")
    films = plugin.nested("film")
    samplers = plugin.nested("sampler")
    media = plugin.nested("medium")
    if len(films) > 1 or len(samplers) > 1 or len(media) > 1:
        raise plugin.error("a sensor takes at most one film, one sampler and one medium")
    width, height, pixel_filter = read_film(films[0] if films else None, reader)
    spp, seed, sampler = read_sampler(samplers[0] if samplers else None, reader)
    render = reader.out.scene["render"]
    render.update(spp=spp, seed=seed, sampler=sampler)
    matrix = plugin.transform("to_world")
    matrix = np.eye(4) if matrix is None else matrix
    _check_rotation(plugin, matrix)
    fov_y = _vertical_fov(plugin, width / height)
    shift = _corner_shift(matrix, fov_y, width, height)
    if shift > MAX_CORNER_SHIFT:
        reader.warn(f"{plugin.element.where()}: to_world is a rotation to {rotation_error(matrix):.2g} only: "
                    f"clrender's camera keeps its view direction and up, so rays at the image's corners "
                    f"pass {shift:.2g} pixels from Mitsuba's")
    clips = {}
    for name, default in (("near_clip", DEFAULT_NEAR_CLIP), ("far_clip", DEFAULT_FAR_CLIP)):
        clips[name] = plugin.number(name, default)
        if clips[name] != default:
            reader.warn(f"{plugin.element.where()}: {name} {clips[name]:g} ignored (clrender's camera "
                        "does not clip; differs only where geometry lies closer than near_clip or beyond far_clip)")
    lens = _read_lens(plugin, clips["far_clip"])
    for name in ("principal_point_offset_x", "principal_point_offset_y"):
        if plugin.number(name, 0.0) != 0.0:
            raise plugin.error(f"{name} is not supported (off-centre projections)")
    plugin.accept("shutter_open", "shutter_close")   # no effect on a static scene
    plugin.finish()
    position = matrix[:3, 3]
    forward = matrix[:3, :3] @ [0.0, 0.0, 1.0]
    camera = {"position": position.tolist(), "look_at": (position + forward / np.linalg.norm(forward)).tolist(),
              "up": (matrix[:3, :3] @ [0.0, 1.0, 0.0]).tolist(), "fov": fov_y,
              "resolution": [width, height], "filter": pixel_filter, **lens}
    reader.out.scene["camera"] = camera
    if media and not reader.ignore_media:
        name = read_medium(media[0], reader)
        camera["medium"] = name
        reader.out.scene["medium"] = name   # shapes without media leave the ray in it (see medium.check_media_nesting)
    else:
        camera["medium"] = None
        if media:
            reader.warn(f"{media[0].element.where()}: ignored, as Mitsuba's `{reader.integrator}` integrator ignores media")
    lens_note = (f", thin lens of aperture radius {lens['aperture_radius']:g} focused at {lens['focus_distance']:g}"
                 if lens else "")
    reader.note(plugin, "camera", f"{width} x {height}, vertical fov {fov_y:.6g} deg{lens_note}, {spp} spp, "
                                  f"seed {seed}, {_describe_filter(pixel_filter)} filter")


def _read_lens(plugin, far_clip):
    """thinlens: the camera's aperture_radius and focus_distance (Mitsuba's default: far_clip's
    value); perspective: none (the focus_distance some scenes give it has no effect)."""
    if plugin.type == "perspective":
        plugin.number("focus_distance")   # checked, of no effect
        return {}
    aperture = plugin.number("aperture_radius")
    if aperture is None:
        raise plugin.error("a thinlens sensor needs an aperture_radius")
    focus = plugin.number("focus_distance", far_clip)
    if not aperture >= 0 or not focus > 0:
        raise plugin.error(f"aperture_radius must be >= 0 and focus_distance > 0, got {aperture:g} and {focus:g}")
    return {"aperture_radius": aperture, "focus_distance": focus}


def _describe_filter(pixel_filter):
    parameter = {"gaussian": "stddev", "tent": "radius"}.get(pixel_filter["type"])
    return pixel_filter["type"] + (f" {parameter} {pixel_filter[parameter]:g}" if parameter else "")


def _check_rotation(plugin, matrix):
    """Mitsuba's camera refuses a to_world that scales or shears (beyond ROTATION_TOLERANCE); it
    renders a mirrored one mirrored, which clrender's camera cannot."""
    if np.linalg.det(matrix[:3, :3]) <= 0:
        raise plugin.error("the sensor's to_world must be a rotation and translation: it mirrors the "
                           "image, which clrender's camera cannot")
    error = rotation_error(matrix)
    if error > ROTATION_TOLERANCE:
        raise plugin.error(f"the sensor's to_world must be a rotation and translation: it scales or "
                           f"shears (|L L^T - I| = {error:.2g} for its linear part L; Mitsuba too refuses "
                           f"more than {ROTATION_TOLERANCE:g})")


def _corner_shift(matrix, fov_y, width, height):
    """How far, in pixels, Mitsuba's rays through the image's corners (the linear part L of
    to_world applied to camera directions) pass from clrender's, whose orthonormal frame keeps
    the view direction L z and the up vector L y: 0 for a rotation."""
    linear = matrix[:3, :3]
    forward = linear @ [0.0, 0.0, 1.0]
    forward /= np.linalg.norm(forward)
    left = np.cross(linear @ [0.0, 1.0, 0.0], forward)   # Mitsuba's camera x: left, up x forward
    left /= np.linalg.norm(left)
    frame = np.column_stack([left, np.cross(forward, left), forward])
    tan_y = np.tan(np.radians(fov_y) / 2)
    tan_x = tan_y * width / height
    corners = np.array([[x, y, 1.0] for x in (-tan_x, tan_x) for y in (-tan_y, tan_y)])
    theirs = corners @ linear.T @ frame   # in clrender's camera frame
    film = theirs[:, :2] / theirs[:, 2:]
    return float(np.max(np.linalg.norm((film - corners[:, :2]) / [2 * tan_x / width, 2 * tan_y / height], axis=1)))


def _vertical_fov(plugin, aspect):
    """Mitsuba's fov along fov_axis (x, y, diagonal, smaller, larger; default x), or its
    focal_length (35 mm film, diagonal; default 50mm), as the vertical fov clrender uses."""
    if plugin.has("fov") and plugin.has("focal_length"):
        raise plugin.error("give either fov or focal_length")
    if plugin.has("focal_length"):
        text = plugin.string("focal_length")
        match = re.fullmatch(r"\s*((?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)\s*(mm)?\s*", text)
        if not match or not float(match.group(1)) > 0:
            raise plugin.error(f"focal_length must be like '50mm', got {text!r}")
        tan_half = np.hypot(36.0, 24.0) / (2 * float(match.group(1)))   # along `axis`
        axis = "diagonal"
    else:
        fov = plugin.number("fov", None)
        axis = plugin.string("fov_axis", "x").lower()
        if fov is None:
            tan_half, axis = np.hypot(36.0, 24.0) / (2 * 50.0), "diagonal"
        elif not 0 < fov < 180:
            raise plugin.error(f"fov must be in (0, 180) degrees, got {fov:g}")
        else:
            tan_half = np.tan(np.radians(fov) / 2)
    if axis == "smaller":
        axis = "x" if aspect <= 1 else "y"
    elif axis == "larger":
        axis = "y" if aspect <= 1 else "x"
    if axis == "x":
        tan_y = tan_half / aspect
    elif axis == "y":
        tan_y = tan_half
    elif axis == "diagonal":
        tan_y = tan_half / np.hypot(aspect, 1.0)
    else:
        raise plugin.error(f"unknown fov_axis '{axis}' (x, y, diagonal, smaller, larger)")
    return float(np.degrees(2 * np.arctan(tan_y)))
