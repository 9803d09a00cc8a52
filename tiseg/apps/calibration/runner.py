"""A whole calibration: the folder check, the search, the uncertainty, calibration.json and
the misfit plot."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from ...errors import InputError
from ...log import stderr_line
from ...output import write_json_atomic
from ...output.atomic import remove_stale_temporaries, replacing
from ...output.paths import refuse_symlinks
from ..sweep.runner import SWEEP_OUTPUTS, check_dask_options, create_output_folder
from ..sweep.spec import _canonical
from .search import FD_STEP, PENALTY, Evaluator, MemberFailed, best_of, search, uncertainty
from .spec import Calibration

RESULT_FILE = "calibration.json"
PLOT_FILE = "misfit.png"
CALIBRATION_VERSION = 1
# what makes two calibrations share a folder: the same scene with the same fixed overrides
SAME_KEYS = ("scene", "set")

MISFIT_TEXT = (
    "sqrt(mean_i(((m_i - y_i) / s_i)^2)) over the targets i: m_i the run's number, y_i the "
    "target, s_i its tolerance if given, else |y_i| (a relative residual); "
    f"{PENALTY:g} for a run whose number is undefined"
)
UNCERTAINTY_TEXT = (
    "linearised least squares at the best point: the sensitivity J_ij = dm_i/dp_j by central "
    f"differences over {FD_STEP:g} of each range (one-sided at its ends), the spread s_i of "
    "each target (its tolerance and the standard deviation over the seeds of --seeds, added "
    "in quadrature where given, else the best run's residual |m_i - y_i|), the covariance "
    "(J^T S^-2 J)^-1 with "
    "S = diag(s_i), and the interval p_j +- sqrt(C_jj), cut to the range"
)


@dataclass
class CalibrationResult:
    out: Path
    result: dict  # what calibration.json holds
    plot: Path | None

    @property
    def best(self) -> dict | None:
        """The best values found (of the members that finished), None when none did."""
        return (self.result["best"] or {}).get("values")

    @property
    def complete(self) -> bool:
        """False when members failed and the calibration stopped before its end."""
        return bool(self.result["complete"])


def check_calibration_folder(cal: Calibration, out) -> None:
    """Refuse an ``out`` whose calibration.json is of another scene or other fixed overrides:
    its members would be run again and its result replaced. (Other ranges, targets or budget
    share the folder: their members are reused where the points coincide.)"""
    path = Path(out) / RESULT_FILE
    hint = "choose a new --out, or pass --overwrite"
    sweep = [n for n in SWEEP_OUTPUTS if (Path(out) / n).exists()]
    if sweep:  # a sweep's members share the calibration's folder names
        raise InputError(
            f"--out {str(out)!r} holds a sweep ({', '.join(sweep)}), whose members a "
            f"calibration there could replace; {hint}"
        )
    if not path.exists():
        return
    try:
        stored = json.loads(path.read_text(encoding="utf-8"))["calibration"]
        theirs = {k: stored[k] for k in SAME_KEYS}
    except (OSError, UnicodeDecodeError, ValueError, KeyError, TypeError):
        raise InputError(
            f"--out {str(out)!r} holds a {RESULT_FILE} tiseg cannot read; {hint}"
        ) from None
    ours = json.loads(json.dumps({k: cal.to_dict()[k] for k in SAME_KEYS}))
    if _canonical(theirs) != _canonical(ours):
        raise InputError(
            f"--out {str(out)!r} holds a calibration of another scene or other --set "
            f"overrides; {hint}"
        )


def run_calibration(
    cal: Calibration,
    out,
    *,
    scheduler: str | None = None,
    workers: int | None = None,
    threads_per_task: int | None = None,
    arch: str = "cpu",
    echo: Callable[[str], None] | None = stderr_line,
    report: Callable[[str], None] | None = None,
    progress_interval: float = 30.0,
    overwrite: bool = False,
    batch: int | None = None,
    execute: Callable[[dict], dict] | None = None,
) -> CalibrationResult:
    """Search the parameters of ``cal`` that reproduce its targets, with each point a member
    folder under ``out`` (run on Dask as a sweep's members are, reused when finished), then
    the uncertainty around the best point; writes ``out/calibration.json`` (also after every
    finished run, with ``"complete": false``) and ``out/misfit.png``.

    The options are those of `tiseg.apps.sweep.run_sweep` (``batch``: the points asked for
    at once, an initial design, the sensitivity runs or the seeds, advance together up to
    this many to a task); ``execute`` runs the members in this process with that function
    instead of `tiseg.apps.sweep.execute_run` on Dask."""
    out = Path(out)
    say = echo or (lambda _s: None)
    check_dask_options(workers, scheduler, threads_per_task, batch)
    if not overwrite:
        check_calibration_folder(cal, out)
    create_output_folder(out)
    refuse_symlinks(out, (RESULT_FILE, PLOT_FILE))  # before any run, as `tiseg run` does
    remove_stale_temporaries(out, (RESULT_FILE, PLOT_FILE))  # a killed calibration's
    ev = Evaluator(
        cal,
        out,
        scheduler=scheduler,
        workers=workers,
        threads_per_task=threads_per_task,
        arch=arch,
        say=say,
        progress_interval=progress_interval,
        overwrite=overwrite,
        execute=execute,
        batch=batch,
    )
    state = {"method": None, "best": None, "uncertainty": None, "failed": None}
    ev.on_batch = lambda: write_json_atomic(out / RESULT_FILE, _result(cal, ev, state, False))
    ev.on_batch()  # at once: the folder is a calibration's before its first member runs
    say(
        f"calibrating {', '.join(cal.keys)} of {cal.scene} against "
        f"{', '.join(f'{t.name} = {t.value:g}' for t in cal.targets)}; at most {cal.budget} "
        f"search runs; members in {out}/"
    )
    evals: list = []
    try:
        evals, state["method"] = search(cal, ev)
        best = best_of(evals)
        state["best"] = best
        say(
            f"best: {', '.join(f'{k} = {v:.6g}' for k, v in best.values.items())} "
            f"(misfit {best.misfit:.4g}, {best.name}); the local sensitivity next"
        )
        state["uncertainty"] = uncertainty(cal, ev, best)
    except MemberFailed as exc:
        # a failed member measured nothing: the search stops rather than take it as a
        # number, and the result says so (complete: false); run again to retry it
        state["failed"] = [e.to_dict() for e in exc.failed]
        if state["best"] is None:
            state["best"] = best_of([e for e in ev.order if e.purpose == "search"])
    finally:
        ev.close()
    complete = state["failed"] is None
    result = _result(cal, ev, state, complete)
    write_json_atomic(out / RESULT_FILE, result)
    plot = plot_misfit(cal, result, out / PLOT_FILE)
    tell = report or say  # the results: on stdout from the command line, which -q keeps
    if not complete:
        for f in state["failed"]:
            say(f"  {f['member']} failed: {f.get('error')}")
        say(
            f"calibration incomplete: {len(state['failed'])} member(s) failed, so the search "
            f"stopped; partial results {out / RESULT_FILE} (complete: false). Run it again to "
            "retry the failed members (finished ones are reused), or narrow the --param "
            "ranges if they fail there every time"
        )
        return CalibrationResult(out, result, plot)
    best = state["best"]
    tell(
        f"best: {', '.join(f'{k} = {v:.6g}' for k, v in best.values.items())} (misfit {best.misfit:.4g})"
    )
    for key, u in state["uncertainty"]["params"].items():
        iv = u["interval"]
        span = "no interval" if iv is None else f"interval [{iv[0]:.6g}, {iv[1]:.6g}]"
        tell(f"  {key} = {u['value']:.6g}: {span}")
    if state["uncertainty"]["note"]:
        tell(f"  note: {state['uncertainty']['note']}")
    tell(f"calibration: {len(evals)} search runs; results {out / RESULT_FILE}, plot {plot}")
    return CalibrationResult(out, result, plot)


def _result(cal: Calibration, ev: Evaluator, state: dict, complete: bool) -> dict:
    best = state["best"]
    runs = {}
    for e in ev.order:
        runs[e.status] = runs.get(e.status, 0) + 1
    return {
        "calibration_version": CALIBRATION_VERSION,
        "complete": complete,
        "calibration": cal.to_dict(),
        "method": {
            "search": state["method"],
            "misfit": MISFIT_TEXT,
            "uncertainty": UNCERTAINTY_TEXT,
        },
        "best": None
        if best is None
        else {
            "member": best.name,
            "values": best.values,
            "misfit": best.misfit,
            "outputs": best.outputs,
        },
        "uncertainty": state["uncertainty"],
        "runs": runs,
        # members that failed and stopped the calibration (null: none); each is run again
        # when the calibration is
        "failed": state.get("failed"),
        "evaluations": [e.to_dict() for e in ev.order],
    }


def plot_misfit(cal: Calibration, result: dict, path: Path) -> Path:
    """The misfit of every search run against each parameter (one panel each), the best point
    and its interval."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    evals = [e for e in result["evaluations"] if e["purpose"] == "search"]
    best = result["best"]
    unc = (result.get("uncertainty") or {}).get("params", {})
    n = len(cal.params)
    fig, axes = plt.subplots(1, n, figsize=(4.2 * n, 3.4), squeeze=False)
    for ax, p in zip(axes[0], cal.params):
        xs = [e["values"][p.key] for e in evals]
        ys = [e["misfit"] for e in evals]
        ok = [i for i, y in enumerate(ys) if y is not None and y < PENALTY]
        bad = [i for i in range(len(ys)) if i not in ok]
        sc = ax.scatter(
            [xs[i] for i in ok], [ys[i] for i in ok], c=ok, cmap="viridis", s=22, zorder=3
        )
        if bad:
            top = max([ys[i] for i in ok], default=1.0)
            ax.scatter(
                [xs[i] for i in bad],
                [top] * len(bad),
                marker="x",
                color="0.4",
                zorder=3,
                label="target undefined",
            )
        iv = (unc.get(p.key) or {}).get("interval")
        if iv:
            ax.axvspan(iv[0], iv[1], color="tab:red", alpha=0.15, label="interval")
        if best is not None:
            ax.scatter(
                [best["values"][p.key]],
                [best["misfit"]],
                marker="*",
                s=160,
                color="tab:red",
                zorder=4,
                label="best",
            )
        ax.set_xlim(p.lo, p.hi)
        if p.log:
            ax.set_xscale("log")
        if ok and min(ys[i] for i in ok) > 0:
            ax.set_yscale("log")
        ax.set_xlabel(p.key)
        ax.set_ylabel("misfit")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="best")
    if evals:
        fig.colorbar(sc, ax=axes[0].tolist(), label="search run")
    fig.suptitle(
        "calibration: "
        + ", ".join(
            f"{t.name} = {t.value:g}" + (f" ± {t.tolerance:g}" if t.tolerance else "")
            for t in cal.targets
        ),
        fontsize=9,
    )
    try:  # atomically: a link put at the name is replaced, never written through
        with replacing(path) as tmp:
            fig.savefig(tmp, dpi=110, bbox_inches="tight", format="png")
    finally:
        plt.close(fig)
    return path
