"""Bed rasters (DEMs): read from ESRI ASCII, NetCDF or GeoTIFF, resampled once onto the grid.

A `Raster` holds cell-centred values on a regular grid, in metres, indexed [i, j] = (x, y):
``values[i, j]`` is the value at (x0 + (i + 1/2) dx, y0 + (j + 1/2) dy), where (x0, y0) is
the lower-left corner of the lower-left cell. x is the downslope coordinate of the reference
plane and the values are bed heights b normal to it (as in `tiseg.setup.terrain`); with
material.zeta_deg = 0 the plane is horizontal and a map-view DEM's elevations are such heights
(x then runs along the raster's columns, not necessarily east). Missing values are nodata,
which the solver is to treat as solid (DESIGN.md, "Terrain").

Formats: ESRI ASCII grids (``.asc``, with no dependency: `tiseg.output.ascii_grid` reads and
writes them, GDAL's ``dx`` and ``dy`` header lines for non-square cells included), NetCDF
(``.nc``: a variable ``b`` on coordinate variables ``x`` and ``y``) and GeoTIFF (``.tif``,
through rasterio, the optional extra ``tiseg[terrain]``). Every malformed file is a one-line
`tiseg.errors.InputError` naming the file.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..output import ascii_grid

METRES = ("m", "metre", "metres", "meter", "meters")
# a fraction of a cell below which coordinates count as equal (round-off of x0 + i dx) and a
# stencil weight counts as zero (a cell centre on a raster centre next to nodata)
TOL = 1e-9


@dataclass(frozen=True)
class Raster:
    """Values (nx, ny) indexed [x, y] on cells of size dx x dy whose lower-left corner is
    (x0, y0) [m]; ``nodata`` a bool mask of the same shape (NaN values are nodata too, and
    nodata values read as NaN)."""

    values: np.ndarray
    x0: float
    y0: float
    dx: float
    dy: float
    nodata: np.ndarray | None = field(default=None, compare=False)

    def __post_init__(self):
        v = np.array(self.values, dtype=float)
        if v.ndim != 2 or min(v.shape) < 1:
            raise InputError(f"raster values of shape {v.shape}: expected a 2D array (nx, ny)")
        for name in ("x0", "y0", "dx", "dy"):
            if not math.isfinite(getattr(self, name)):
                raise InputError(f"raster {name}={getattr(self, name)!r}: must be finite")
        if not (self.dx > 0 and self.dy > 0):
            raise InputError(f"raster cell size {self.dx!r} x {self.dy!r}: must be > 0")
        mask = np.isnan(v)
        if self.nodata is not None:
            given = np.asarray(self.nodata, dtype=bool)
            if given.shape != v.shape:
                raise InputError(f"raster nodata mask {given.shape} != values {v.shape}")
            mask |= given
        if np.any(np.isinf(v[~mask])):
            raise InputError("raster values: an infinite value")
        v[mask] = np.nan
        v.flags.writeable = False
        mask.flags.writeable = False
        object.__setattr__(self, "values", v)
        object.__setattr__(self, "nodata", mask)

    @property
    def shape(self) -> tuple[int, int]:
        return self.values.shape

    def centres(self) -> tuple[np.ndarray, np.ndarray]:
        """Cell-centre coordinates (x of length nx, y of length ny) [m]."""
        nx, ny = self.shape
        return self.x0 + (np.arange(nx) + 0.5) * self.dx, self.y0 + (np.arange(ny) + 0.5) * self.dy


# ---- ESRI ASCII -----------------------------------------------------------------------------------
def read_asc(path) -> Raster:
    """An ESRI ASCII grid, read by `tiseg.output.ascii_grid.read_asc` (its rows run north to
    south; ``xllcenter`` or ``xllcorner``; NODATA_value and NaN are nodata)."""
    head, values = ascii_grid.read_asc(path)  # (ny, nx), the first row at the smallest y
    return Raster(values.T, head["xllcorner"], head["yllcorner"], head["dx"], head["dy"])


# ---- NetCDF --------------------------------------------------------------------------------------
def _axis(name: str, c, where: str) -> tuple[float, float, bool]:
    """(lower edge, spacing, reversed) of evenly spaced centres ``c``."""
    c = np.asarray(c, dtype=float)
    if c.ndim != 1 or c.size < 2 or not np.all(np.isfinite(c)):
        raise InputError(f"{where}: coordinate {name} needs two or more finite values")
    d = np.diff(c)
    if not (np.all(d > 0) or np.all(d < 0)) or not np.allclose(d, d[0], rtol=1e-6, atol=0):
        raise InputError(f"{where}: coordinate {name} is not evenly spaced")
    step = abs(float(d[0]))
    return float(min(c[0], c[-1])) - step / 2, step, bool(d[0] < 0)


def _check_units(var, label: str, where: str) -> None:
    units = getattr(var, "units", None)
    if units is not None and str(units).strip().lower() not in METRES:
        raise InputError(f"{where}: {label} is in {units!r}; terrain rasters are in metres")


def read_netcdf(path) -> Raster:
    """A NetCDF raster: variable ``b`` with dimensions (x, y) or (y, x) and 1D coordinate
    variables ``x`` and ``y`` holding the cell centres (either may decrease). Masked
    (_FillValue) and NaN values are nodata; ``units``, where given, must be metres."""
    import netCDF4  # a dependency, but heavy to import for an .asc

    where = str(path)
    try:
        ds = netCDF4.Dataset(path, "r")
    except OSError as e:
        raise InputError(f"{where}: not a readable NetCDF file ({e.strerror or e})") from None
    with ds:
        if "b" not in ds.variables:
            found = ", ".join(ds.variables) or "none"
            raise InputError(f"{where}: no variable 'b' (the bed height); variables: {found}")
        var = ds.variables["b"]
        dims = tuple(var.dimensions)
        if sorted(dims) != ["x", "y"]:
            raise InputError(f"{where}: b has dimensions {dims}; expected (x, y) or (y, x)")
        for name in ("x", "y"):
            if name not in ds.variables:
                raise InputError(f"{where}: no coordinate variable {name!r}")
            _check_units(ds.variables[name], f"coordinate {name}", where)
        _check_units(var, "b", where)
        a = np.ma.masked_invalid(np.ma.asarray(var[...], dtype=float))
        xs, ys = ds.variables["x"][...], ds.variables["y"][...]
    if dims == ("y", "x"):
        a = a.T
    if a.shape != (np.size(xs), np.size(ys)):
        raise InputError(f"{where}: b is {a.shape} on {np.size(xs)} x and {np.size(ys)} y")
    x_lo, dx, x_rev = _axis("x", xs, where)
    y_lo, dy, y_rev = _axis("y", ys, where)
    if x_rev:
        a = a[::-1, :]
    if y_rev:
        a = a[:, ::-1]
    return Raster(a.filled(np.nan), x_lo, y_lo, dx, dy, np.ma.getmaskarray(a))


# ---- GeoTIFF -------------------------------------------------------------------------------------
def read_geotiff(path) -> Raster:
    """The first band of a GeoTIFF, through rasterio (``pip install "tiseg[terrain]"``). The
    transform must be north-up or south-up without rotation; a geographic CRS (degrees) is
    refused. The dataset's nodata (and its mask) is nodata."""
    where = str(path)
    try:
        import rasterio  # optional: its wheels bundle GDAL
    except ImportError:
        raise InputError(
            f'{where}: reading GeoTIFF needs rasterio: pip install "tiseg[terrain]" '
            "(or convert the raster to ESRI ASCII .asc, which needs nothing)"
        ) from None
    errors = (OSError, getattr(getattr(rasterio, "errors", None), "RasterioError", OSError))
    try:
        with rasterio.open(path) as ds:
            t = ds.transform
            crs = ds.crs
            if crs is not None and getattr(crs, "is_geographic", False):
                raise InputError(f"{where}: geographic coordinates (degrees); metres only")
            if t.b != 0 or t.d != 0:
                raise InputError(f"{where}: a rotated raster (transform {tuple(t)[:6]})")
            a = np.ma.asarray(ds.read(1, masked=True), dtype=float)  # (rows, columns)
    except errors as e:
        raise InputError(f"{where}: cannot read it as GeoTIFF ({e})") from None
    rows, cols = a.shape
    dx, dy = abs(float(t.a)), abs(float(t.e))
    a = a.T  # [column, row]
    x0 = float(t.c) if t.a > 0 else float(t.c) - dx * cols
    if t.a < 0:
        a = a[::-1, :]
    if t.e < 0:  # north-up: row 0 at the top, the largest y
        a, y0 = a[:, ::-1], float(t.f) - dy * rows
    else:
        y0 = float(t.f)
    a = np.ma.masked_invalid(a)
    return Raster(a.filled(np.nan), x0, y0, dx, dy, np.ma.getmaskarray(a))


READERS = {".asc": read_asc, ".nc": read_netcdf, ".tif": read_geotiff, ".tiff": read_geotiff}


def read_raster(path) -> Raster:
    """A `Raster` from ``path``, the reader chosen by its suffix (`READERS`)."""
    path = Path(path)
    reader = READERS.get(path.suffix.lower())
    if reader is None:
        raise InputError(
            f"{path}: unknown raster format {path.suffix or '(no suffix)'!r}; "
            f"known: {', '.join(READERS)}"
        )
    if not path.is_file():
        raise InputError(f"{path}: no such file")
    return reader(path)


# ---- onto the grid -------------------------------------------------------------------------------
def _stencil(q: np.ndarray, start: float, d: float, n: int) -> tuple[np.ndarray, np.ndarray]:
    """(left node index, fraction t in [0, 1]) of points ``q`` between raster centres
    start + k d: q = centre[i] + t d, i in [0, n - 2]. In the outer half-cell, beyond the last
    centre, t is clamped: the edge value holds there (extrapolating would overshoot a peak at
    the edge, and b stays within the raster's values)."""
    s = (q - start) / d
    i = np.clip(np.floor(s), 0, n - 2).astype(int)
    return i, np.clip(s - i, 0.0, 1.0)


def resample(raster: Raster, xc, yc, origin=(0.0, 0.0)) -> tuple[np.ndarray, np.ndarray]:
    """(b, solid) on the cells centred at ``xc`` (nx) and ``yc`` (ny): the raster, its corner
    placed at (x0 + origin[0], y0 + origin[1]) in the domain's coordinates, bilinearly
    interpolated between its cell centres onto the cell centres (point values, not cell
    averages: resample a raster much finer than the grid with care). A cell centre whose
    stencil gives weight to a nodata value is solid, with b = 0.

    The raster must cover every cell centre, up to its edge (in the outer half-cell, beyond its
    last centre, b is the value at the nearest point between centres); one that falls short is
    an InputError naming the side and the shortfall. It needs two or more cells each way."""
    xc = np.asarray(xc, dtype=float)
    yc = np.asarray(yc, dtype=float)
    nx, ny = raster.shape
    if nx < 2 or ny < 2:
        raise InputError(f"a raster of {nx} x {ny} cells: bilinear resampling needs 2 x 2")
    ox, oy = (float(v) for v in origin)
    x_lo, y_lo = raster.x0 + ox, raster.y0 + oy
    x_hi, y_hi = x_lo + nx * raster.dx, y_lo + ny * raster.dy
    short = []
    for side, gap, d in (
        ("upslope side x_lo", x_lo - xc.min(), raster.dx),
        ("downslope side x_hi", xc.max() - x_hi, raster.dx),
        ("cross-slope side y_lo", y_lo - yc.min(), raster.dy),
        ("cross-slope side y_hi", yc.max() - y_hi, raster.dy),
    ):
        if gap > TOL * d:
            short.append(f"{side} by {gap:.6g} m")
    if short:
        raise InputError(
            f"the terrain raster (placed at [{x_lo:g}, {x_hi:g}] x [{y_lo:g}, {y_hi:g}]) "
            f"does not cover every cell centre: it falls short on the {'; '.join(short)}"
        )
    i, tx = _stencil(xc, x_lo + raster.dx / 2, raster.dx, nx)
    j, ty = _stencil(yc, y_lo + raster.dy / 2, raster.dy, ny)
    values = np.where(raster.nodata, 0.0, raster.values)
    missing = raster.nodata.astype(float)
    b = np.zeros((xc.size, yc.size))
    w_ok = np.zeros_like(b)
    w_missing = np.zeros_like(b)
    for di, wx in ((0, 1.0 - tx), (1, tx)):
        for dj, wy in ((0, 1.0 - ty), (1, ty)):
            w = np.outer(wx, wy)
            node = np.ix_(i + di, j + dj)
            b += w * values[node]
            w_ok += w * (1.0 - missing[node])
            w_missing += np.abs(w) * missing[node]
    solid = w_missing > TOL
    # where a nodata node's weight is round-off, the others' weights sum to 1 - tiny
    b = np.where(solid, 0.0, b / np.where(solid, 1.0, w_ok))
    return b, solid


__all__ = [
    "READERS",
    "Raster",
    "read_asc",
    "read_geotiff",
    "read_netcdf",
    "read_raster",
    "resample",
]
