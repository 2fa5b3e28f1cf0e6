"""The errors a user can cause, one class per remedy (docs/errors.md).

Every error that bad input, a missing driver or an unwritable file can cause, from the API or the
CLI, is a `ClrenderError`; anything else escaping clrender is a bug. `where` names the place
(a JSON path such as ``materials[2].ior``, a parameter or flag such as ``spp`` or ``--spp``).
The CLI exits with the class's `exit_code`; an interrupted render exits with 128 + the signal.
Messages and places are made printable (`printable`): they echo what the user gave, and a newline
in an XML id must not forge a second error line, nor a 16 MB attribute fill the terminal.
"""
import re

MAX_MESSAGE = 2000   # characters of an error message; the rest is cut
MAX_WORD = 400       # characters of one word (no space) in a message: a long value echoed (paths fit)
_CONTROL = re.compile(r"[\x00-\x1f\x7f-\x9f\u2028\u2029]")
_LONG_WORD = re.compile(r"\S{%d,}" % (MAX_WORD + 1))


class ClrenderError(Exception):
    """Base of clrender's errors; `str(error)` is the message meant for the user."""
    exit_code = 1
    multiline = False   # the message may hold lines of its own (a compiler's build log)

    def __init__(self, message, where=""):
        self.where = printable(where)
        self.message = message if self.multiline else printable(message)
        super().__init__(f"{self.where}: {self.message}" if self.where else self.message)

    def with_message(self, message):
        """The same error (class and place) with another message, e.g. one saying more."""
        return _rebuild(type(self), message, self.where)

    def __reduce__(self):   # pickled between processes (Dask workers): same class, message, place
        return _rebuild, (type(self), self.message, self.where)


def printable(text):
    """`text` on one line, control characters escaped (a newline as \\n), each over-long word and
    the whole cut to a readable length, saying how much was left out."""
    text = _CONTROL.sub(lambda m: repr(m.group())[1:-1], str(text))
    text = _LONG_WORD.sub(lambda m: f"{m.group()[:MAX_WORD // 2]}...({len(m.group())} characters)", text)
    if len(text) > MAX_MESSAGE:
        text = f"{text[:MAX_MESSAGE]}...({len(text) - MAX_MESSAGE} more characters)"
    return text


def _rebuild(cls, message, where):
    error = cls.__new__(cls)
    ClrenderError.__init__(error, message, where)
    return error


class ArgumentError(ClrenderError, ValueError):
    """An API argument or a command-line flag is invalid: fix the call or the command line."""
    exit_code = 2

    def __init__(self, where, message):
        super().__init__(message, where)


class MissingDependency(ArgumentError):
    """An option needs an optional extra that is not installed: install it, or drop the option."""


class DenoiserUnavailable(MissingDependency):
    """Denoising was asked for, and pyoidn (Intel Open Image Denoise) is not installed."""


class SceneError(ClrenderError, ValueError):
    """A scene file or dict is invalid; `where` names the place, e.g. ``materials[2].ior``."""
    exit_code = 3

    def __init__(self, where, message):
        super().__init__(message, where)


class DeviceError(ClrenderError, RuntimeError):
    """The OpenCL driver or device cannot do the work: none installed, out of memory, failed."""
    exit_code = 4


class KernelBuildError(DeviceError):
    """The OpenCL compiler rejected the kernel; the message carries the build log."""
    multiline = True


class FileError(ClrenderError, OSError):
    """An image file cannot be written or read (a folder in the way, no permission, disk full)."""
    exit_code = 5


class Interrupted(KeyboardInterrupt):
    """SIGTERM or SIGHUP, raised where Ctrl-C raises KeyboardInterrupt (`signal` holds which)."""

    def __init__(self, signal):
        super().__init__(f"signal {signal}")
        self.signal = signal
