"""The frame kernel's picture computed with NumPy, and the picture sizes and shading settings
both share.

`render_fields_numpy` paints a snapshot exactly as `tiseg.post.render.render_fields` does
(the colouring and relief shading of `tiseg.post.render.frame`, the same nearest-cell pixel
mapping and colour table), but without Taichi: the matplotlib panels (``tiseg render --panels``)
then need no Taichi runtime (no start-up, no kernel compilation, no cache folder). The tests hold
the two to within one 8-bit level (the f32 tanh of two maths libraries may differ by an ulp).
"""

from __future__ import annotations

import math

import numpy as np

from ...errors import InputError
from . import colours as C
from .relief import bed_of, slope, with_relief

DEFAULT_SHADE = 0.35  # S: at most +-35 % brightness from relief
DEFAULT_RELIEF = 10.0  # R: vertical exaggeration of the slopes of h
MIN_1D_HEIGHT = 40  # a 1D run (one row of cells) is drawn as a band this tall
MAX_SIDE = 16384  # pixels: the largest picture side (video encoders stop at 8192)


def image_size(nx: int, ny: int, scale: float = 1.0, aspect: float = 1.0) -> tuple[int, int]:
    """(width, height) in pixels of a map of nx x ny cells: ``scale`` pixels per cell along x,
    ``aspect = dy / dx`` keeps cells of other shapes true to size. A 1D run (ny = 1) becomes a
    band at least MIN_1D_HEIGHT pixels tall, so that it can be seen."""
    if not (scale > 0 and math.isfinite(scale)):
        raise ValueError(f"scale={scale!r} must be a positive number")
    w, h = nx * scale, ny * scale * aspect
    if not (w <= MAX_SIDE and h <= MAX_SIDE):
        raise InputError(
            f"scale={scale:g} pixels per cell makes a {w:.3g} x {h:.3g} pixel "
            f"picture of {nx} x {ny} cells; at most {MAX_SIDE} pixels a side: "
            f"use a scale of at most {MAX_SIDE / max(nx, ny * aspect):.3g}"
        )
    h = max(1, int(round(h)))
    if ny == 1:
        h = max(h, MIN_1D_HEIGHT)
    return max(1, int(round(w))), h


PAPER_DX = 1.0 / 750.0  # N_x / L_x = 750 per metre (figure 12)


def _spacing(coord, given, fallback):
    """Cell size: the given one, else the spacing of a coordinate array, else fallback."""
    if given is not None:
        return float(given)
    if coord is not None and np.size(coord) > 1:
        return float(
            abs(
                np.asarray(coord, dtype=np.float64).ravel()[1]
                - np.asarray(coord, dtype=np.float64).ravel()[0]
            )
        )
    return float(fallback)


def _shade_strength(shade) -> float:
    if shade is True:
        return DEFAULT_SHADE
    if shade is False or shade is None:
        return 0.0
    s = float(shade)
    if not (0.0 <= s <= 1.0):
        raise ValueError(f"shade={shade!r}: give True/False or a strength in [0, 1]")
    return s


def checked_fields(fields: dict, field: str, vrange, h_min: float):
    """What both renderers settle first: the field's own name, h as a (ny, nx) array (a 1D
    run is one row), and the colour range (default: the data range of the flowing cells;
    none for phi). A ValueError names an array the field needs and ``fields`` lacks."""
    field = C.canonical_field(field)
    h = np.asarray(fields["h"])
    if h.ndim == 1:
        h = h[None, :]
    if field == "phi" and "phi" not in fields:
        raise ValueError(
            "field='phi' needs a 'phi' array (this run has no segregation); choose h, speed, u or v"
        )
    if field in ("u", "v", "speed") and "u" not in fields:
        raise ValueError(f"field={field!r} needs a 'u' array")
    if vrange is None and field != "phi":
        vrange = C.default_range(field, data=fields, h_min=h_min)
    return field, h, vrange


def render_fields_numpy(
    fields: dict,
    h_min: float,
    field: str = "phi",
    shade=True,
    scale: float = 1,
    vrange=None,
    relief: float = DEFAULT_RELIEF,
    aspect: float = 1.0,
    dx: float | None = None,
    dy: float | None = None,
) -> np.ndarray:
    """`tiseg.post.render.render_fields` without its colour bar, in NumPy (same arguments):
    uint8 (H, W, 3), row 0 at the top."""
    field, h, vrange = checked_fields(fields, field, vrange, h_min)
    ny, nx = h.shape

    def cells(name):  # (ny, nx) float64, NaN as 0 and a missing array as zeros, as uploaded
        a = fields.get(name)
        if a is None:
            return np.zeros((ny, nx))
        return np.nan_to_num(np.asarray(a, dtype=np.float64).reshape(ny, nx))

    h = cells("h")
    if field == "phi":
        phi = np.clip(cells("phi"), 0.0, 1.0)[..., None]
        c = (1.0 - phi) * np.asarray(C.COARSE_RGB) + phi * np.asarray(C.FINES_RGB)
        empty = C.CHUTE_RGB
    else:
        u, v = cells("u"), cells("v")
        value = {"h": h, "speed": np.sqrt(u * u + v * v), "u": u, "v": v}[field]
        lo, hi = vrange
        t = (value - lo) / max(hi - lo, 1e-30)
        # the kernel's table lookup, in f32 like the kernel
        x = (np.clip(t, 0.0, 1.0) * (C.LUT_SIZE - 1)).astype(np.float32)
        i0 = np.minimum(np.floor(x).astype(np.int64), C.LUT_SIZE - 2)
        w = (x - i0.astype(np.float32))[..., None]
        lut = C.viridis_table(C.LUT_SIZE)
        c = ((1.0 - w) * lut[i0] + w * lut[i0 + 1]).astype(np.float64)
        empty = C.EMPTY_MAP_RGB
    strength = _shade_strength(shade)
    if strength > 0.0:
        dx = _spacing(fields.get("x"), dx, PAPER_DX)
        dy = _spacing(fields.get("y"), dy, dx)
        # 1 - S tanh(R grad(h) . l), central differences, one-sided at the edges
        d = -math.sqrt(0.5) * slope(h, 1, dx) + math.sqrt(0.5) * slope(h, 0, dy)
        tanh = np.tanh((relief * d).astype(np.float32)).astype(np.float64)  # f32, as the kernel
        f = (1.0 - strength * tanh)[..., None]
        c = np.where(f < 1.0, c * f, c + (1.0 - c) * np.minimum(f - 1.0, 1.0))
    c = np.where((h >= h_min)[..., None], c, np.asarray(empty))
    # nearest cell per pixel; picture row 0 is the top, i.e. the last y row
    width, height = image_size(nx, ny, scale, aspect)
    cols = np.minimum(((np.arange(width) + 0.5) * nx / width).astype(np.int64), nx - 1)
    rows = np.minimum(((np.arange(height) + 0.5) * ny / height).astype(np.int64), ny - 1)
    out = C.to_uint8(c[rows[::-1]][:, cols].astype(np.float32))
    b, solid = bed_of(fields, ny, nx)
    if b is not None:  # a run with terrain: its relief under the colours (flat: untouched)
        dx = _spacing(fields.get("x"), dx, PAPER_DX)
        dy = _spacing(fields.get("y"), dy, dx)
        out = with_relief(out, b, solid, dx, dy, strength)
    return out
