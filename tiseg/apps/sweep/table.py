"""The tables of a sweep: ``sweep.csv`` (one row per run), ``summary.csv`` (ensembles), reading them back."""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path
from typing import Any, Mapping
from .spec import (
    COST_COLUMNS,
    DEPOSIT_METRICS,
    ENSEMBLE_KEYS,
    OUTPUTS,
    FINAL_METRICS,
    SUMMARY_METRICS,
    Sweep,
    SweepRun,
    TIME_METRICS,
    _canonical,
    time_index,
)
from ...output import write_json_atomic, write_text_atomic
from ...output.numbers import measured_text


def table_columns(sweep: Sweep) -> list[str]:
    member = ["member", "block"] if sweep.sample is not None else []
    cols = [
        "run",
        *member,
        *sweep.axes,
        "status",
        "nx",
        "ny",
        "cells",
        "dx",
        "t_final",
        *FINAL_METRICS,
    ]
    cols += [f"deposit_{k}" for k in DEPOSIT_METRICS]
    for t in sweep.times:
        cols += [f"{m}@{t:g}" for m in TIME_METRICS]
    return cols + [*COST_COLUMNS, "dir", "error"]


def table_rows(sweep: Sweep, records: Mapping[str, dict]) -> list[dict]:
    """One row per run (grid order) with the columns of `table_columns`."""
    rows = []
    for run in sweep.runs:
        rec = records.get(run.name)
        row: dict[str, Any] = {
            "run": run.name,
            **{k: _cell(v) for k, v in run.values.items()},
            "member": run.member,
            "block": None if sweep.sample is None else sweep.sample.block(run.member),
            "status": "pending" if rec is None else rec.get("status"),
            "nx": run.scene.domain.nx,
            "ny": run.scene.domain.ny,
            "cells": run.cells,
            "dx": run.scene.dx,
            "dir": run.name,
        }
        if rec is not None:
            m = rec.get("metrics") or {}
            times = m.get("time") or []
            if times:
                row["t_final"] = times[-1]
                for k in FINAL_METRICS:
                    row[k] = (m.get(k) or [None])[-1]
            for k in DEPOSIT_METRICS:
                row[f"deposit_{k}"] = (m.get("deposit") or {}).get(k)
            for t in sweep.times:
                i = time_index(times, t)
                for k in TIME_METRICS:
                    series = m.get(k) or []
                    row[f"{k}@{t:g}"] = series[i] if i is not None and i < len(series) else None
            for k in COST_COLUMNS:
                row[k] = rec.get(k)
            row["error"] = rec.get("error")
        rows.append(row)
    return rows


def member_outputs(rec: Mapping | None) -> dict:
    """The numbers of `OUTPUTS` of one member's completion record (None where undefined, and
    all None for a member that has not finished)."""
    out = dict.fromkeys(OUTPUTS)
    if rec is None or rec.get("status") not in ("done", "reused"):
        return out
    m = rec.get("metrics") or {}
    deposit = m.get("deposit") or {}
    for k in OUTPUTS:
        v = deposit.get(k[8:]) if k.startswith("deposit_") else (m.get(k) or [None])[-1]
        if isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v):
            out[k] = float(v)
    return out


def summary_groups(sweep: Sweep) -> tuple[list[str], list[tuple[dict, list[SweepRun]]]]:
    """(the grid keys that tell ensembles apart, [(their values, the member runs), ...]) in grid
    order: runs that differ only in the keys of `ENSEMBLE_KEYS` form one group."""
    keys = [k for k in sweep.grid if k not in ENSEMBLE_KEYS]
    groups: dict[str, tuple[dict, list]] = {}
    for run in sweep.runs:
        values = {k: run.values[k] for k in keys}
        groups.setdefault(_canonical(values), (values, []))[1].append(run)
    return keys, list(groups.values())


def summary_columns(sweep: Sweep) -> list[str]:
    keys, _ = summary_groups(sweep)
    names = list(SUMMARY_METRICS) + [
        f"{m}@{t:g}" for t in sweep.times for m in SUMMARY_METRICS if m in TIME_METRICS
    ]
    stats = [f"{m}_{s}" for m in names for s in ("mean", "std", "n")]
    return [*keys, "n", "runs", *stats, "wall_s_mean", "wall_s_std"]


def summary_rows(sweep: Sweep, records: Mapping[str, dict]) -> list[dict]:
    """One row per ensemble (see the module docstring): n, mean, sd and count of each metric."""
    import numpy as np

    keys, groups = summary_groups(sweep)
    by_run = {r["run"]: r for r in table_rows(sweep, records)}
    rows = []
    for values, runs in groups:
        done = [by_run[r.name] for r in runs if by_run[r.name]["status"] in ("done", "reused")]
        row: dict[str, Any] = {k: _cell(v) for k, v in values.items()}
        row["n"] = len(done)
        row["runs"] = " ".join(r["run"] for r in done)
        for col in [c[:-5] for c in summary_columns(sweep) if c.endswith("_mean")]:
            vals = np.array(
                [r[col] for r in done if isinstance(r.get(col), (int, float))], dtype=float
            )
            row[f"{col}_mean"] = float(vals.mean()) if vals.size else None
            row[f"{col}_std"] = float(vals.std(ddof=1)) if vals.size > 1 else None
            if col != "wall_s":
                row[f"{col}_n"] = int(vals.size)
        rows.append(row)
    return rows


def _cell(v):
    return v if isinstance(v, (int, float, str)) else _canonical(v)


def _write_outputs(sweep: Sweep, out: Path, records: Mapping[str, dict]) -> Path:
    """Write sweep.csv (the table) and sweep.json (definition and full records) atomically."""

    table = out / "sweep.csv"
    write_text_atomic(table, _csv_text(table_columns(sweep), table_rows(sweep, records)))
    write_text_atomic(
        out / "summary.csv", _csv_text(summary_columns(sweep), summary_rows(sweep, records))
    )
    write_json_atomic(
        out / "sweep.json",
        {
            "sweep": sweep.to_dict(),
            "runs": [
                {"run": r.name, "values": r.values, **records.get(r.name, {"status": "pending"})}
                for r in sweep.runs
            ],
        },
    )
    return table


def _csv_text(cols: list[str], rows: list[dict]) -> str:
    """CSV of rows under the header cols (missing and undefined values as empty cells)."""
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=cols, extrasaction="ignore", lineterminator="\n")
    w.writeheader()
    for row in rows:
        w.writerow({k: _csv_value(row.get(k)) for k in cols})
    return buf.getvalue()


def _csv_value(v) -> str:
    if v is None:
        return ""
    if isinstance(v, float):
        return "" if not math.isfinite(v) else measured_text(v)  # 12 significant digits
    return str(v)


def read_table(path) -> list[dict]:
    """Rows of a sweep.csv with numbers parsed (empty cells -> None)."""
    with open(path, newline="", encoding="utf-8") as fh:
        return [{k: _parse(v) for k, v in row.items()} for row in csv.DictReader(fh)]


def _parse(v: str):
    if v == "":
        return None
    for conv in (int, float):
        try:
            return conv(v)
        except ValueError:
            pass
    return v
