"""Arrays computed at start-up, kept on disk for the next process beside the kernel binaries
(cache_dir(), in a folder per kind): tables the device computes with a program
(plastic.py, energy.py), keyed by that program's build key; the meshes of OBJ files
(obj_reader.py), wide BVHs (arrays.wide_bvh_of) and bitmap means (textures.py), keyed by their
inputs' hashes and the source of the code that computes them (code_digest). The key covers every
input, so an entry is never stale; an entry is its SHA-256 and its bytes, and one that is damaged
(truncated, of another size, or failing the checksum) is computed again and rewritten."""
import contextlib
import functools
import hashlib
import json
import math
import os
import tempfile
from pathlib import Path

import numpy as np

_MAGIC = b"clrender array cache 1\n"
_DIGEST = 32


def key(*parts):
    """An entry's key: the hash of its inputs' reprs (strings, numbers, bytes, tuples of them)."""
    return hashlib.sha256(repr(parts).encode()).hexdigest()


@functools.cache
def code_digest(*modules):
    """The hash of these modules' source files and numpy's version: in the key of an entry that
    code computed, so that a changed computation never reads an old entry."""
    digest = hashlib.sha256(np.__version__.encode())
    for module in modules:
        digest.update(Path(module.__file__).read_bytes())
    return digest.hexdigest()


def array_digest(*arrays):
    """The hash of arrays' contents, types and shapes (an entry's inputs)."""
    digest = hashlib.sha256()
    for a in arrays:
        a = np.ascontiguousarray(a)
        digest.update(repr((a.dtype.str, a.shape)).encode())
        digest.update(a)
    return digest.hexdigest()


def load(kind, entry_key, shape, dtype=np.float32):
    """The array of `shape` and `dtype` stored under `entry_key`, or None (absent, unreadable,
    damaged or of another size)."""
    payload = _payload(kind, entry_key)
    if payload is None or len(payload) != math.prod(shape) * np.dtype(dtype).itemsize:
        return None
    return np.frombuffer(payload, dtype).reshape(shape)


def store(kind, entry_key, array):
    """Write `array` under `entry_key`, atomically (a reader sees the old entry or the whole new
    one); an unwritable cache only costs the next process the computation."""
    data = np.ascontiguousarray(array)
    _write(_path(kind, entry_key), [data], hashlib.sha256(data).digest())


def load_arrays(kind, entry_key):
    """The named arrays (a dict; None values kept) stored under `entry_key` by store_arrays, or
    None (absent, unreadable or damaged)."""
    payload = _payload(kind, entry_key)
    if payload is None:
        return None
    try:   # an entry whose checksum holds but whose header does not (written by other code)
        header_size = int.from_bytes(payload[:8], "little")
        arrays, offset = {}, 8 + header_size
        for name, dtype, shape in json.loads(bytes(payload[8:offset])):
            if dtype is None:
                arrays[name] = None
                continue
            size = math.prod(shape) * np.dtype(dtype).itemsize   # (np.prod: 9 ms over 774 meshes)
            arrays[name] = np.frombuffer(payload[offset:offset + size], dtype).reshape(shape)
            offset += size
    except (ValueError, TypeError):
        return None
    return arrays if offset == len(payload) else None


def store_arrays(kind, entry_key, arrays):
    """Write the named arrays (a dict; values may be None) under `entry_key`, as store does.
    Plain dtypes and at least one dimension: a structured array comes back as bytes (void) for
    its reader to view, a 0-d array as a 1-d one."""
    data = {name: None if a is None else np.ascontiguousarray(a) for name, a in arrays.items()}
    header = json.dumps([(name, None if a is None else a.dtype.str, None if a is None else a.shape)
                         for name, a in data.items()]).encode()
    parts = [len(header).to_bytes(8, "little"), header] + [a for a in data.values() if a is not None]
    digest = hashlib.sha256()
    for part in parts:
        digest.update(part)
    _write(_path(kind, entry_key), parts, digest.digest())


def _payload(kind, entry_key):
    """The bytes stored under `entry_key` after the magic and the checksum, or None where the
    entry is absent, unreadable or fails either."""
    try:
        with open(_path(kind, entry_key), "rb") as f:
            entry = f.read()
    except OSError:
        return None
    payload = memoryview(entry)[len(_MAGIC) + _DIGEST:]
    if not entry.startswith(_MAGIC) or hashlib.sha256(payload).digest() != entry[len(_MAGIC):len(_MAGIC) + _DIGEST]:
        return None
    return payload


def _write(path, parts, digest):
    tmp = None
    try:
        folder = os.path.dirname(path)
        os.makedirs(folder, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=folder, prefix=f".{os.path.basename(path)}.")
        with os.fdopen(fd, "wb") as f:
            f.write(_MAGIC + digest)
            for part in parts:
                f.write(part)
        os.replace(tmp, path)
    except OSError:   # a full disk leaves no partial file behind
        if tmp is not None:
            with contextlib.suppress(OSError):
                os.unlink(tmp)


def cache_dir():
    """$CLRENDER_CACHE_DIR, default ~/.cache/clrender: kernel binaries (device.py) and these."""
    return os.environ.get("CLRENDER_CACHE_DIR") or os.path.join(os.path.expanduser("~"), ".cache", "clrender")


def _path(kind, entry_key):
    # Strings, not pathlib: a scene of hundreds of meshes asks for hundreds of entries.
    return os.path.join(cache_dir(), kind, f"{entry_key}.bin")


def load_table(build_key, fields, shape):
    """A table of `shape` that the program of `build_key` (device.program_key) computed for
    `fields` (what else it depends on), stored by an earlier process; None if there is none."""
    return load("tables", key(build_key, *fields), shape)


def store_table(build_key, fields, table):
    """Store the table that the program of `build_key` computed for `fields` (see load_table)."""
    store("tables", key(build_key, *fields), table)
