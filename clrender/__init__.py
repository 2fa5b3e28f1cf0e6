"""clrender: a physically based path tracer with OpenCL C kernels and a Python host.

    import clrender
    scene = clrender.load_scene("scenes/cornell_box.json")
    image = clrender.render(scene, spp=64)
    clrender.save_image(image, "cornell.png")

Names are imported on first use (PEP 562), so `import clrender` is quick and the command line
can handle a Ctrl-C during its start-up itself.
"""
import importlib
import sys
import types

_EXPORTS = {
    "choose_device": "device", "list_devices": "device",
    "ArgumentError": "errors", "ClrenderError": "errors", "DeviceError": "errors", "FileError": "errors",
    "KernelBuildError": "errors", "SceneError": "errors",
    "load_image": "image", "save_image": "image",
    "efficiency": "metrics", "mse": "metrics", "relative_mse": "metrics", "rmse": "metrics",
    "Renderer": "render", "RenderInterrupted": "render", "RenderResult": "render", "render": "render",
    "load_scene": "scene", "load_scene_dict": "scene",
}
__all__ = sorted(_EXPORTS)


def __getattr__(name):
    if name not in _EXPORTS:
        raise AttributeError(f"module 'clrender' has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{_EXPORTS[name]}", __name__), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(__all__))


class _Package(types.ModuleType):
    """`clrender.render` is the function even after the submodule clrender.render is imported
    (the import system would otherwise set the package attribute to the module)."""

    @property
    def render(self):
        return importlib.import_module(".render", __name__).render

    @render.setter
    def render(self, value):
        pass


sys.modules[__name__].__class__ = _Package
