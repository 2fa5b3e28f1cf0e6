"""Arrays computed at start-up, kept on disk for the next process beside the kernel binaries
(cache_dir(), in a folder per kind): tables the device computes with a program
(plastic.py, energy.py), keyed by that program's build key. The key covers every input, so an
entry is never stale; an entry is its SHA-256 and its bytes, and one that is damaged (truncated, of
another size, or failing the checksum) is computed again and rewritten."""
import hashlib
import os
import tempfile
from pathlib import Path

import numpy as np

_MAGIC = b"clrender array cache 1\n"
_DIGEST = 32


def key(*parts):
    """An entry's key: the hash of its inputs' reprs (strings, numbers, bytes, tuples of them)."""
    return hashlib.sha256(repr(parts).encode()).hexdigest()


def load(kind, entry_key, shape, dtype=np.float32):
    """The array of `shape` and `dtype` stored under `entry_key`, or None (absent, unreadable or
    damaged)."""
    path = _path(kind, entry_key)
    size = len(_MAGIC) + _DIGEST + int(np.prod(shape)) * np.dtype(dtype).itemsize
    entry = bytearray(size)
    try:
        with open(path, "rb") as f:
            if f.readinto(entry) != size or f.read(1):
                return None
    except OSError:
        return None
    payload = memoryview(entry)[len(_MAGIC) + _DIGEST:]
    if not entry.startswith(_MAGIC) or hashlib.sha256(payload).digest() != entry[len(_MAGIC):len(_MAGIC) + _DIGEST]:
        return None
    return np.frombuffer(payload, dtype).reshape(shape)


def store(kind, entry_key, array):
    """Write `array` under `entry_key`, atomically (a reader sees the old entry or the whole new
    one); an unwritable cache only costs the next process the computation."""
    path = _path(kind, entry_key)
    data = np.ascontiguousarray(array)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{entry_key}.")
        with os.fdopen(fd, "wb") as f:
            f.write(_MAGIC + hashlib.sha256(data).digest())
            f.write(data)
        os.replace(tmp, path)
    except OSError:
        pass


def cache_dir():
    """$CLRENDER_CACHE_DIR, default ~/.cache/clrender: kernel binaries (device.py) and these."""
    return os.environ.get("CLRENDER_CACHE_DIR") or str(Path.home() / ".cache" / "clrender")


def _path(kind, entry_key):
    return Path(cache_dir()) / kind / f"{entry_key}.bin"


def load_table(build_key, fields, shape):
    """A table of `shape` that the program of `build_key` (device.program_key) computed for
    `fields` (what else it depends on), stored by an earlier process; None if there is none or
    the program has no build key."""
    return None if build_key is None else load("tables", key(build_key, *fields), shape)


def store_table(build_key, fields, table):
    """Store the table that the program of `build_key` computed for `fields` (see load_table)."""
    if build_key is not None:
        store("tables", key(build_key, *fields), table)
