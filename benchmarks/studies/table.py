"""The README's study table (markdown) from the sweeps' summary.csv files.

    python benchmarks/studies/table.py runs/sweeps   # the folder holding grid-study/ etc.

Each row is one point of a study: mean ± sd over its seeds at t = 7.5 s (x_l also at 2.5 and
5 s), and the mean wall time per run. Nothing is computed here but formatting.
"""

from __future__ import annotations

import csv
import math
import sys
from pathlib import Path

STUDIES = [
    ("grid", "grid-study", "domain.resolution", lambda v: f"{v:g}/m"),
    ("width (250/m)", "width-study", "domain.Ly", lambda v: f"Ly = {v:g} m"),
    ("ν (500/m)", "nu-study", "flow.nu", lambda v: f"{v:g}"),
]


def _pm(row, key, fmt, scale=1.0, sd_fmt=None) -> str:
    """mean ± sd of a summary column (sd 0 is written 0: the seeds agreed exactly)."""
    m, s = row.get(f"{key}_mean", ""), row.get(f"{key}_std", "")
    if m in ("", None):
        return "-"
    m = float(m) * scale
    s = float(s) * scale if s not in ("", None) else math.nan
    if math.isnan(s):
        return f"{m:{fmt}}"
    return f"{m:{fmt}} ± " + ("0" if s == 0 else f"{s:{sd_fmt or fmt}}")


def _count(row, key) -> str:
    return _pm(row, key, ".3g", sd_fmt=".1f")


def rows(folder: Path) -> list[str]:
    out = []
    for label, name, key, show in STUDIES:
        path = folder / name / "summary.csv"
        if not path.is_file():
            continue
        with open(path, newline="", encoding="utf-8") as fh:
            for r in csv.DictReader(fh):
                if not r.get("wall_s_mean"):  # a point with no finished run yet
                    continue
                cells = [
                    label,
                    show(float(r[key])),
                    _count(r, "finger_count"),
                    _pm(r, "wavelength", ".3g", 100, ".2f"),
                    _pm(r, "wavelength_spectral", ".2f", 100),
                    _pm(r, "elongation@2.5", ".3f"),
                    _pm(r, "elongation@5", ".3f"),
                    _pm(r, "elongation", ".3f"),
                    _pm(r, "channel_speed_over_u0", ".2f"),
                    _pm(r, "channel_phi", ".2f"),
                    _pm(r, "levee_speed_over_u0", ".2f"),
                    f"{float(r['wall_s_mean']):.0f}",
                ]
                out.append("| " + " | ".join(cells) + " |")
    return out


HEADER = (
    "| study | point | fingers | Λ [cm] | Λ_spec [cm] | x_l 2.5 s [m] | x_l 5 s [m] | "
    "x_l 7.5 s [m] | channel \\|u\\|/u0 | channel φ | levee \\|u\\|/u0 | wall [s] |\n"
    "|---|---|---|---|---|---|---|---|---|---|---|---|"
)

if __name__ == "__main__":
    print(HEADER)
    print("\n".join(rows(Path(sys.argv[1] if len(sys.argv) > 1 else "runs/sweeps"))))
