"""Input files as a reader meets them: what a path is when it is not a regular file (a folder, a
named pipe that would block a read forever, a device), and reads bounded by a size checked before
the first byte is read (limits.MAX_*_FILE_BYTES); and which paths are one file (an output must
not be an input). Each reader turns the ValueError raised here
into its own error class, naming the file and, where it has one, the place that named it."""
import contextlib
import contextvars
import os
import stat
from pathlib import Path

_KINDS = ((stat.S_ISDIR, "a directory"), (stat.S_ISFIFO, "a named pipe (FIFO)"), (stat.S_ISSOCK, "a socket"),
          (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"))


_inputs = contextvars.ContextVar("inputs", default=None)   # the set recording_inputs() fills


@contextlib.contextmanager
def recording_inputs():
    """`with recording_inputs() as inputs:` the file_identity of every regular file a reader
    checks in the block (each reader checks its files through not_a_file) lands in `inputs`."""
    inputs = set()
    token = _inputs.set(inputs)
    try:
        yield inputs
    finally:
        _inputs.reset(token)


_folders = contextvars.ContextVar("resolved folders", default=None)   # resolving_folders_once()'s


@contextlib.contextmanager
def resolving_folders_once():
    """`with resolving_folders_once():` resolved() resolves each folder once in the block (one
    scene's load, during which its folders do not change)."""
    token = _folders.set({})
    try:
        yield
    finally:
        _folders.reset(token)


def resolved(path):
    """Path(path).resolve(): absolute, links followed. Inside resolving_folders_once() each folder
    is resolved once: a scene names hundreds of files in a few folders, and resolving a path
    costs a system call per component (the staircase's 774 meshes: 9,500 of them)."""
    folders = _folders.get()
    # Split as text: a Path per call was most of this function's time over hundreds of files.
    parent, name = os.path.split(os.fspath(path))
    if folders is None or name in ("", ".", ".."):
        return Path(path).resolve()
    return Path(_resolved_in(parent or ".", name, folders))


# Links followed in a row before resolved() leaves the rest to os.path.realpath (Linux's limit).
_MAX_LINKS = 40


def _resolved_in(parent, name, folders, links=0):
    """os.path.realpath(parent/name), folders from `folders` (resolved once each): a link in the
    last component is followed from its folder the same way (a mirrored scene, as
    tools/real_scenes.py makes one, links each of its files)."""
    if parent not in folders:
        folders[parent] = os.path.realpath(parent)
    candidate = os.path.join(folders[parent], name)
    if not os.path.islink(candidate):
        return candidate
    try:
        head, tail = os.path.split(os.path.join(folders[parent], os.readlink(candidate)))
    except OSError:   # gone since islink: as realpath sees it now
        return os.path.realpath(candidate)
    if links >= _MAX_LINKS or tail in ("", ".", ".."):
        return os.path.realpath(candidate)
    return _resolved_in(head, tail, folders, links + 1)


def not_a_file(path):
    """None when `path` is a regular file (or a link to one); else what it is, for a message:
    'not found', 'a directory', 'a named pipe (FIFO)', ..."""
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        return "not found"
    except OSError as e:   # a loop of links, a name too long, no permission to look
        return f"not readable ({e.strerror or e})"
    if stat.S_ISREG(mode):
        if _inputs.get() is not None:
            _inputs.get().add(file_identity(path))
        return None
    return next((kind for is_kind, kind in _KINDS if is_kind(mode)), "not a regular file")


def check_regular_file(path, what, limit):
    """The size of `path`; ValueError('WHAT PATH is ...') unless it is a regular file of at most
    `limit` bytes."""
    if not_a_file(path) is not None:
        raise ValueError(describe(path, what))
    size = os.stat(path).st_size
    if size > limit:
        raise ValueError(f"{what} {path} is {size} bytes, more than the {limit} clrender reads "
                         f"from a {what}")
    return size


def read_bounded(path, what, limit):
    """The bytes of `path`, checked by check_regular_file first; a file that grew past `limit`
    while being read is refused too (nothing reads more than `limit` + 1 bytes)."""
    check_regular_file(path, what, limit)
    try:
        with open(path, "rb") as f:
            data = f.read(limit + 1)
    except OSError as e:
        raise ValueError(f"cannot read {what} {path}: {e.strerror or e}") from None
    if len(data) > limit:
        raise ValueError(f"{what} {path} is more than the {limit} bytes clrender reads from a {what}")
    return data


def file_identity(path):
    """What makes two paths the same file: device and inode for an existing file (hard and
    symbolic links too), else the path with links resolved."""
    try:
        info = os.stat(path)
        return info.st_dev, info.st_ino
    except OSError:
        return os.path.realpath(path)


def describe(path, what="file"):
    """A message for a path that is not a regular file: 'WHAT not found: P', 'P is a directory,
    not a WHAT', 'P is a named pipe (FIFO), not a WHAT'."""
    problem = not_a_file(Path(path))
    return f"{what} not found: {path}" if problem == "not found" else f"{path} is {problem}, not a {what}"
