"""Field snapshots as a CF-1.8 NetCDF-4 file (the IOOS compliance checker reports no error).

Layout: dimensions ``time`` (unlimited), ``y``, ``x``; coordinate variables of the cell centres;
data variables (time, y, x).

* ``time`` is the simulated time in seconds since t = 0 of the run, ``units = "s"``, with no
  reference date, calendar or ``standard_name``: model time is a duration, not a date. CF calls
  a coordinate a time coordinate by its units ("<unit> since <date>", section 4.4), so this is a
  plain coordinate named ``time``, as CF allows, and the CF community's checker (cfchecks 4.1)
  reports no error. xarray keeps it as float seconds (``ds.sel(time=1.0)``; plot titles read
  "time = 1.0 [s]"), cftime reads no dates, and VTK's CF reader and GDAL take it as the time
  axis. The IOOS compliance checker alone refuses it: it takes any variable *named* ``time``
  for a time coordinate (its section 5.1 check); CI accepts that one finding and no other.
* ``x`` and ``y`` carry ``axis`` and the ``projection_x/y_coordinate`` standard names
  (`COORD_ATTRS`): GDAL and QGIS place the rasters in metres.
* ``phi`` is missing (``_FillValue``, NaN after xarray's decoding) where h < h_min: there is no
  material there, and 0 would read as pure coarse grains.
* Data are stored as f8 or f4 (``output.precision``), optionally quantised to
  ``output.significant_digits`` decimal digits (netCDF-C's quantisation, which zlib then
  compresses far better), and zlib-compressed. Every `FieldsWriter.write` ends with a sync, which flushes the
HDF5 metadata and data to disk: if the process is killed later, the file still opens with every
snapshot written before the kill (the run is then restartable from the last snapshot).

Peak fields (`tiseg.run.peaks`, ``output.peak_fields``): 2D variables (y, x) without a time
axis, ``h_max``, ``speed_max``, ``arrival_time``, ``deposit_h`` and ``deposit_phi``, missing
(``_FillValue``) where undefined (never reached, not at rest). `FieldsWriter.write_static`
overwrites them with every snapshot, so they hold the run up to its last snapshot's step, and
at the end the whole run. That time t is the scalar time coordinate ``peak_time`` of these
variables; ``h_max`` and ``speed_max`` are maxima over [0, t] (their ``cell_methods`` "time:
maximum", CF section 7.3, names the standard name time, which both checkers accept; the scalar
coordinate's own name, also valid CF, is refused by cfchecks).

Static fields (kind "static" of `tiseg.output.fields`): 2D variables (y, x) written once when
the file is made, by `FieldsWriter.write_fixed`: the terrain's bed ``b`` (f8, m) and ``solid``
(i1 flags, 0 open, 1 solid), only in runs with a ``[terrain]`` (a flat run's file has neither).
They hold at every time and have no time coordinate.

`FieldsWriter.append` continues such a file when a killed run is resumed from a checkpoint
(`tiseg.run.checkpoint`): it keeps the snapshots the checkpoint knows of and drops any written
after it (and a record left half-written by the kill) by copying the kept records into a new
file that replaces the old one atomically, so the file on disk is always either the old or the
new complete file.
"""

from __future__ import annotations

from .names import FIELDS_FILE

import contextlib
import datetime as _dt
import json
import math
from pathlib import Path
from typing import Mapping, Sequence

import netCDF4
import numpy as np

from .atomic import replacing
from .fields import OUTPUT_FIELDS, peak_variables, specs
from .._version import __version__
from ..errors import InputError
from ..errors import TisegError

# model time: a duration in seconds, no reference date (module docstring)
TIME_UNITS = "s"
REFERENCES = (
    "Baker, J. L., Johnson, C. G. & Gray, J. M. N. T. 2016 Segregation-induced finger "
    "formation in granular free-surface flows. J. Fluid Mech. 809, 168-212, "
    "doi:10.1017/jfm.2016.653"
)

# CF attributes of the cell-centre coordinates. ``axis`` is what GDAL's netCDF driver (QGIS's
# reader) needs to take x and y as a regular grid and give the rasters a geotransform in metres;
# without it they are placed in pixels. The projection_*_coordinate standard names say that
# they are plane coordinates, not longitude and latitude (the CF checker reads an axis alone
# as those); the plane is the chute's, x down the slope and y across it, in no map projection.
COORD_ATTRS = {
    "x": {
        "standard_name": "projection_x_coordinate",
        "long_name": "downslope distance",
        "units": "m",
        "axis": "X",
    },
    "y": {
        "standard_name": "projection_y_coordinate",
        "long_name": "cross-slope distance",
        "units": "m",
        "axis": "Y",
    },
}


# The variables and their CF attributes are those of the registered output fields
# (`tiseg.output.fields`): ``FIELD_ATTRS`` (the snapshot variables) and ``STATIC_ATTRS`` (the
# peak fields) are read from the registry when asked.
def __getattr__(name: str):
    if name in ("FIELD_ATTRS", "STATIC_ATTRS"):
        kind = "snapshot" if name == "FIELD_ATTRS" else "peak"
        return {n: dict(spec.attrs) for n, spec in specs(kind).items()}
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


_DTYPES = {"f8": "f8", "f4": "f4", "float64": "f8", "float32": "f4", "f64": "f8", "f32": "f4"}


class FieldsWriter:
    """Append snapshots of (ny, nx) fields to a NetCDF-4 file.

    ``x``, ``y``: cell-centre coordinates [m] (lengths nx, ny). ``attrs``: global attributes
    added to the CF ones (e.g. ``{"scene": scene.to_toml()}``); values that NetCDF cannot store
    natively (dicts, lists of strings, None, bools) are stored as JSON / text. ``fields``: the
    variables that exist (a run without segregation passes no "phi"). ``dtype``: "f8" or "f4".
    ``h_min``: phi is written as missing where h < h_min (None: never).
    ``significant_digits``: quantise the data variables to this many decimal digits (None: keep
    every bit). ``static``: the 2D variables without a time axis the file holds (names of
    `STATIC_ATTRS`), written by `write_static`.
    """

    def __init__(
        self,
        path,
        x,
        y,
        attrs: Mapping | None = None,
        fields: Sequence[str] = ("h", "u", "v", "phi"),
        dtype: str = "f8",
        atomic: bool = True,
        h_min: float | None = None,
        significant_digits: int | None = None,
        static: Sequence[str] = (),
    ):
        self.path = Path(path)
        self.fields = tuple(fields)
        known = specs("snapshot")
        unknown = [f for f in self.fields if f not in known]
        if unknown or len(set(self.fields)) != len(self.fields) or not self.fields:
            raise ValueError(f"fields={fields!r}: choose distinct names from {tuple(known)}")
        self.static = tuple(static)
        if any(n not in specs("peak") for n in self.static):
            raise ValueError(f"static={static!r}: choose names from {tuple(specs('peak'))}")
        if dtype not in _DTYPES:
            raise ValueError(f"dtype={dtype!r}: choose 'f8' or 'f4'")
        self.dtype = _DTYPES[dtype]
        self.h_min = h_min
        self.significant_digits = significant_digits
        x = np.asarray(x, dtype="f8").reshape(-1)
        y = np.asarray(y, dtype="f8").reshape(-1)
        self.shape = (y.size, x.size)
        self._last_t = -math.inf
        self.count = 0
        self.fixed: tuple[str, ...] = ()

        self.path.parent.mkdir(parents=True, exist_ok=True)
        if not atomic:
            self._ds = self._create(self.path, x, y, attrs)
            return
        # made under a temporary name and renamed when complete: a kill while the file is
        # being created leaves no file or a whole (empty) one, never an unreadable one
        with replacing(self.path) as tmp:
            self._create(tmp, x, y, attrs).close()
        self._ds = netCDF4.Dataset(self.path, "a")

    def _create(self, path, x, y, attrs):
        ds = netCDF4.Dataset(path, "w", format="NETCDF4")
        try:
            self._define(ds, x, y, dict(attrs or {}))
            ds.sync()
        except BaseException:
            ds.close()
            raise
        return ds

    def _define(self, ds, x, y, attrs: dict) -> None:

        now = _dt.datetime.now(_dt.timezone.utc).replace(microsecond=0).isoformat()
        ds.setncattr("Conventions", "CF-1.8")
        ds.setncattr("title", "tiseg simulation of segregation-induced fingering")
        ds.setncattr(
            "source",
            f"tiseg {__version__}: depth-averaged segregation-mobility model "
            "of Baker, Johnson & Gray (2016), eqs (6.1)-(6.3)",
        )
        ds.setncattr("history", f"{now} created by tiseg {__version__}")
        ds.setncattr("references", f"{REFERENCES}; tiseg {__version__}")
        for key, value in attrs.items():
            value = _attr_value(value)
            if value is not None:
                ds.setncattr(str(key), value)

        ds.createDimension("time", None)
        ds.createDimension("y", y.size)
        ds.createDimension("x", x.size)
        t = ds.createVariable("time", "f8", ("time",))
        t.setncatts(
            {
                "long_name": "simulated time",
                "units": TIME_UNITS,
                "comment": "seconds since t = 0 of the run (model time, no date)",
            }
        )
        yv = ds.createVariable("y", "f8", ("y",))
        yv.setncatts(COORD_ATTRS["y"])
        yv[:] = y
        xv = ds.createVariable("x", "f8", ("x",))
        xv.setncatts(COORD_ATTRS["x"])
        xv[:] = x
        ny, nx = self.shape
        for name in self.fields:
            # one chunk per snapshot: appending a record touches only its own chunk
            kw = {}
            if self.significant_digits is not None:
                kw["significant_digits"] = int(self.significant_digits)
            var = ds.createVariable(
                name,
                self.dtype,
                ("time", "y", "x"),
                zlib=True,
                complevel=4,
                shuffle=True,
                chunksizes=(1, ny, nx),
                fill_value=netCDF4.default_fillvals[self.dtype],
                **kw,
            )
            var.setncatts(OUTPUT_FIELDS[name].attrs)
            if OUTPUT_FIELDS[name].missing_where_dry and self.h_min is not None:
                var.setncattr(
                    "comment", f"missing where h < h_min = {self.h_min:g} m (no material)"
                )
        for name in self.static:
            self._define_static(ds, name)

    @staticmethod
    def _define_peak_time(ds) -> None:
        """The scalar time coordinate of the 2D variables: the maxima are over [0, t]."""
        t = ds.createVariable("peak_time", "f8", ())
        t.setncatts(
            {
                "long_name": "time up to which the peak fields hold, from t = 0 of the run",
                "units": TIME_UNITS,
            }
        )

    def _define_static(self, ds, name: str):
        """The 2D variable ``name`` (y, x), all missing until `write_static` fills it."""
        if "peak_time" not in ds.variables:
            self._define_peak_time(ds)
        kw = {}
        if self.significant_digits is not None:
            kw["significant_digits"] = int(self.significant_digits)
        var = ds.createVariable(
            name,
            self.dtype,
            ("y", "x"),
            zlib=True,
            complevel=4,
            shuffle=True,
            fill_value=netCDF4.default_fillvals[self.dtype],
            **kw,
        )
        var.setncatts({**OUTPUT_FIELDS[name].attrs, "coordinates": "peak_time"})
        return var

    @classmethod
    def append(
        cls,
        path,
        keep: int,
        t_max: float | None = None,
        h_min: float | None = None,
        shape: tuple[int, int] | None = None,
    ) -> "FieldsWriter":
        """Reopen the file of an interrupted run to append snapshots after its first ``keep``.

        Records beyond ``keep`` (written after the checkpoint the run resumes from, or left
        half-written by a kill: the data of a record is written before its time) are dropped,
        by rewriting the file through a temporary copy and ``os.replace``. Raises
        `FieldsFileError` when the file cannot be read or holds fewer than ``keep``
        complete records (or a kept time after ``t_max``), or when a kept record's data cannot
        be read (a damaged block). ``h_min``: as for a new writer; the quantisation and the
        precision are the file's own. ``shape``: the run's (ny, nx); a file of another grid is
        not this run's file (an InputError: it is neither damaged nor to be replaced).
        """
        path = Path(path)
        try:
            with netCDF4.Dataset(path, "r") as ds:
                fields = tuple(v for v in ds.variables if v in specs("snapshot"))
                static = tuple(v for v in ds.variables if v in specs("peak"))
                fixed = tuple(v for v in ds.variables if v in specs("static"))
                times = np.ma.filled(ds.variables["time"][:].astype("f8"), np.nan)
                n = ds.dimensions["time"].size
                grid = (ds.dimensions["y"].size, ds.dimensions["x"].size)
                dtype = ds.variables[fields[0]].dtype.str[1:] if fields else "f8"
                quant = ds.variables[fields[0]].quantization() if fields else None
        except (OSError, KeyError, IndexError, RuntimeError) as exc:
            raise FieldsFileError(
                f"{path}: cannot be read as a tiseg fields file ({exc})"
            ) from None
        kept = times[:keep]
        if (
            len(kept) < keep
            or not np.isfinite(kept).all()
            or np.any(np.diff(kept) <= 0)
            or (t_max is not None and keep and kept[-1] > t_max * (1 + 1e-12))
        ):
            raise FieldsFileError(
                f"{path}: holds {n} records with times {kept.tolist()[:8]}, "
                f"but the checkpoint expects {keep} complete snapshots"
                + (f" up to t={t_max!r}" if t_max is not None else "")
            )
        if shape is not None and tuple(grid) != tuple(shape):
            raise InputError(
                f"{str(path)!r} holds fields on a {grid[1]} x {grid[0]} grid, the run's scene "
                f"has {shape[1]} x {shape[0]} cells: it is not this run's fields file; put the "
                "run's own fields.nc back"
            )
        digits = int(quant[0]) if quant else None
        try:
            if n != keep:
                _truncate_copy(path, keep, fields, dtype, h_min, digits, static, fixed)
            else:  # every kept record must be readable: a damaged block is found now
                _read_records(path, keep, fields)
        except (OSError, RuntimeError) as exc:
            raise FieldsFileError(f"{path}: a record cannot be read ({exc})") from None
        self = cls.__new__(cls)
        self.path = path
        self.fields = fields
        self.static = static
        self.fixed = fixed
        self.dtype = _DTYPES.get(dtype, "f8")
        self.h_min = h_min
        self.significant_digits = digits
        self._ds = ds = netCDF4.Dataset(path, "a")
        self.shape = (ds.dimensions["y"].size, ds.dimensions["x"].size)
        self.count = keep
        self._last_t = float(kept[-1]) if keep else -math.inf

        now = _dt.datetime.now(_dt.timezone.utc).replace(microsecond=0).isoformat()
        history = str(getattr(ds, "history", ""))
        ds.setncattr(
            "history",
            (history + "\n" if history else "")
            + f"{now} resumed by tiseg {__version__} after {keep} snapshots",
        )
        ds.sync()
        return self

    def write(self, t: float, **arrays) -> None:
        """Append the snapshot at time ``t`` [s]; give exactly the writer's fields, each (ny, nx)
        (a 1D run has ny = 1; arrays of shape (nx,) are accepted then)."""
        if self._ds is None:
            raise ValueError(f"{self.path}: writer is closed")
        missing = [f for f in self.fields if f not in arrays]
        extra = [f for f in arrays if f not in self.fields]
        if missing or extra:
            raise ValueError(
                f"write(): expected fields {self.fields}, missing {missing}, unexpected {extra}"
            )
        t = float(t)
        if not (math.isfinite(t) and t > self._last_t):
            raise ValueError(
                f"write(): time {t!r} must be finite and after the previous "
                f"snapshot ({self._last_t!r})"
            )
        data = {}
        for name in self.fields:
            a = np.asarray(arrays[name])
            if a.shape != self.shape and not (self.shape[0] == 1 and a.shape == self.shape[1:]):
                raise ValueError(f"write(): {name} has shape {a.shape}, expected {self.shape}")
            data[name] = a.reshape(self.shape)
        if self.h_min is not None and "h" in data:
            for name in data:  # no material, no value
                if OUTPUT_FIELDS[name].missing_where_dry:
                    data[name] = np.ma.masked_where(data["h"] < self.h_min, data[name])
        i = self.count
        for name, a in data.items():
            self._ds.variables[name][i, :, :] = a
        # time last: a record counts only once all its fields are in
        self._ds.variables["time"][i] = t
        self._ds.sync()
        self.count += 1
        self._last_t = t

    def write_static(self, t: float, **arrays) -> None:
        """Overwrite the 2D variables without a time axis (names of `STATIC_ATTRS`, each
        (ny, nx), NaN where missing) with their values at time ``t`` [s] (``peak_time``);
        a variable the file lacks is added."""
        if self._ds is None:
            raise ValueError(f"{self.path}: writer is closed")
        for name, a in arrays.items():
            if name not in specs("peak"):
                raise ValueError(f"write_static(): {name!r} is not one of {tuple(specs('peak'))}")
            a = np.asarray(a, dtype="f8")
            if a.shape != self.shape and not (self.shape[0] == 1 and a.shape == self.shape[1:]):
                raise ValueError(
                    f"write_static(): {name} has shape {a.shape}, expected {self.shape}"
                )
            var = self._ds.variables.get(name)
            if var is None:
                var = self._define_static(self._ds, name)
                self.static += (name,)
            var[:, :] = np.ma.masked_invalid(a.reshape(self.shape))
        if arrays:
            self._ds.variables["peak_time"].assignValue(float(t))
        self._ds.sync()

    def write_fixed(self, **arrays) -> None:
        """Write the static fields (kind "static", each (ny, nx)) once: variables (y, x)
        without a time coordinate, in each spec's own type (``FieldSpec.dtype``) and never
        quantised (the bed enters b + h exactly)."""
        if self._ds is None:
            raise ValueError(f"{self.path}: writer is closed")
        known = specs("static")
        for name, a in arrays.items():
            if name not in known:
                raise ValueError(f"write_fixed(): {name!r} is not one of {tuple(known)}")
            if name in self.fixed:
                raise ValueError(f"write_fixed(): {name!r} is written already")
            a = np.asarray(a)
            if a.shape != self.shape and not (self.shape[0] == 1 and a.shape == self.shape[1:]):
                raise ValueError(
                    f"write_fixed(): {name} has shape {a.shape}, expected {self.shape}"
                )
            dtype = known[name].dtype or self.dtype
            var = self._ds.createVariable(name, dtype, ("y", "x"), zlib=True, complevel=4)
            var.setncatts(known[name].attrs)
            var[:, :] = a.reshape(self.shape).astype(dtype)
            self.fixed += (name,)
        self._ds.sync()

    def close(self) -> None:
        if self._ds is not None:
            self._ds.close()
            self._ds = None

    def __enter__(self) -> "FieldsWriter":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __del__(self):  # pragma: no cover - best effort at interpreter exit
        try:
            self.close()
        except Exception:
            pass


class FieldsFileError(Exception):
    """A fields file that cannot be continued (unreadable, or fewer records than expected)."""


def _truncate_copy(
    path: Path,
    keep: int,
    fields,
    dtype: str,
    h_min: float | None = None,
    digits: int | None = None,
    static=(),
    fixed=(),
) -> None:
    """Replace ``path`` by a copy holding only its first ``keep`` records and its 2D variables
    without a time axis (peak and static fields; atomic replace)."""
    with replacing(path) as tmp, netCDF4.Dataset(path, "r") as src:
        attrs = {k: src.getncattr(k) for k in src.ncattrs()}
        x = src.variables["x"][:]
        y = src.variables["y"][:]
        w = FieldsWriter(
            tmp,
            x,
            y,
            fields=fields,
            dtype=dtype,
            atomic=False,
            h_min=h_min,
            significant_digits=digits,
            static=static,
        )
        try:
            for k, v in attrs.items():  # the original title, history, scene, ...
                w._ds.setncattr(k, v)
            for name in static + (("peak_time",) if static else ()):
                w._ds.variables[name][...] = src.variables[name][...]
            w.write_fixed(**{n: src.variables[n][...] for n in fixed})
            for i in range(keep):
                w.write(
                    float(src.variables["time"][i]),
                    **{f: np.ma.filled(src.variables[f][i], np.nan) for f in fields},
                )
        finally:
            w.close()


def _read_records(path: Path, keep: int, fields) -> None:
    """Read (and drop) the first ``keep`` records of every field: the library raises on a
    damaged data block."""
    with netCDF4.Dataset(path, "r") as ds:
        for f in fields:
            for i in range(keep):
                ds.variables[f][i]


def read_fields(path):
    """Open a fields file as an `xarray.Dataset` (time stays float seconds); a file
    that cannot be read (truncated, damaged, not NetCDF) is an InputError saying so.

    Records whose time is missing (NaN or the NetCDF fill value) are left out: a writer stores
    a record's time after its fields, so such a record was cut short by a kill and is not a
    snapshot (its "time" would read as 9.97e36 s)."""
    import xarray as xr

    try:
        ds = xr.open_dataset(path, engine="netcdf4", decode_times=False, decode_timedelta=False)
    except (OSError, RuntimeError, ValueError, KeyError) as exc:
        raise InputError(unreadable_message(path, exc)) from None
    if "time" in ds.variables and ds["time"].ndim == 1 and ds.sizes.get("time", 0):
        ok = written_times(ds["time"].values)
        if not ok.all():
            whole = ds.isel(time=np.flatnonzero(ok))
            whole.set_close(ds.close)  # closing the selection closes the file
            return whole
    return ds


class TimeFrames:
    """The snapshots of one variable of a `read_fields` dataset, read a block of times at a
    time: ``frames[i]`` is the (ny, nx) array at time index i. An analysis that visits every
    time several times (fronts, deposit, fingers) reads each block once instead of asking the
    file for every frame (a read costs about 1 ms however small the frame), and holds at most
    ``block_bytes`` of it."""

    def __init__(self, ds, name: str, block_bytes: float = 64e6):
        self.var = ds[name]
        frame = int(np.prod(self.var.shape[1:])) * 8
        self.block = max(1, int(block_bytes // max(frame, 1)))
        self.start = None
        self.data = None

    def __len__(self) -> int:
        return self.var.shape[0]

    def __getitem__(self, i: int) -> np.ndarray:
        i = int(i)
        if not 0 <= i < len(self):
            raise IndexError(f"time index {i} outside 0..{len(self) - 1}")
        if self.start is None or not self.start <= i < self.start + len(self.data):
            self.start = i - i % self.block
            self.data = np.asarray(
                self.var.isel(time=slice(self.start, self.start + self.block)).values
            )
        return self.data[i - self.start]


@contextlib.contextmanager
def reading(path):
    """Errors of the NetCDF / HDF5 library while the data of ``path`` are read (lazily, after
    `read_fields` opened it) become one InputError line: a damaged data block is a
    damaged file, not a bug of tiseg. ``path``: the file, or the run folder that holds it."""

    path = Path(path) / FIELDS_FILE if Path(path).is_dir() else Path(path)

    try:
        yield
    except TisegError:
        raise
    except (OSError, RuntimeError) as exc:
        if "NetCDF:" not in str(exc):
            raise  # not the library's (a movie that cannot be written, a bug): as it was
        raise InputError(unreadable_message(path, exc)) from None


def written_times(times) -> np.ndarray:
    """Mask of the records whose time was written: finite and not the NetCDF fill value
    (9.97e36; netCDF4 may also hand it over masked)."""
    t = np.ma.filled(np.ma.asarray(times, dtype="f8"), np.nan)
    return np.isfinite(t) & (np.abs(t) < 0.5 * netCDF4.default_fillvals["f8"])


def unreadable_message(path, exc: BaseException) -> str:
    """Why ``path`` could not be read, in one line: the run that is writing it (the HDF5
    library refuses to open a file another process writes), or a damaged file."""
    from .paths import RunLock

    holder = RunLock(Path(path).parent).busy() if Path(path).parent.is_dir() else None
    if holder is not None:
        return (
            f"{str(path)!r} is being written by a running tiseg run ({holder}); "
            "wait for it to finish"
        )
    reason = getattr(exc, "strerror", None) or str(exc).split("\n")[0] or type(exc).__name__
    return (
        f"{str(path)!r} cannot be read as a NetCDF fields file ({reason}): "
        "it is damaged or truncated (a resumable run repairs it with "
        "`tiseg run --resume`)"
    )


def _attr_value(value):
    """A value NetCDF can store as an attribute, or None to skip it."""
    if value is None:
        return None
    if isinstance(value, bool):
        return int(value)
    if isinstance(value, (str, int, float, np.integer, np.floating)):
        return value
    if isinstance(value, (list, tuple, np.ndarray)):
        arr = np.asarray(value)
        if arr.dtype.kind in "if" and arr.ndim == 1 and arr.size > 0:
            return arr
    return json.dumps(value, default=str)


__all__ = [
    "FieldsWriter",
    "FieldsFileError",
    "read_fields",
    "reading",
    "TimeFrames",
    "written_times",
    "COORD_ATTRS",
    "peak_variables",
]
