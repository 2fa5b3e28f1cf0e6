"""Values of Mitsuba properties: numbers, triples, points and colours.

| element | value |
|---|---|
| `<float>`, `<integer>` | one number |
| `<point>`, `<vector>` | `value="x y z"` (or `x, y, z`; one number: all three) or `x= y= z=` attributes |
| `<rgb value>` | three numbers (one: grey), as given |
| `<spectrum value="v">` | uniform: v, but on an emitter the equal-energy illuminant v x cie.equal_energy_rgb() (a warning) |
| `<spectrum value="400:0.1, 500:0.5, ...">` | sampled: RGB by cie.spectrum_to_rgb, clamped to [0, 1] unless on an emitter (a warning) |
"""
import numpy as np

from .. import cie
from .xml import attribute


def parse_numbers(element, text=None):
    text = attribute(element, "value") if text is None else text
    try:
        return [float(v) for v in text.replace(",", " ").split()]
    except ValueError:
        raise element.error(f"not a list of numbers: {text!r}") from None


def parse_float(element, text=None):
    values = parse_numbers(element, text)
    if len(values) != 1:
        raise element.error(f"expected one number, got {element.attrs['value'] if text is None else text!r}")
    return values[0]


def parse_triple(element, text):
    """Three numbers from "x y z" or "x, y, z" (one number: all three)."""
    values = parse_numbers(element, text)
    if len(values) == 1:
        values = values * 3
    if len(values) != 3:
        raise element.error(f"expected 3 numbers, got {text!r}")
    return np.array(values)


def parse_xyz(element, default):
    """<point x= y= z=/>, <vector value="x y z"/> and the like."""
    if "value" in element.attrs:
        return parse_triple(element, element.attrs["value"])
    return np.array([parse_float(element, element.attrs.get(axis, str(default))) for axis in "xyz"])


def parse_color(element, warnings_, emitter):
    """Mitsuba's RGB variants: <rgb> and <float> as given; a uniform <spectrum> as given, but
    on an emitter it is an equal-energy illuminant (value x cie.equal_energy_rgb()); a sampled
    <spectrum> converted by cie.spectrum_to_rgb (clamped to [0, 1] unless on an emitter)."""
    if element.tag in ("float", "integer"):
        return np.full(3, parse_float(element))
    if element.tag == "rgb":
        values = parse_numbers(element)
        if len(values) == 1:
            values = values * 3
        if len(values) != 3:
            raise element.error(f"expected 3 numbers (or 1), got {element.attrs['value']!r}")
        return np.array(values)
    if "filename" in element.attrs or "value" not in element.attrs:
        raise element.error("only spectra given by value are supported (no .spd files)")
    text = element.attrs["value"]
    if ":" not in text:
        value = parse_float(element)
        if not emitter:
            return np.full(3, value)
        rgb = value * cie.equal_energy_rgb()
        warnings_.append(f"{element.where()}: a uniform spectrum on an emitter is an equal-energy "
                         f"illuminant in Mitsuba's RGB variants: RGB {fmt(rgb)}")
        return rgb
    pairs = [item.split(":") for item in text.replace(",", " ").split()]
    try:
        wavelengths, values = np.array([[float(w), float(v)] for w, v in pairs]).T
    except ValueError:
        raise element.error(f"not a list of wavelength:value pairs: {text!r}") from None
    if len(wavelengths) < 2 or np.any(np.diff(wavelengths) <= 0):
        raise element.error("a sampled spectrum needs at least two increasing wavelengths")
    rgb = cie.spectrum_to_rgb(wavelengths, values, illuminant=emitter)
    clamped = np.maximum(rgb, 0.0) if emitter else np.clip(rgb, 0.0, 1.0)
    warnings_.append(f"{element.where()}: spectrum converted to RGB {fmt(clamped)} (CIE 1931"
                     + (", D65" if not emitter else "") + ")"
                     + (f", clamped from {fmt(rgb)}" if np.any(clamped != rgb) else ""))
    return clamped


def fmt(values):
    """Numbers for messages: (0.5, 1, 2.25)."""
    return "(" + ", ".join(f"{v:.4g}" for v in values) + ")"
