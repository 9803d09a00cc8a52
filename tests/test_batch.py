"""A batch runs its members together and each member's run is bitwise the member run alone:
its fields.nc, diagnostics.csv and final state; a member that fails its guard stops alone."""

import shutil

import netCDF4
import numpy as np
import pytest

from tiseg.errors import InputError
from tiseg.run.failures import SimulationError
from tiseg.run.batch import Batch
from tiseg.run.callbacks import Callback
from tiseg.run import checkpoint
from tiseg.run.checkpoint import CHECKPOINT_NAME
from tiseg.run.schedules import IterationInterval
from tiseg.run.simulation import Simulation
from tiseg.setup.reading import load_scene

SMALL = {"output.interval": 0.25}


def _fields(path):
    with netCDF4.Dataset(path) as ds:
        return {k: np.array(v[:]) for k, v in ds.variables.items()}


def _diagnostics(path):
    # every column but the wall time, which no two runs share
    rows = [ln.split(",") for ln in path.read_text().splitlines()]
    keep = [k for k, name in enumerate(rows[0]) if "wall" not in name]
    return [[r[k] for k in keep] for r in rows]


def _same_runs(a, b) -> None:
    fa, fb = _fields(a / "fields.nc"), _fields(b / "fields.nc")
    assert fa.keys() == fb.keys()
    for k in fa:
        assert np.array_equal(fa[k], fb[k], equal_nan=True), k
    assert _diagnostics(a / "diagnostics.csv") == _diagnostics(b / "diagnostics.csv")


CASES = {
    # the split sweeps with their viscous sub-step, seeds and nu differing; the members end
    # at different times
    "fingers": (
        {"domain.resolution": 40, "time.t_end": 1.5},
        [{"inflow.seed": 3}, {"inflow.seed": 4, "flow.nu": 0.004}, {"time.t_end": 1.0}],
    ),
    # RKC with the projected friction and a law with hysteresis (resting regions skipped)
    "finite-release-deposit": (
        {"domain.resolution": 60, "time.t_end": 0.6},
        [{}, {"material.zeta_deg": 31.5}],
    ),
}


@pytest.mark.parametrize("name", sorted(CASES))
def test_a_batch_member_is_the_member_run_alone(ti_cpu, tmp_path, name):
    base, members = CASES[name]
    scenes = [load_scene(name, {**SMALL, **base, **m}) for m in members]
    batch = Batch(scenes)
    dirs = [tmp_path / f"batch{e}" for e in range(len(scenes))]
    stats = batch.run(out_dirs=dirs)
    for e, sc in enumerate(scenes):
        alone = Simulation(sc)
        alone.run(out_dir=tmp_path / f"alone{e}", progress=False)
        assert stats[e].steps == alone.stats.steps and stats[e].stages == alone.stats.stages
        assert batch.sims[e].t == alone.t
        assert np.array_equal(batch.sims[e].conserved(), alone.conserved())
        _same_runs(dirs[e], tmp_path / f"alone{e}")
    assert not np.array_equal(batch.sims[0].conserved(), batch.sims[1].conserved())
    # one set of observer kernels for the batch, each member at its own index
    assert len({id(sim.guard.store) for sim in batch.sims}) == 1
    assert len({id(sim.peaks.store) for sim in batch.sims}) == 1
    assert [sim.guard.member for sim in batch.sims] == list(range(len(scenes)))


def test_a_member_that_fails_stops_alone(ti_cpu, tmp_path):
    scenes = [
        load_scene("fingers", {**SMALL, "domain.resolution": 40, "time.t_end": 0.5, **m})
        for m in ({}, {"inflow.seed": 2})
    ]
    batch = Batch(scenes)

    def poison(snap):  # the second member's state turns to NaN after its first snapshot
        if snap.t > 0:
            op = batch.op
            op.state.par[1, 0] = float("nan")

    stats = batch.run(on_output=[None, poison], out_dirs=[tmp_path / "a", tmp_path / "b"])
    assert isinstance(stats[1], SimulationError)
    assert not isinstance(stats[0], Exception) and batch.sims[0].t == 0.5
    alone = Simulation(scenes[0])
    alone.run(progress=False)
    assert np.array_equal(batch.sims[0].conserved(), alone.conserved())


def test_a_failing_member_saves_the_states_it_saves_alone(ti_cpu, tmp_path):
    """The guard's last good state (kept for the members that passed, in one launch after
    the batch's step) and the offending one, as the member run alone saves them."""
    scenes = [
        load_scene("fingers", {**SMALL, "domain.resolution": 40, "time.t_end": 0.75, **m})
        for m in ({}, {"inflow.seed": 2})
    ]

    def poison(op, e):
        def cb(snap):  # the member's state turns to NaN after its second snapshot
            if snap.t > 0.3:
                op.state.par[e, 0] = float("nan")

        return cb

    batch = Batch(scenes)
    stats = batch.run(
        on_output=[None, poison(batch.op, 1)], out_dirs=[tmp_path / "a", tmp_path / "b"]
    )
    assert isinstance(stats[1], SimulationError) and len(stats[1].files) == 2
    alone = Simulation(scenes[1])
    with pytest.raises(SimulationError) as err:
        alone.run(out_dir=tmp_path / "alone", on_output=poison(alone.op, 0), progress=False)
    assert [f.name for f in stats[1].files] == [f.name for f in err.value.files]
    for mine, theirs in zip(stats[1].files, err.value.files):
        with np.load(mine) as a, np.load(theirs) as b:
            assert sorted(a.files) == sorted(b.files)
            for k in a.files:
                if a[k].dtype.kind in "fiub" and k != "wall":  # (wall: the run's wall clock)
                    assert np.array_equal(a[k], b[k], equal_nan=True), (mine.name, k)
    # the last good state is a state before the poison, not the one the check broke on
    with np.load(stats[1].files[0]) as good:
        assert np.isfinite(good["q"]).all() and float(good["t"]) < 0.75


def test_the_members_due_a_check_are_scanned_in_one_launch(ti_cpu, tmp_path, monkeypatch):
    scenes = [
        load_scene("fingers", {**SMALL, "domain.resolution": 40, "time.t_end": 0.3, **m})
        for m in ({}, {"inflow.seed": 2}, {"inflow.seed": 3})
    ]
    batch = Batch(scenes)
    store = batch.guards
    calls = {"one": 0, "all": 0, "keep": 0}
    for name, key in (("_scan", "one"), ("_scan_members", "all"), ("_keep_members", "keep")):
        kernel = getattr(store, name)

        def counted(*args, _k=kernel, _key=key):
            calls[_key] += 1
            return _k(*args)

        monkeypatch.setattr(store, name, counted)
    for sim in batch.sims:
        sim.check_every = 2
    stats = batch.run(out_dirs=[tmp_path / f"m{e}" for e in range(3)])
    assert all(not isinstance(s, Exception) for s in stats)
    steps = max(s.steps for s in stats)
    # the first check, every second step and every step with a snapshot check each member:
    # no member alone
    assert calls["one"] == 0 and 1 < calls["all"] <= steps + 1
    assert 0 < calls["keep"] <= steps
    # the last good state is each member's last (its end time is a snapshot)
    assert all(sim.guard.good_meta["t"] == sim.t == 0.3 for sim in batch.sims)


def test_a_kept_last_good_state_survives_a_state_set_from_the_host(ti_cpu):
    """A batch copies a passed check's state after the step; a state set from the host in
    between is set only after that copy is made."""
    scenes = [
        load_scene("fingers", {"domain.resolution": 40, "time.t_end": 0.2, "inflow.seed": s})
        for s in (1, 2)
    ]
    batch = Batch(scenes)
    batch.run()
    sim = batch.sims[0]
    checked = sim.op.get(0)
    sim._guard()  # passes: its copy waits for the batch
    assert batch.guards._pending[0] == 1
    sim.set_conserved(0.5 * sim.conserved())
    q, _, meta = sim.guard.last_good()
    assert np.array_equal(q, checked) and meta["t"] == sim.t
    assert not np.array_equal(sim.op.get(0), checked)


def test_members_must_share_their_compiled_options(ti_cpu):
    a = load_scene("fingers", {"domain.resolution": 40})
    b = load_scene("fingers", {"domain.resolution": 50})
    with pytest.raises(InputError, match="share"):
        Batch([a, b])
    with pytest.raises(InputError, match="at least two"):
        Batch([a])


def test_a_members_totals_and_budget_follow_its_state(ti_cpu, tmp_path):
    """The totals and budgets of a batch's step are every member's, taken once; a member's
    state or budget set anew is read anew (not the step's)."""
    scenes = [
        load_scene("fingers", {"domain.resolution": 40, "time.t_end": 0.2, "inflow.seed": s})
        for s in (1, 2)
    ]
    batch = Batch(scenes)
    batch.run(out_dirs=[tmp_path / "a", tmp_path / "b"])
    before = [sim.totals()["mass"] for sim in batch.sims]  # (the step's, shared)
    assert before == [
        sim.op.batch.sums(0, e)[0] * (scenes[e].dx * scenes[e].dy)
        for e, sim in enumerate(batch.sims)
    ]
    # so are the boundary budgets (read once for all), which an inflow has filled
    budgets = [sim.budget()["mass_in"] for sim in batch.sims]
    assert all(b > 0 for b in budgets) and budgets[0] != budgets[1]
    for e, sim in enumerate(batch.sims):
        assert np.array_equal(sim.op.budget(0), batch.op.state.budget(0, e))
    sim = batch.sims[1]
    sim.set_conserved(0.5 * sim.conserved())
    assert sim.totals()["mass"] == pytest.approx(0.5 * before[1], rel=1e-14)
    assert batch.sims[0].totals()["mass"] == before[0]
    sim.op.reset_budget()  # a budget set from the host is read anew
    assert sim.budget()["mass_in"] == 0.0 and batch.sims[0].budget()["mass_in"] == budgets[0]


def test_members_write_folders_of_their_own(ti_cpu, tmp_path):
    scenes = [load_scene("fingers", {"domain.resolution": 40, "inflow.seed": s}) for s in (1, 2)]
    with pytest.raises(InputError, match="two members were given the folder"):
        Batch(scenes).run(out_dirs=[tmp_path / "run", tmp_path / "." / "run"])
    assert not (tmp_path / "run").exists()


class _Kill(Exception):
    """Stands for a kill of the whole batch's process."""


@pytest.mark.parametrize("name", sorted(CASES))
def test_a_killed_batch_resumes_each_member_from_its_own_checkpoint(ti_cpu, tmp_path, name):
    """A batch stopped mid-run (as if killed) leaves a checkpoint in each member's folder;
    the batch resumed from them, and a member resumed alone (`tiseg run --resume`), end
    bitwise as the members run alone without a stop."""
    base, members = CASES[name]
    every = {**SMALL, **base, "output.checkpoint_interval": 0.1}
    scenes = [load_scene(name, {**every, **m}) for m in members]
    t_kill = 0.45 * min(sc.t_end for sc in scenes)

    killed = Batch(scenes)

    def kill(sim):  # once every member is past t_kill (their times differ)
        if all(s.t >= t_kill for s in killed.sims):
            raise _Kill

    dirs = [tmp_path / f"batch{e}" for e in range(len(scenes))]
    with pytest.raises(_Kill):
        killed.run(out_dirs=dirs, callbacks=[Callback(kill, IterationInterval(1))])
    for d in dirs:
        assert (d / CHECKPOINT_NAME).is_file()
    solo = tmp_path / "solo"
    shutil.copytree(dirs[-1], solo)

    batch = Batch.resume(dirs)
    assert all(0 < sim.t <= s.t for sim, s in zip(batch.sims, killed.sims))
    results = batch.run(out_dirs=dirs)
    assert not any(isinstance(r, Exception) for r in results)
    alone = Simulation.resume(solo)
    alone.run(out_dir=solo, progress=False)
    for e, sc in enumerate(scenes):
        Simulation(sc).run(out_dir=tmp_path / f"alone{e}", progress=False)
        _same_runs(dirs[e], tmp_path / f"alone{e}")
        assert not (dirs[e] / CHECKPOINT_NAME).exists()
    _same_runs(solo, tmp_path / f"alone{len(scenes) - 1}")


def test_a_batch_member_checkpoints_what_the_member_alone_does(ti_cpu, tmp_path):
    """Stopped before the scene's end, each member's checkpoint holds the state, budget, time,
    step counts and active ranges of the member's run alone (its own ranges, not the batch's
    union; the rest mask may differ outside them, where no step reads it)."""
    base, members = CASES["finite-release-deposit"]
    scenes = [load_scene("finite-release-deposit", {**SMALL, **base, **m}) for m in members]
    dirs = [tmp_path / f"batch{e}" for e in range(len(scenes))]
    Batch(scenes).run(out_dirs=dirs, t_end=0.35)
    ranges = []
    for e, sc in enumerate(scenes):
        Simulation(sc).run(out_dir=tmp_path / f"alone{e}", t_end=0.35, progress=False)
        a = checkpoint.load(dirs[e] / CHECKPOINT_NAME)
        b = checkpoint.load(tmp_path / f"alone{e}" / CHECKPOINT_NAME)
        peaks = [k for k in b if k.startswith("peak_")]
        for key in ("q", "budget", "t", "steps", "stages", "last_stages", "ranges", *peaks):
            assert np.array_equal(a[key], b[key]), key
        ranges.append(tuple(a["ranges"]))
    assert ranges[0] != ranges[1]  # the members' own ranges, not one union


def test_a_batch_resumes_only_run_folders(ti_cpu, tmp_path):
    (tmp_path / "other").mkdir()
    with pytest.raises(InputError, match="no such folder"):
        Batch.resume([tmp_path / "none", tmp_path / "other"])
    with pytest.raises(InputError, match="not a tiseg run folder"):
        Batch.resume([tmp_path / "other", tmp_path / "other"])
