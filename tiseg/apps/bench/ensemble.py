"""Ensemble throughput: members × cells × stages per second of a seed ensemble.

The ensemble row of ``tiseg bench gpu``. M members of the fingers scene that differ in their
inflow seed run as a sweep batch does (`tiseg.apps.sweep.members.execute_batch`): together,
on one operator with a member axis (`tiseg.run.batch.Batch`: one launch a stage for all of
them), once to compile the kernels (not timed) and then again from their initial states. No
output folder: the number is the members' steps alone. The throughput counted is

    sum over members of (cells × stages) / wall,

with ``stages`` the operator evaluations of the member's run (sweeps and viscous stages of a
split step, RKC stages), so that a GPU's number can be held against the issue's target of
20 G cell-stages/s with 64 members at 250 cells/m. Each (backend, precision) runs in a child
process of its own (Taichi's precision is fixed at initialisation).
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

from . import run_child
from ...errors import TisegError

#: how the members advance (the row says so)
MODE = "together: one launch a stage for all members"


def measure(arch: str, precision: str, members: int, resolution: float, t_end: float) -> dict:
    """Run the ensemble in this process (Taichi initialised here) and return its row."""
    from ...run.batch import Batch
    from ...run.simulation import Simulation
    from ...setup.scene import load_scene

    sets = {"domain.resolution": resolution, "time.t_end": t_end, "output.times": []}
    scenes = [load_scene("fingers", {**sets, "inflow.seed": m + 1}) for m in range(members)]
    if members > 1:
        batch = Batch(scenes, arch=arch, precision=precision)
        sims = batch.sims
    else:
        batch, sims = None, [Simulation(scenes[0], arch=arch, precision=precision)]

    def run_all() -> list:
        return batch.run() if batch is not None else [sims[0].run(progress=False)]

    run_all()  # compiles every kernel of the run: not timed
    for sim in sims:
        sim.reset()
    t0 = time.perf_counter()
    stats = run_all()
    wall = time.perf_counter() - t0
    for s in stats:
        if isinstance(s, Exception):
            raise s
    sim = sims[0]
    cell_stages = sum(sim.layout.nx * sim.layout.ny * s.stages for s in stats)
    steps = sum(s.steps for s in stats)
    return {
        "arch": sim.backend.arch,
        "precision": precision,
        "members": members,
        "resolution": resolution,
        "t_end": t_end,
        "cells": sim.layout.nx * sim.layout.ny,
        "steps": steps,
        "wall_s": wall,
        "member_cell_stages_per_s": cell_stages / wall,
        "mode": MODE,
    }


def ensemble_rows(arch: str, members: int, resolution: float, t_end: float, work: Path) -> list:
    """The ensemble's row on the CPU and on ``arch``, each in f32 and f64 (a failure, e.g. a
    precision the device lacks, is a row with ``ok`` False and the error)."""
    rows = []
    for be in ["cpu"] + ([arch] if arch != "cpu" else []):
        for prec in ("f32", "f64"):
            task = {
                "arch": be,
                "precision": prec,
                "members": members,
                "resolution": resolution,
                "t_end": t_end,
            }
            try:
                row = run_child(__name__, task, work, f"ensemble-{be}-{prec}")
                rows.append({"backend": be, "ok": True, **row})
            except TisegError as exc:  # the child's own messages went to stderr
                rows.append({"backend": be, "precision": prec, "ok": False, "error": str(exc)})
    return rows


def _child(task_path: str) -> int:
    task = json.loads(Path(task_path).read_text())
    row = measure(
        task["arch"], task["precision"], task["members"], task["resolution"], task["t_end"]
    )
    Path(task["result"]).write_text(json.dumps(row))
    return 0


if __name__ == "__main__":
    if len(sys.argv) == 3 and sys.argv[1] == "--child":
        sys.exit(_child(sys.argv[2]))
    sys.exit("usage: python -m tiseg.apps.bench.ensemble --child TASK.json")


__all__ = ["measure", "ensemble_rows", "MODE"]
