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

`read_asc` reads what other tools write as well: keywords in any case, ``xllcenter`` /
``yllcenter`` (the centre of the lower-left cell) in place of the corner, ``cellsize`` or
``dx`` and ``dy``, NODATA_value optional, values wrapped over lines at will. A malformed file
is a one-line `tiseg.errors.InputError` naming the file (bed rasters, `tiseg.setup.rasters`,
come from users).
"""

from __future__ import annotations

import io
import math
from pathlib import Path

import numpy as np

from ..errors import InputError
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
    if dx is None:
        raise ValueError("a grid of one cell needs its cell size")
    return _header(x.size, y.size, _corner(x[0], dx), _corner(y[0], dy), dx, dy)


def _header(nx: int, ny: int, x0, y0, dx, dy, nodata=NODATA) -> dict:
    """The header of ``nx`` x ``ny`` cells of ``dx`` x ``dy`` whose lower-left corner is
    (``x0``, ``y0``): ``cellsize`` where the cells are square, else GDAL's ``dx`` and ``dy``."""
    if not all(math.isfinite(v) for v in (x0, y0, dx, dy)) or not (dx > 0 and dy > 0):
        raise ValueError(f"corner ({x0!r}, {y0!r}), cells {dx!r} x {dy!r}: finite, sizes > 0")
    out = {"ncols": nx, "nrows": ny, "xllcorner": x0, "yllcorner": y0}
    if math.isclose(dx, dy, rel_tol=1e-9):
        out["cellsize"] = dx
    else:
        out["dx"], out["dy"] = dx, dy
    out["NODATA_value"] = nodata
    return out


def write_asc(
    path,
    values,
    x=None,
    y=None,
    dx: float | None = None,
    dy: float | None = None,
    *,
    corner: tuple[float, float] | None = None,
    nodata: float = NODATA,
    fmt: str = "%.17g",
) -> Path:
    """Write the map ``values`` (ny, nx) to ``path`` (replaced atomically: a reader sees the
    old grid or the new one). The cells are placed by their centres ``x`` (nx) and ``y`` (ny)
    (``dx``/``dy`` as in `header`), or by ``corner`` = (x0, y0), the lower-left corner of the
    lower-left cell, with cells of ``dx`` x ``dy`` (``dy`` defaults to ``dx``), written as given.
    NaN is written as ``nodata``; a finite value equal to it, or an infinite one, is an
    InputError (it would read back as missing). The default ``fmt`` keeps every float64 bit."""
    a = np.asarray(values, dtype=float)
    if a.ndim == 1:
        a = a.reshape(1, -1)
    if a.ndim != 2:
        raise ValueError(f"values of shape {a.shape}: expected a map (ny, nx)")
    if corner is None:
        head = header(x, y, dx, dy)
        head["NODATA_value"] = nodata
    else:
        if x is not None or y is not None:
            raise ValueError("give the cell centres x and y or the corner, not both")
        if dx is None:
            raise ValueError("a grid placed by its corner needs its cell size dx")
        x0, y0 = (float(c) for c in corner)
        head = _header(a.shape[1], a.shape[0], x0, y0, dx, dx if dy is None else dy, nodata)
    if a.shape != (head["nrows"], head["ncols"]):
        raise ValueError(f"values of shape {a.shape} on {head['nrows']} x {head['ncols']} cells")
    if np.any(a == nodata):
        raise InputError(
            f"{path}: a value equals NODATA_value {nodata:g}; it would read back missing"
        )
    if np.any(np.isinf(a)):
        raise InputError(f"{path}: a value is infinite")
    buf = io.StringIO()
    for k, v in head.items():
        buf.write(f"{k:<13} {v!r}\n" if isinstance(v, float) else f"{k:<13} {v}\n")
    rows = np.where(np.isnan(a), nodata, a)[::-1]  # north (largest y) first
    np.savetxt(buf, rows, fmt=fmt)
    path = Path(path)
    with replacing(path) as tmp:
        tmp.write_text(buf.getvalue(), encoding="ascii")
    return path


# ---- reading --------------------------------------------------------------------------------------
_KEYS = "ncols nrows xllcorner xllcenter yllcorner yllcenter cellsize dx dy nodata_value".split()


def _read_header(lines: list[str], where: str) -> tuple[dict, int]:
    """The header (lower-case keys) and the index of the first data line. A header line is a
    keyword and one number; the data start at the first line that begins with a number."""
    head: dict = {}
    i = 0
    for i, line in enumerate(lines):
        parts = line.split()
        if not parts:
            continue
        if not parts[0][0].isalpha() or parts[0].lower() in ("nan", "inf", "-inf"):
            break
        key = parts[0].lower()
        if key not in _KEYS:
            raise InputError(f"{where}: line {i + 1}: unknown header keyword {parts[0]!r}")
        if len(parts) != 2:
            raise InputError(f"{where}: line {i + 1}: expected '{parts[0]} <number>'")
        if key in head:
            raise InputError(f"{where}: line {i + 1}: {parts[0]} given twice")
        try:
            head[key] = int(parts[1]) if key in ("ncols", "nrows") else float(parts[1])
        except ValueError:
            kind = "an integer" if key in ("ncols", "nrows") else "a number"
            msg = f"{where}: line {i + 1}: {parts[0]} {parts[1]!r} is not {kind}"
            raise InputError(msg) from None
    else:
        i = len(lines)
    for need in ("ncols", "nrows"):
        if need not in head or head[need] < 1:
            raise InputError(f"{where}: header needs {need} >= 1")
    for axis in ("x", "y"):
        if (f"{axis}llcorner" in head) == (f"{axis}llcenter" in head):
            raise InputError(f"{where}: header needs one of {axis}llcorner, {axis}llcenter")
    if "cellsize" in head:
        if "dx" in head or "dy" in head:
            raise InputError(f"{where}: header gives cellsize and dx/dy; give one")
        head["dx"] = head["dy"] = head["cellsize"]
    elif not ("dx" in head and "dy" in head):
        raise InputError(f"{where}: header needs cellsize (or dx and dy)")
    if not (head["dx"] > 0 and head["dy"] > 0 and math.isfinite(head["dx"] * head["dy"])):
        raise InputError(f"{where}: cell size {head['dx']:g} x {head['dy']:g}: must be > 0")
    for axis, d in (("x", head["dx"]), ("y", head["dy"])):
        if f"{axis}llcorner" not in head:
            head[f"{axis}llcorner"] = head[f"{axis}llcenter"] - d / 2
    return head, i


def _is_number(token: str) -> bool:
    try:
        float(token)
    except ValueError:
        return False
    return True


def read_asc(path) -> tuple[dict, np.ndarray]:
    """(header, values) of the ESRI ASCII grid at ``path``: the inverse of `write_asc`.

    ``header``: the file's keywords in lower case, as numbers (ncols and nrows as int), and
    always ``xllcorner``, ``yllcorner`` (from ``xllcenter - dx / 2`` where the file gives the
    centre), ``dx`` and ``dy`` (from ``cellsize`` where it gives that). ``values``: (nrows,
    ncols), the first row the one at the smallest y (the file's last), NaN where the file has
    NODATA_value or NaN. A malformed file is a one-line InputError naming it and the line."""
    path = Path(path)
    where = str(path)
    try:
        lines = path.read_text(encoding="ascii").splitlines()
    except UnicodeDecodeError:
        raise InputError(f"{where}: not an ESRI ASCII grid (not plain ASCII text)") from None
    except OSError as e:
        raise InputError(f"{where}: cannot read it ({e.strerror or e})") from None
    head, first = _read_header(lines, where)
    nx, ny = head["ncols"], head["nrows"]
    tokens = " ".join(lines[first:]).split()
    if len(tokens) != nx * ny:
        raise InputError(
            f"{where}: {len(tokens)} values, expected nrows x ncols = {ny} x {nx} = {nx * ny}"
        )
    try:
        flat = np.array(tokens, dtype=float)
    except ValueError:
        k = next(k for k, t in enumerate(tokens) if not _is_number(t))
        raise InputError(
            f"{where}: value {tokens[k]!r} (data row {k // nx + 1}, column {k % nx + 1}) "
            "is not a number"
        ) from None
    a = flat.reshape(ny, nx)[::-1]  # rows north first -> the first row at the smallest y
    if "nodata_value" in head:
        a[a == head["nodata_value"]] = np.nan
    if np.any(np.isinf(a)):
        raise InputError(f"{where}: an infinite value")
    return head, a


__all__ = ["write_asc", "read_asc", "header", "NODATA"]
