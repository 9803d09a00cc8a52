"""Probability maps of a sweep: ``OUT/probability.nc`` from the members' peak fields.

A ``[probability]`` table in the sweep file asks for them::

    [probability]
    h_thresholds = [0.0005, 0.001, 0.002]      # [m], thresholds of the peak thickness h_max
    speed_thresholds = [0.1, 0.5]              # [m/s], thresholds of the peak speed speed_max

Every finished member of the sweep (status done or reused: each grid combination and each
sample point once, all with the same weight) contributes its ``fields.nc`` peak fields
(`tiseg.run.peaks`): ``h_max``, ``speed_max`` and ``arrival_time`` on the common (y, x) grid.
Over these N members, per cell:

* ``p_h_max_above(h_threshold, y, x)``: the fraction of members with h_max > threshold
  (strictly above);
* ``p_speed_max_above(speed_threshold, y, x)``: the fraction with speed_max > threshold; a
  member the flow never reached there (speed_max missing) counts as not above;
* ``h_max_mean(y, x)`` and ``h_max_quantile(quantile_level, y, x)``: the mean and the 5 %, 50 % and
  95 % quantiles of h_max over all N members (h_max is 0 where a member stayed empty);
* ``p_arrival(y, x)``: the fraction of members in which the flow reached the cell
  (arrival_time given: h >= numerics.h_min at some step, the wet threshold of section 6.2);
* ``arrival_time_mean(y, x)`` and ``arrival_time_quantile(quantile_level, y, x)``: the mean and the
  quantiles of arrival_time over the members in which the flow reached the cell only (the
  arrival time given that it arrives), missing where it reached the cell in no member. Read
  them with ``p_arrival``: a 5 % quantile of 0.2 s where p_arrival = 0.1 says that in the few
  members where the flow came, it came after about 0.2 s.

Quantiles are numpy's default, linear interpolation between the order statistics (Hyndman and
Fan's definition 7). The members counted are listed in ``run(member)``. Members that ran on
terrain lend the file their bed ``b(y, x)`` and ``solid(y, x)`` (the static fields of their
fields.nc), so that the maps are drawn over the relief (`tiseg.post.render.probability`); only
when every member has the same bed, else (a sweep over the terrain) none, with a log line.

The members must share one grid, which `check_probability` checks before any run (a sweep over
``domain.resolution`` cannot be stacked per cell), and keep their peak fields
(``output.peak_fields``, on by default). A member whose fields.nc lacks the peak fields (a run
made before they existed) is left out, with a log line naming it.
"""

from __future__ import annotations

from ...output.names import FIELDS_FILE, PROBABILITY_FILE

import datetime as _dt
import difflib
import logging
import math
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Mapping

import numpy as np

from ..._version import __version__
from ...output.atomic import replacing
from ...output.fields import OUTPUT_FIELDS

PROBABILITY_KEYS = ("h_thresholds", "speed_thresholds")
QUANTILES = (0.05, 0.5, 0.95)
# the peak fields of a member's fields.nc that the maps are drawn from (tiseg.run.peaks)
MEMBER_FIELDS = ("h_max", "speed_max", "arrival_time")
# the terrain's static fields of a member's fields.nc, carried over when the members share them
BED_FIELDS = ("b", "solid")
# the keys that decide a member's grid: members differing in any cannot be stacked per cell
GRID_KEYS = ("Lx", "Ly", "nx", "ny")

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Probability:
    """A validated ``[probability]`` table: the thresholds, ascending."""

    h_thresholds: tuple[float, ...] = ()
    speed_thresholds: tuple[float, ...] = ()

    def to_dict(self) -> dict:
        return {
            "h_thresholds": list(self.h_thresholds),
            "speed_thresholds": list(self.speed_thresholds),
        }


_UNITS = {"h_thresholds": ("m", "0.001"), "speed_thresholds": ("m/s", "0.1")}


def parse_probability(table: Any, fail: Callable[[str], None]) -> Probability:
    """Read the ``[probability]`` table; ``fail(message)`` raises the one-line error."""
    if not isinstance(table, Mapping):
        fail("[probability] must be a table such as [probability] h_thresholds = [0.001, 0.002]")
    for key in table:
        if key not in PROBABILITY_KEYS:
            close = difflib.get_close_matches(str(key), PROBABILITY_KEYS, n=1)
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            fail(
                f"[probability] unknown key {key!r}{hint}; allowed keys: "
                f"{', '.join(PROBABILITY_KEYS)}"
            )
    if not any(k in table for k in PROBABILITY_KEYS):
        fail(
            "[probability] needs h_thresholds [m] or speed_thresholds [m/s] (or both), "
            "e.g. h_thresholds = [0.001, 0.002]"
        )
    out = {}
    for key in PROBABILITY_KEYS:
        values = table.get(key, [])
        unit, example = _UNITS[key]
        if not isinstance(values, list) or (key in table and not values):
            fail(f"[probability] {key} = {values!r}: give a non-empty list of thresholds [{unit}]")
        for v in values:
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                fail(
                    f"[probability] {key} lists {v!r}: thresholds are finite numbers [{unit}], "
                    f"e.g. {key} = [{example}]"
                )
            if v <= 0:
                fail(f"[probability] {key} lists {v!r}: thresholds must be above 0 [{unit}]")
        floats = [float(v) for v in values]
        dup = next((v for v in floats if floats.count(v) > 1), None)
        if dup is not None:
            fail(f"[probability] {key} lists {dup!r} more than once")
        out[key] = tuple(sorted(floats))
    return Probability(**out)


def check_probability(runs, fail: Callable[[str], None]) -> None:
    """Refuse ``[probability]`` before anything runs where the members cannot be stacked cell
    by cell: their grids differ (domain Lx, Ly, nx or ny), or one keeps no peak fields."""
    first = None
    for run in runs:
        dom = run.scene.domain
        if not run.scene.output.peak_fields:
            fail(
                f"[probability] needs the members' peak fields, but run {run.name!r} has "
                "output.peak_fields = false; remove that override"
            )
        if first is None:
            first = run
            continue
        ref = first.scene.domain
        for k in GRID_KEYS:
            a, b = getattr(ref, k), getattr(dom, k)
            if a != b:
                fail(
                    f"[probability] stacks the members cell by cell, but their grids differ "
                    f"(domain.{k} = {a:g} in run {first.name!r}, {b:g} in run {run.name!r}); "
                    "keep the grid fixed (no domain.resolution, nx, ny, Lx or Ly in [grid] or "
                    "[sample]) or drop [probability]"
                )


# =================================================================================================
# The maps
# =================================================================================================
def read_members(sweep, records: Mapping[str, dict], out: Path):
    """The peak fields of the finished members: (names, {field: array (N, ny, nx)}, (x, x
    attributes), (y, y attributes), names left out, bed), or None when no member has them or
    their grids differ (a line is logged). Each run of the sweep is read at most once, and a
    member counts only when all of its fields were read: one whose file lacks a field or
    cannot be read is left out whole (a logged line names it). ``bed``: {"b": (ny, nx),
    "solid": (ny, nx)} of the members' terrain when all of them have the same, else None."""
    import netCDF4

    from ...output.netcdf import COORD_ATTRS

    names: list[str] = []
    left_out: list[str] = []  # finished members whose peak fields could not all be read
    stacks: dict[str, list] = {k: [] for k in MEMBER_FIELDS}
    beds: list[dict] = []  # each member's static terrain fields ({} on a flat plane)
    grid = None
    for run in sweep.runs:
        rec = records.get(run.name)
        if rec is None or rec.get("status") not in ("done", "reused"):
            continue
        path = Path(out) / run.name / FIELDS_FILE
        try:
            with netCDF4.Dataset(path, "r") as ds:
                missing = [
                    k
                    for k in MEMBER_FIELDS
                    if k not in ds.variables or ds[k].dimensions != ("y", "x")
                ]
                if missing:
                    log.warning(
                        "probability.nc: member %s is left out: its fields.nc has no %s",
                        run.name,
                        ", ".join(missing),
                    )
                    left_out.append(run.name)
                    continue
                x, y = np.asarray(ds["x"][:], float), np.asarray(ds["y"][:], float)
                if grid is None:
                    grid = (
                        (x, dict(COORD_ATTRS["x"])),
                        (y, dict(COORD_ATTRS["y"])),
                    )
                elif (
                    x.shape != grid[0][0].shape
                    or y.shape != grid[1][0].shape
                    or not (np.allclose(x, grid[0][0]) and np.allclose(y, grid[1][0]))
                ):
                    log.warning(
                        "no probability.nc: the members' grids differ (member %s), so their "
                        "peak fields cannot be stacked cell by cell",
                        run.name,
                    )
                    return None
                # every field of the member is read before any is kept: a read failure on
                # the second must not leave the first stacked (the stacks would misalign)
                fields = {}
                for k in MEMBER_FIELDS:
                    v = ds[k]
                    v.set_auto_mask(True)
                    fields[k] = np.ma.filled(np.ma.asarray(v[:], dtype=float), np.nan)
                bed = {
                    k: np.asarray(ds[k][:])
                    for k in BED_FIELDS
                    if k in ds.variables and ds[k].dimensions == ("y", "x")
                }
        except (OSError, RuntimeError, KeyError, IndexError, ValueError) as exc:
            log.warning(
                "probability.nc: member %s is left out: cannot read the peak fields of %s: %s",
                run.name,
                path,
                exc,
            )
            left_out.append(run.name)
            continue
        for k in MEMBER_FIELDS:
            stacks[k].append(fields[k])
        beds.append(bed)
        names.append(run.name)
    if not names:
        log.warning("no probability.nc: no finished member has peak fields")
        return None
    stacked = {k: np.stack(v) for k, v in stacks.items()}
    return names, stacked, grid[0], grid[1], left_out, _common_bed(beds, names)


def _common_bed(beds: list[dict], names: list[str]) -> dict | None:
    """The members' terrain fields when every member has the same (None on a flat plane);
    None with a log line when they differ (a sweep over the terrain has no one relief)."""

    def same(a: dict, b: dict) -> bool:
        return a.keys() == b.keys() and all(np.array_equal(a[k], b[k]) for k in a)

    first = beds[0]
    other = next((n for n, bed in zip(names[1:], beds[1:]) if not same(bed, first)), None)
    if other is not None:
        log.warning(
            "probability.nc holds no bed: the terrains of members %s and %s differ, so the "
            "maps are drawn without relief",
            names[0],
            other,
        )
        return None
    return first if "b" in first else None


def probability_maps(h_max, speed_max, arrival_time, probability: Probability) -> dict:
    """The maps of the module docstring from stacks of shape (N, ny, nx) (NaN: missing) as
    plain arrays: name -> array."""
    h_max = np.asarray(h_max, float)
    speed = np.asarray(speed_max, float)
    arrival = np.asarray(arrival_time, float)
    n = h_max.shape[0]
    q = np.asarray(QUANTILES)
    out = {
        # NaN > t is False: a missing speed (never reached) is not above any threshold
        "p_h_max_above": np.stack([(h_max > t).sum(0) / n for t in probability.h_thresholds])
        if probability.h_thresholds
        else None,
        "p_speed_max_above": np.stack(
            [(speed > t).sum(0) / n for t in probability.speed_thresholds]
        )
        if probability.speed_thresholds
        else None,
    }
    with warnings.catch_warnings():  # an all-missing column: NaN, as documented
        warnings.simplefilter("ignore", RuntimeWarning)
        out["h_max_mean"] = np.nanmean(h_max, axis=0)
        out["h_max_quantile"] = np.nanquantile(h_max, q, axis=0)
        reached = np.isfinite(arrival)
        out["p_arrival"] = reached.sum(0) / n
        out["arrival_time_mean"] = np.nanmean(arrival, axis=0)
        out["arrival_time_quantile"] = np.nanquantile(arrival, q, axis=0)
    return {k: v for k, v in out.items() if v is not None}


ATTRS = {
    "p_h_max_above": {
        "long_name": "probability that the peak flow thickness h_max exceeds h_threshold",
        "units": "1",
        "comment": "fraction of the members with h_max > h_threshold in the cell",
    },
    "p_speed_max_above": {
        "long_name": "probability that the peak speed speed_max exceeds speed_threshold",
        "units": "1",
        "comment": "fraction of the members with speed_max > speed_threshold in the cell; a "
        "member the flow never reached there counts as not above",
    },
    "h_max_mean": {
        "long_name": "mean over the members of the peak flow thickness h_max",
        "units": "m",
        "comment": "over all members; h_max is 0 where a member stayed empty",
    },
    "h_max_quantile": {
        "long_name": "quantile over the members of the peak flow thickness h_max",
        "units": "m",
        "comment": "over all members; linear interpolation between order statistics",
    },
    "p_arrival": {
        "long_name": "probability that the flow reaches the cell, h >= h_min at some step",
        "units": "1",
        "comment": "fraction of the members whose arrival_time is given in the cell",
    },
    "arrival_time_mean": {
        "long_name": "mean arrival time over the members in which the flow reached the cell",
        "units": "s",
        "comment": "conditional on arrival (see p_arrival); missing where no member's flow "
        "reached the cell; seconds since t = 0 of the runs",
    },
    "arrival_time_quantile": {
        "long_name": "quantile of the arrival time over the members in which the flow "
        "reached the cell",
        "units": "s",
        "comment": "conditional on arrival (see p_arrival); linear interpolation between "
        "order statistics; missing where no member's flow reached the cell",
    },
}
DIMS = {
    "p_h_max_above": ("h_threshold", "y", "x"),
    "p_speed_max_above": ("speed_threshold", "y", "x"),
    "h_max_quantile": ("quantile_level", "y", "x"),
    "arrival_time_quantile": ("quantile_level", "y", "x"),
}


def probability_dataset(sweep, records: Mapping[str, dict], out: Path):
    """The `xarray.Dataset` of ``probability.nc``, or None (with a logged line) when no
    member can be stacked (see `read_members`)."""
    import xarray as xr

    prob = sweep.probability
    got = read_members(sweep, records, out)
    if got is None:
        return None
    names, fields, (x, xa), (y, ya), left_out, bed = got
    maps = probability_maps(fields["h_max"], fields["speed_max"], fields["arrival_time"], prob)
    coords = {
        "x": ("x", x, xa),
        "y": ("y", y, ya),
        "quantile_level": (
            "quantile_level",
            np.asarray(QUANTILES),
            {"long_name": "probability level of the quantile over the members", "units": "1"},
        ),
    }
    if prob.h_thresholds:
        coords["h_threshold"] = (
            "h_threshold",
            np.asarray(prob.h_thresholds),
            {"long_name": "threshold of the peak flow thickness h_max", "units": "m"},
        )
    if prob.speed_thresholds:
        coords["speed_threshold"] = (
            "speed_threshold",
            np.asarray(prob.speed_thresholds),
            {"long_name": "threshold of the peak speed speed_max", "units": "m s-1"},
        )
    data = {k: (DIMS.get(k, ("y", "x")), v, ATTRS[k]) for k, v in maps.items()}
    for k, v in (bed or {}).items():  # the members' terrain: the maps are drawn over it
        spec = OUTPUT_FIELDS[k]
        data[k] = (("y", "x"), v.astype(spec.dtype or "f8"), dict(spec.attrs))
    data["run"] = (
        "member",
        np.array(names, dtype=object),
        {"long_name": "run folder of a member the maps are drawn from"},
    )
    now = _dt.datetime.now(_dt.timezone.utc).replace(microsecond=0).isoformat()
    n, total = len(names), len(sweep.runs)
    attrs = {
        "Conventions": "CF-1.8",
        "title": f"tiseg probability maps of sweep {sweep.name}",
        "summary": f"exceedance probabilities, means and quantiles per cell of the peak fields "
        f"of {n} of the {total} members of sweep {sweep.name}",
        "source": f"tiseg {__version__}: tiseg sweep of scene {sweep.scene}",
        "history": f"{now} created by tiseg {__version__}",
        "comment": "every finished member weighs the same; probabilities are fractions of the "
        "members; quantiles interpolate linearly between order statistics; arrival-time "
        "statistics are over the members in which the flow reached the cell (p_arrival)",
        "members": n,
        # finished members whose peak fields could not all be read (named in the log too)
        "members_left_out": ", ".join(left_out) if left_out else "none",
    }
    return xr.Dataset(data, coords=coords, attrs=attrs)


def write_probability(sweep, out: Path, records: Mapping[str, dict]) -> Path | None:
    """Write ``OUT/probability.nc`` (atomically) for a sweep with ``[probability]``; return
    its path, or None when the sweep asks for none or no member can be stacked."""
    if getattr(sweep, "probability", None) is None:
        return None
    ds = probability_dataset(sweep, records, Path(out))
    if ds is None:
        return None
    encoding = {
        name: {"_FillValue": np.nan, **({"zlib": True, "complevel": 4} if var.ndim > 1 else {})}
        for name, var in ds.data_vars.items()
        if var.dtype.kind == "f"
    }
    for name in ds.coords:
        encoding[name] = {"_FillValue": None}
    path = Path(out) / PROBABILITY_FILE
    with replacing(path) as tmp:
        ds.to_netcdf(tmp, engine="netcdf4", encoding=encoding)
    return path
