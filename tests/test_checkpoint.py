"""Checkpoints and restart: a run killed with SIGKILL and resumed with `tiseg run --resume DIR`
ends with exactly the files of a run that was never interrupted (bitwise in f64), and no crash
leaves an output file that cannot be read."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time

import netCDF4
import numpy as np
import pytest

from tiseg.run import checkpoint
from tiseg.apps.cli import main
from tiseg.errors import InputError
from tiseg.output import read_diagnostics
from tiseg.setup.scene import load_scene
from tiseg.run.schedules import IterationInterval
from tiseg.run.simulation import Simulation

# A small 2D fingers run (24 x 8 cells, inflow, segregation, viscosity, RKC): output every
# 0.1 s, a checkpoint also every 0.05 s of simulated time.
SETS = [
    "domain.resolution=40",
    "domain.Lx=0.6",
    "domain.Ly=0.2",
    "time.t_end=1.0",
    "output.times=[]",
    "output.interval=0.1",
    "output.checkpoint_interval=0.05",
]


def _cli_args(out) -> list[str]:
    args = ["run", "fingers", "--out", str(out), "--no-progress"]
    for s in SETS:
        args += ["--set", s]
    return args


def assert_same_run(a, b) -> None:
    """fields.nc identical bit for bit (every variable, every record), times strictly increasing
    (no duplicates); diagnostics.csv identical except the wall-time column."""
    with netCDF4.Dataset(a / "fields.nc") as A, netCDF4.Dataset(b / "fields.nc") as B:
        ta, tb = A["time"][:], B["time"][:]
        assert np.all(np.diff(ta) > 0), ta
        np.testing.assert_array_equal(ta, tb)
        assert set(A.variables) == set(B.variables)
        for name in A.variables:
            np.testing.assert_array_equal(A[name][:], B[name][:], err_msg=name)
    da, db = read_diagnostics(a / "diagnostics.csv"), read_diagnostics(b / "diagnostics.csv")
    assert list(da) == list(db)
    for col in da:
        if col not in ("wall_time", "wall_time_cumulative"):
            np.testing.assert_array_equal(da[col], db[col], err_msg=col)
    assert np.all(np.diff(da["time"]) > 0)
    # cumulative: it continues from the checkpoint's wall time
    assert np.all(np.diff(da["wall_time_cumulative"]) >= 0)


@pytest.fixture(scope="module")
def reference(tmp_path_factory, ti_cpu):
    """The uninterrupted run."""
    out = tmp_path_factory.mktemp("ref") / "run"
    assert main(_cli_args(out)) == 0
    assert not (out / checkpoint.CHECKPOINT_NAME).exists()  # finished: nothing to resume
    return out


@pytest.mark.slow
def test_sigkill_then_resume_equals_uninterrupted_run(tmp_path, reference, capsys):
    """`python -m tiseg.apps.cli run ...` is killed with SIGKILL as soon as its first checkpoint
    exists; the files it leaves are readable; `tiseg run --resume DIR` finishes the run, and
    the result is bitwise the uninterrupted run's."""
    out = tmp_path / "killed"
    proc = subprocess.Popen(
        [sys.executable, "-m", "tiseg.apps.cli"] + _cli_args(out),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    ck = out / checkpoint.CHECKPOINT_NAME
    deadline = time.monotonic() + 300
    while not ck.exists() and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.002)
    proc.send_signal(signal.SIGKILL)
    _, err = proc.communicate()
    assert proc.returncode == -signal.SIGKILL, f"run ended before it was killed: {err}"
    # nothing left corrupt: the checkpoint, the NetCDF file and the CSV all read back
    state = checkpoint.load(ck)
    assert 0 < state["t"] < 1.0
    with netCDF4.Dataset(out / "fields.nc") as nc:
        assert nc.dimensions["time"].size >= 1 and np.isfinite(nc["h"][:]).all()
    assert read_diagnostics(out / "diagnostics.csv")["time"].size >= state["diag_rows"]

    assert main(["run", "--resume", str(out), "--no-progress"]) == 0
    assert f"resuming from {ck}" in capsys.readouterr().out
    assert_same_run(reference, out)
    assert not ck.exists()
    with netCDF4.Dataset(out / "fields.nc") as nc:
        assert "resumed" in nc.history


@pytest.mark.parametrize(
    "sig, code",
    [(signal.SIGTERM, 143), pytest.param(signal.SIGINT, 130, marks=pytest.mark.slow)],
)
@pytest.mark.slow  # a long run: the slow set (README), which CI runs after the suite
def test_a_signal_stops_at_a_step_with_a_checkpoint(tmp_path, reference, capsys, sig, code):
    """SIGTERM / SIGINT let the step finish, write a checkpoint of it, say how to resume and
    exit 128 + the signal; the resumed run is bitwise the uninterrupted one."""
    out = tmp_path / "stopped"
    proc = subprocess.Popen(
        [sys.executable, "-m", "tiseg.apps.cli"] + _cli_args(out),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    diag = out / "diagnostics.csv"
    deadline = time.monotonic() + 300
    while (
        proc.poll() is None
        and time.monotonic() < deadline
        and (not diag.exists() or len(diag.read_text().splitlines()) < 8)
    ):
        time.sleep(0.005)
    proc.send_signal(sig)
    _, err = proc.communicate()
    assert proc.returncode == code, err
    assert f"stopped by {signal.Signals(sig).name}" in err and "--resume" in err, err
    state = checkpoint.load(out / checkpoint.CHECKPOINT_NAME)
    assert read_diagnostics(diag)["time"][-1] == state["t"]  # the last step is the checkpoint's
    assert main(["run", "--resume", str(out), "--no-progress"]) == 0
    assert_same_run(reference, out)


class _Stop(Exception):
    """Stands for a kill: raised by a callback after a given step."""


def _run_until(sim, out, steps: int) -> None:
    """Run into ``out`` and stop (as if killed) after step ``steps``, before its checkpoint."""

    def stop(s):
        if s.stats.steps == steps:
            raise _Stop

    sim.add_callback(stop, IterationInterval(1), name="stop")
    with pytest.raises(_Stop):
        sim.run(out_dir=out, progress=False)
    sim.remove_callback("stop")


@pytest.mark.slow  # a long regression run: CI runs it in the slow set
def test_resume_drops_output_written_after_the_checkpoint(tmp_path, reference):
    """A run killed after writing snapshots and diagnostics rows its last checkpoint does not
    know of (and half a CSV line): the resume drops them (rewriting the files atomically)
    instead of duplicating times, and still ends bitwise equal to the uninterrupted run."""
    sc = load_scene("fingers", SETS)
    out = tmp_path / "run"
    _run_until(Simulation(sc), out, 3)
    early = checkpoint.load(out / checkpoint.CHECKPOINT_NAME)
    assert 0.1 <= early["t"] < 0.5 and early["snapshots"] >= 2
    shutil.copy(out / checkpoint.CHECKPOINT_NAME, tmp_path / "early.npz")
    _run_until(Simulation.resume(out), out, 6)  # more snapshots ...
    shutil.copy(tmp_path / "early.npz", out / checkpoint.CHECKPOINT_NAME)  # ... unknown to it
    with open(out / "diagnostics.csv", "a") as fh:
        fh.write("0.41,1e-3,2")  # a row cut by the kill
    with netCDF4.Dataset(out / "fields.nc") as nc:
        assert nc.dimensions["time"].size > early["snapshots"]
    sim = Simulation.resume(out)
    assert sim.t == early["t"] and sim.stats.steps == early["steps"]
    sim.run(out_dir=out, progress=False)
    assert_same_run(reference, out)
    assert not [p for p in os.listdir(out) if p.endswith(".tmp")]


def test_checkpoint_contents_and_atomic_write(tmp_path, ti_cpu):
    """The checkpoint holds slot 0 with its ghost cells in the run's precision, the boundary
    budget, time and counters, and the resolved scene; it is replaced atomically (no temporary
    file is left) and restoring it gives back the same state bit for bit."""
    sc = load_scene("fingers", SETS)
    sim = Simulation(sc)
    sim.run(out_dir=tmp_path, progress=False, t_end=0.3)
    ck = checkpoint.load(tmp_path / checkpoint.CHECKPOINT_NAME)
    assert ck["format"] == "tiseg-checkpoint" and ck["version"] == 1
    assert ck["q"].dtype == np.float64 and ck["q"].shape == (4, 24 + 4, 8 + 4)
    np.testing.assert_array_equal(ck["q"], sim.op.get(0))
    np.testing.assert_array_equal(ck["budget"], sim.op.budget(0))
    assert ck["t"] == sim.t == 0.3 and ck["steps"] == sim.stats.steps
    assert ck["last_stages"] == sim._last_stages and ck["precision"] == "f64"
    assert load_scene("fingers", SETS) == load_scene(str(tmp_path / "scene.toml"))
    assert ck["scene"] == sc.to_toml()
    assert ck["snapshots"] == 4 and ck["diag_rows"] == sim.stats.steps + 1
    assert not [p for p in os.listdir(tmp_path) if p.endswith(".tmp")]
    other = Simulation(sc)
    checkpoint.restore(other, ck)
    np.testing.assert_array_equal(other.op.get(0), sim.op.get(0))
    assert other.budget() == sim.budget() and other.t == sim.t


@pytest.mark.slow  # a long run: the slow set (README), which CI runs after the suite
def test_damaged_fields_file_is_kept_aside(tmp_path, ti_cpu, caplog):
    """A fields.nc that cannot be read any more (here: overwritten with junk) does not block
    the resume: it is moved to fields.damaged-1.nc, a new fields.nc starts at the checkpoint,
    and a warning says so."""
    sc = load_scene(
        "fingers", [s for s in SETS if not s.startswith("time.t_end")] + ["time.t_end=0.4"]
    )
    out = tmp_path / "run"
    Simulation(sc).run(out_dir=out, progress=False, t_end=0.2)
    (out / "fields.nc").write_bytes(b"not a netcdf file")
    with caplog.at_level("WARNING", logger="tiseg"):
        Simulation.resume(out).run(out_dir=out, progress=False)
    assert any("fields.damaged-1.nc" in r.getMessage() for r in caplog.records)
    assert (out / "fields.damaged-1.nc").read_bytes() == b"not a netcdf file"
    with netCDF4.Dataset(out / "fields.nc") as nc:
        np.testing.assert_allclose(nc["time"][:], [0.3, 0.4])


def test_wall_clock_checkpoints(tmp_path, reference):
    """With checkpoint_wall = 0 a checkpoint is written after every step, and the results do
    not depend on it (checkpoints never shorten a step): the run's files are the uninterrupted
    reference run's, bit for bit."""
    sc = load_scene("fingers", SETS)
    out = tmp_path / "run"
    sim = Simulation(sc)
    writes = []
    orig = checkpoint.save

    def counting(path, s, **kw):
        writes.append(s.t)
        return orig(path, s, **kw)

    checkpoint.save = counting
    try:
        sim.run(out_dir=out, progress=False, checkpoint_wall=0.0)
    finally:
        checkpoint.save = orig
    assert len(writes) >= sim.stats.steps
    assert_same_run(reference, out)


def _count_saves(monkeypatch) -> list:
    """The simulated times of the checkpoints written from here on."""
    writes = []
    orig = checkpoint.save

    def counting(path, s, **kw):
        writes.append(s.t)
        return orig(path, s, **kw)

    monkeypatch.setattr(checkpoint, "save", counting)
    return writes


def test_checkpoints_of_output_times_are_spaced_in_wall_time(tmp_path, monkeypatch, ti_cpu):
    """Without a checkpoint interval, the output times' checkpoints are at least
    ``checkpoint_spacing`` wall seconds apart: a run shorter than the spacing writes none,
    and one that stops before the scene's end (t_end = 0.3) one, of its last state, which a
    resume continues from; with a spacing of 0 one at every output time, and the same files
    bit for bit. The peak fields in fields.nc are those of the run's end. (The spacing is an
    hour here: the default 10 s can pass inside a run of a second on a busy machine.)"""
    sets = [s for s in SETS if not s.startswith("output.checkpoint_interval")]
    sc = load_scene("fingers", sets)
    writes = _count_saves(monkeypatch)
    whole = Simulation(sc)
    whole.run(out_dir=tmp_path / "whole", progress=False, checkpoint_spacing=3600.0)
    assert writes == []  # a fast run to the end: nothing left to resume, no checkpoint
    with netCDF4.Dataset(tmp_path / "whole" / "fields.nc") as nc:
        np.testing.assert_array_equal(nc["h_max"][:].filled(np.nan), whole.peak_fields()["h_max"])
        assert float(nc["peak_time"][:]) == whole.t == 1.0

    part = Simulation(sc)
    part.run(out_dir=tmp_path / "part", progress=False, t_end=0.3, checkpoint_spacing=3600.0)
    assert writes == [0.3]  # the state a later run continues from
    later = Simulation.resume(tmp_path / "part")
    assert later.t == 0.3 and later.stats.steps == part.stats.steps
    np.testing.assert_array_equal(later.op.get(0), part.op.get(0))
    later.run(out_dir=tmp_path / "part", progress=False)
    with netCDF4.Dataset(tmp_path / "part" / "fields.nc") as nc:
        np.testing.assert_allclose(nc["time"][:], np.arange(11) / 10, rtol=1e-12)

    writes.clear()
    Simulation(sc).run(out_dir=tmp_path / "every", progress=False, checkpoint_spacing=0.0)
    # one after each step that crossed one of the ten output times (steps are not shortened
    # to them, and may cross two; the last ends at t_end)
    ends = read_diagnostics(tmp_path / "every" / "diagnostics.csv")["time"]
    outputs = [round(0.1 * k, 12) for k in range(1, 11)]
    crossed = [b for a, b in zip(ends[:-1], ends[1:]) if any(a < o <= b for o in outputs)]
    assert writes == crossed and len(writes) >= 5 and writes[-1] == 1.0
    assert_same_run(tmp_path / "whole", tmp_path / "every")
    with pytest.raises(InputError, match="checkpoint_spacing"):
        Simulation(sc).run(out_dir=tmp_path / "bad", progress=False, checkpoint_spacing=-1)
