"""What a device needs to run the megakernel: figures per feature combination.

A GPU driver keeps a work-item's private memory in registers, spilling the rest to slow memory,
and may kill a launch that runs longer than its watchdog (a few seconds on a display GPU). The
renderer cannot launch less than one sample for every pixel, so that launch, the first of a
render (it also writes the auxiliary buffers), bounds the longest one. docs/portability.md
records the figures for PoCL, Intel's CPU runtime and Oclgrind (`clrender info --kernel`).
"""
import statistics
from dataclasses import dataclass

import pyopencl as cl

from .aovs import SAMPLE_AOVS
from .device import build_program
from .feature_scenes import feature_scene
from .render import Renderer


@dataclass
class KernelFigures:
    private_bytes: int         # CL_KERNEL_PRIVATE_MEM_SIZE of render_pass, per work-item
    preferred_multiple: int    # CL_KERNEL_PREFERRED_WORK_GROUP_SIZE_MULTIPLE
    max_work_group: int        # CL_KERNEL_WORK_GROUP_SIZE
    launch_seconds: float = None   # one sample for every pixel (median of a few), or None


def kernel_figures(context, features):
    """The render kernel's resource figures for `features` on the context's device."""
    kernel = cl.Kernel(build_program(context, features), "render_pass")
    device = context.devices[0]
    query = lambda name: int(kernel.get_work_group_info(getattr(cl.kernel_work_group_info, name), device))
    return KernelFigures(query("PRIVATE_MEM_SIZE"), query("PREFERRED_WORK_GROUP_SIZE_MULTIPLE"),
                         query("WORK_GROUP_SIZE"))


def one_sample_launch_seconds(renderer, repeats=3, aovs=()):
    """Median seconds of the renderer's shortest possible launch: sample 0 of every pixel (with
    the auxiliary buffers and the AOVs named), after one warm-up launch."""
    renderer.render(spp=1, samples_per_pass=1, aovs=aovs)
    return statistics.median(renderer.render(spp=1, samples_per_pass=1, aovs=aovs).seconds
                             for _ in range(repeats))


def scene_figures(renderer, launch=True):
    """KernelFigures of a Renderer's scene, the launch at the scene's resolution and depth."""
    figures = kernel_figures(renderer.context, renderer.features)
    if launch:
        figures.launch_seconds = one_sample_launch_seconds(renderer)
    return figures


def combination_launch_seconds(device, features, resolution=(256, 256)):
    """one_sample_launch_seconds of a feature combination's scene (clrender/feature_scenes.py)
    at `resolution`, max depth 8."""
    scene, method = feature_scene(features, resolution, subdivisions=3)
    scene.render.max_depth = 8
    aovs = SAMPLE_AOVS if features["AOVS"] else ()
    renderer = Renderer(scene, device, volume_method=method, packets=features["LANES"] > 1)
    return one_sample_launch_seconds(renderer, aovs=aovs)
