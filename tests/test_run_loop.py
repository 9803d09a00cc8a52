"""The run loop: output observes the steps and never changes them, snapshots are the linear
interpolation of the step states around them, callbacks run on their schedules, one override
shortens a run, and the mutators change a simulation explicitly."""

from __future__ import annotations

import json
import logging
import subprocess
import sys

import netCDF4
import numpy as np
import pytest

from tiseg.run.callbacks import Callback
from tiseg.apps.cli import main
from tiseg.errors import InputError
from tiseg.output import read_diagnostics
from tiseg.setup.scene import load_scene
from tiseg.run.schedules import (
    AnyOf,
    IterationInterval,
    SpecifiedTimes,
    TimeInterval,
    WallSpaced,
    WallTimeInterval,
)
from tiseg.run.simulation import Simulation

# a small 2D fingers run: inflow, segregation, viscosity, WENO, RKC (24 x 8 cells)
SMALL = {
    "domain.resolution": 40,
    "domain.Lx": 0.6,
    "domain.Ly": 0.2,
    "time.t_end": 0.6,
    "output.times": [],
    "output.interval": 0.3,
}


def small(**over):
    return load_scene("fingers", {**SMALL, **over})


# ------------------------------------------------------------------ output does not perturb
@pytest.mark.slow  # a long run: the slow set (README), which CI runs after the suite
def test_output_schedule_does_not_change_the_run(ti_cpu, tmp_path):
    """Two runs differing only in their output schedule (and checkpoints) take the same steps
    and end with bitwise-equal fields at t_end."""
    a = Simulation(small(**{"output.interval": 0.01}))
    a.run(out_dir=tmp_path / "a", progress=False)
    b = Simulation(small(**{"output.interval": None, "output.times": [0.123, 0.4567]}))
    b.run(progress=False, checkpoint_wall=None)
    assert a.t == b.t == 0.6
    assert a.stats.steps == b.stats.steps and a.stats.stages == b.stats.stages
    np.testing.assert_array_equal(a.op.get(0), b.op.get(0))
    with netCDF4.Dataset(tmp_path / "a" / "fields.nc") as nc:
        assert nc["time"].size == 61  # every 0.01 s, t = 0 and t_end included


@pytest.mark.slow  # a long run: the slow set (README), which CI runs after the suite
def test_snapshots_are_the_interpolated_step_states(ti_cpu, tmp_path):
    """Each snapshot in fields.nc equals (1 - theta) q(t_n) + theta q(t_n+1) of the two step
    states around it, recomputed here in NumPy from a second run stepped by hand; it keeps the
    bounds and the mass balance of the step states."""
    times = [0.2, 0.2221, 0.41, 0.6]  # (at 0.2 s the inflow has wetted the first cells)
    sc = small(**{"output.interval": None, "output.times": times[:-1]})
    Simulation(sc).run(out_dir=tmp_path / "r", progress=False)
    ref = Simulation(sc)
    states = [(0.0, ref.fields())]
    while ref.t < sc.t_end:
        ref.step()
        states.append((ref.t, ref.fields()))
    with netCDF4.Dataset(tmp_path / "r" / "fields.nc") as nc:
        t_file = np.asarray(nc["time"][:])
        h_file = np.asarray(nc["h"][:])
        phi_file = np.ma.filled(nc["phi"][:], np.nan)  # missing where h < h_min
    np.testing.assert_array_equal(t_file, [0.0] + times)
    ts = np.array([t for t, _ in states])
    for k, tk in enumerate(times):
        n = int(np.searchsorted(ts, tk))  # ts[n - 1] < tk <= ts[n]
        (t0, f0), (t1, f1) = states[n - 1], states[n]
        theta = (tk - t0) / (t1 - t0)
        h = (1 - theta) * f0["h"] + theta * f1["h"]
        np.testing.assert_allclose(h_file[k + 1], h, rtol=0, atol=1e-16)
        assert h_file[k + 1].min() >= 0.0
        assert 0.0 <= np.nanmin(phi_file[k + 1]) and np.nanmax(phi_file[k + 1]) <= 1.0
        assert np.array_equal(np.isnan(phi_file[k + 1]), h_file[k + 1] < sc.numerics.h_min)
    # the last one is the final step state itself
    np.testing.assert_array_equal(h_file[-1], states[-1][1]["h"])


def test_snapshot_mass_balance_holds(ti_cpu):
    """The snapshot's budget is interpolated with its state: mass = inflow to round-off."""
    got = []

    def check(snap):
        got.append((snap.t, snap.theta, snap.totals()["mass"], snap.budget()["mass_in"]))

    sim = Simulation(small())
    sim.add_callback(check, TimeInterval(0.0777), snapshot=True)
    sim.run(progress=False)
    assert [round(t, 6) for t, *_ in got] == [
        0.0777,
        0.1554,
        0.2331,
        0.3108,
        0.3885,
        0.4662,
        0.5439,
    ]
    assert any(0 < th < 1 for _, th, _, _ in got)
    for t, _, mass, mass_in in got:
        assert abs(mass - mass_in) <= 1e-12 * mass, t
    # (the ramped inflow starts at h = 0; the first step, 0.088 s here, admits nothing)
    assert all(mass > 0 for t, _, mass, _ in got if t > 0.1)


@pytest.mark.slow  # a long run: the slow set (README), which CI runs after the suite
def test_resume_from_a_step_state_is_bitwise(ti_cpu, tmp_path):
    """A checkpoint holds a step state (not an interpolated one): a run stopped between
    checkpoints and resumed takes the very steps of the uninterrupted run."""

    class Stop(Exception):
        pass

    sc = small(**{"output.interval": 0.07, "time.t_end": 1.5})
    whole = Simulation(sc)
    whole.run(progress=False)
    n_stop = 2 * whole.stats.steps // 3  # past a few output times (checkpoints)
    assert n_stop > 5

    def stop(sim):
        if sim.stats.steps == n_stop:
            raise Stop

    part = Simulation(sc)
    part.add_callback(stop, IterationInterval(1))
    with pytest.raises(Stop):  # (a checkpoint at every output time, however fast the run)
        part.run(out_dir=tmp_path / "p", progress=False, checkpoint_spacing=0.0)
    again = Simulation.resume(tmp_path / "p")
    assert 0 < again.stats.steps < n_stop
    again.run(out_dir=tmp_path / "p", progress=False)
    assert again.stats.steps == whole.stats.steps
    np.testing.assert_array_equal(again.op.get(0), whole.op.get(0))


def test_no_sliver_step_before_t_end(ti_cpu):
    """Only t_end is landed on, and the last two steps share what is left instead of ending
    with a sliver."""
    sim = Simulation(small())
    dts = []
    sim.add_callback(lambda s: dts.append(s.last_step.dt), IterationInterval(1))
    sim.run(progress=False)
    assert sim.t == 0.6
    assert min(dts[-2:]) > 0.3 * np.median(dts)


# ------------------------------------------------------------------ schedules and callbacks
def test_schedules():
    ti = TimeInterval(0.1)
    assert ti.times_in(0.0, 0.35) == [0.1, 0.2, 0.3]
    assert ti.times_in(0.3, 0.3) == [] and ti.times_in(0.29999, 0.3) == [0.3]
    assert ti.times_in(1.85, 1.95) == [1.9]  # 19 * 0.1 rounded as a user writes it
    assert ti.contains(0.3) and not ti.contains(0.0) and not ti.contains(0.25)
    st = SpecifiedTimes([0.5, 0.1, 0.5])
    assert st.times == (0.1, 0.5) and st.times_in(0.1, 0.5) == [0.5] and st.contains(0.1)
    it = IterationInterval(3)
    assert [n for n in range(1, 10) if it.due(0, 1, n)] == [3, 6, 9]
    clock = iter([0.0, 0.5, 1.2, 1.3, 2.5]).__next__
    wt = WallTimeInterval(1.0, clock=clock)  # starts at 0.0
    assert [wt.due(0, 1, n) for n in range(4)] == [False, True, False, True]
    assert AnyOf(IterationInterval(2), SpecifiedTimes([0.15])).due(0.1, 0.2, 1)
    # the inner schedule's firings, at least 1 s of wall time apart (the clock is read only
    # when the inner one is due: at 0.5, 1.2 and 1.3 here)
    clock = iter([0.0, 0.5, 1.2, 1.3]).__next__
    sp = WallSpaced(IterationInterval(2), 1.0, clock=clock)  # starts at 0.0
    assert [sp.due(0, 1, n) for n in range(1, 7)] == [False, False, False, True, False, False]
    for bad in (
        lambda: TimeInterval(0),
        lambda: IterationInterval(0),
        lambda: IterationInterval(1.5),
        lambda: WallTimeInterval(-1),
        lambda: WallSpaced(IterationInterval(1), -1),
        lambda: WallSpaced(1.0, 1),
        lambda: SpecifiedTimes([float("nan")]),
    ):
        with pytest.raises(InputError):
            bad()
    with pytest.raises(InputError, match="time schedule"):
        Callback(print, IterationInterval(2), snapshot=True)


def test_callbacks_run_on_their_schedules(ti_cpu):
    sim = Simulation(small(**{"time.t_end": 0.3}))
    every3, snaps = [], []
    sim.add_callback(lambda s: every3.append(s.stats.steps), IterationInterval(3), name="n3")
    sim.add_callback(
        lambda snap: snaps.append(snap.t),
        SpecifiedTimes([0.0, 0.1, 0.25]),
        name="snap",
        snapshot=True,
    )
    sim.run(progress=False)
    assert every3 == list(range(3, sim.stats.steps + 1, 3))
    assert snaps == [0.0, 0.1, 0.25]  # t = 0 from the state at the start
    sim.remove_callback("n3")
    assert "n3" not in sim.callbacks and "snap" in sim.callbacks


def test_guard_is_a_callback_on_an_iteration_schedule(ti_cpu):
    sim = Simulation(small(), check_every=4)
    guard = sim.callbacks["guard"]
    assert isinstance(guard.schedule, IterationInterval) and guard.schedule.n == 4
    seen = []
    real = sim._guard
    sim._guard = lambda full=True: (seen.append(sim.stats.steps), real(full))
    for _ in range(9):
        sim.step()
    assert seen == [4, 8]
    sim.check_every = 0
    assert "guard" not in sim.callbacks


# ------------------------------------------------------------------ shortening a run
def test_t_end_override_drops_later_output_times_with_a_note(caplog):
    with caplog.at_level(logging.WARNING, logger="tiseg"):
        sc = load_scene("fingers", {"time.t_end": 2.0})
    assert sc.output_times[-1] == 2.0 and max(sc.output.times) == 1.9
    notes = [r.getMessage() for r in caplog.records]
    assert len(notes) == 1 and "3.3, 5.1, 6.2, 7.5" in notes[0] and "dropped" in notes[0]


@pytest.mark.slow  # a long run: the slow set (README), which CI runs after the suite
def test_cli_t_end_override_runs_and_notes(ti_cpu, tmp_path, capsys):
    rc = main(
        [
            "run",
            "fingers",
            "--set",
            "domain.resolution=30",
            "--set",
            "time.t_end=0.2",
            "--out",
            str(tmp_path),
            "--no-progress",
            "--json",
        ]
    )
    assert rc == 0
    cap = capsys.readouterr()
    assert json.loads(cap.out)["t_end"] == 0.2
    assert "note: output.times 1.9, 3.3, 5.1, 6.2, 7.5 lie past time.t_end=0.2 s" in cap.err


# ------------------------------------------------------------------ mutators
def test_set_parameters_changes_scene_and_operator(ti_cpu):
    from tiseg.model.physics.pointwise import Params, slot_bases

    sim = Simulation(small())
    sim.set_parameters({"flow.nu": 0.02, "material.zeta_deg": 28.0})
    assert sim.scene.flow.nu == 0.02 and sim.scene.material.zeta_deg == 28.0
    par = sim.op.par.to_numpy()[0]
    NU = slot_bases(sim.op.cfg)["viscosity"]
    assert par[NU] == 0.02 and sim.op.cfg.nu == 0.02
    assert par[Params.G_SIN] == pytest.approx(9.81 * np.sin(np.radians(28.0)), rel=1e-14)
    sim.set_parameters({"flow.nu": 0.0})  # viscosity off: same kernels (and slots), nu = 0
    assert slot_bases(sim.op.cfg)["viscosity"] == NU and sim.op.par.to_numpy()[0, NU] == 0.0
    for change, what in (
        ({"domain.resolution": 50}, "the grid"),
        ({"numerics.reconstruction": "minmod"}, "numerics.reconstruction"),
        ({"effects.segregation": False}, "segregation"),
        ({"material.transport": "bagnold"}, "material.transport"),
        ({"numerics.friction_scheme": "regularised"}, "numerics.friction_scheme"),
    ):
        with pytest.raises(InputError, match=what):
            sim.set_parameters(change)
    sim.step()


def test_set_state_and_state_round_trip(ti_cpu):
    sim = Simulation(small())
    ny, nx = sim.layout.ny, sim.layout.nx
    h = np.full((ny, nx), 1e-3)
    h[:, nx // 2 :] = 0.0
    phi = np.full((ny, nx), 0.3)
    sim.set_state(h, u=np.full((ny, nx), 0.1), phi=phi)
    st = sim.state()
    np.testing.assert_array_equal(st["h"], h)
    np.testing.assert_allclose(st["u"][:, : nx // 2], 0.1, rtol=1e-15)
    np.testing.assert_allclose(st["phi"][:, : nx // 2], 0.3, rtol=1e-15)
    assert sim.initial_totals["mass"] == pytest.approx(h.sum() * sim.scene.dx * sim.scene.dy)
    for _ in range(12):  # the guard's mass balance starts here
        sim.step()
    for kw, match in (
        ({"h": np.ones((2, 2))}, "shape"),
        ({"h": -h}, ">= 0"),
        ({"h": h, "phi": phi + 1}, r"\[0, 1\]"),
        ({"h": h * np.nan}, "NaN"),
    ):
        with pytest.raises(InputError, match=match):
            sim.set_state(**kw)


@pytest.mark.slow  # a long run: the slow set (README), which CI runs after the suite
def test_fixed_stage_count(ti_cpu):
    sim = Simulation(small())
    assert sim.step(stages=7).stages == 7
    ss = Simulation(small(**{"numerics.stepper": "ssprk3"}))
    with pytest.raises(InputError, match="3 stage"):
        ss.step(stages=2)


def test_other_precision_is_an_error_not_a_reinitialisation(ti_cpu):
    from tiseg import backend

    gen = backend.state().generation
    with pytest.raises(InputError, match=r"tiseg.init"):
        Simulation(small(**{"numerics.precision": "f32"}))
    with pytest.raises(InputError, match="threads"):
        Simulation(small(), threads=3)
    assert backend.state().generation == gen and backend.state().precision == "f64"


def test_estimate_command_does_not_import_run_command():
    code = (
        "import sys, tiseg.apps.commands.estimate; print('tiseg.apps.commands.run' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


# ------------------------------------------------------------------ diagnostics units
def test_diagnostics_state_their_units(ti_cpu, tmp_path):
    Simulation(small(**{"time.t_end": 0.05})).run(out_dir=tmp_path, progress=False)
    meta = json.loads((tmp_path / "diagnostics.csv-metadata.json").read_text())
    cols = {c["name"]: c for c in meta["tableSchema"]["columns"]}
    header = (tmp_path / "diagnostics.csv").read_text().splitlines()[0].split(",")
    assert list(cols) == header
    assert cols["mass"]["unit"] == "m3" and cols["dt"]["unit"] == "s"
    assert "cumulative" in cols["wall_time_cumulative"]["dc:description"]
    d = read_diagnostics(tmp_path / "diagnostics.csv")
    assert np.all(np.diff(d["wall_time_cumulative"]) >= 0)
    np.testing.assert_array_equal(d["wall_time"], d["wall_time_cumulative"])  # the old name


# ------------------------------------------------------------------ review cases
def test_no_checkpoint_is_written_from_a_broken_state(ti_cpu, tmp_path):
    """With checks only at snapshots (check_every=0) and a checkpoint after every step, a NaN
    made mid-run stops the run before the checkpoint could save it."""
    from tiseg.run import checkpoint
    from tiseg.model.physics.pointwise import Params
    from tiseg.run.simulation import SimulationError

    sim = Simulation(small(**{"output.interval": None}), check_every=0)

    def poison(s):
        if s.stats.steps == 4:
            s.op.par[0, Params.G_SIN] = float("nan")

    sim.add_callback(poison, IterationInterval(1))
    with pytest.raises(SimulationError):
        sim.run(out_dir=tmp_path, progress=False, checkpoint_wall=0.0)
    ck = checkpoint.load(tmp_path / checkpoint.CHECKPOINT_NAME)
    checkpoint.validate(ck, sim.scene)  # finite: the last good step
    assert ck["steps"] == 4


def test_bad_callbacks_are_refused_before_the_folder_is_touched(ti_cpu, tmp_path):
    sim = Simulation(small())
    with pytest.raises(InputError, match="not a tiseg.run.callbacks.Callback"):
        sim.run(out_dir=tmp_path / "r", progress=False, callbacks=[print])
    assert not (tmp_path / "r").exists()
    sim.run(out_dir=tmp_path / "r", progress=False, t_end=0.1)  # nothing left locked


@pytest.mark.slow  # a long run: the slow set (README), which CI runs after the suite
def test_a_later_run_into_the_same_folder_continues_it(ti_cpu, tmp_path):
    whole = Simulation(small())
    whole.run(out_dir=tmp_path / "w", progress=False)
    sim = Simulation(small())
    sim.run(out_dir=tmp_path / "p", progress=False, t_end=0.3)
    sim.run(out_dir=tmp_path / "p", progress=False)
    with (
        netCDF4.Dataset(tmp_path / "w" / "fields.nc") as a,
        netCDF4.Dataset(tmp_path / "p" / "fields.nc") as b,
    ):
        np.testing.assert_array_equal(a["time"][:], b["time"][:])
    assert not (tmp_path / "p" / "checkpoint.npz").exists()


def test_step_to_a_time_already_reached_is_an_input_error(ti_cpu):
    sim = Simulation(small())
    sim.step()
    with pytest.raises(InputError, match="already at"):
        sim.step(t_stop=sim.t)


def test_set_parameters_reaches_the_guard(ti_cpu):
    sim = Simulation(small())
    sim.set_parameters({"numerics.h_min": 5e-5})
    assert sim.guard.store.par.to_numpy()[0, 2] == 5e-5 and sim.op.cfg.h_min == 5e-5
