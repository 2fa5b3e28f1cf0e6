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


def at_source(origins, where, message):
    """(place, message) for a message about scene field `where`: at the place in the file the
    field came from, the message naming the field, where that is known; else (where, message)."""
    origin = None if origins is None else place(origins.places, where)
    return (where, message) if origin is None else (origin, f"{message} (scene field {where})")


def located(error, origins):
    """A SceneError naming a scene field, at the place in the file the field came from."""
    if origins is None or isinstance(error, origins.error):
        return error
    where, message = at_source(origins, error.where, error.message)
    return error if where == error.where else origins.error(where, message)


@contextmanager
def errors_at_source(scene):
    """SceneErrors raised inside name the place in the scene's file (see `located`)."""
    try:
        yield
    except SceneError as e:
        raise located(e, scene.origins) from None
