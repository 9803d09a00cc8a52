"""Sweep members in batches (`tiseg sweep --batch`, `tiseg.apps.sweep.members.execute_batch`):
members that share their compiled kernels advance together on one operator, and each
member's fields, diagnostics and metrics are bitwise those of the member run alone."""

from __future__ import annotations

import csv
import shutil
import json
from pathlib import Path

import numpy as np
import pytest

from tests.solver_helpers import exit_code
from tiseg.apps.sweep import load_sweep
from tiseg.apps.sweep import members
from tiseg.apps.sweep.members import compiled_fingerprint, execute_batch, execute_run
from tiseg.apps.sweep import runner
from tiseg.apps.sweep.runner import batch_size, batches, member_spec

ROOT = Path(__file__).resolve().parents[1]
TINY = ROOT / "tiseg" / "data" / "sweeps" / "tiny.toml"
# the diagnostics columns that measure the machine, not the run
WALL_COLUMNS = {"wall_time_cumulative"}


def _fields(path: Path) -> dict:
    import netCDF4

    with netCDF4.Dataset(path) as ds:
        return {name: np.array(var[:]) for name, var in ds.variables.items()}


def _diagnostics(path: Path) -> list[dict]:
    with open(path, newline="") as f:
        return [
            {k: v for k, v in row.items() if k not in WALL_COLUMNS} for row in csv.DictReader(f)
        ]


def _same_run(a: Path, b: Path) -> None:
    fa, fb = _fields(a / "fields.nc"), _fields(b / "fields.nc")
    assert fa.keys() == fb.keys()
    for name in fa:
        assert np.array_equal(fa[name], fb[name], equal_nan=True), name
    assert _diagnostics(a / "diagnostics.csv") == _diagnostics(b / "diagnostics.csv")
    ma = json.loads((a / "fingers.json").read_text())
    mb = json.loads((b / "fingers.json").read_text())
    ma.pop("file"), mb.pop("file")
    assert ma == mb


def _specs(sweep, out: Path) -> list[dict]:
    return [member_spec(run, out, "cpu", 1) for run in sweep.runs]


def test_a_batch_gives_each_member_the_bits_of_its_run_alone(ti_cpu, tmp_path):
    """Four members of the tiny sweep (two viscosities, two inflow seeds), run as one batch on
    one simulation and each alone on a fresh Taichi runtime: the same fields (every variable
    of fields.nc, peak fields included), diagnostics and finger metrics, bit for bit."""
    from tiseg import backend

    sweep = load_sweep(TINY, grid_overrides={"inflow.seed": [1, 2]})
    assert len(sweep.runs) == 4
    assert len({compiled_fingerprint(r.scene) for r in sweep.runs}) == 1
    members._LAST.clear()  # (a batch of an earlier test in this process is not this one's)
    g0 = backend.state().generation
    together = execute_batch(_specs(sweep, tmp_path / "batch"))
    assert backend.state().generation == g0 + 1  # one Taichi start for the four
    alone = [execute_run(spec) for spec in _specs(sweep, tmp_path / "alone")]
    assert backend.state().generation == g0 + 5
    assert [r["status"] for r in together] == ["done"] * 4
    assert [r["status"] for r in alone] == ["done"] * 4
    for run in sweep.runs:
        _same_run(tmp_path / "batch" / run.name, tmp_path / "alone" / run.name)
    # the members differ: the batch did not hand one member's state to the next
    f0 = _fields(tmp_path / "batch" / sweep.runs[0].name / "fields.nc")
    f1 = _fields(tmp_path / "batch" / sweep.runs[1].name / "fields.nc")
    assert not np.array_equal(f0["h"], f1["h"])


def test_a_workers_next_task_reuses_its_batch(ti_cpu, tmp_path):
    """A worker's next task of members with the same kernels, as many, runs on the batch of
    its last (no new Taichi runtime: each member given its scene and reset), and each member
    is bitwise its run alone."""
    from tiseg import backend

    first = load_sweep(TINY, grid_overrides={"inflow.seed": [1]})
    second = load_sweep(TINY, grid_overrides={"inflow.seed": [2]})
    members._LAST.clear()
    execute_batch(_specs(first, tmp_path / "first"))
    g = backend.state().generation
    batch = members._LAST["held"]
    again = execute_batch(_specs(second, tmp_path / "second"))
    assert backend.state().generation == g and members._LAST["held"] is batch
    assert [r["status"] for r in again] == ["done"] * 2
    for run, spec in zip(second.runs, _specs(second, tmp_path / "alone")):
        execute_run(spec)
        _same_run(tmp_path / "second" / run.name, tmp_path / "alone" / run.name)


class _InProcess:
    """A Dask client that runs each task where it is submitted (one worker: this process)."""

    class _Done:
        def __init__(self, value):
            self.value = value

        def result(self):
            return self.value

    def submit(self, fn, arg, **_options):
        return self._Done(fn(arg))


def test_a_workers_lone_members_run_on_the_simulation_of_its_last(ti_cpu, tmp_path):
    """Tasks of one member (`--batch 1`, or members too large to group on the CPU) run on the
    simulation the worker built for its last member with the same kernels: one Taichi
    start-up for all four, and each member bitwise its run on a fresh runtime."""
    from tiseg import backend

    sweep = load_sweep(TINY, grid_overrides={"inflow.seed": [1, 2]})
    members._LAST.clear()
    g = backend.state().generation
    futures = runner.submit_tasks(
        _InProcess(), batches(sweep.runs, 1), tmp_path / "lone", "cpu", 1, False
    )
    records = [rec for fut, task in futures.items() for rec in runner.task_records(fut, task)]
    assert [r["status"] for r in records] == ["done"] * 4
    assert backend.state().generation == g + 1  # the first member's start-up, then reuse
    for run, spec in zip(sweep.runs, _specs(sweep, tmp_path / "fresh")):
        execute_run(spec)  # (no reuse: each on a fresh runtime)
        _same_run(tmp_path / "lone" / run.name, tmp_path / "fresh" / run.name)
    assert backend.state().generation == g + 5


def test_a_batch_of_different_kernels_builds_a_simulation_for_each(ti_cpu, tmp_path):
    """Two grids in one batch: the second member needs other kernels and gets its own
    simulation; both equal their runs alone, and a batch is reused as a sweep's folders are."""
    sweep = load_sweep(TINY, grid_overrides={"flow.nu": [0.01], "domain.resolution": [40, 50]})
    a, b = (compiled_fingerprint(r.scene) for r in sweep.runs)
    assert a != b
    together = execute_batch(_specs(sweep, tmp_path / "batch"))
    alone = [execute_run(spec) for spec in _specs(sweep, tmp_path / "alone")]
    assert [r["status"] for r in together + alone] == ["done"] * 4
    for run in sweep.runs:
        _same_run(tmp_path / "batch" / run.name, tmp_path / "alone" / run.name)
    again = execute_batch(_specs(sweep, tmp_path / "batch"))
    assert [r["status"] for r in again] == ["reused"] * 2


def test_tasks_group_members_that_share_kernels():
    """The default batch keeps about two tasks per worker, at most 16 members; tasks never
    mix compiled fingerprints."""
    assert batch_size(16, 2) == 4
    assert batch_size(3, 2) == 1
    assert batch_size(1000, 1) == 16
    sweep = load_sweep(
        TINY, grid_overrides={"domain.resolution": [40, 50], "inflow.seed": [1, 2, 3]}
    )
    tasks = batches(sweep.runs, 2)
    assert sorted(len(t) for t in tasks) == [2] * 6  # 2 grids x (2 nu x 3 seeds) / 2
    for t in tasks:
        assert len({compiled_fingerprint(r.scene) for r in t}) == 1
    assert sorted(r.name for t in tasks for r in t) == sorted(r.name for r in sweep.runs)


def test_the_default_batch_fits_a_workers_share_of_the_memory(monkeypatch):
    """Without --batch a local task takes no more members than a worker's share of the
    available memory holds: memory_needed counts a batch's Taichi fields once a member and
    its host arrays and overhead once (by hand below)."""
    from tiseg.run import limits
    from tiseg.run.batch import slots_of
    from tiseg.solver.numerics.config import config_from_scene

    sweep = load_sweep(TINY, grid_overrides={"inflow.seed": list(range(1, 17))})
    scene = sweep.runs[0].scene
    lay, nslots = config_from_scene(scene).layout, slots_of(scene)
    state = lay.nc * lay.NX * lay.NY * 8  # f64
    one = limits.memory_needed(lay, nslots, "f64")
    assert one == (2 * nslots + limits.WORK_ARRAYS + limits.HOST_ARRAYS["f64"]) * state + (
        limits.OVERHEAD
    )
    more = (nslots + limits.WORK_ARRAYS) * state
    assert limits.memory_needed(lay, nslots, "f64", members=5) == one + 4 * more
    assert runner.default_batch(sweep.runs, 2, local=True) in (8, runner.MAX_AUTO_BATCH)
    # two workers sharing room for one member and three more each: tasks of 4
    monkeypatch.setattr(limits, "memory_available", lambda: 2 * (one + 3 * more + more // 2))
    assert runner.default_batch(sweep.runs, 2, local=True) == 4
    assert runner.default_batch(sweep.runs, 2, local=False) == 8  # a remote cluster's: unknown
    monkeypatch.setattr(limits, "memory_available", lambda: one // 2)
    assert runner.default_batch(sweep.runs, 2, local=True) == 1  # (each alone then says why)
    monkeypatch.setattr(limits, "memory_available", lambda: None)
    assert runner.default_batch(sweep.runs, 2, local=True) == 8


def test_large_members_run_one_at_a_time_by_default_on_the_cpu(monkeypatch):
    """Members above MAX_CPU_BATCH_CELLS run alone without --batch on the CPU (measured: no
    gain there), batched on a GPU; --batch still groups them."""
    sweep = load_sweep(TINY, grid_overrides={"inflow.seed": list(range(1, 9))})  # 16 runs
    assert runner.default_batch(sweep.runs, 2, local=False) == 4
    domain = sweep.runs[0].scene.domain
    cells = domain.nx * domain.ny
    monkeypatch.setattr(runner, "MAX_CPU_BATCH_CELLS", cells - 1)
    assert runner.default_batch(sweep.runs, 2, local=False) == 1
    assert runner.default_batch(sweep.runs, 2, local=False, arch="gpu") == 4
    monkeypatch.setattr(runner, "MAX_CPU_BATCH_CELLS", cells)
    assert runner.default_batch(sweep.runs, 2, local=False) == 4
    # the study point of the grid study at 375 cells/m is above it
    assert 375 * 375 * 0.75 > runner.MAX_CPU_BATCH_CELLS


@pytest.mark.parametrize("value", ["0", "-2"])
def test_a_batch_below_one_is_refused(tmp_path, capsys, value):
    code = exit_code(["sweep", str(TINY), "--out", str(tmp_path / "s"), "--batch", value])
    assert code == 2
    err = capsys.readouterr().err
    assert "--batch" in err and ">= 1" in err


def test_a_new_taichi_runtime_is_never_reused_across(ti_cpu, tmp_path):
    """The simulation kept for the next member is dropped when anything has started a new
    Taichi runtime since (its fields are gone): the member then builds its own, and equals
    its run alone."""
    from tiseg import backend

    sweep = load_sweep(TINY, grid_overrides={"flow.nu": [0.01]})
    (run,) = sweep.runs
    first = execute_batch([member_spec(run, tmp_path / "a", "cpu", 1)])
    backend.init("cpu", "f64", 1, force=True)  # as another test or a user script may
    g = backend.state().generation
    again = execute_batch([member_spec(run, tmp_path / "b", "cpu", 1)])
    assert backend.state().generation == g + 1  # a fresh runtime, not the freed simulation
    assert first[0]["status"] == again[0]["status"] == "done"
    _same_run(tmp_path / "a" / run.name, tmp_path / "b" / run.name)


def test_a_sweep_on_dask_runs_its_batch_in_one_task(tmp_path):
    """`run_sweep(batch=2)` on one worker: both members of the tiny sweep in one task,
    each recorded as done, and each folder bitwise that of its run alone."""
    from tiseg.apps.sweep import run_sweep

    lines: list[str] = []
    res = run_sweep(
        load_sweep(TINY), tmp_path / "dask", workers=1, threads_per_task=1, batch=2,
        echo=lines.append,
    )  # fmt: skip
    assert [r["status"] for r in res.records] == ["done", "done"]
    assert any("in 1 tasks of up to 2 runs" in ln for ln in lines), lines
    for run in load_sweep(TINY).runs:
        assert execute_run(member_spec(run, tmp_path / "alone", "cpu", 1))["status"] == "done"
        _same_run(tmp_path / "dask" / run.name, tmp_path / "alone" / run.name)


class _Kill(Exception):
    """Stands for the kill of a sweep's worker."""


def test_a_killed_sweeps_members_resume_from_their_own_checkpoints(ti_cpu, tmp_path):
    """Members of a killed sweep, each stopped with a checkpoint in its folder, continue from
    it when the sweep runs again, together (a batch) or alone, and end bitwise as members
    that were never stopped; a checkpoint of another scene is not resumed."""
    from tiseg.run.schedules import IterationInterval
    from tiseg.run.simulation import Simulation

    def kill(sim):
        if sim.t >= 0.3:
            raise _Kill

    sweep = load_sweep(TINY, grid_overrides={"inflow.seed": [1, 2]})
    specs = _specs(sweep, tmp_path / "killed")
    for run, spec in zip(sweep.runs, specs):
        scene = run.scene
        if run is sweep.runs[3]:  # a folder whose checkpoint is another scene's
            scene = scene.with_overrides({"flow.nu": 0.03})
        sim = Simulation(scene)
        sim.add_callback(kill, IterationInterval(1), name="kill")
        with pytest.raises(_Kill):
            sim.run(out_dir=spec["dir"], progress=False, checkpoint_spacing=0)
        assert (Path(spec["dir"]) / "checkpoint.npz").is_file()
    damaged = _specs(sweep, tmp_path / "damaged")[0]
    shutil.copytree(specs[0]["dir"], damaged["dir"])
    members._LAST.clear()
    again = execute_batch(specs[:2]) + [execute_run(spec) for spec in specs[2:]]
    assert [r["status"] for r in again] == ["done"] * 4
    assert all(0.25 < r["resumed_at"] <= 0.3 for r in again[:3]), again
    assert "resumed_at" not in again[3]  # another scene's checkpoint: run from the start
    assert again[0]["batch_members"] == 2
    # a damaged checkpoint: the member is run from the start, not resumed and not failed
    (Path(damaged["dir"]) / "checkpoint.npz").write_bytes(b"not a checkpoint")
    rec = execute_run(damaged)
    assert rec["status"] == "done" and "resumed_at" not in rec, rec
    _same_run(tmp_path / "damaged" / sweep.runs[0].name, tmp_path / "killed" / sweep.runs[0].name)
    for spec in _specs(sweep, tmp_path / "fresh"):
        assert "resumed_at" not in execute_run(spec)
    for run in sweep.runs:
        _same_run(tmp_path / "killed" / run.name, tmp_path / "fresh" / run.name)
