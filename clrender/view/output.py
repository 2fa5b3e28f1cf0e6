"""The viewer's save action: an EXR with layers and a PNG of what the page shows, at paths fixed
when the viewer starts (the page chooses none: it can write nothing else)."""
from pathlib import Path

from ..aovs import AOV_NAMES
from ..errors import ArgumentError
from ..files import file_identity
from ..image import check_output_path, save_display_image, save_image
from .tonemap import tone_map

SUFFIXES = (".exr", ".png")


def output_paths(output, scene, where="output"):
    """(EXR path, PNG path) of the save action, both checked writable now: `output` with either
    suffix (or none) names both, else they go next to the scene file as STEM.exr and STEM.png
    (a scene given as a dict: view.exr and view.png in the current folder)."""
    if output is None:
        base = scene.path.with_suffix("") if scene.path is not None else Path("view")
    else:
        base = Path(output)
        if base.suffix.lower() in SUFFIXES:
            base = base.with_suffix("")
        elif base.suffix:
            raise ArgumentError(where, f"the viewer saves {' and '.join(SUFFIXES)}; got {output} (name one or neither)")
    paths = tuple(base.with_name(base.name + suffix) for suffix in SUFFIXES)
    for path in paths:
        if scene.path is not None and file_identity(path) == file_identity(scene.path):
            raise ArgumentError(where, f"saving to {path} would replace the scene file")
        check_output_path(path, where)
    return paths


def save_view(views, paths, layer, exposure, curve, denoiser):
    """Write the Views of a snapshot: the EXR holds the image (linear, as rendered) with every
    AOV as a layer and, with `denoiser`, the layer "denoised"; the PNG is `layer` as the page
    shows it (radiance layers through tone_map with the page's `exposure` and `curve`).
    Returns the paths written."""
    exr, png = paths
    result = views.result()
    layers = {name: result.aovs[name] for name in AOV_NAMES}
    if denoiser:
        layers["denoised"] = views.denoised()
    kind, pixels = views.layer(layer)
    display = tone_map(pixels, exposure, curve) if kind == "radiance" else pixels
    save_image(result.image, exr, layers=layers)
    save_display_image(display, png)
    return [str(exr), str(png)]
