"""Exceptions that carry where in the input something went wrong."""


class SceneError(ValueError):
    """A scene file or dict is invalid; `where` names the place, e.g. ``materials[2].ior``."""

    def __init__(self, where, message):
        self.where = where
        self.message = message
        super().__init__(f"{where}: {message}" if where else message)


class KernelBuildError(RuntimeError):
    """The OpenCL compiler rejected the kernel; the message carries the build log."""
