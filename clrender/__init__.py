"""clrender: a physically based path tracer with OpenCL C kernels and a Python host.

    import clrender
    scene = clrender.load_scene("scenes/cornell_box.json")   # or a Mitsuba 3 .xml scene
    image = clrender.render(scene, spp=64)
    clrender.save_image(image, "cornell.png")
"""
from . import distributed
from .aovs import AOV_NAMES
from .denoise import DenoiserUnavailable, denoise
from .device import choose_device, list_devices
from .errors import KernelBuildError, SceneError
from .image import load_exr_layers, load_image, save_image
from .metrics import efficiency, mse, relative_mse, rmse
from .mitsuba_xml import MitsubaXmlError, MitsubaXmlWarning
from .render import Accumulation, Renderer, RenderInterrupted, RenderResult, render
from .scene import load_scene, load_scene_dict

__all__ = [
    "AOV_NAMES", "Accumulation", "DenoiserUnavailable", "KernelBuildError", "MitsubaXmlError",
    "MitsubaXmlWarning", "RenderInterrupted", "RenderResult", "Renderer", "SceneError", "choose_device",
    "denoise", "distributed", "efficiency", "list_devices", "load_exr_layers", "load_image", "load_scene",
    "load_scene_dict", "mse", "relative_mse", "render", "rmse", "save_image",
]
