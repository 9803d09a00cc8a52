"""Per-step diagnostics as CSV, and atomic text files.

The CSV is flushed after every row so that a running or killed simulation can be followed with
``tail -f`` and read back with :func:`read_diagnostics`.
"""
from __future__ import annotations

import csv
import json
import math
from pathlib import Path
from typing import Sequence

import numpy as np

from .atomic import replacing

DEFAULT_COLUMNS = ("time", "dt", "stages", "mass", "small_mass", "max_speed", "wall_time")


class DiagnosticsWriter:
    """CSV with a header row and one row per :meth:`write`.

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
        unknown = [k for k in values if k not in self.columns]
        if unknown:
            raise ValueError(f"write(): unknown columns {unknown}; columns are {self.columns}")
        self._writer.writerow([_format(values.get(c)) for c in self.columns])
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


def _format(v) -> str:
    if v is None:
        return ""
    if isinstance(v, (bool, np.bool_)):
        return str(int(v))
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        return repr(float(v))        # shortest string that round-trips exactly
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
    return out


def write_text_atomic(path, text: str) -> Path:
    """Write ``text`` to ``path`` via a temporary file in the same folder and ``os.replace``, so
    that readers see either the old or the new content, never a half-written file."""
    path = Path(path)
    with replacing(path) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return path


def write_json_atomic(path, obj, **json_kw) -> Path:
    """:func:`write_text_atomic` of ``obj`` as JSON (non-finite floats become null)."""
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


__all__ = ["DiagnosticsWriter", "read_diagnostics", "DEFAULT_COLUMNS", "write_text_atomic",
           "write_json_atomic", "json_clean"]
