"""The errors a user can cause, one class per remedy (docs/errors.md).

Every error that bad input, a missing driver or an unwritable file can cause, from the API or the
CLI, is a `ClrenderError`; anything else escaping clrender is a bug. `where` names the place
(a JSON path such as ``materials[2].ior``, a parameter or flag such as ``spp`` or ``--spp``).
The CLI exits with the class's `exit_code`; an interrupted render exits with 128 + the signal.
"""


class ClrenderError(Exception):
    """Base of clrender's errors; `str(error)` is the message meant for the user."""
    exit_code = 1

    def __init__(self, message, where=""):
        self.where = where
        self.message = message
        super().__init__(f"{where}: {message}" if where else message)

    def with_message(self, message):
        """The same error (class and place) with another message, e.g. one saying more."""
        return _rebuild(type(self), message, self.where)

    def __reduce__(self):   # pickled between processes (Dask workers): same class, message, place
        return _rebuild, (type(self), self.message, self.where)


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


class FileError(ClrenderError, OSError):
    """An image file cannot be written or read (a folder in the way, no permission, disk full)."""
    exit_code = 5


class Interrupted(KeyboardInterrupt):
    """SIGTERM or SIGHUP, raised where Ctrl-C raises KeyboardInterrupt (`signal` holds which)."""

    def __init__(self, signal):
        super().__init__(f"signal {signal}")
        self.signal = signal
