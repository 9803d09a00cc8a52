"""Field snapshots as a CF-1.8 NetCDF-4 file.

Layout: dimensions ``time`` (unlimited), ``y``, ``x``; coordinate variables of the cell centres;
data variables (time, y, x). Every :meth:`FieldsWriter.write` ends with a sync, which flushes the
HDF5 metadata and data to disk: if the process is killed later, the file still opens with every
snapshot written before the kill (the run is then restartable from the last snapshot).
"""
from __future__ import annotations

import datetime as _dt
import json
import math
from pathlib import Path
from typing import Mapping, Sequence

import netCDF4
import numpy as np

# CF attributes of the primitive fields of (6.1)-(6.3).
FIELD_ATTRS = {
    "h": {"long_name": "flow thickness", "units": "m"},
    "u": {"long_name": "depth-averaged downslope velocity", "units": "m s-1"},
    "v": {"long_name": "depth-averaged cross-slope velocity", "units": "m s-1"},
    "phi": {"long_name": "depth-averaged small-particle concentration", "units": "1"},
}

_DTYPES = {"f8": "f8", "f4": "f4", "float64": "f8", "float32": "f4", "f64": "f8", "f32": "f4"}


class FieldsWriter:
    """Append snapshots of (ny, nx) fields to a NetCDF-4 file.

    ``x``, ``y``: cell-centre coordinates [m] (lengths nx, ny). ``attrs``: global attributes
    added to the CF ones (e.g. ``{"scene": scene.to_toml()}``); values that NetCDF cannot store
    natively (dicts, lists of strings, None, bools) are stored as JSON / text. ``fields``: the
    variables that exist (a run without segregation passes no "phi"). ``dtype``: "f8" or "f4".
    """

    def __init__(self, path, x, y, attrs: Mapping | None = None,
                 fields: Sequence[str] = ("h", "u", "v", "phi"), dtype: str = "f8"):
        self.path = Path(path)
        self.fields = tuple(fields)
        unknown = [f for f in self.fields if f not in FIELD_ATTRS]
        if unknown or len(set(self.fields)) != len(self.fields) or not self.fields:
            raise ValueError(f"fields={fields!r}: choose distinct names from {tuple(FIELD_ATTRS)}")
        if dtype not in _DTYPES:
            raise ValueError(f"dtype={dtype!r}: choose 'f8' or 'f4'")
        self.dtype = _DTYPES[dtype]
        x = np.asarray(x, dtype="f8").reshape(-1)
        y = np.asarray(y, dtype="f8").reshape(-1)
        self.shape = (y.size, x.size)
        self._last_t = -math.inf
        self.count = 0

        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._ds = ds = netCDF4.Dataset(self.path, "w", format="NETCDF4")
        try:
            self._define(ds, x, y, dict(attrs or {}))
            ds.sync()
        except BaseException:
            ds.close()
            raise

    def _define(self, ds, x, y, attrs: dict) -> None:
        from .. import __version__
        now = _dt.datetime.now(_dt.timezone.utc).replace(microsecond=0).isoformat()
        ds.setncattr("Conventions", "CF-1.8")
        ds.setncattr("title", "tiseg simulation of segregation-induced fingering")
        ds.setncattr("source", f"tiseg {__version__}: depth-averaged segregation-mobility model "
                               "of Baker, Johnson & Gray (2016), eqs (6.1)-(6.3)")
        ds.setncattr("history", f"{now} created by tiseg {__version__}")
        for key, value in attrs.items():
            value = _attr_value(value)
            if value is not None:
                ds.setncattr(str(key), value)

        ds.createDimension("time", None)
        ds.createDimension("y", y.size)
        ds.createDimension("x", x.size)
        t = ds.createVariable("time", "f8", ("time",))
        t.setncatts({"standard_name": "time", "long_name": "time", "units": "s", "axis": "T"})
        # 'units = "s"' (no reference date) keeps time a plain float in xarray/CF readers
        yv = ds.createVariable("y", "f8", ("y",))
        yv.setncatts({"long_name": "cross-slope distance", "units": "m", "axis": "Y"})
        yv[:] = y
        xv = ds.createVariable("x", "f8", ("x",))
        xv.setncatts({"long_name": "downslope distance", "units": "m", "axis": "X"})
        xv[:] = x
        ny, nx = self.shape
        for name in self.fields:
            # one chunk per snapshot: appending a record touches only its own chunk
            var = ds.createVariable(name, self.dtype, ("time", "y", "x"), zlib=True, complevel=4,
                                    shuffle=True, chunksizes=(1, ny, nx))
            var.setncatts(FIELD_ATTRS[name])

    def write(self, t: float, **arrays) -> None:
        """Append the snapshot at time ``t`` [s]; give exactly the writer's fields, each (ny, nx)
        (a 1D run has ny = 1; arrays of shape (nx,) are accepted then)."""
        if self._ds is None:
            raise ValueError(f"{self.path}: writer is closed")
        missing = [f for f in self.fields if f not in arrays]
        extra = [f for f in arrays if f not in self.fields]
        if missing or extra:
            raise ValueError(f"write(): expected fields {self.fields}, missing {missing}, "
                             f"unexpected {extra}")
        t = float(t)
        if not (math.isfinite(t) and t > self._last_t):
            raise ValueError(f"write(): time {t!r} must be finite and after the previous "
                             f"snapshot ({self._last_t!r})")
        data = {}
        for name in self.fields:
            a = np.asarray(arrays[name])
            if a.shape != self.shape and not (self.shape[0] == 1 and a.shape == self.shape[1:]):
                raise ValueError(f"write(): {name} has shape {a.shape}, expected {self.shape}")
            data[name] = a.reshape(self.shape)
        i = self.count
        for name, a in data.items():
            self._ds.variables[name][i, :, :] = a
        # time last: a record counts only once all its fields are in
        self._ds.variables["time"][i] = t
        self._ds.sync()
        self.count += 1
        self._last_t = t

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


def read_fields(path):
    """Open a fields file as an :class:`xarray.Dataset` (time stays float seconds)."""
    import xarray as xr
    return xr.open_dataset(path, engine="netcdf4", decode_times=False, decode_timedelta=False)


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


__all__ = ["FieldsWriter", "read_fields", "FIELD_ATTRS"]
