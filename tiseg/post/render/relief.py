"""The terrain under the colours: a hillshade of the bed b and the solid cells, in NumPy.

A run with a ``[terrain]`` stores its bed ``b`` (m, normal to the reference plane) and its
``solid`` mask in fields.nc (`tiseg.output.fields`, static fields); the pictures then shade the
relief under the colours of the flow and of the empty chute alike, lit from the upper left of
the picture as the thickness shading of `tiseg.post.render.frame` is::

    f = 1 - S tanh(R_b grad(b) . l),   l = (-1, 1) / sqrt(2)  (towards the light, picture axes)

f < 1 darkens (c f), f > 1 brightens towards white (c + (1 - c)(f - 1)); S is the pictures'
shading strength, R_b = BED_RELIEF a vertical exaggeration larger than the thickness's, as a
bed is gentle (the shallow equations assume |grad b| small). Solid cells (walls) are drawn in
SOLID_RGB. `bed_cells` gives both per cell, and two kinds of picture use them:

* pictures of NumPy fields (`tiseg.post.render.render_fields`, its NumPy twin, the panels, the
  probability and peak maps) blend them into the finished 8-bit map (`with_relief`, before its
  colour bar), so the Taichi kernel and its NumPy twin share one blend;
* frames straight from a simulation (`tiseg.post.render.FrameRenderer`: the live viewer, its
  screenshots and recordings, ``tiseg run --movie``) upload them once into the frame kernel,
  which blends them per cell as it paints (the same formula, to within one 8-bit level).

A run without ``b`` never comes here, and its pictures are those of before, byte for byte.
"""

from __future__ import annotations

import math

import numpy as np

from . import colours as C

BED_RELIEF = 25.0  # R_b: a bed slope of 0.04 gives tanh(1)
SOLID_RGB = (96 / 255, 96 / 255, 104 / 255)  # walls: a dark grey, no flow colour


def slope(a: np.ndarray, axis: int, spacing: float) -> np.ndarray:
    """d a along ``axis`` of a (ny, nx) map: central differences, one-sided at the ends."""
    n = a.shape[axis]
    if n < 2:
        return np.zeros_like(a)
    hi = np.minimum(np.arange(n) + 1, n - 1)
    lo = np.maximum(np.arange(n) - 1, 0)
    return (np.take(a, hi, axis=axis) - np.take(a, lo, axis=axis)) / (
        np.expand_dims(hi - lo, 1 - axis) * spacing
    )


def hillshade(b, dx: float, dy: float, strength: float, relief: float = BED_RELIEF):
    """The factor f (ny, nx) of the module docstring for the bed ``b`` (ny, nx) [m] on cells
    of dx x dy [m]; 1 exactly where b is flat."""
    b = np.nan_to_num(np.asarray(b, dtype=np.float64))
    d = -math.sqrt(0.5) * slope(b, 1, dx) + math.sqrt(0.5) * slope(b, 0, dy)
    return 1.0 - strength * np.tanh(relief * d)


def pixel_cells(nx: int, ny: int, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """(rows, cols): the cell row (y index) of each picture row, top first, and the cell
    column of each picture column; nearest cell per pixel, as the painters map them."""
    cols = np.minimum(((np.arange(width) + 0.5) * nx / width).astype(np.int64), nx - 1)
    rows = np.minimum(((np.arange(height) + 0.5) * ny / height).astype(np.int64), ny - 1)
    return rows[::-1], cols


def bed_cells(b, solid, dx: float, dy: float, strength: float):
    """Per cell of the bed ``b`` (ny, nx) [m]: (f, wall), the hillshade factor f (float32
    (ny, nx), exactly 1 everywhere when ``strength`` is 0) and the walls (bool (ny, nx): the
    ``solid`` cells, bool-like or None)."""
    b = np.asarray(b, dtype=np.float64)
    if strength > 0.0:
        f = hillshade(b, dx, dy, strength).astype(np.float32)
    else:
        f = np.ones(b.shape, dtype=np.float32)
    if solid is None:
        wall = np.zeros(b.shape, dtype=bool)
    else:
        wall = np.nan_to_num(np.asarray(solid, dtype=np.float64)).reshape(b.shape) > 0.5
    return f, wall


def with_relief(img: np.ndarray, b, solid, dx: float, dy: float, strength: float) -> np.ndarray:
    """The map ``img`` (uint8 (H, W, 3), row 0 at the top, no colour bar) with the bed's
    hillshade blended in and the ``solid`` cells (bool-like (ny, nx), or None) drawn as walls;
    ``b`` is (ny, nx) [m]."""
    f, wall = bed_cells(b, solid, dx, dy, strength)
    ny, nx = f.shape
    rows, cols = pixel_cells(nx, ny, img.shape[1], img.shape[0])
    c = img.astype(np.float32) / 255.0
    if strength > 0.0:
        f = f[rows][:, cols][..., None]
        c = np.where(f < 1.0, c * f, c + (1.0 - c) * np.minimum(f - 1.0, 1.0))
    if wall.any():
        c = np.where(wall[rows][:, cols][..., None], np.asarray(SOLID_RGB, np.float32), c)
    return C.to_uint8(c)


def bed_of(fields: dict, ny: int, nx: int):
    """(b, solid) of a snapshot dict (as `tiseg.post.render.movie` reads them from fields.nc,
    ``b`` and ``solid`` (ny, nx)), or (None, None) for a flat run."""
    b = fields.get("b")
    if b is None:
        return None, None
    solid = fields.get("solid")
    b = np.asarray(b, dtype=np.float64).reshape(ny, nx)
    return b, (None if solid is None else np.asarray(solid).reshape(ny, nx))
