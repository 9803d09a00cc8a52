"""How floats are written into tiseg's CSV and JSON files: the digits that matter.

Two kinds of number, two rules:

* **exact** values (`exact_text`): what a run is made of and must read back bit for bit,
  such as the simulated time and the step (a resumed run matches its checkpoint's time against
  ``diagnostics.csv``) and every scene input. They are written as Python's ``repr``: the
  shortest decimal that reads back as the same double (``0.1``, not ``0.1000000000000000055``).
* **measured** values (`measured`): what a run computes from its state, such as finger
  statistics, front positions, wall times and throughputs. Their last binary digits are round-off
  of the computation (a front at cell centre ``(i + 0.5) dx`` reads ``0.43600000000000005``),
  so they are written to `MEASURED_DIGITS` significant digits (``0.436``), far below
  any error of the model or the scheme. Conserved totals (mass) keep
  `CONSERVED_DIGITS`, enough to see a mass balance at round-off.
"""

from __future__ import annotations

import math

import numpy as np

MEASURED_DIGITS = 12
CONSERVED_DIGITS = 15  # DBL_DIG: every 15-digit decimal survives a round trip through a double
# keys whose values are simulated times: exact, so that they match the times in fields.nc
EXACT_KEYS = frozenset({"time", "t", "t_end", "t_final"})


def measured(value, digits: int = MEASURED_DIGITS):
    """``value`` rounded to ``digits`` significant digits, as a Python float; integers, booleans,
    non-finite floats and non-numbers are returned unchanged (NumPy scalars as Python ones)."""
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if not isinstance(value, (float, np.floating)):
        return value
    x = float(value)
    if not math.isfinite(x) or x == 0.0:
        return x
    return float(f"{x:.{int(digits)}g}")


def measured_all(obj, digits: int = MEASURED_DIGITS):
    """A copy of ``obj`` (dicts, lists, tuples, NumPy arrays, nested) with every float rounded
    by `measured`; strings, integers and other values are kept, and so are the values of
    the keys in `EXACT_KEYS` (simulated times, which name snapshots of fields.nc)."""
    if isinstance(obj, dict):
        return {k: obj[k] if k in EXACT_KEYS else measured_all(v, digits) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [measured_all(v, digits) for v in obj]
    if isinstance(obj, np.ndarray):
        return measured_all(obj.tolist(), digits)
    return measured(obj, digits)


def exact_text(value) -> str:
    """The shortest text that reads back as the same double (Python's ``repr``)."""
    return repr(float(value))


def measured_text(value, digits: int = MEASURED_DIGITS) -> str:
    """`measured` as text: the shortest text of the rounded value."""
    return repr(measured(float(value), digits))


__all__ = [
    "MEASURED_DIGITS",
    "CONSERVED_DIGITS",
    "EXACT_KEYS",
    "measured",
    "measured_all",
    "exact_text",
    "measured_text",
]
