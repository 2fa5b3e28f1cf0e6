"""Where a scene's fields came from in a file of another format (a Mitsuba XML element), so that
errors found after loading (at upload: degenerate shapes, sizes for the device) name that place
rather than the scene field. A Scene read from such a file carries its `origins`."""
from contextlib import contextmanager
from dataclasses import dataclass

from .errors import SceneError


@dataclass
class Origins:
    places: dict   # scene field ('shapes[2]'; '': what no element accounts for) -> its place
    error: type    # the format's SceneError subclass, whose `where` is such a place


def place(places, where):
    """The place of scene field `where`: that of the field or of its nearest enclosing one
    ('shapes[2]' for 'shapes[2].transform'); None if none is known."""
    best = None
    for key in places:
        if key in ("", where) or where.startswith(key + ".") or where.startswith(key + "["):
            if best is None or len(key) > len(best):
                best = key
    return places.get(best)


def located(error, origins):
    """A SceneError naming a scene field, at the place in the file the field came from."""
    if origins is None or isinstance(error, origins.error):
        return error
    origin = place(origins.places, error.where)
    if origin is None:
        return error
    return origins.error(origin, f"{error.message} (scene field {error.where})")


@contextmanager
def errors_at_source(scene):
    """SceneErrors raised inside name the place in the scene's file (see `located`)."""
    try:
        yield
    except SceneError as e:
        raise located(e, scene.origins) from None
