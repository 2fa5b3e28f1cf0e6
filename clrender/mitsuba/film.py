"""Films: the image size and the pixel filter.

| plugin | parameter (Mitsuba's default) | clrender |
|---|---|---|
| `hdrfilm` | `width` (768), `height` (576) | `camera.resolution` |
| | nested `rfilter` (gaussian) | `camera.filter`, read by rfilter.py |
| | accepted (output encoding only) | `file_format`, `pixel_format`, `component_format`, `compensate`, `banner`, `high_quality_edges` |
| | `sample_border` (false) | true is a warning with a filter wider than the box: Mitsuba then also samples outside the image, so the filter of a pixel at the edge reaches beyond it; clrender's stops at the edge |
| | errors | crop windows (`crop_offset_*`, `crop_width`, `crop_height` other than the whole image) |
| none | | hdrfilm 768 x 576 with a gaussian filter (a warning) |
"""
from .rfilter import read_rfilter


def read_film(plugin, reader):
    """(width, height, camera.filter); plugin None: the sensor has no film."""
    if plugin is None:
        reader.warn("no <film>: Mitsuba's default hdrfilm is 768 x 576 with a gaussian filter")
        return 768, 576, read_rfilter(None, reader)
    if plugin.type != "hdrfilm":
        raise plugin.error(f"unsupported film '{plugin.type}' (supported: hdrfilm)")
    width, height = plugin.integer("width", 768), plugin.integer("height", 576)
    if width < 1 or height < 1:
        raise plugin.error(f"width and height must be >= 1, got {width} x {height}")
    crop = (plugin.integer("crop_offset_x", 0), plugin.integer("crop_offset_y", 0),
            plugin.integer("crop_width", width), plugin.integer("crop_height", height))
    if crop != (0, 0, width, height):
        raise plugin.error("crop windows are not supported")
    plugin.accept("file_format", "pixel_format", "component_format", "compensate", "banner",
                  "high_quality_edges")   # output encoding only
    sample_border = plugin.boolean("sample_border", False)
    filters = plugin.nested("rfilter")
    if len(filters) > 1:
        raise plugin.error("a film takes one rfilter")
    pixel_filter = read_rfilter(filters[0] if filters else None, reader)
    if sample_border and pixel_filter["type"] != "box":
        reader.warn(f"{plugin.element.where()}: sample_border: Mitsuba also samples outside the image, so the "
                    "filter of a pixel at its edge reaches beyond it; clrender's stops at the edge")
    plugin.finish()
    return width, height, pixel_filter
