"""What accuracy costs in time: error against wall time on problems with known answers.

``tiseg bench accuracy --out DIR [--quick]`` runs every combination of

* resolution (per problem, below),
* reconstruction: first-order, minmod (theta: ``--thetas``), weno,
* flux: kt, central-upwind (``--fluxes``) and the h phi flux: central, upwind
  (``--phi-fluxes``); by default only the scenes' kt + central,
* stepper: rkc, ssprk3, euler (a run that blows up is recorded as ``unstable``),
* precision: f32, f64 (each in its own process: Taichi's precision is process-wide),
* backend: cpu, and gpu where one is present,

on the verification problems of ``tiseg/data/problems`` (`tiseg.problems`: each file
names its scene, resolutions, end time, exact or reference solution and score; the comment at
its top says what it checks):

``transport``  T6b: smooth large-particle transport, exact by characteristics.
``ritter``     T2: frictionless dam break onto a dry bed, exact Ritter solution.
``growth``     T7: growth rate of the most unstable linear mode of the uniform flow.
``fingers``    the fingers front position x_f^+ at t = 2 s against the finest run.
``fingers-late``  the same front after it has broken into fingers (t = 7.5 s).
``channel``    phi across a straight channel's contacts, exact: unchanged.
``channel-speed``  the channel's u(y) against the steady cross-slope profile.

The study's parts: `accuracy_points` (the numerics varied, the plan),
`accuracy_runner` (one group of points, timed and scored), `accuracy_report` (the
Pareto fronts, the verdict on the defaults, the files); this module runs them and is the
child processes' entry.

Wall time is the time of the simulation alone (Taichi kernels compiled beforehand by one
warm-up step, error evaluation excluded), the minimum over 3 repeats for runs under 1 s and 2
for runs under 5 s (see `REPEATS`). Output: ``accuracy.csv`` (one row per point), one
``<problem>.png`` per problem with the Pareto front (the points no other point beats in both
error and wall time), and ``summary.json`` / ``summary.md`` saying whether the scenes'
defaults (weno + rkc + f64, cfl 0.25) sit on the front.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from . import available_backends, log_stderr, machine_info, machine_line, run_child

# the study's parts, under the names this module has always offered
from .accuracy_points import (  # noqa: F401
    DEFAULT_COMBO,
    DEFAULT_SCHEME,
    LEGACY_SCHEME,
    NUMERICS_KEYS,
    PRECISIONS,
    PROBLEMS,
    QUICK_RECONSTRUCTIONS,
    QUICK_STEPPERS,
    RECONSTRUCTIONS,
    STEPPERS,
    Problem,
    _numerics,
    plan_points,
    scheme_label,
)
from .accuracy_report import (  # noqa: F401
    COLUMNS,
    FRONT_KEYS,
    WORK_KEYS,
    _fill_relative_errors,
    _fmt,
    _is_default,
    _work,
    assess_defaults,
    mark_pareto,
    pareto_front,
    plot_problem,
    read_csv,
    summary_markdown,
    verdict,
    write_csv,
)
from .accuracy_runner import (  # noqa: F401
    REPEATS,
    SPEED_LIMIT,
    STEP_LIMIT,
    _guard,
    _Unstable,
    repeats_for,
    run_group,
    run_points,
)
from ..problems import front_position, transport_exact  # noqa: F401
from ..problems.solutions import channel_cells as _channel_cells  # noqa: F401

# the T6b transport problem's numbers (tiseg/data/problems/transport.toml)
_T6B = PROBLEMS["transport"]
T6B_L, T6B_U0, T6B_AMP, T6B_MEAN = (_T6B.exact[k] for k in ("L", "u0", "amp", "mean"))
T6B_T_END = _T6B.end(quick=False)


def run_study(
    out_dir,
    quick: bool = False,
    problems=None,
    precisions=PRECISIONS,
    backends=None,
    reconstructions=None,
    steppers=None,
    cfls=(0.25,),
    threads: int = 0,
    in_process: bool | None = None,
    log=None,
    fluxes=("kt",),
    phi_fluxes=("upwind",),
    thetas=(1.5,),
) -> dict:
    """Run the study, write accuracy.csv, one PNG per problem and summary.json/.md.

    Each (precision, backend) runs in a child process unless there is only one combination
    and ``in_process`` is not False (then this process's Taichi is used: tests, quick runs)."""
    from .. import backend as _backend
    from ..errors import InputError

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    backends = list(backends) if backends else available_backends()
    for p in precisions:
        if p not in PRECISIONS:
            raise InputError(f"precision {p!r}: choose f32 or f64")
    combos = [(p, b) for b in backends for p in precisions]
    points = plan_points(
        quick, problems, reconstructions, steppers, cfls, fluxes, phi_fluxes, thetas
    )
    # the reference runs (finest fingers run) belong to the default combination if studied
    ref_combo = ("f64", "cpu") if ("f64", "cpu") in combos else combos[0]
    t0 = time.perf_counter()
    rows: list[dict] = []
    if in_process is None:
        in_process = len(combos) == 1
    for prec, be in combos:
        pts = [p for p in points if not p["reference"] or (prec, be) == ref_combo]
        if in_process:
            if len(combos) > 1:
                raise InputError("in-process runs take one precision and one backend")
            if _backend.is_initialised():
                st = _backend.state()
                threads = threads or st.threads
            rows += run_points(pts, quick, prec, be, threads, reinit=False, log=log)
        else:
            res = run_child(
                "tiseg.bench.accuracy",
                {
                    "points": pts,
                    "quick": quick,
                    "precision": prec,
                    "backend": be,
                    "threads": threads,
                },
                out / ".work",
                f"{prec}-{be}",
            )
            rows += res["rows"]
    return write_outputs(
        rows,
        out,
        machine_info(threads),
        quick=quick,
        study_wall_s=time.perf_counter() - t0,
        combinations=[list(c) for c in combos],
    )


def write_outputs(rows: list[dict], out_dir, machine: dict, **extra) -> dict:
    """Score relative errors, mark the Pareto fronts and write accuracy.csv, one PNG per
    problem, summary.json and summary.md into out_dir; return the summary."""
    from ..output import write_json_atomic, write_text_atomic

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    _fill_relative_errors(rows)
    mark_pareto(rows)
    write_csv(rows, out / "accuracy.csv")
    pngs = [
        plot_problem(rows, prob, out / f"{prob}.png", machine_line(machine))
        for prob in dict.fromkeys(r["problem"] for r in rows)
    ]
    assessment = assess_defaults(rows)
    summary = {
        "machine": machine,
        **extra,
        "points": len(rows),
        "assessment": assessment,
        "verdict": verdict(assessment),
        "files": ["accuracy.csv", *[p.name for p in pngs], "summary.json", "summary.md"],
    }
    write_json_atomic(out / "summary.json", summary, indent=2)
    write_text_atomic(out / "summary.md", summary_markdown(rows, assessment, machine))
    return summary


# =================================================================================================
# Child process entry
# =================================================================================================
def _child(task_path: str) -> int:
    task = json.loads(Path(task_path).read_text())

    rows = run_points(
        task["points"],
        task["quick"],
        task["precision"],
        task["backend"],
        task.get("threads", 0),
        reinit=True,
        log=log_stderr,
    )
    Path(task["result"]).write_text(json.dumps({"rows": rows}, default=_json_default))
    return 0


def _json_default(o):
    if isinstance(o, (np.floating, np.integer)):
        return o.item()
    raise TypeError(type(o))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m tiseg.bench.accuracy")
    ap.add_argument("--child", required=True, help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    return _child(a.child)


if __name__ == "__main__":  # pragma: no cover - entered in the child processes
    sys.exit(main())
