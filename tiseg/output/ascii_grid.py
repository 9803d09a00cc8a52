"""Maps as ESRI ASCII grids (``.asc``), the raster format hazard tools exchange peak maps in
(AvaFrame writes its peak files so); GDAL, QGIS and ArcGIS open it without a plug-in, and it
needs no library to write.

A grid is a header and the values row by row, the first row the one at the largest y (the
format's rows run from north to south):

    ncols         nx
    nrows         ny
    xllcorner     x of the lower-left corner of the lower-left cell [m]
    yllcorner     y of that corner [m]
    cellsize      dx [m]            (dx and dy, GDAL's extension, where the cells are not square)
    NODATA_value  -9999

Coordinates are those of fields.nc (x down the slope, y across it, metres, no map projection).
Missing values (NaN: never reached, not at rest) become NODATA_value. Values are written with
17 significant digits, so that reading a grid back gives the float64 values bit for bit.
"""

from __future__ import annotations

import io
import math
from pathlib import Path

import numpy as np

from .atomic import replacing

NODATA = -9999.0


def _spacing(coord: np.ndarray, name: str) -> float:
    """The constant spacing of cell centres ``coord`` (a ValueError for an irregular axis)."""
    if coord.size < 2:
        raise ValueError(f"{name}: one cell gives no spacing; pass it")
    d = np.diff(coord)
    if not (np.all(d > 0) and np.allclose(d, d[0], rtol=1e-9, atol=0.0)):
        raise ValueError(f"{name}: cell centres are not evenly spaced")
    return float(d[0])


def _corner(centre: float, d: float) -> float:
    """The lower edge of a cell: centre - d / 2, with the round-off of a grid that starts at 0
    (0.0125 - 0.0125 computed as -1.7e-18) snapped to 0."""
    c = float(centre - d / 2)
    return 0.0 if abs(c) < 1e-9 * d else c


def header(x, y, dx: float | None = None, dy: float | None = None) -> dict:
    """The header of a grid whose cell centres are ``x`` (nx) and ``y`` (ny) [m]. ``dx``/``dy``:
    the cell size where an axis has a single cell (a 1D run's y); a missing one is the other."""
    x = np.asarray(x, dtype=float).reshape(-1)
    y = np.asarray(y, dtype=float).reshape(-1)
    dx = _spacing(x, "x") if dx is None and x.size > 1 else dx
    dy = _spacing(y, "y") if dy is None and y.size > 1 else dy
    dx = dy if dx is None else dx
    dy = dx if dy is None else dy
    if dx is None or not (dx > 0 and dy > 0 and math.isfinite(dx) and math.isfinite(dy)):
        raise ValueError("a grid of one cell needs its cell size")
    out = {
        "ncols": x.size,
        "nrows": y.size,
        "xllcorner": _corner(x[0], dx),
        "yllcorner": _corner(y[0], dy),
    }
    if math.isclose(dx, dy, rel_tol=1e-9):
        out["cellsize"] = dx
    else:
        out["dx"], out["dy"] = dx, dy
    out["NODATA_value"] = NODATA
    return out


def write_asc(path, values, x, y, dx: float | None = None, dy: float | None = None) -> Path:
    """Write the map ``values`` (ny, nx), on cell centres ``x`` and ``y``, to ``path``
    (replaced atomically: a reader sees the old grid or the new one). NaN is written as
    NODATA_value; a finite value equal to it is refused (it would read back as missing)."""
    a = np.asarray(values, dtype=float)
    head = header(x, y, dx, dy)
    if a.ndim == 1:
        a = a.reshape(1, -1)
    if a.shape != (head["nrows"], head["ncols"]):
        raise ValueError(f"values of shape {a.shape} on {head['nrows']} x {head['ncols']} cells")
    if np.any(a == NODATA):
        raise ValueError(f"a value equals NODATA_value {NODATA:g}")
    if np.any(np.isinf(a)):
        raise ValueError("a value is infinite")
    buf = io.StringIO()
    for k, v in head.items():
        buf.write(f"{k:<13} {v!r}\n" if isinstance(v, float) else f"{k:<13} {v}\n")
    rows = np.where(np.isnan(a), NODATA, a)[::-1]  # north (largest y) first
    np.savetxt(buf, rows, fmt="%.17g")
    path = Path(path)
    with replacing(path) as tmp:
        tmp.write_text(buf.getvalue(), encoding="ascii")
    return path


def read_asc(path) -> tuple[dict, np.ndarray]:
    """(header, values (ny, nx) with the first row at the smallest y, NaN for NODATA) of an
    ESRI ASCII grid: the inverse of `write_asc`."""
    lines = Path(path).read_text(encoding="ascii").splitlines()
    head: dict = {}
    i = 0
    while i < len(lines) and lines[i].split() and lines[i].split()[0][0].isalpha():
        k, v = lines[i].split()[:2]
        head[k.lower()] = int(v) if k.lower() in ("ncols", "nrows") else float(v)
        i += 1
    a = np.loadtxt(lines[i:], ndmin=2).reshape(head["nrows"], head["ncols"])[::-1]
    return head, np.where(a == head.get("nodata_value", NODATA), np.nan, a)


__all__ = ["write_asc", "read_asc", "header", "NODATA"]
