"""Hardening: runs stay inside their folder, one writer per folder, limits before work."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest

from tiseg.apps.cli import main
from tiseg.errors import InputError
from tiseg.output.paths import RunLock, safe_name
from tiseg.setup.scene import load_scene
from tiseg.run.simulation import Simulation

TINY = {
    "domain.resolution": 40,
    "domain.Lx": 0.3,
    "domain.Ly": 0.1,
    "time.t_end": 0.05,
    "output.times": [],
    "output.interval": None,
}


def tiny():
    return load_scene("fingers", TINY)


def _cli(*args) -> list[str]:
    out = ["run", "fingers"]
    for k, v in TINY.items():
        if v is not None:
            out += ["--set", f"{k}={v}"]
    return out + ["--no-progress", *args]


# ------------------------------------------------------------------ limits
def test_more_threads_than_cores_are_refused(capsys):
    from tiseg import backend

    cores = backend.available_cores()
    assert main(["run", "fingers", "--threads", "100000"]) == 2
    assert f"offers {cores} core(s)" in capsys.readouterr().err
    with pytest.raises(InputError, match="core"):
        backend.init("cpu", "f64", cores + 1)


# ------------------------------------------------------------------ names
@pytest.mark.parametrize("name", ["..", ".", ".hidden", "-rf", "a/b", "a b", ""])
def test_unsafe_scene_names_are_refused(name, capsys):
    assert main(["run", "fingers", "--set", f"name={name!r}"]) == 2
    assert "starting with a letter or digit" in capsys.readouterr().err


def test_scene_file_stem_is_made_safe(tmp_path):
    src = load_scene("fingers").to_toml().replace('name = "fingers"\n', "")
    path = tmp_path / "my scene (v2).toml"
    path.write_text(src)
    assert load_scene(str(path)).name == "my_scene_v2_"
    assert safe_name("..") == "scene" and safe_name("../etc") == "etc"


# ------------------------------------------------------------------ the output folder
def test_symlinks_inside_the_output_folder_are_not_followed(ti_cpu, tmp_path):
    target = tmp_path / "precious.txt"
    target.write_text("keep me")
    out = tmp_path / "run"
    out.mkdir()
    (out / "diagnostics.csv").symlink_to(target)
    with pytest.raises(InputError, match="symbolic link"):
        Simulation(tiny()).run(out_dir=out, progress=False)
    assert target.read_text() == "keep me"


@pytest.mark.slow
def test_foreign_files_and_finished_runs_need_overwrite(ti_cpu, tmp_path, capsys):
    out = tmp_path / "run"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    assert main(_cli("--out", str(out))) == 2
    assert "notes.txt" in capsys.readouterr().err and (out / "notes.txt").read_text() == "mine"
    (out / "notes.txt").unlink()
    assert main(_cli("--out", str(out))) == 0
    capsys.readouterr()
    assert main(_cli("--out", str(out))) == 2  # a finished run
    assert "earlier run" in capsys.readouterr().err
    assert main(_cli("--out", str(out), "--overwrite")) == 0
    with pytest.raises(InputError, match="earlier run"):
        Simulation(tiny()).run(out_dir=out, progress=False)  # the API alike


HOLD = """
import sys, time
from tiseg.output.paths import RunLock
lock = RunLock(sys.argv[1]).acquire()
print("held", flush=True)
time.sleep(60)
"""


@pytest.fixture
def held_folder(tmp_path):
    """A folder whose run lock another process holds."""
    d = tmp_path / "busy"
    d.mkdir()
    p = subprocess.Popen([sys.executable, "-c", HOLD, str(d)], stdout=subprocess.PIPE, text=True)
    assert p.stdout.readline().strip() == "held"
    yield d, p.pid
    p.kill()
    p.wait()


def test_a_second_writer_is_refused_naming_the_holder(ti_cpu, held_folder):
    d, pid = held_folder
    with pytest.raises(InputError, match=f"in use by another tiseg run \\(pid {pid} on"):
        Simulation(tiny()).run(out_dir=d, progress=False)
    assert RunLock(d).busy() is not None


def test_a_killed_holder_releases_the_lock(tmp_path):
    d = tmp_path / "x"
    d.mkdir()
    p = subprocess.Popen([sys.executable, "-c", HOLD, str(d)], stdout=subprocess.PIPE, text=True)
    assert p.stdout.readline().strip() == "held"
    assert RunLock(d).busy() is not None
    p.kill()
    p.wait()
    assert RunLock(d).busy() is None
    with RunLock(d):
        pass


def test_sweep_skips_a_run_another_process_holds(held_folder):
    from tiseg.apps.sweep import execute_run

    d, pid = held_folder
    rec = execute_run(
        {"name": "busy", "dir": str(d), "scene_toml": tiny().to_toml(), "fingerprint": "x"}
    )
    assert rec["status"] == "busy" and f"pid {pid}" in rec["holder"]


@pytest.mark.slow
def test_resume_removes_stale_temporaries(ti_cpu, tmp_path):
    from tiseg.run import checkpoint

    out = tmp_path / "run"
    sc = load_scene("fingers", {**TINY, "time.t_end": 0.2, "output.interval": 0.05})
    sim = Simulation(sc)
    sim.run(out_dir=out, progress=False, t_end=0.1)
    stale = out / ".checkpoint.npz.abc123.tmp"
    stale.write_bytes(b"half")
    assert (out / checkpoint.CHECKPOINT_NAME).is_file()
    Simulation.resume(out).run(out_dir=out, progress=False)
    assert not stale.exists()
    assert not [p for p in os.listdir(out) if p.endswith(".tmp")]


# ------------------------------------------------------------------ limits before work
def test_a_grid_that_cannot_fit_in_memory_is_refused_with_the_numbers(ti_cpu, monkeypatch):
    import tiseg.run.limits as L

    monkeypatch.setattr(L, "memory_available", lambda: 10_000)
    with pytest.raises(InputError, match=r"needs about .* GB of memory .* available"):
        Simulation(tiny())


def test_output_larger_than_the_free_disk_gives_a_note(ti_cpu, tmp_path, monkeypatch, caplog):
    import collections
    import logging

    import tiseg.run.limits as L

    usage = collections.namedtuple("usage", "total used free")
    monkeypatch.setattr(L.shutil, "disk_usage", lambda p: usage(1, 1, 10))
    with caplog.at_level(logging.WARNING, logger="tiseg"):
        Simulation(tiny()).run(out_dir=tmp_path / "r", progress=False)
    assert any("may need up to" in r.getMessage() for r in caplog.records)


@pytest.mark.parametrize(
    "over, match",
    [
        ({"flow.nu": 1e308}, "flow.nu"),
        ({"domain.Ly": 1e308}, "cells"),
        ({"domain.Lx": 1e300}, "cells"),
    ],
)
def test_parameters_out_of_range_are_input_errors(over, match):
    with pytest.raises(InputError, match=match):
        load_scene("fingers", over)


def test_a_run_that_cannot_advance_stops_with_a_reason(ti_cpu):
    from tiseg.run.simulation import SimulationError

    sim = Simulation(tiny())
    sim.stepper.plan = lambda *a, **k: (1e-30, 2)  # as an overflowing stiffness would
    with pytest.raises(
        SimulationError, match="of the convective limit .* stiffness is out of range"
    ):
        sim.step()
    sim.t = 1.0
    with pytest.raises(SimulationError, match="time stalled"):
        sim.step(t_stop=2.0)


# ------------------------------------------------------------------ write errors
@pytest.mark.slow
def test_a_full_disk_is_one_line_and_the_run_resumes(ti_cpu, tmp_path, monkeypatch):
    import errno

    import netCDF4

    from tiseg.output.netcdf import FieldsWriter
    from tiseg.run.run_folder import OutputError

    sc = load_scene("fingers", {**TINY, "time.t_end": 0.2, "output.interval": 0.05})
    whole = Simulation(sc)
    whole.run(progress=False)
    real = FieldsWriter.write
    calls = []

    def failing(self, t, **a):
        calls.append(t)
        if len(calls) == 4:  # t = 0.15 s: the first step (0.13 s) wrote a checkpoint
            raise OSError(errno.ENOSPC, "No space left on device")
        return real(self, t, **a)

    monkeypatch.setattr(FieldsWriter, "write", failing)
    out = tmp_path / "run"
    with pytest.raises(OutputError) as info:
        # (a checkpoint at every output time: this run takes under a second)
        Simulation(sc).run(out_dir=out, progress=False, checkpoint_spacing=0.0)
    msg = str(info.value)
    assert "fields.nc" in msg and "No space left on device" in msg and "--resume" in msg
    monkeypatch.setattr(FieldsWriter, "write", real)
    again = Simulation.resume(out)
    again.run(out_dir=out, progress=False)
    np.testing.assert_array_equal(again.op.get(0), whole.op.get(0))
    with netCDF4.Dataset(out / "fields.nc") as nc:
        np.testing.assert_allclose(nc["time"][:], [0.0, 0.05, 0.1, 0.15, 0.2])


def test_fields_file_is_never_left_half_created(tmp_path, monkeypatch):
    from tiseg.output.netcdf import FieldsWriter

    def boom(*a, **k):
        raise KeyboardInterrupt  # a kill while the header is written

    monkeypatch.setattr(FieldsWriter, "_define", boom)
    with pytest.raises(KeyboardInterrupt):
        FieldsWriter(tmp_path / "fields.nc", [0.5], [0.5])
    assert os.listdir(tmp_path) == []


# ------------------------------------------------------------------ checkpoints
@pytest.mark.slow
@pytest.mark.parametrize(
    "damage, message",
    [
        (lambda d: d.update(t=np.array(99.0)), "outside [0, time.t_end"),
        (lambda d: d["q"].__setitem__((0, 3, 3), np.nan), "NaN, Inf"),
        (lambda d: d.pop("budget"), "lacks budget"),
        (lambda d: d.update(steps=np.array(-4)), "steps=-4"),
        (lambda d: d.pop("version"), "no readable checkpoint version"),
    ],
)
def test_damaged_checkpoints_are_refused_each_with_its_message(
    ti_cpu, tmp_path, capsys, damage, message
):
    from tiseg.run import checkpoint

    out = tmp_path / "run"
    sc = load_scene("fingers", {**TINY, "time.t_end": 0.2, "output.interval": 0.05})
    Simulation(sc).run(out_dir=out, progress=False, t_end=0.1)
    path = out / checkpoint.CHECKPOINT_NAME
    with np.load(path) as z:
        d = {k: z[k].copy() for k in z.files}
    damage(d)
    with open(path, "wb") as fh:
        np.savez(fh, **d)
    assert main(["run", "--resume", str(out), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err, err


def test_running_out_of_field_trees_is_an_error_not_a_crash(ti_cpu, monkeypatch):
    from tiseg import backend
    from tiseg.errors import TisegError

    monkeypatch.setattr(backend, "field_trees", lambda: backend.MAX_FIELD_TREES - 1)
    with pytest.raises(TisegError, match="force=True"):
        Simulation(tiny())


def test_a_sweep_task_takes_its_workers_thread_count():
    import distributed

    from tiseg.apps.sweep import _worker_threads

    assert _worker_threads() == 0  # not inside a worker
    with (
        distributed.LocalCluster(
            n_workers=1, threads_per_worker=1, processes=False, dashboard_address=":0"
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        assert client.submit(_worker_threads).result(timeout=60) == 1


def test_a_sweep_retries_a_transient_failure_once(tmp_path, monkeypatch):
    """A task that fails once (as a transient ti.init failure would) is run again; one that
    keeps failing is reported as failed after its retry."""
    import distributed

    from tiseg.apps import sweep as S

    tally = tmp_path / "calls"
    tally.mkdir()

    def flaky(spec):  # (Dask runs a copy of this: count in files)
        mark = tally / spec["name"]
        n = (int(mark.read_text()) if mark.exists() else 0) + 1
        mark.write_text(str(n))
        if n == 1 or "0.02" in spec["name"]:
            raise OSError("Resource temporarily unavailable")
        return {
            "name": spec["name"],
            "status": "done",
            "steps": 1,
            "wall_s": 0.0,
            "metrics": {
                "time": [0.5],
                "finger_count": [0],
                "wavelength": [None],
                "elongation": [None],
            },
        }

    monkeypatch.setattr(S.runner, "execute_run", flaky)
    sw = S.load_sweep("tiny")
    with distributed.LocalCluster(
        n_workers=1, threads_per_worker=1, processes=False, dashboard_address=":0"
    ) as cluster:
        res = S.run_sweep(sw, tmp_path / "sw", scheduler=cluster.scheduler_address, echo=None)
    status = {r["name"]: r["status"] for r in res.records}
    assert status == {"nu-0.01": "done", "nu-0.02": "failed"}, status
    assert {p.name: int(p.read_text()) for p in tally.iterdir()} == {"nu-0.01": 2, "nu-0.02": 2}


def test_an_interrupted_sweep_cancels_the_runs_not_started(tmp_path, monkeypatch):
    """Ctrl-C in the client (here: raised by its progress output after the first run) cancels
    the tasks still queued (the sweep cancels its futures, and closes its client): of three
    runs on one worker slot, the third never starts."""
    import time

    import distributed

    from tiseg.apps import sweep as S

    started = tmp_path / "started"
    started.mkdir()

    def slow(spec):  # (Dask runs a copy of this: report in files)
        (started / spec["name"]).write_text("")
        time.sleep(1.0)
        return {
            "name": spec["name"],
            "status": "done",
            "steps": 1,
            "wall_s": 0.0,
            "metrics": {
                "time": [0.5],
                "finger_count": [0],
                "wavelength": [None],
                "elongation": [None],
            },
        }

    def echo(line):
        if line.startswith("[1/3]"):
            raise KeyboardInterrupt

    monkeypatch.setattr(S.runner, "execute_run", slow)
    sw = S.load_sweep("tiny", grid_overrides={"flow.nu": [0.01, 0.02, 0.03]})
    with distributed.LocalCluster(
        n_workers=1, threads_per_worker=1, processes=False, dashboard_address=":0"
    ) as cluster:
        with pytest.raises(KeyboardInterrupt):
            S.run_sweep(  # one run a task (the default would put two in one)
                sw, tmp_path / "sw", scheduler=cluster.scheduler_address, echo=echo, batch=1
            )
        time.sleep(3.0)  # long enough for a third run to have started
    assert len(list(started.iterdir())) <= 2
