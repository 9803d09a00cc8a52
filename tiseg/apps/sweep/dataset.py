"""A sweep's results as one CF-1.8 NetCDF dataset: ``OUT/sweep.nc``.

Layout:

* A grid: one dimension per grid key, named by the key with its dots as underscores
  (``flow.nu`` -> ``flow_nu``; the attribute ``scene_key`` keeps the dotted name), its values as
  the coordinate. ``xr.open_dataset("sweep.nc").wavelength.sel(flow_nu=0.01)`` picks a run.
* A sample: a dimension ``member`` (the design's index, `tiseg.apps.sweep.design`) with each
  sampled key as a coordinate along it (``flow_nu(member)``), after the grid's dimensions when
  the sweep has both.
* The outputs of `tiseg.apps.sweep.spec.OUTPUTS` (finger metrics at the final time, the
  deposit's numbers) as variables over those dimensions, with units and long names, NaN
  (``_FillValue``) where undefined or not finished; the metrics of `TIME_METRICS` at the
  sweep's extra ``times`` as ``<metric>_at_time`` with the further dimension ``output_time``;
  the run costs; ``run`` (the member's folder) and ``status`` (CF flags).
* Per-member peak fields: where the members' ``fields.nc`` hold ``h_max``, ``speed_max``,
  ``arrival_time``, ``deposit_h`` or ``deposit_phi`` (2D, without a time axis), they are
  stacked into variables of the member dimensions and ``y``, ``x`` (NaN for members without
  them), with each member's ``peak_time`` (the time up to which they hold). Members on
  different grids cannot be stacked: the fields are then left out (logged).
"""

from __future__ import annotations

from ...output.names import FIELDS_FILE

import datetime as _dt
import json
import logging
import math
import re
from pathlib import Path
from typing import Mapping

import numpy as np

from ..._version import __version__
from ...output.atomic import replacing
from .spec import OUTPUTS, TIME_METRICS, Sweep, _canonical, time_index
from .table import member_outputs

# the 2D fields without a time axis of a run's fields.nc (tiseg.run.peaks)
PEAK_FIELDS = ("h_max", "speed_max", "arrival_time", "deposit_h", "deposit_phi")
STATUS_FLAGS = ("pending", "done", "reused", "failed", "busy", "missing")
COSTS = {
    "wall_s": ("simulation wall time", "s"),
    "steps": ("time steps", "1"),
    "rhs_evaluations": ("operator evaluations", "1"),
}
TIME_UNITS = {
    "finger_count": "1",
    "wavelength": "m",
    "wavelength_spectral": "m",
    "elongation": "m",
    "x_front_max": "m",
    "x_front_min": "m",
    "channel_speed_over_u0": "1",
}

log = logging.getLogger(__name__)


def dim_name(key: str) -> str:
    """A scene key as a NetCDF/CF name: letters, digits and underscores (``flow.nu`` ->
    ``flow_nu``)."""
    name = re.sub(r"[^A-Za-z0-9_]", "_", key)
    return name if name[:1].isalpha() else f"k_{name}"


def _coord_values(values: list):
    """A grid axis as coordinate values: numbers as float (int when all are), others as text."""
    if all(isinstance(v, bool) for v in values):
        return np.array([int(v) for v in values], dtype="i1")
    if all(isinstance(v, int) and not isinstance(v, bool) for v in values):
        return np.array(values, dtype="i8")
    if all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values):
        return np.array(values, dtype="f8")
    return np.array([v if isinstance(v, str) else _canonical(v) for v in values], dtype=object)


def _with_units(attrs: dict, key: str, values=None) -> dict:
    """``attrs`` with the CF ``units`` of the scene key ``key`` where it declares one (and its
    values are numbers): a plot or a CF reader shows them."""
    from ...setup.sections import key_units

    units = key_units(key)
    numeric = values is None or all(
        isinstance(v, (int, float)) and not isinstance(v, bool) for v in values
    )
    return {**attrs, "units": units} if units is not None and numeric else attrs


def sweep_dataset(sweep: Sweep, records: Mapping[str, dict], out: Path | None = None):
    """The `xarray.Dataset` of ``sweep.nc`` (see the module docstring). ``out``: the sweep
    folder, where the members' fields.nc are read for their peak fields (None: none)."""
    import xarray as xr

    dims = [dim_name(k) for k in sweep.grid]
    shape = [len(v) for v in sweep.grid.values()]
    coords: dict = {}
    for key, values in sweep.grid.items():
        coords[dim_name(key)] = (
            dim_name(key),
            _coord_values(values),
            _with_units({"long_name": f"scene key {key}", "scene_key": key}, key, values),
        )
    sample = sweep.sample
    if sample is not None:
        dims.append("member")
        shape.append(sample.size)
        points = sample.points()
        coords["member"] = (
            "member",
            np.arange(sample.size, dtype="i4"),
            {"long_name": f"member of the {sample.method} sample design"},
        )
        for r in sample.ranges:
            coords[dim_name(r.key)] = (
                "member",
                np.array([p[r.key] for p in points]),
                _with_units(
                    {
                        "long_name": f"scene key {r.key}",
                        "scene_key": r.key,
                        "sample_range": [r.lo, r.hi],
                        "sample_log_uniform": int(r.log),
                    },
                    r.key,
                ),
            )
        if sample.method == "sobol":
            coords["design_block"] = (
                "member",
                np.array([sample.block(i) for i in range(sample.size)], dtype=object),
                {"long_name": "block of the Saltelli design: A, B or AB<i> (the i-th key from B)"},
            )
    shape = tuple(shape)
    runs = np.empty(shape, dtype=object).reshape(-1)
    status = np.zeros(runs.size, dtype="i1")
    outputs = {k: np.full(runs.size, np.nan) for k in OUTPUTS}
    costs = {k: np.full(runs.size, np.nan) for k in COSTS}
    series = {k: np.full((len(sweep.times), runs.size), np.nan) for k in TIME_METRICS}
    for i, run in enumerate(sweep.runs):  # grid order with the members last: C order of dims
        rec = records.get(run.name)
        runs[i] = run.name
        st = "pending" if rec is None else rec.get("status", "missing")
        status[i] = STATUS_FLAGS.index(st) if st in STATUS_FLAGS else STATUS_FLAGS.index("missing")
        for k, v in member_outputs(rec).items():
            if v is not None:
                outputs[k][i] = v
        if rec is None or st not in ("done", "reused"):
            continue
        for k in COSTS:
            v = rec.get(k)
            if isinstance(v, (int, float)) and not isinstance(v, bool):
                costs[k][i] = v
        m = rec.get("metrics") or {}
        for j, t in enumerate(sweep.times):
            ti = time_index(m.get("time") or [], t)
            for k in TIME_METRICS:
                s = m.get(k) or []
                v = s[ti] if ti is not None and ti < len(s) else None
                if isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v):
                    series[k][j, i] = v

    data: dict = {}
    for k, (long_name, units) in OUTPUTS.items():
        data[k] = (dims, outputs[k].reshape(shape), {"long_name": long_name, "units": units})
    if sweep.times:
        coords["output_time"] = (
            "output_time",
            np.array(sweep.times),
            {"long_name": "simulated time of the tabulated metrics", "units": "s"},
        )
        for k in TIME_METRICS:
            data[f"{k}_at_time"] = (
                ["output_time", *dims],
                series[k].reshape((len(sweep.times), *shape)),
                {"long_name": f"{k} at the output time", "units": TIME_UNITS[k]},
            )
    for k, (long_name, units) in COSTS.items():
        data[k] = (dims, costs[k].reshape(shape), {"long_name": long_name, "units": units})
    data["run"] = (dims, runs.reshape(shape), {"long_name": "run folder of the member"})
    data["status"] = (
        dims,
        status.reshape(shape),
        {
            "long_name": "state of the member",
            "flag_values": np.arange(len(STATUS_FLAGS), dtype="i1"),
            "flag_meanings": " ".join(STATUS_FLAGS),
        },
    )
    if out is not None:
        peaks = _peak_fields(sweep, records, Path(out))
        if peaks is not None:
            (x, xa), (y, ya), fields, peak_time = peaks
            coords["x"] = ("x", x, xa)
            coords["y"] = ("y", y, ya)
            if not np.isnan(peak_time).all():
                data["peak_time"] = (
                    dims,
                    peak_time.reshape(shape),
                    {"long_name": "time up to which the member's peak fields hold", "units": "s"},
                )
            for k, (arr, attrs) in fields.items():
                data[k] = ([*dims, "y", "x"], arr.reshape((*shape, y.size, x.size)), attrs)

    now = _dt.datetime.now(_dt.timezone.utc).replace(microsecond=0).isoformat()
    attrs = {
        "Conventions": "CF-1.8",
        "title": f"tiseg sweep {sweep.name}",
        "summary": sweep.description or f"results of the members of sweep {sweep.name}",
        "source": f"tiseg {__version__}: tiseg sweep of scene {sweep.scene}",
        "history": f"{now} created by tiseg {__version__}",
        "sweep": json.dumps(sweep.to_dict() | {"runs": len(sweep.runs)}, default=str),
    }
    return xr.Dataset(data, coords=coords, attrs=attrs)


def _peak_fields(sweep: Sweep, records: Mapping[str, dict], out: Path):
    """((x, attrs), (y, attrs), {name: (array (runs, ny, nx), attrs)}) of the members' peak
    fields, or None when no member has any or their grids differ."""
    import netCDF4

    from ...output.netcdf import COORD_ATTRS

    found: dict[int, dict] = {}
    peak_time = np.full(len(sweep.runs), np.nan)
    grid = None
    attrs: dict = {}
    for i, run in enumerate(sweep.runs):
        rec = records.get(run.name)
        if rec is None or rec.get("status") not in ("done", "reused"):
            continue
        path = out / run.name / FIELDS_FILE
        try:
            with netCDF4.Dataset(path, "r") as ds:
                names = [
                    n for n in PEAK_FIELDS if n in ds.variables and ds[n].dimensions == ("y", "x")
                ]
                if not names:
                    continue
                x, y = np.asarray(ds["x"][:], float), np.asarray(ds["y"][:], float)
                if grid is None:
                    grid = (
                        x,
                        y,
                        dict(COORD_ATTRS["x"]),
                        dict(COORD_ATTRS["y"]),
                    )
                elif (
                    x.shape != grid[0].shape
                    or y.shape != grid[1].shape
                    or not (np.allclose(x, grid[0]) and np.allclose(y, grid[1]))
                ):
                    log.warning(
                        "sweep.nc: the members' peak fields are left out (their grids differ)"
                    )
                    return None
                # all of the member's fields are read before any is kept: one that fails
                # leaves the member without peak fields, not with some of them
                got, got_attrs, t_peak = {}, {}, np.nan
                if "peak_time" in ds.variables and ds["peak_time"].size == 1:
                    t_peak = float(np.ma.filled(ds["peak_time"][:], np.nan).ravel()[0])
                for n in names:
                    v = ds[n]
                    v.set_auto_mask(True)
                    got[n] = np.ma.filled(np.ma.asarray(v[:], dtype=float), np.nan)
                    got_attrs[n] = {
                        a: v.getncattr(a)
                        # not cell_methods: it names the member file's peak_time
                        for a in ("long_name", "units", "standard_name", "comment")
                        if a in v.ncattrs()
                    }
        except (OSError, RuntimeError, KeyError, IndexError, ValueError) as exc:
            log.warning("sweep.nc: cannot read the peak fields of %s: %s", path, exc)
            continue
        found[i], peak_time[i] = got, t_peak
        for n, a in got_attrs.items():
            attrs.setdefault(n, a)
    if not found:
        return None
    x, y, xa, ya = grid
    fields = {}
    for n in PEAK_FIELDS:
        if n not in attrs:
            continue
        arr = np.full((len(sweep.runs), y.size, x.size), np.nan)
        for i, got in found.items():
            if n in got:
                arr[i] = got[n]
        fields[n] = (arr, attrs[n])
    return (x, xa), (y, ya), fields, peak_time


def write_dataset(sweep: Sweep, out: Path, records: Mapping[str, dict]) -> Path:
    """Write ``OUT/sweep.nc`` (atomically) and return its path."""
    ds = sweep_dataset(sweep, records, out)
    encoding = {
        name: {"_FillValue": np.nan, **({"zlib": True, "complevel": 4} if var.ndim > 1 else {})}
        for name, var in ds.variables.items()
        if var.dtype.kind == "f" and name not in ds.coords
    }
    for name in ds.coords:
        encoding[name] = {"_FillValue": None}
    path = Path(out) / "sweep.nc"
    with replacing(path) as tmp:
        ds.to_netcdf(tmp, engine="netcdf4", encoding=encoding)
    return path
