"""Running a calibration: its members on Dask, the misfit, the search and the uncertainty."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from ...backend import available_cores
from ...errors import TisegError
from ..sweep.members import check_member_folder, read_marker, refresh_metrics
from ..sweep.runner import (
    batches,
    close_dask,
    default_batch,
    member_spec,
    open_dask,
    progress_handler,
    submit_tasks,
    task_records,
    worker_count,
)
from ..sweep.spec import PROGRESS_TOPIC, SweepRun, time_index
from .spec import Calibration

# The misfit of a run whose target is undefined (null: no deposit by the end of the run, no
# fingers): larger than any misfit of a run that gives the number, so the search leaves it.
PENALTY = 1e3


class MemberFailed(TisegError):
    """Members of a calibration failed (their run raised, a worker was lost, ...): a failed
    member measured nothing, so the search and the interval stop instead of taking it as a
    number. ``failed``: the evaluations that failed."""

    def __init__(self, failed: list):
        self.failed = list(failed)
        first = self.failed[0]
        more = f" (and {len(self.failed) - 1} more)" if len(self.failed) > 1 else ""
        super().__init__(f"member {first.name!r} failed{more}: {first.error}")


# The finite-difference step of the local sensitivity, as a fraction of each range.
FD_STEP = 0.05
# The search ends when its points are this close, as a fraction of each range.
XATOL = 1e-5


@dataclass
class Evaluation:
    """One member: its values, the targets' numbers it gave, their misfit and why it ran."""

    name: str
    values: dict
    purpose: str  # "search", "sensitivity" or "seed"
    status: str  # done / reused / failed
    outputs: dict = field(default_factory=dict)  # target name -> number (None: undefined)
    misfit: float | None = PENALTY  # None: a failed member, which measured nothing
    error: str | None = None

    def to_dict(self) -> dict:
        return {
            "member": self.name,
            "purpose": self.purpose,
            "status": self.status,
            "values": self.values,
            "outputs": self.outputs,
            "misfit": self.misfit,
            **({"error": self.error} if self.error else {}),
        }


def outputs_of(cal: Calibration, rec: dict) -> dict:
    """The targets' numbers in a member's completion record (its `tiseg fingers` numbers)."""
    metrics = rec.get("metrics") or {}
    deposit = metrics.get("deposit") or {}
    times = metrics.get("time") or []
    i = None if cal.time is None else time_index(times, cal.time)
    out = {}
    for t in cal.targets:
        if t.deposit:
            v = deposit.get(t.name.split(".", 1)[1])
        else:
            series = metrics.get(t.name) or []
            v = series[i] if i is not None and i < len(series) else None
        out[t.name] = None if v is None or not math.isfinite(float(v)) else float(v)
    return out


def misfit(cal: Calibration, outputs: dict) -> float:
    """sqrt(mean(((m_i - y_i) / s_i)^2)) over the targets, s_i the target's tolerance, else
    |y_i|; `PENALTY` where a number is undefined."""
    r = []
    for t in cal.targets:
        m = outputs.get(t.name)
        if m is None:
            return PENALTY
        r.append((m - t.value) / t.scale)
    return float(math.sqrt(sum(x * x for x in r) / len(r)))


class Evaluator:
    """Evaluates points of a calibration as members of a sweep: a folder ``out/<name>`` per
    point (named after its values), reused when a finished run of the same scene is there
    (`tiseg.apps.sweep.members.read_marker`), else run by `execute_run` on Dask; the Dask
    client starts with the first run that is not found finished. ``batch``: points asked for
    at once run up to this many to a task, advanced together (`tiseg sweep --batch`'s
    meaning; None: enough tasks for every worker). ``execute``: run pending members in this
    process with that function instead, one at a time (tests)."""

    def __init__(
        self,
        cal: Calibration,
        out,
        *,
        scheduler=None,
        workers=None,
        threads_per_task=None,
        arch="cpu",
        say: Callable[[str], None] = lambda s: None,
        progress_interval: float = 30.0,
        overwrite: bool = False,
        execute: Callable[[dict], dict] | None = None,
        batch: int | None = None,
    ):
        self.cal, self.out = cal, Path(out)
        self.batch = batch  # points a task advances together (None: as the sweep chooses)
        self.scheduler, self.workers, self.threads_per_task = scheduler, workers, threads_per_task
        self.arch, self.say, self.progress_interval = arch, say, progress_interval
        self.overwrite, self.execute = overwrite, execute
        self.done: dict[str, Evaluation] = {}  # by member name
        self.order: list[Evaluation] = []  # first evaluation of each member
        self.on_batch: Callable[[], None] = lambda: None  # after each finished run
        self._client = self._cluster = self._threads = None

    def evaluate(self, points: list[dict], purpose: str) -> list[Evaluation]:
        """The evaluations of ``points`` (dicts of key -> value), running those not found.

        Raises `MemberFailed` once the batch has finished when a member of it failed: a
        failed member is no number, and the search must not see one (the members that did
        finish are kept, and a calibration run again runs the failed ones again)."""
        runs: list[SweepRun] = [self.cal.run(p) for p in points]
        pending = {}
        for run in runs:
            if run.name in self.done or run.name in pending:
                continue
            rec = read_marker(self.out / run.name, run.scene)
            if rec is not None:
                self._record(
                    run, {**refresh_metrics(self.out / run.name, rec), "status": "reused"}, purpose
                )
            else:
                # never another command's finished member of the same name (a sweep's)
                check_member_folder(
                    self.out / run.name,
                    run.scene,
                    self.overwrite,
                    "choose a new --out, or pass --overwrite to replace it",
                )
                pending[run.name] = run
        if pending:
            for name, rec in self._run(list(pending.values())):
                self._record(pending[name], rec, purpose)
                self.on_batch()  # calibration.json so far: it survives an interruption
        got = [self.done[r.name] for r in runs]
        failed = list({e.name: e for e in got if e.status == "failed"}.values())
        if failed:
            raise MemberFailed(failed)
        return got

    def _record(self, run: SweepRun, rec: dict, purpose: str) -> None:
        status = rec.get("status", "done")
        if status == "busy":
            raise TisegError(
                f"member {run.name!r} is being run by another process ({rec.get('holder')}); "
                "run the calibration again when it has finished"
            )
        ev = Evaluation(run.name, dict(run.values), purpose, status)
        if status == "failed":
            ev.error = rec.get("error") or "failed"
            ev.outputs = {t.name: None for t in self.cal.targets}
            ev.misfit = None
        else:
            ev.outputs = outputs_of(self.cal, rec)
            ev.misfit = misfit(self.cal, ev.outputs)
        self.done[run.name] = ev
        self.order.append(ev)
        shown = ", ".join(f"{k} = {v:.6g}" for k, v in run.values.items())
        what = ev.error if ev.error else f"misfit {ev.misfit:.4g}"
        self.say(f"  {run.name} ({status}): {shown}: {what}")

    def _run(self, runs: list[SweepRun]):
        """(name, completion record) of each run, as they finish."""
        self.out.mkdir(parents=True, exist_ok=True)
        if self.execute is not None:
            for run in runs:
                spec = member_spec(
                    run, self.out, self.arch, self.threads_per_task or 1, self.overwrite
                )
                yield run.name, self.execute({**spec, "reuse": True})
            return
        from distributed import as_completed

        if self._client is None:
            n = self.workers or max(1, min(available_cores(), self._widest_batch()))
            self._client, self._cluster, self._threads, where = open_dask(
                self.scheduler,
                n if self.scheduler is None else None,
                self.threads_per_task,
                n,
                self.say,
            )
            self.say(f"calibration runs on the {where}")
            try:
                self._client.subscribe_topic(
                    PROGRESS_TOPIC, progress_handler(self.say, self.progress_interval)
                )
            except Exception:  # older distributed: no progress events
                pass
        futures = {}
        try:
            # every point of a calibration has the same kernels: the points asked for at
            # once (a design, the sensitivity runs, the seeds) advance together in tasks of
            # up to `batch` (sweep.members.execute_batch), and a worker runs a lone point
            # on the simulation of its last (execute_run's reuse)
            size = self.batch or default_batch(
                runs, worker_count(self._client), self.scheduler is None, self.arch
            )
            futures = submit_tasks(
                self._client,
                batches(runs, size),
                self.out,
                self.arch,
                self._threads,
                self.overwrite,
            )
            for fut in as_completed(list(futures), loop=self._client.loop):
                task = futures[fut]
                # a failed run counts as undefined, the search goes on
                for run, rec in zip(task, task_records(fut, task)):
                    yield run.name, rec
        except BaseException:
            for fut in futures:
                fut.cancel()
            raise

    def _widest_batch(self) -> int:
        """The most runs a calibration asks for at once: its initial design, its sensitivity
        runs or its seeds."""
        p = len(self.cal.params)
        return max(1 if p == 1 else initial_design_size(self.cal), 2 * p, self.cal.seeds - 1)

    def close(self) -> None:
        if self._client is not None:
            try:
                self._client.unsubscribe_topic(PROGRESS_TOPIC)
            except Exception:
                pass
            close_dask(self._client, self._cluster)
            self._client = self._cluster = None


class _Spent(Exception):
    """The search has used its budget of runs."""


def initial_design_size(cal: Calibration) -> int:
    """Points of the Latin hypercube that starts a search of several parameters: 2P + 1, at
    most a third of the budget, at least P + 1 (as many as the budget allows)."""
    p = len(cal.params)
    return max(min(p + 1, cal.budget), min(2 * p + 1, cal.budget // 3))


def search(cal: Calibration, ev: Evaluator) -> tuple[list[Evaluation], str]:
    """Minimise the misfit over the box of the ranges with at most ``cal.budget`` members;
    the evaluations of the search in order and the method, in words.

    One parameter: scipy's bounded Brent method (`scipy.optimize.minimize_scalar`, "bounded").
    Several: a Latin hypercube (`scipy.stats.qmc.LatinHypercube`, seeded) evaluated at once,
    then Nelder-Mead with bounds (`scipy.optimize.minimize`) from its best point. Both work in
    unit coordinates (log ones for a log range) and end at `XATOL` of the ranges, at a run
    that reproduces the targets exactly, or when the budget is spent. Each is deterministic, so a calibration run
    again asks for the same points and finds them finished."""
    from scipy import optimize
    from scipy.stats import qmc

    params = cal.params
    seen: list[Evaluation] = []

    def point(u) -> dict:
        return {p.key: p.value(x) for p, x in zip(params, np.atleast_1d(u))}

    def f(u) -> float:
        values = point(u)
        name = cal.run(values).name
        hit = next((e for e in seen if e.name == name), None)
        if hit is not None:
            return hit.misfit
        if len(seen) >= cal.budget:
            raise _Spent
        e = ev.evaluate([values], "search")[0]
        seen.append(e)
        if e.misfit == 0.0:  # the targets reproduced exactly: nothing left to find
            raise _Spent
        return e.misfit

    if len(params) == 1:
        method = "bounded Brent (scipy.optimize.minimize_scalar, method='bounded')"
        try:
            optimize.minimize_scalar(
                lambda u: f([u]),
                bounds=(0.0, 1.0),
                method="bounded",
                options={"xatol": XATOL, "maxiter": 20 * cal.budget},
            )
        except _Spent:
            pass
        return seen, method
    n0 = initial_design_size(cal)
    method = (
        f"Latin hypercube of {n0} points (scipy.stats.qmc, seed {cal.design_seed}), then "
        "Nelder-Mead with bounds (scipy.optimize.minimize) from its best point"
    )
    design = qmc.LatinHypercube(d=len(params), seed=cal.design_seed).random(n0)
    first = ev.evaluate([point(u) for u in design], "search")
    for e in first:
        if all(e.name != s.name for s in seen):
            seen.append(e)
    if any(e.misfit == 0.0 for e in first):
        return seen, method
    best = min(range(n0), key=lambda i: first[i].misfit)
    u0 = np.array([p.unit(first[best].values[p.key]) for p in params])
    simplex = [u0]
    for j in range(len(params)):  # a step of 0.15 of the range along each axis, inwards
        v = u0.copy()
        v[j] += 0.15 if v[j] <= 0.85 else -0.15
        simplex.append(v)
    try:
        optimize.minimize(
            f,
            u0,
            method="Nelder-Mead",
            bounds=[(0.0, 1.0)] * len(params),
            options={
                "initial_simplex": np.array(simplex),
                "maxfev": 20 * cal.budget,
                "xatol": XATOL,
                "fatol": 1e-12,
            },
        )
    except _Spent:
        pass
    return seen, method


def best_of(evals: list[Evaluation]) -> Evaluation | None:
    """The evaluation of least misfit (the first of equal ones) among the members that
    finished; None when none did."""
    measured = [e for e in evals if e.misfit is not None]
    return min(measured, key=lambda e: e.misfit) if measured else None


def uncertainty(cal: Calibration, ev: Evaluator, best: Evaluation) -> dict:
    """The interval of each parameter around the best point (linearised least squares).

    The sensitivity J_ij = d m_i / d p_j of each target to each parameter by central
    differences over `FD_STEP` of its range around the best point (one-sided at a range's
    end); the spread s_i of each target: its tolerance and the sample standard deviation of
    the target over the seeds (``--seeds N``: the best point run with N seeds) added in
    quadrature, where given, else the best run's residual |m_i - y_i|. The covariance of the parameters is
    (J^T S^-2 J)^-1, S = diag(s_i), and the interval of p_j is p_j +- sqrt of its diagonal,
    cut to the range. For one parameter and one target this is p +- s / |dm/dp|."""
    params, targets = cal.params, cal.targets
    names = [t.name for t in targets]
    pts, pairs = [], []
    for p in params:
        u = p.unit(best.values[p.key])
        up, dn = min(1.0, u + FD_STEP), max(0.0, u - FD_STEP)
        hi = {**best.values, p.key: p.value(up)}
        lo = {**best.values, p.key: p.value(dn)}
        pairs.append((lo, hi))
        pts += [lo, hi]
    evals = ev.evaluate(pts, "sensitivity")
    jac = np.full((len(targets), len(params)), np.nan)
    for j, p in enumerate(params):
        e_lo, e_hi = evals[2 * j], evals[2 * j + 1]
        dp = e_hi.values[p.key] - e_lo.values[p.key]
        for i, n in enumerate(names):
            a, b = e_lo.outputs.get(n), e_hi.outputs.get(n)
            if a is not None and b is not None and dp:
                jac[i, j] = (b - a) / dp

    spread, source = [], []
    seed_values = None
    if cal.seeds >= 2:
        seeds = [cal.base_seed + k for k in range(1, cal.seeds)]
        runs = ev.evaluate([{**best.values, cal.seed_key: s} for s in seeds], "seed")
        seed_values = {n: [best.outputs.get(n)] + [r.outputs.get(n) for r in runs] for n in names}
    for t in targets:
        parts, kinds = [], []
        if t.tolerance:
            parts.append(t.tolerance)
            kinds.append("tolerance")
        if seed_values is not None and None not in seed_values[t.name]:
            parts.append(float(np.std(seed_values[t.name], ddof=1)))
            kinds.append(f"seeds ({cal.seeds})")
        if not parts:
            m = best.outputs.get(t.name)
            parts.append(abs(m - t.value) if m is not None else math.nan)
            kinds.append("residual")
        # independent sources of spread (the measurement's, the model's realisations) add in
        # quadrature
        spread.append(float(math.sqrt(sum(x * x for x in parts))))
        source.append(" + ".join(kinds))

    result = {
        "sensitivity": {
            p.key: {
                n: (None if math.isnan(jac[i, j]) else float(jac[i, j]))
                for i, n in enumerate(names)
            }
            for j, p in enumerate(params)
        },
        "spread": {n: {"value": s, "source": src} for n, s, src in zip(names, spread, source)},
        "seed_values": seed_values,
        "fd_members": [[e.name for e in evals[2 * j : 2 * j + 2]] for j in range(len(params))],
        "params": {},
        "note": None,
    }
    s = np.array(spread, dtype=float)
    if np.isnan(jac).any() or np.isnan(s).any():
        result["note"] = (
            "a target is undefined at the best point or beside it: no interval (widen the "
            "range or lengthen the run)"
        )
        for p in params:
            result["params"][p.key] = {
                "value": best.values[p.key],
                "interval": None,
                "half_width": None,
            }
        return result
    floor = 1e-12 * np.maximum(np.abs([t.value for t in targets]), 1.0)
    weighted = jac / np.maximum(s, floor)[:, None]
    sv = np.linalg.svd(weighted, compute_uv=False)
    determined = len(sv) == len(params) and sv.min() > 1e-10 * max(sv.max(), 1e-300)
    cov = np.linalg.pinv(weighted.T @ weighted) if determined else None
    if not determined:
        result["note"] = (
            "the targets do not determine every parameter near the best point (fewer targets "
            "than parameters, or a parameter the targets do not depend on): no interval"
        )
    elif not s.any():
        result["note"] = (
            "the best run reproduces the targets exactly and no spread is known: the interval "
            "has no width; give a tolerance (NAME=VALUE+-TOL) or --seeds N"
        )
    for j, p in enumerate(params):
        v = best.values[p.key]
        if cov is None:
            result["params"][p.key] = {"value": v, "interval": None, "half_width": None}
            continue
        w = float(math.sqrt(max(cov[j, j], 0.0)))
        result["params"][p.key] = {
            "value": v,
            "interval": [max(p.lo, v - w), min(p.hi, v + w)],
            "half_width": w,
        }
    return result
