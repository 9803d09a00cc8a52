"""What the finger-ensemble benchmarks share: the metrics of a sweep's table, its finished runs,
and the statistics of an ensemble (mean, sd, and the 95 % Welch interval of a difference).

Imported by ``friction_default.py`` and ``split_fingers.py`` (run as scripts from this folder).
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

from scipy import stats

# the finger metrics of a grid-study sweep's table: (column of sweep.csv, label, display scale)
FINGER_METRICS = [
    ("finger_count@7.5", "fingers at 7.5 s", 1.0),
    ("wavelength@7.5", "Λ at 7.5 s [cm]", 100.0),
    ("wavelength_spectral@7.5", "spectral Λ at 7.5 s [cm]", 100.0),
    ("elongation@2.5", "x_l at 2.5 s [m]", 1.0),
    ("elongation@5", "x_l at 5 s [m]", 1.0),
    ("elongation@7.5", "x_l at 7.5 s [m]", 1.0),
    ("channel_speed_over_u0", "channel speed / u0", 1.0),
    ("channel_phi", "channel φ", 1.0),
]


def sweep_rows(path: Path) -> list[dict]:
    """The finished runs of a sweep: its folder's sweep.csv, or that file itself."""
    path = Path(path)
    f = path / "sweep.csv" if path.is_dir() else path
    with open(f, newline="") as fh:
        return [r for r in csv.DictReader(fh) if r["status"] in ("done", "reused")]


def summary(v: list[float]) -> tuple[float, float, int]:
    """Mean, sample sd (nan for one value) and count."""
    n = len(v)
    m = sum(v) / n
    sd = math.sqrt(sum((x - m) ** 2 for x in v) / (n - 1)) if n > 1 else math.nan
    return m, sd, n


def welch(a: list[float], b: list[float]) -> tuple[float, float]:
    """The difference of the means a - b and the half-width of its 95 % Welch interval (0 where
    neither varies, nan where either has fewer than two values)."""
    ma, sa, na = summary(a)
    mb, sb, nb = summary(b)
    if na < 2 or nb < 2:
        return ma - mb, math.nan
    va, vb = sa * sa / na, sb * sb / nb
    se = math.sqrt(va + vb)
    if se == 0.0:
        return ma - mb, 0.0
    dof = (va + vb) ** 2 / (va * va / (na - 1) + vb * vb / (nb - 1))
    return ma - mb, stats.t.ppf(0.975, dof) * se
