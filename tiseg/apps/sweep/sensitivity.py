"""Sobol' sensitivity indices of a sweep's outputs from its ``method = "sobol"`` sample.

For an output y and the members of the Saltelli design (`tiseg.apps.sweep.design`: blocks A,
B and AB_i of n members each), with V the variance of y over A and B together:

* first-order index  S_i  = mean(y_B (y_ABi - y_A)) / V        (Saltelli et al. 2010, eq (b))
* total index        ST_i = mean((y_A - y_ABi)^2) / (2 V)      (Jansen 1999)

S_i is the share of the variance of y explained by key i alone, ST_i the share key i takes part
in (alone or with others): ST_i near 0 means the key does not matter, ST_i - S_i is its share
through interactions. The indices are scipy.stats.sobol_indices' (these estimators, its
``saltelli_2010``), given the design's outputs, and so are those of each bootstrap resample (all resamples in one
call, as SciPy's outputs axis). The confidence intervals are a percentile bootstrap over the n
design rows (resampling A, B and every AB_i row together) from a generator seeded by the
sample's seed, so that the same sweep gives the same ``sensitivity.csv``. SciPy's own
``SobolResult.bootstrap()`` is not used: it draws from an unseeded generator, its BCa intervals
need a jackknife that a design of 2 or 4 rows cannot give, and its percentiles are not
nan-aware (a resample of a small design that repeats one row has no variance).

Outputs are those of `tiseg.apps.sweep.spec.OUTPUTS` (the finger metrics at the final time and
the deposit's numbers). An output that is undefined in some member (a wavelength without
fingers, a run-out of a flow that never stopped) or that is the same in every member has no
indices: its rows say why in ``note``.
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Mapping

import numpy as np

from ...output.atomic import replacing
from .design import Sample
from .spec import OUTPUTS, Sweep
from .table import _cell, member_outputs, summary_groups

CONFIDENCE = 0.95
RESAMPLES = 1000
SENSITIVITY_COLUMNS = (
    "output",
    "parameter",
    "n",
    "members",
    "S1",
    "S1_low",
    "S1_high",
    "ST",
    "ST_low",
    "ST_high",
    "note",
)

log = logging.getLogger(__name__)


def indices(f_a: np.ndarray, f_b: np.ndarray, f_ab: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """First-order and total indices (S, ST) by scipy.stats.sobol_indices, each of shape
    (d, ...), from the outputs on A and B (shape (n, ...)) and on AB_i (shape (d, n, ...)):
    the leading n axis is the design's rows, the trailing axes are outputs estimated apart."""
    from scipy.stats import sobol_indices

    n, d, rest = f_a.shape[0], f_ab.shape[0], f_a.shape[1:]
    # SciPy's layout: outputs first, rows last; (s, n) for A and B, (d, s, n) for AB
    a = f_a.reshape(n, -1).T
    b = f_b.reshape(n, -1).T
    ab = np.moveaxis(f_ab.reshape(d, n, -1), 1, 2)
    with np.errstate(divide="ignore", invalid="ignore"):
        res = sobol_indices(func={"f_A": a, "f_B": b, "f_AB": ab}, n=n)
    s1, st = (
        np.reshape(v, (-1, d)).T.reshape(d, *rest) for v in (res.first_order, res.total_order)
    )
    return s1, st


def sobol_analysis(
    sample: Sample,
    y,
    *,
    confidence: float = CONFIDENCE,
    resamples: int = RESAMPLES,
    seed: int | None = None,
) -> dict:
    """Indices of one output ``y`` (one value per member of the "sobol" design, in member
    order) with bootstrap intervals: ``{"S1", "S1_low", "S1_high", "ST", "ST_low",
    "ST_high"}``, arrays over the sample's keys. ``seed``: of the bootstrap (default: the
    sample's)."""
    if sample.method != "sobol":
        raise ValueError(f"Sobol' indices need a 'sobol' sample, not {sample.method!r}")
    y = np.asarray(y, dtype=float)
    n, d = sample.n, len(sample.ranges)
    if y.shape != (n * (d + 2),):
        raise ValueError(f"expected {n * (d + 2)} outputs (n (d + 2)), got {y.shape}")
    f_a, f_b, f_ab = y[:n], y[n : 2 * n], y[2 * n :].reshape(d, n)
    s1, st = indices(f_a, f_b, f_ab)
    rng = np.random.default_rng(sample.seed if seed is None else seed)
    rows = rng.integers(0, n, size=(resamples, n)).T  # (n, resamples): resampled design rows
    bs1, bst = indices(f_a[rows], f_b[rows], f_ab[:, rows])  # (d, resamples)
    lo, hi = 50 * (1 - confidence), 50 * (1 + confidence)
    # nan-aware: a resample of a small design that repeats one row has no variance
    return {
        "S1": s1,
        "S1_low": np.nanpercentile(bs1, lo, axis=1),
        "S1_high": np.nanpercentile(bs1, hi, axis=1),
        "ST": st,
        "ST_low": np.nanpercentile(bst, lo, axis=1),
        "ST_high": np.nanpercentile(bst, hi, axis=1),
    }


def sensitivity_rows(sweep: Sweep, records: Mapping[str, dict]) -> list[dict]:
    """Rows of ``sensitivity.csv``: per grid combination (its keys first), per output of
    `OUTPUTS`, per sampled key; [] unless the sweep has a "sobol" sample."""
    sample = sweep.sample
    if sample is None or sample.method != "sobol":
        return []
    keys, groups = summary_groups(sweep)
    rows = []
    for values, runs in groups:
        outs = [member_outputs(records.get(r.name)) for r in runs]
        head = {k: _cell(v) for k, v in values.items()}
        for name in OUTPUTS:
            y = [o[name] for o in outs]
            missing = sum(v is None for v in y)
            note = None
            if missing:
                note = f"undefined in {missing} of {len(y)} members"
            elif max(y) == min(y):
                note = "the same in every member: no variance to share out"
            res = None if note else sobol_analysis(sample, y)
            for j, key in enumerate(sample.keys):
                row = {**head, "output": name, "parameter": key, "n": sample.n}
                row["members"] = len(y) - missing
                if res is not None:
                    row.update({c: float(res[c][j]) for c in res})
                row["note"] = note
                rows.append(row)
    return rows


def sensitivity_columns(sweep: Sweep) -> list[str]:
    keys, _ = summary_groups(sweep)
    return [*keys, *SENSITIVITY_COLUMNS]


def plot_sensitivity(sweep: Sweep, rows: list[dict], out: Path, dpi: int = 100) -> list[Path]:
    """Bar charts of S1 and ST with their intervals, one panel per output that has indices:
    ``sensitivity.png`` (or one ``sensitivity-<grid values>.png`` per grid combination)."""
    from matplotlib.figure import Figure  # no pyplot: the caller's backend is left alone

    keys, groups = summary_groups(sweep)
    params = sweep.sample.keys
    paths = []
    for values, runs in groups:
        mine = [r for r in rows if all(r.get(k) == _cell(v) for k, v in values.items())]
        outputs = [
            o for o in OUTPUTS if any(r["output"] == o and r.get("S1") is not None for r in mine)
        ]
        if not outputs:
            continue
        ncol = min(3, len(outputs))
        nrow = -(-len(outputs) // ncol)
        fig = Figure(figsize=(3.2 * ncol + 0.6, 2.6 * nrow + 0.6), layout="tight")
        axes = fig.subplots(nrow, ncol, squeeze=False)
        x = np.arange(len(params))
        for ax, name in zip(axes.flat, outputs):
            by = {r["parameter"]: r for r in mine if r["output"] == name}
            for shift, idx, label in ((-0.18, "S1", "first order"), (0.18, "ST", "total")):
                v = np.array([by[p][idx] for p in params])
                err = np.abs(
                    np.array([[by[p][f"{idx}_low"], by[p][f"{idx}_high"]] for p in params]).T - v
                )
                ax.bar(x + shift, v, 0.36, yerr=err, capsize=3, label=label)
            ax.set_xticks(x, [p.rsplit(".", 1)[-1] for p in params])
            ax.axhline(0, color="0.5", lw=0.6)
            ax.set_title(f"{name} [{OUTPUTS[name][1]}]", fontsize=9)
            ax.set_ylim(min(-0.05, ax.get_ylim()[0]), max(1.05, ax.get_ylim()[1]))
        for ax in list(axes.flat)[len(outputs) :]:
            ax.axis("off")
        axes.flat[0].legend(fontsize=8)
        where = ", ".join(f"{k} = {v}" for k, v in values.items())
        fig.suptitle(
            f"Sobol' indices of sweep {sweep.name!r}{' at ' + where if where else ''} "
            f"({int(100 * CONFIDENCE)} % bootstrap intervals, n = {sweep.sample.n})",
            fontsize=10,
        )
        name = (
            "sensitivity.png"
            if not keys
            else f"sensitivity-{runs[0].name.rsplit('_member-', 1)[0]}.png"
        )
        path = out / name
        # atomically: a link put at the name is replaced, never written through
        with replacing(path) as tmp:
            fig.savefig(tmp, dpi=dpi, format="png")
        paths.append(path)
    return paths
