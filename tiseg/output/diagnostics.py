"""Per-step diagnostics as CSV, and atomic text files.

The CSV is flushed after every row so that a running or killed simulation can be followed with
``tail -f`` and read back with `read_diagnostics`. Its units are stated beside it in
``diagnostics.csv-metadata.json``, a W3C "CSV on the Web" metadata file (the name CSVW tools
look for next to a CSV): per column a title, a description with the unit, the datatype and
``"unit"`` (`write_units`). The columns of a run (`DEFAULT_COLUMNS`):

======================== ======================================================================
``time``                 simulated time at the end of the step [s]
``dt``                   the step [s] (0 on the row of the initial state)
``stages``               operator evaluations of the step (RKC stages) [1]
``mass``                 total mass, the integral of h [m^3] (per metre of width in 1D: [m^2])
``small_mass``           integral of h phi [m^3] (1D: [m^2])
``max_speed``            max |u| over the wet cells at the start of the step [m/s]
``wall_time_cumulative`` wall time since the run started, resumed runs included [s]
======================== ======================================================================

Floats are written with the digits that matter (`tiseg.output.numbers`): ``time``, ``dt``
and ``max_speed``, which make the steps (a resume matches the time against its checkpoint), as
the shortest text that reads back exactly; ``mass`` and ``small_mass`` to 15 significant digits
(a mass balance stays visible at round-off); ``wall_time_cumulative`` to 12.

Files written before the column was renamed call it ``wall_time``; `read_diagnostics`
returns both names for either file, and a resumed old run keeps its old header.
"""

from __future__ import annotations

from .names import UNITS_SUFFIX

import csv
import json
import math
from pathlib import Path
from typing import Sequence

import numpy as np

from .atomic import replacing
from .numbers import CONSERVED_DIGITS, MEASURED_DIGITS, measured

DEFAULT_COLUMNS = (
    "time",
    "dt",
    "stages",
    "mass",
    "small_mass",
    "max_speed",
    "wall_time_cumulative",
)
# significant digits of a column's floats (columns not named here: exact, shortest repr)
DIGITS = {
    "mass": CONSERVED_DIGITS,
    "small_mass": CONSERVED_DIGITS,
    "wall_time_cumulative": MEASURED_DIGITS,
    "wall_time": MEASURED_DIGITS,
}
# new name -> the name older files use for the same column
ALIASES = {"wall_time_cumulative": "wall_time"}
# column -> (unit in 2D, unit in 1D, description)
UNITS = {
    "time": ("s", "s", "simulated time at the end of the step"),
    "dt": ("s", "s", "time step (0 on the row of the initial state)"),
    "stages": ("1", "1", "operator evaluations of the step (RKC stages)"),
    "mass": ("m3", "m2", "total mass: integral of the thickness h over the chute"),
    "small_mass": ("m3", "m2", "small-particle mass: integral of h phi"),
    "max_speed": ("m/s", "m/s", "largest |u| over wet cells at the start of the step"),
    "wall_time_cumulative": (
        "s",
        "s",
        "wall time since the run started (resumed runs continue it), cumulative",
    ),
}


class DiagnosticsWriter:
    """CSV with a header row and one row per `write`.

    ``columns``: the column names (the defaults: time [s], dt [s], RKC stages, mass = integral
    of h [m^3], small_mass = integral of h phi [m^3], max_speed [m/s], wall_time [s]); ``extra``
    appends columns to them. A value left out of a row is written as an empty cell (read back as
    NaN); an unknown column name is an error.
    """

    def __init__(self, path, columns: Sequence[str] = DEFAULT_COLUMNS, extra: Sequence[str] = ()):
        self.path = Path(path)
        self.columns = tuple(columns) + tuple(extra)
        if not self.columns or len(set(self.columns)) != len(self.columns):
            raise ValueError(f"columns={self.columns!r}: need distinct, non-empty column names")
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._fh = open(self.path, "w", newline="", encoding="utf-8")
        self._writer = csv.writer(self._fh)
        self._writer.writerow(self.columns)
        self._fh.flush()
        self.rows = 0

    def write(self, **values) -> None:
        if self._fh is None:
            raise ValueError(f"{self.path}: writer is closed")
        for new_name, old_name in ALIASES.items():  # a resumed file with old names
            if new_name in values and new_name not in self.columns and old_name in self.columns:
                values[old_name] = values.pop(new_name)
        unknown = [k for k in values if k not in self.columns]
        if unknown:
            raise ValueError(f"write(): unknown columns {unknown}; columns are {self.columns}")
        self._writer.writerow([_format(values.get(c), DIGITS.get(c)) for c in self.columns])
        self._fh.flush()
        self.rows += 1

    def close(self) -> None:
        if self._fh is not None:
            self._fh.close()
            self._fh = None

    def __enter__(self) -> "DiagnosticsWriter":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _format(v, digits: int | None = None) -> str:
    """A cell: integers as such, floats as the shortest text that reads back exactly, or
    rounded to ``digits`` significant digits first."""
    if v is None:
        return ""
    if isinstance(v, (bool, np.bool_)):
        return str(int(v))
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        v = float(v) if digits is None else measured(v, digits)
        return repr(v)  # shortest string that round-trips exactly
    return str(v)


def read_diagnostics(path) -> dict[str, np.ndarray]:
    """Columns of a diagnostics CSV as numpy arrays (float; empty cells are NaN). A column that
    is not numeric is returned as an array of strings. A partly written last line (a killed run)
    is dropped."""
    with open(path, newline="", encoding="utf-8") as fh:
        rows = list(csv.reader(fh))
    if not rows:
        raise ValueError(f"{path}: empty diagnostics file (no header)")
    header, body = rows[0], rows[1:]
    body = [r for r in body if len(r) == len(header)]
    out = {}
    for j, name in enumerate(header):
        col = [r[j] for r in body]
        try:
            out[name] = np.array([float(c) if c != "" else math.nan for c in col], dtype=float)
        except ValueError:
            out[name] = np.array(col, dtype=str)
    for new_name, old_name in ALIASES.items():  # both names, for old and new files
        if new_name in out and old_name not in out:
            out[old_name] = out[new_name]
        elif old_name in out and new_name not in out:
            out[new_name] = out[old_name]
    return out


def write_units(csv_path, columns: Sequence[str], one_d: bool = False) -> Path:
    """Write ``<csv>-metadata.json`` (CSV on the Web) stating each column's unit and meaning;
    the units of mass are per metre of width in a 1D run (``one_d``). Columns not in
    `UNITS` are listed without a unit."""
    csv_path = Path(csv_path)
    cols = []
    for c in columns:
        unit_2d, unit_1d, text = UNITS.get(c, (None, None, ""))
        unit = unit_1d if one_d else unit_2d
        col = {"name": c, "titles": c, "datatype": "integer" if c == "stages" else "double"}
        if unit is not None:
            col["dc:description"] = f"{text} [{unit}]"
            col["unit"] = unit
        cols.append(col)
    meta = {
        "@context": "http://www.w3.org/ns/csvw",
        "url": csv_path.name,
        "dc:title": "tiseg per-step diagnostics",
        "tableSchema": {"columns": cols},
    }
    return write_json_atomic(csv_path.with_name(csv_path.name + UNITS_SUFFIX), meta)


# a gauge column's quantity (the part after the gauge's name) -> (unit, description)
GAUGE_UNITS = {
    "h": ("m", "flow thickness"),
    "u": ("m/s", "depth-averaged downslope velocity"),
    "v": ("m/s", "depth-averaged cross-slope velocity"),
    "phi": ("1", "depth-averaged small-particle concentration (empty: no material)"),
}


def write_gauge_units(csv_path, columns: Sequence[str]) -> Path:
    """``gauges.csv-metadata.json`` (CSV on the Web): per column ``<gauge>_<quantity>`` its
    unit and meaning (tiseg.run.gauges); ``time`` as in diagnostics.csv."""
    csv_path = Path(csv_path)
    cols = []
    for c in columns:
        if c == "time":
            unit, text = "s", "simulated time at the end of the step"
        else:
            gauge, quantity = c.rsplit("_", 1)
            unit, what = GAUGE_UNITS[quantity]
            text = f"{what} at gauge {gauge}, interpolated bilinearly"
        cols.append(
            {
                "name": c,
                "titles": c,
                "datatype": "double",
                "dc:description": f"{text} [{unit}]",
                "unit": unit,
            }
        )
    meta = {
        "@context": "http://www.w3.org/ns/csvw",
        "url": csv_path.name,
        "dc:title": "tiseg gauges: h, u, v, phi at points after every step",
        "tableSchema": {"columns": cols},
    }
    return write_json_atomic(csv_path.with_name(csv_path.name + UNITS_SUFFIX), meta)


def write_text_atomic(path, text: str) -> Path:
    """Write ``text`` to ``path`` via a temporary file in the same folder and ``os.replace``, so
    that readers see either the old or the new content, never a half-written file."""
    path = Path(path)
    with replacing(path) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return path


def write_json_atomic(path, obj, **json_kw) -> Path:
    """`write_text_atomic` of ``obj`` as JSON (non-finite floats become null)."""
    json_kw.setdefault("indent", 2)
    return write_text_atomic(path, json.dumps(json_clean(obj), **json_kw) + "\n")


def json_clean(obj):
    """A JSON-safe copy: NumPy scalars and arrays become Python values, non-finite floats
    become null (JSON has no inf/nan), paths become strings."""
    if isinstance(obj, (float, np.floating)):
        f = float(obj)
        return f if math.isfinite(f) else None
    if isinstance(obj, (bool, np.bool_)):
        return bool(obj)
    if isinstance(obj, (int, np.integer)):
        return int(obj)
    if isinstance(obj, dict):
        return {str(k): json_clean(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [json_clean(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return json_clean(obj.tolist())
    if isinstance(obj, Path):
        return str(obj)
    return obj


__all__ = [
    "DiagnosticsWriter",
    "read_diagnostics",
    "write_units",
    "write_gauge_units",
    "DEFAULT_COLUMNS",
    "UNITS",
    "write_text_atomic",
    "write_json_atomic",
    "json_clean",
]
