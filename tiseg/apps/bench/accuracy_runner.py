"""One point of the accuracy study, timed and scored: a simulation per group of points that
differ only in the stepper, repeated for the minimum wall time, guarded against runs that blow
up."""

from __future__ import annotations

import math
import time
from typing import Sequence

import numpy as np

from .accuracy_points import DEFAULT_SCHEME, PROBLEMS, _numerics, scheme_label
from ...errors import TisegError
from ...solver.timestepping import stepper_for
from ... import backend


# On a shared machine other jobs steal cores at random moments and a parallel kernel waits for
# its slowest thread, so single timings scatter by 2-3x; the minimum over a few repeats is what
# the code costs without interference. Short runs are repeated more often (they are cheap).
REPEATS = ((1.0, 3), (5.0, 2))  # (runs shorter than this many seconds, are timed this often)


def repeats_for(wall: float) -> int:
    """How many timed repeats a run of this (best so far) wall time gets."""
    for limit, n in REPEATS:
        if wall < limit:
            return n
    return 1


SPEED_LIMIT = 10.0  # [m/s] nothing in these problems moves faster: beyond it a run blew up
STEP_LIMIT = 200_000


class _Unstable(Exception):
    pass


def _guard(sim):
    """on_step callback that stops a run that blew up (non-finite or absurd speeds, or a step
    count that means dt collapsed)."""

    def on_step(info):
        spd = sim.last_stability.max_speed
        if not math.isfinite(spd) or spd > SPEED_LIMIT or not math.isfinite(info.dt):
            raise _Unstable(f"speed {spd!r} at t = {sim.t:.4g}")
        if sim.stats.steps > STEP_LIMIT:
            raise _Unstable("too many steps")

    return on_step


def _blank_row(point: dict, scene, precision: str, backend_name: str) -> dict:
    row = {k: point[k] for k in ("problem", "resolution", "reconstruction", "stepper", "cfl")}
    row.update({k: point.get(k, DEFAULT_SCHEME[k]) for k in ("theta", "flux", "phi_flux")})
    row.update(
        precision=precision,
        backend=backend_name,
        cells=scene.domain.nx * scene.domain.ny,
        error=float("nan"),
        value=float("nan"),
        wall_s=float("nan"),
        steps=0,
        rhs_evals=0,
        status="reference" if point.get("reference") else "ok",
    )
    return row


def _group_key(point: dict) -> tuple:
    """Points differing only in the stepper share one simulation (and its compiled kernels)."""
    return (
        point["problem"],
        point["resolution"],
        *(point.get(k, DEFAULT_SCHEME[k]) for k in ("reconstruction", "theta", "flux", "phi_flux")),
        point["cfl"],
        point.get("reference", False),
    )


def run_group(points: Sequence[dict], quick: bool, precision: str, backend_name: str) -> list[dict]:
    """Time and score points that differ only in the stepper, in this process.

    The operator's kernels do not depend on the stepper, so one Simulation is built (with RKC,
    which needs the most state slots) and its stepper swapped per point: compiling costs
    seconds per simulation, more than most of these runs. Each point is warmed up (its
    combination kernels and the field export compile on first use), then reset and timed."""
    from ...run.simulation import Simulation

    p0 = points[0]
    prob = PROBLEMS[p0["problem"]]
    scene = prob.build(p0["resolution"], _numerics(p0, "rkc"), quick)
    rows = [_blank_row(p, scene, precision, backend_name) for p in points]
    try:
        sim = Simulation(scene, precision=precision)
    except TisegError as exc:
        for r in rows:
            r.update(status="unstable", note=str(exc)[:200])
        return rows
    for point, row in zip(points, rows):
        sim.stepper = stepper_for(scene.numerics, point["stepper"])
        try:
            sim.reset()
            sim.step()
            sim.fields()
            best, raw, k = math.inf, None, 0
            while True:
                sim.reset()
                guard = _guard(sim)
                t0 = time.perf_counter()
                raw = prob.run(sim, guard)
                best = min(best, time.perf_counter() - t0)
                k += 1
                if k >= repeats_for(best):
                    break
            row.update(wall_s=best, steps=sim.stats.steps, rhs_evals=sim.stats.stages)
            value, err = prob.score(raw, scene)
            row.update(value=value, error=err)
            finite = math.isfinite(value) if prob.reference_resolution else math.isfinite(err)
            if not finite:
                row["status"] = "unstable"
        except (_Unstable, TisegError, FloatingPointError, np.linalg.LinAlgError) as exc:
            row.update(status="unstable", note=str(exc)[:200])
    return rows


def run_points(
    points: Sequence[dict],
    quick: bool,
    precision: str,
    backend_name: str = "cpu",
    threads: int = 0,
    reinit: bool = False,
    log=None,
) -> list[dict]:
    """All points for one (precision, backend) in this process, in the given order.

    ``reinit``: re-initialise Taichi before each simulation (children do, so that the fields
    of hundreds of simulations do not pile up in one runtime); in-process callers keep theirs."""

    groups: dict[tuple, list[int]] = {}
    for i, pt in enumerate(points):
        groups.setdefault(_group_key(pt), []).append(i)
    rows: list[dict | None] = [None] * len(points)
    backend.init(backend_name, precision, threads)
    done = 0
    for g, idx in enumerate(groups.values()):
        if reinit and g:
            backend.init(backend_name, precision, threads, force=True)
        for i, row in zip(idx, run_group([points[i] for i in idx], quick, precision, backend_name)):
            rows[i] = row
            done += 1
            if log is not None:
                log(
                    f"[{precision}/{backend_name} {done}/{len(points)}] {row['problem']} "
                    f"{row['resolution']} {scheme_label(row)} {row['stepper']}: "
                    f"error {row['error']:.3g} wall {row['wall_s']:.3g} s {row['status']}"
                )
    return rows
