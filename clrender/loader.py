"""Scene files: each format's reader, picked by the file's suffix.

| suffix | format | reader |
|---|---|---|
| `.xml` | Mitsuba 3 XML (docs/mitsuba-xml.md) | `clrender.mitsuba` |
| `.json`, any other | clrender's JSON scenes (docs/scene-format.md) | `clrender.scene` |

A reader is a module with `read_scene_file(path, parameters) -> LoadedScene`, imported when a
file of its format is first loaded.
"""
import importlib
import os
import warnings
from dataclasses import dataclass, field
from pathlib import Path

from .errors import ArgumentError, SceneError

READERS = {".json": "scene", ".xml": "mitsuba"}   # suffix -> clrender's module reading it
DEFAULT_READER = READERS[".json"]                  # clrender's own format, whatever the suffix


@dataclass
class LoadedScene:
    scene: object                                   # the validated Scene
    warnings: list = field(default_factory=list)   # Warning instances: approximations made
    notes: list = None   # formats translated into clrender's: 'element -> scene field: summary'


def read_scene_file(path, parameters=None):
    """The scene file `path` read by its format's reader: a LoadedScene. `parameters` (name ->
    value) override the file's defaults, for formats that have them (Mitsuba's -D)."""
    from .files import resolving_folders_once

    path = path_argument(path, "path")
    module = importlib.import_module(f".{READERS.get(path.suffix.lower(), DEFAULT_READER)}", __package__)
    with resolving_folders_once():
        return module.read_scene_file(path, parameters)


def load_scene(path, parameters=None):
    """Load and validate a scene file: JSON, or Mitsuba 3 XML (`.xml`, docs/mitsuba-xml.md;
    `parameters` override its <default> values, like Mitsuba's -D); each approximation the
    reader made is a Python warning. Relative file paths resolve against the file's folder."""
    loaded = read_scene_file(path, parameters)
    for warning in loaded.warnings:
        warnings.warn(warning, stacklevel=2)
    return loaded.scene


def path_argument(value, where):
    if not isinstance(value, (str, os.PathLike)):
        raise ArgumentError(where, f"must be a file path, got {type(value).__name__}")
    return Path(value)


def read_scene_bytes(path, error=SceneError):
    """The contents of the scene file `path`, at most limits.MAX_SCENE_FILE_BYTES (checked before
    reading); `error("", message)` naming it where it is missing, not a regular file (a folder, a
    named pipe), too large or unreadable."""
    from . import files, limits

    try:
        return files.read_bounded(path, "scene file", limits.MAX_SCENE_FILE_BYTES)
    except ValueError as e:
        raise error("", str(e)) from None
