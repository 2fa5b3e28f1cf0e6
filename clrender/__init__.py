"""clrender: a physically based path tracer with OpenCL C kernels and a Python host.

    import clrender
    scene = clrender.load_scene("scenes/cornell_box.json")   # or a Mitsuba 3 .xml scene
    image = clrender.render(scene, spp=64)
    clrender.save_image(image, "cornell.png")
    clrender.view(scene)                                    # watch it converge in the browser

Names are imported on first use (PEP 562), so `import clrender` is quick and the command line
can handle a Ctrl-C during its start-up itself.
"""
import importlib
import importlib.util
import sys
import types

# name -> the submodule defining it (None: the name is a submodule itself).
_EXPORTS = {
    "AOV_NAMES": "aovs",
    "denoise": "denoise",
    "choose_device": "device", "list_devices": "device",
    "distributed": None,
    "ArgumentError": "errors", "ClrenderError": "errors", "DenoiserUnavailable": "errors",
    "DeviceError": "errors", "FileError": "errors", "KernelBuildError": "errors",
    "MissingDependency": "errors", "SceneError": "errors",
    "load_exr_layers": "image", "load_image": "image", "save_image": "image",
    "efficiency": "metrics", "mse": "metrics", "relative_mse": "metrics", "rmse": "metrics",
    "MitsubaXmlError": "mitsuba", "MitsubaXmlWarning": "mitsuba",
    "Accumulation": "render", "Renderer": "render", "RenderInterrupted": "render", "RenderResult": "render",
    "render": "render",
    "load_scene": "loader", "load_scene_dict": "scene",
    "view": "view",
}
__all__ = sorted(_EXPORTS)


def __getattr__(name):
    if name in _EXPORTS:
        module = importlib.import_module(f".{_EXPORTS[name] or name}", __name__)
        value = module if _EXPORTS[name] is None else getattr(module, name)
    elif name.isidentifier() and importlib.util.find_spec(f".{name}", __name__):   # any submodule: clrender.limits
        value = importlib.import_module(f".{name}", __name__)
    else:
        raise AttributeError(f"module 'clrender' has no attribute {name!r}")
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(__all__))


def _function_over_submodule(name):
    """A package property: the function `name` of the submodule of the same name."""
    def get(self):
        return getattr(importlib.import_module(f".{name}", __name__), name)

    return property(get, lambda self, value: None)


class _Package(types.ModuleType):
    """`clrender.render`, `clrender.denoise` and `clrender.view` are the functions even after the
    submodules of the same names are imported (the import system would otherwise set the package
    attributes to the modules)."""
    render = _function_over_submodule("render")
    denoise = _function_over_submodule("denoise")
    view = _function_over_submodule("view")

    def __reduce__(self):   # pickled by name, as modules are (cloudpickle: functions sent to Dask)
        return importlib.import_module, (self.__name__,)


sys.modules[__name__].__class__ = _Package
