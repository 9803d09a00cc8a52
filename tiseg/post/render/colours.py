"""Colour constants and tables shared by every picture tiseg makes.

The concentration picture mimics the experiments of section 2 and the simulations of figure 12:

* ``FINES_RGB``  (phi = 1): white spherical ballotini, 75-150 um. A slightly warm white, because
  pure white next to the brown looks bluish on screen and the ballotini photograph off-white.
* ``COARSE_RGB`` (phi = 0): brown angular carborundum, 305-355 um. A mid sienna brown, dark enough
  that the coarse-rich front and the levees stand out against the fines, light enough that
  hill-shading (which darkens) still reads on it.
* ``CHUTE_RGB``  (h < h_min): the turquoise ballotini glued to the chute, seen where the chute
  is empty. A muted turquoise, as in the photographs of figure 2 rather than the saturated CSS one.

Between phi = 0 and phi = 1 the colour blends linearly, ``(1 - phi) COARSE + phi FINES``; this is
what a mixture of the two looks like from above if the grains are much smaller than a pixel.

The other fields (h, |u|, u, v) use matplotlib's perceptually uniform "viridis" map, sampled once
into ``VIRIDIS`` (256 x 3); the Taichi frame kernel and the colour bars / matplotlib panels use the
same table, so a colour means the same value everywhere. Viridis contains teal shades, so in those
maps the empty chute is drawn in a neutral grey (``EMPTY_MAP_RGB``) instead of turquoise.

All colours are linear floats in [0, 1] (they are written straight to 8-bit images; no gamma
correction is applied anywhere, so a GGUI window shows the same 8-bit values as a PNG).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from ...output.fields import OUTPUT_FIELDS

FINES_RGB = (245 / 255, 242 / 255, 233 / 255)  # white ballotini (phi = 1)
COARSE_RGB = (140 / 255, 84 / 255, 44 / 255)  # brown carborundum (phi = 0)
CHUTE_RGB = (58 / 255, 178 / 255, 178 / 255)  # turquoise chute, h < h_min
EMPTY_MAP_RGB = (212 / 255, 212 / 255, 212 / 255)  # empty chute in the viridis maps
BACKGROUND_RGB = (30 / 255, 30 / 255, 34 / 255)  # margins, caption strip, viewer panel
TEXT_RGB = (235 / 255, 235 / 255, 235 / 255)

# Field codes of the frame kernel (a run-time integer: switching field recompiles nothing).
FIELD_CODES = {"phi": 0, "h": 1, "speed": 2, "u": 3, "v": 4}
FIELD_ALIASES = {"|u|": "speed", "umag": "speed", "concentration": "phi", "thickness": "h"}
FIELD_NAMES = tuple(FIELD_CODES)

# Axis labels and the unit each field is shown in (value * factor, unit), and plain-ASCII short
# labels for burned-in captions (the small bitmap text has no Greek glyph guarantee across
# fonts): from each field's spec (`tiseg.output.fields`), which the writer reads as well.
FIELD_LABELS = {
    n: (OUTPUT_FIELDS[n].label, OUTPUT_FIELDS[n].factor, OUTPUT_FIELDS[n].unit) for n in FIELD_CODES
}
FIELD_SHORT = {n: OUTPUT_FIELDS[n].short for n in FIELD_CODES}


def canonical_field(name: str) -> str:
    """'phi', 'h', 'speed', 'u' or 'v' for a field name or alias ('|u|' -> 'speed')."""
    key = FIELD_ALIASES.get(name, name)
    if key not in FIELD_CODES:
        choices = ", ".join(FIELD_NAMES + ("|u|",))
        raise ValueError(f"field={name!r}: choose one of {choices}")
    return key


@lru_cache(maxsize=None)
def _viridis(n: int) -> np.ndarray:
    from matplotlib import colormaps

    table = colormaps["viridis"].resampled(n)(np.linspace(0.0, 1.0, n))[:, :3]
    table = np.ascontiguousarray(table, dtype=np.float32)
    table.setflags(write=False)
    return table


def viridis_table(n: int = 256) -> np.ndarray:
    """The viridis colour map sampled at n points, (n, 3) float32 in [0, 1] (read-only)."""
    return _viridis(int(n))


# The table the frame kernel uploads; fixed size so its Taichi field has a fixed shape.
LUT_SIZE = 256


def map_values(t) -> np.ndarray:
    """Colours of normalised values t in [0, 1] through the viridis table, (..., 3) float32.

    The same linear interpolation between table entries as the frame kernel, for colour bars and
    for tests; values outside [0, 1] are clamped."""
    lut = viridis_table(LUT_SIZE)
    x = np.clip(np.asarray(t, dtype=np.float64), 0.0, 1.0) * (LUT_SIZE - 1)
    i0 = np.minimum(np.floor(x).astype(np.int64), LUT_SIZE - 2)
    w = (x - i0)[..., None]
    return ((1.0 - w) * lut[i0] + w * lut[i0 + 1]).astype(np.float32)


def phi_colours(phi) -> np.ndarray:
    """Colours of concentrations phi (clamped to [0, 1]): the linear coarse-to-fines blend."""
    p = np.clip(np.asarray(phi, dtype=np.float64), 0.0, 1.0)[..., None]
    return ((1.0 - p) * np.asarray(COARSE_RGB) + p * np.asarray(FINES_RGB)).astype(np.float32)


def colours_for(field: str, t) -> np.ndarray:
    """Colour bar colours of a field at normalised positions t in [0, 1]."""
    return (
        phi_colours(t) if OUTPUT_FIELDS[canonical_field(field)].colours == "phi" else map_values(t)
    )


def to_uint8(rgb) -> np.ndarray:
    """Float colours in [0, 1] to 8-bit (round to nearest)."""
    return (np.clip(np.asarray(rgb, dtype=np.float32), 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8)


def matplotlib_cmap(field: str):
    """A matplotlib colour map with the same colours as the frame kernel for ``field``."""
    from matplotlib.colors import LinearSegmentedColormap, ListedColormap

    if OUTPUT_FIELDS[canonical_field(field)].colours == "phi":
        return LinearSegmentedColormap.from_list("tiseg_phi", [COARSE_RGB, FINES_RGB], N=256)
    return ListedColormap(viridis_table(LUT_SIZE), name="tiseg_viridis")


def default_range(field: str, scene=None, data=None, h_min: float = 0.0):
    """A sensible (vmin, vmax) for a colour-mapped field.

    With ``data`` (a dict of (ny, nx) arrays) the range covers the flowing cells (h >= h_min):
    h and |u| from 0 to their maximum, u from min(0, min) to its maximum, v symmetric about 0.
    Without data, a range from the scene's reference flow (h0, u0) when it has one, else None.
    phi always gives (0, 1).
    """
    field = canonical_field(field)
    if field == "phi":
        return (0.0, 1.0)
    if data is not None:
        h = np.nan_to_num(np.asarray(data["h"], dtype=np.float64))
        wet = h >= h_min
        if field == "h":
            vals = h
        elif field == "speed":
            vals = np.hypot(data["u"], data["v"]) if "v" in data else np.abs(data["u"])
        else:
            vals = np.asarray(data[field]) if field in data else np.zeros_like(h)
        vals = np.nan_to_num(np.asarray(vals, dtype=np.float64))[wet]
        if vals.size == 0:
            lo, hi = 0.0, 0.0
        elif field == "v":
            m = float(np.max(np.abs(vals)))
            lo, hi = -m, m
        elif field == "u":
            lo, hi = min(0.0, float(vals.min())), float(vals.max())
        else:
            lo, hi = 0.0, float(vals.max())
        return _nondegenerate(lo, hi, field)
    if scene is not None:
        h0 = getattr(scene.flow, "h0", None)
        u0 = getattr(scene.flow, "u0", None)
        if field == "h" and h0:
            return (0.0, 2.5 * h0)  # fronts and levees reach ~2 h0 in figure 14
        if field in ("speed", "u") and u0:
            return (0.0, 1.5 * u0)
        if field == "v" and u0:
            return (-0.25 * u0, 0.25 * u0)
    return None


def _nondegenerate(lo: float, hi: float, field: str):
    """Widen an empty range so the normalisation never divides by zero."""
    if hi > lo:
        return (lo, hi)
    pad = 1e-3 if field == "h" else 1e-2
    return (lo - pad, hi + pad) if field == "v" else (lo, lo + pad)
