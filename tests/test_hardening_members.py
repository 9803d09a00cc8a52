"""Hardening of the members of sweeps and calibrations (issue 48, items 3 to 7): a member's
result is used only when all of it was read and it succeeded, a search never sees a failed
member as a number, a finished member is never replaced by another command's member of the
same name, and a result that cannot be made again does not survive as a stale file."""

from __future__ import annotations

import json
from pathlib import Path

import netCDF4
import numpy as np
import pytest

from tiseg.apps.sweep import sweep_from_dict
from tiseg.errors import InputError

# a 1D dam break of three members (their fields files are written here, nothing runs)
PROB = {
    "scene": "dam-break",
    "set": {"domain": {"nx": 40}, "time": {"t_end": 0.15}, "output": {"interval": 0.15}},
    "sample": {"method": "lhs", "n": 3, "seed": 3, "initial.h_left": [0.001, 0.003]},
    "probability": {"h_thresholds": [0.001]},
}


def peak_file(path: Path, *, compress: str | None = None) -> None:
    """A member's fields.nc with peak fields on a 2 x 8 grid where the flow reached every
    cell (arrival_time given everywhere); ``compress``: the one field stored compressed."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with netCDF4.Dataset(path, "w") as ds:
        ds.createDimension("y", 2)
        ds.createDimension("x", 8)
        for name, n in (("y", 2), ("x", 8)):
            ds.createVariable(name, "f8", (name,))[:] = 0.01 * np.arange(n) + 0.005
            ds[name].setncatts({"long_name": name, "units": "m"})
        rng = np.random.default_rng(1)
        for name in ("h_max", "speed_max", "arrival_time"):
            v = ds.createVariable(
                name, "f8", ("y", "x"), fill_value=np.nan, zlib=name == compress, complevel=4
            )
            v.setncatts({"long_name": name, "units": "s" if name == "arrival_time" else "m"})
            v[:] = 0.002 + 0.01 * rng.random((2, 8))


def damage_the_compressed_block(path: Path) -> None:
    """Overwrite the zlib stream of the file's one compressed variable (its header kept)."""
    data = bytearray(path.read_bytes())
    o = next(i for i in range(len(data) - 1) if data[i] == 0x78 and data[i + 1] == 0x5E)
    data[o + 2 : o + 40] = b"\xff" * 38
    path.write_bytes(bytes(data))


# ------------------------------------------------------------------ 3: one damaged peak field
@pytest.mark.parametrize("which", ["speed_max", "arrival_time"])
def test_a_member_with_one_unreadable_peak_field_is_left_out_whole(tmp_path, caplog, which):
    """A read failure on a member's second (or third) field left its first fields stacked:
    the stacks misaligned and p_arrival topped out at 2/3 where every member arrived."""
    from tiseg.apps.sweep.probability import write_probability
    import xarray as xr

    sw = sweep_from_dict(json.loads(json.dumps(PROB)), source="s.toml")
    names = [r.name for r in sw.runs]
    for name in names:
        peak_file(tmp_path / name / "fields.nc", compress=which if name == names[1] else None)
    damage_the_compressed_block(tmp_path / names[1] / "fields.nc")
    path = write_probability(sw, tmp_path, {n: {"status": "reused"} for n in names})
    with xr.open_dataset(path) as ds:
        assert ds.run.values.tolist() == [names[0], names[2]]
        assert float(ds.p_arrival.min()) == 1.0  # the flow reached every cell in each member
        assert ds.attrs["members_left_out"] == names[1]
    assert f"member {names[1]} is left out" in caplog.text


def test_sweep_nc_keeps_no_part_of_a_member_whose_peak_fields_cannot_all_be_read(tmp_path):
    from tiseg.apps.sweep import write_dataset
    import xarray as xr

    sw = sweep_from_dict(json.loads(json.dumps(PROB)), source="s.toml")
    names = [r.name for r in sw.runs]
    for name in names:
        peak_file(tmp_path / name / "fields.nc", compress="speed_max" if name == names[1] else None)
    damage_the_compressed_block(tmp_path / names[1] / "fields.nc")
    path = write_dataset(sw, tmp_path, {n: {"status": "reused"} for n in names})
    with xr.open_dataset(path) as ds:
        assert np.isnan(ds.h_max.isel(member=1)).all()  # not its h_max without its speed_max
        assert not np.isnan(ds.h_max.isel(member=0)).any()


# ------------------------------------------------------------------ 4: a failed calibration member
def _calibrate(tmp_path, monkeypatch, model, *more) -> int:
    """`tiseg calibrate` of the dam break's mu against a run-out, members run by ``model``."""
    import tiseg.apps.commands.calibrate as command
    from tiseg.apps.calibration import run_calibration as real
    from tiseg.apps.cli import main

    monkeypatch.setattr(
        command,
        "run_calibration",
        lambda cal, out, **kw: real(cal, out, **{**kw, "execute": model}),
    )
    argv = ["calibrate", "dam-break", "--param", "effects.coulomb_mu=0.1:0.4", "--target"]
    argv += ["runout=0.15+-0.001", "--budget", "12", "--out", str(tmp_path), *more]
    return main([*argv, "--set", "effects.friction=coulomb", "--set", "domain.nx=40"])


class Failing:
    """The calibration tests' stand-in model, whose members fail (as execute_run reports a
    failed run) where ``fails(mu)``."""

    def __init__(self, fails):
        from test_calibration import Model, run_out_of_mu

        self.model, self.fails, self.failed = Model(run_out_of_mu), fails, []

    def __call__(self, spec: dict) -> dict:
        from tiseg.setup.scene import scene_from_text

        mu = scene_from_text(spec["scene_toml"]).effects.coulomb_mu
        if self.fails(mu):
            self.failed.append(spec["name"])
            return {"name": spec["name"], "status": "failed", "error": "SimulationError: boom"}
        return self.model(spec)


def test_a_failed_calibration_member_stops_the_search_and_is_no_number(
    tmp_path, monkeypatch, capsys
):
    """The second point of Brent's search fails: it was scored as misfit 1000, the search went
    on around it and the calibration ended `complete: true` with exit 0. Now it stops there,
    exit 1, complete: false, the member listed as failed with a null misfit; run again (the
    member no longer failing) it completes, reusing the member that finished."""
    model = Failing(lambda mu: mu > 0.25)  # Brent's second point, 0.1 + 0.618 * 0.3
    assert _calibrate(tmp_path, monkeypatch, model) == 1
    err = capsys.readouterr().err
    assert "calibration incomplete" in err and model.failed[0] in err, err
    data = json.loads((tmp_path / "calibration.json").read_text())
    assert data["complete"] is False and data["uncertainty"] is None
    assert [f["member"] for f in data["failed"]] == model.failed == [model.failed[0]]
    failed = [e for e in data["evaluations"] if e["status"] == "failed"]
    assert [e["misfit"] for e in failed] == [None] and "boom" in failed[0]["error"]
    # nothing ran after the failure: the search saw no number for it
    assert data["evaluations"][-1]["member"] == model.failed[0]
    assert (tmp_path / "misfit.png").is_file()

    again = Failing(lambda mu: False)
    assert _calibrate(tmp_path, monkeypatch, again) == 0
    data = json.loads((tmp_path / "calibration.json").read_text())
    assert data["complete"] is True and data["failed"] is None
    assert again.model.runs[0] == model.failed[0]  # the failed member is run again
    assert data["best"]["values"]["effects.coulomb_mu"] == pytest.approx(0.2, rel=1e-3)


def test_a_failed_member_of_the_first_design_stops_before_nelder_mead(tmp_path):
    """Two parameters: a failed member of the Latin hypercube is no candidate for the start of
    Nelder-Mead (it was, with its misfit 1000, and steered the search)."""
    from test_calibration import FIXED, linear_pair

    from tiseg.apps.calibration import calibration_from_args, run_calibration

    cal = calibration_from_args(
        "dam-break",
        ["effects.coulomb_mu=0.1:0.4", "initial.h_left=0.01:0.03"],
        ["x_front_max=1.3", "deposit.thickness_mean=0.2"],
        fixed=FIXED,
        budget=24,
    )
    from test_calibration import Model

    inner = Model(linear_pair)

    def execute(spec):
        if len(inner.runs) == 1:  # the design's second point fails
            inner.runs.append(spec["name"])
            return {"name": spec["name"], "status": "failed", "error": "OSError: disk full"}
        return inner(spec)

    res = run_calibration(cal, tmp_path, echo=None, execute=execute)
    assert not res.complete and res.result["failed"][0]["error"] == "OSError: disk full"
    assert all(e["purpose"] == "search" for e in res.result["evaluations"])
    assert len(res.result["evaluations"]) == len(inner.runs)  # the design only, then stop
    assert res.result["best"]["misfit"] is not None


# ------------------------------------------------------------------ 5: numbers and unreadable files
@pytest.mark.parametrize(
    "param, target",
    [
        ("effects.coulomb_mu=1e-400:0.3", "runout=0.2"),
        ("effects.coulomb_mu=0.1:0.3", "runout=1e-400"),
        ("effects.coulomb_mu=0.1:0.3", "runout=0.2+-1e-330"),
    ],
)
def test_a_number_that_underflows_is_refused_not_read_as_zero(param, target):
    from tiseg.apps.calibration import calibration_from_args

    with pytest.raises(InputError, match="1e-[34][03]0: smaller than the smallest normal"):
        calibration_from_args("dam-break", [param], [target], fixed={"effects.friction": "coulomb"})


def _finished_member(d: Path, scene, **rec) -> None:
    from tiseg.apps.sweep import DONE_MARKER, MARKER_VERSION

    d.mkdir(parents=True, exist_ok=True)
    (d / "scene.toml").write_text(scene.to_toml(), encoding="utf-8")
    peak_file(d / "fields.nc")
    rec = {"marker_version": MARKER_VERSION, "name": d.name, **rec}
    (d / DONE_MARKER).write_text(json.dumps(rec), encoding="utf-8")


@pytest.mark.parametrize("damage", ["garbage", "truncated", "resized"])
def test_a_member_whose_fields_file_is_unreadable_is_run_again(tmp_path, monkeypatch, damage):
    """A finished member whose fields.nc no longer opens (or is not the size its record
    gives) was reused on every run of the sweep; it is run again."""
    import tiseg.apps.sweep as S

    sw = S.load_sweep("tiny")
    for run in sw.runs:
        _finished_member(tmp_path / run.name, run.scene)
    bad = tmp_path / sw.runs[0].name / "fields.nc"
    size = bad.stat().st_size
    if damage == "garbage":
        bad.write_bytes(b"\x00" * size)
    elif damage == "truncated":
        bad.write_bytes(bad.read_bytes()[: size // 2])
    else:  # a file that opens but is not the one the run finished with
        rec = json.loads((bad.parent / S.DONE_MARKER).read_text())
        (bad.parent / S.DONE_MARKER).write_text(json.dumps({**rec, "fields_bytes": size + 1}))
    pending = []
    monkeypatch.setattr(
        S.runner, "_run_on_dask", lambda sweep, out, todo, *a, **k: pending.extend(todo)
    )
    monkeypatch.setattr(S.runner, "write_results", lambda *a: [])
    S.run_sweep(sw, tmp_path, echo=None)
    assert [r.name for r in pending] == [sw.runs[0].name]


# ------------------------------------------------------------------ 6: another command's members
def test_a_sweep_and_a_calibration_do_not_share_an_out_folder(tmp_path):
    import tiseg.apps.sweep as S
    from tiseg.apps.calibration import calibration_from_args, run_calibration
    from test_calibration import FIXED, Model, run_out_of_mu

    cal = calibration_from_args(
        "dam-break", ["effects.coulomb_mu=0.1:0.4"], ["runout=0.15"], fixed=FIXED, budget=2
    )
    run_calibration(cal, tmp_path / "cal", echo=None, execute=Model(run_out_of_mu))
    with pytest.raises(InputError, match="holds a calibration .*--overwrite"):
        S.run_sweep(S.load_sweep("tiny"), tmp_path / "cal", echo=None)
    S.table._write_outputs(S.load_sweep("tiny"), tmp_path / "sw", {})
    with pytest.raises(InputError, match="holds a sweep .*--overwrite"):
        run_calibration(cal, tmp_path / "sw", echo=None, execute=Model(run_out_of_mu))


def test_a_finished_member_of_another_scene_is_not_replaced(tmp_path, monkeypatch):
    """A calibration of flow.nu (other --set) left a finished member ``nu-0.01`` in the folder
    (killed before its calibration.json, or that file removed): a sweep of the same name ran
    its own member there and replaced it. Now the sweep is refused before anything runs, the
    calibration too, and a worker given the member refuses it as well."""
    import tiseg.apps.sweep as S
    from tiseg.apps.calibration import calibration_from_args

    sw = S.load_sweep("tiny")
    theirs = S.load_sweep("tiny", extra_overrides={"flow.h0": 0.0021}).runs[0]
    member = tmp_path / theirs.name
    _finished_member(member, theirs.scene)
    before = {p.name: p.read_bytes() for p in member.iterdir()}
    monkeypatch.setattr(S.runner, "_run_on_dask", lambda *a, **k: pytest.fail("ran"))
    with pytest.raises(InputError, match="holds a finished run of another scene.*--overwrite"):
        S.run_sweep(sw, tmp_path, echo=None)

    cal = calibration_from_args(
        "fingers",
        ["flow.nu=0.01:0.02"],
        ["x_front_max=0.1"],
        fixed={"domain.resolution": 40, "domain.Lx": 0.3, "domain.Ly": 0.1, "time.t_end": 0.5},
        budget=2,
    )
    from tiseg.apps.calibration.search import Evaluator

    ev = Evaluator(cal, tmp_path, execute=lambda spec: pytest.fail("ran"))
    with pytest.raises(InputError, match="holds a finished run of another scene"):
        ev.evaluate([{"flow.nu": 0.01}], "search")  # the member nu-0.01

    spec = {"name": member.name, "dir": str(member), "fingerprint": "x", "report": False}
    rec = S.execute_run({**spec, "scene_toml": sw.runs[0].scene.to_toml()})
    assert rec["status"] == "failed" and "another scene" in rec["error"], rec
    assert {p.name: p.read_bytes() for p in member.iterdir()} == before


# ------------------------------------------------------------------ 7: stale results
def test_a_result_that_cannot_be_made_again_is_not_left_stale(tmp_path, caplog):
    """A rerun that cannot write probability.nc (no member can be stacked now) or a
    sensitivity chart (no output with indices) left the old file, which `tiseg render` drew."""
    from tiseg.apps.sweep import write_results

    sw = sweep_from_dict(json.loads(json.dumps(PROB)), source="s.toml")
    names = [r.name for r in sw.runs]
    for name in names:
        peak_file(tmp_path / name / "fields.nc")
    records = {n: {"status": "reused"} for n in names}
    assert (tmp_path / "probability.nc") in write_results(sw, tmp_path, records)
    failed = {n: {"status": "failed", "error": "x"} for n in names}
    assert (tmp_path / "probability.nc") not in write_results(sw, tmp_path, failed)
    assert not (tmp_path / "probability.nc").exists()
    assert "removed the stale" in caplog.text

    sobol = json.loads(json.dumps(PROB))
    sobol["sample"] = {"method": "sobol", "n": 2, "seed": 1, "initial.h_left": [0.001, 0.003]}
    sobol["sample"]["flow.h0"] = [0.001, 0.002]
    sw = sweep_from_dict(sobol, source="s.toml")
    (tmp_path / "sensitivity.png").write_bytes(b"an earlier chart")
    paths = write_results(sw, tmp_path, {})  # no member finished: no indices to draw
    assert (tmp_path / "sensitivity.csv") in paths
    assert not (tmp_path / "sensitivity.png").exists()


# ------------------------------------------------------------------ 10: links at result names
def test_calibration_results_are_not_written_through_links(tmp_path):
    from tiseg.apps.calibration import calibration_from_args, plot_misfit, run_calibration
    from test_calibration import FIXED, Model, run_out_of_mu

    cal = calibration_from_args(
        "dam-break", ["effects.coulomb_mu=0.1:0.4"], ["runout=0.15"], fixed=FIXED, budget=2
    )
    outside = tmp_path / "outside.png"
    outside.write_bytes(b"keep")
    out = tmp_path / "cal"
    out.mkdir()
    (out / "misfit.png").symlink_to(outside)
    model = Model(run_out_of_mu)
    with pytest.raises(InputError, match="misfit.png' is a symbolic link"):
        run_calibration(cal, out, echo=None, execute=model)
    assert model.runs == [] and outside.read_bytes() == b"keep"
    # a link made while it ran is replaced, not followed
    (out / "misfit.png").unlink()
    result = run_calibration(cal, out, echo=None, execute=model).result
    (out / "misfit.png").unlink()
    (out / "misfit.png").symlink_to(outside)
    plot_misfit(cal, result, out / "misfit.png")
    assert outside.read_bytes() == b"keep" and not (out / "misfit.png").is_symlink()


def test_sweep_results_are_not_written_through_links(tmp_path, monkeypatch):
    import tiseg.apps.sweep as S
    from tiseg.apps.sweep.sensitivity import plot_sensitivity

    sobol = json.loads(json.dumps(PROB))
    sobol["sample"] = {"method": "sobol", "n": 2, "seed": 1, "initial.h_left": [0.001, 0.003]}
    sobol["sample"]["flow.h0"] = [0.001, 0.002]
    sw = sweep_from_dict(sobol, source="s.toml")
    outside = tmp_path / "outside.png"
    outside.write_bytes(b"keep")
    out = tmp_path / "sw"
    out.mkdir()
    (out / "sensitivity.png").symlink_to(outside)
    monkeypatch.setattr(S.runner, "_run_on_dask", lambda *a, **k: pytest.fail("ran"))
    with pytest.raises(InputError, match="sensitivity.png' is a symbolic link"):
        S.run_sweep(sw, out, echo=None)
    rows = [
        {"output": "x_front_max", "parameter": k, "S1": 0.5, "S1_low": 0.4, "S1_high": 0.6}
        | {"ST": 0.5, "ST_low": 0.4, "ST_high": 0.6}
        for k in sw.sample.keys
    ]
    plot_sensitivity(sw, rows, out, dpi=20)
    assert outside.read_bytes() == b"keep" and not (out / "sensitivity.png").is_symlink()


# ------------------------------------------------------------------ 13: tracebacks
@pytest.mark.parametrize("seed", ["-1", str(2**64)])
def test_a_design_seed_numpy_cannot_take_is_one_line(seed, capsys, tmp_path):
    from tiseg.apps.cli import main

    argv = ["calibrate", "dam-break", "--set", "effects.friction=coulomb", "--out", str(tmp_path)]
    argv += ["--param", "effects.coulomb_mu=0.1:0.3", "--param", "initial.h_left=0.01:0.02"]
    assert main([*argv, "--target", "runout=0.2", "--design-seed", seed]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and f"--design-seed {seed}: give a whole number" in err


def test_a_member_failing_with_any_error_is_one_line_not_retried(tmp_path, monkeypatch, capfd):
    """A member whose run raised an error other than tiseg's (here a full disk as its folder
    is prepared) was run twice by Dask, which printed its traceback blocks; it is reported as
    failed once, in one line, its traceback kept in the record."""
    import errno

    import distributed

    import tiseg.apps.sweep as S

    calls = []

    def full_disk(*a, **k):
        calls.append(1)
        raise OSError(errno.ENOSPC, "No space left on device")

    # as the member's folder is prepared (the in-process workers share this process's
    # Taichi runtime, which a real run there would reset)
    monkeypatch.setattr(S.members, "check_fresh_folder", full_disk)
    sw = S.load_sweep("tiny", grid_overrides={"flow.nu": [0.01]})
    with distributed.LocalCluster(
        n_workers=1, threads_per_worker=1, processes=False, dashboard_address=":0"
    ) as cluster:
        res = S.run_sweep(sw, tmp_path, scheduler=cluster.scheduler_address, echo=print)
    (rec,) = res.records
    assert (
        rec["status"] == "failed" and rec["error"] == "OSError: [Errno 28] No space left on device"
    )
    out, err = capfd.readouterr()
    assert len(calls) == 1  # not retried
    assert "Traceback" not in out + err and "FAILED (OSError" in out, out + err
    assert "full_disk" in rec["traceback"]


# ------------------------------------------------------------------ 9: --scheduler that never answers
@pytest.fixture
def not_dask():
    """A real TCP service on 127.0.0.1 that accepts connections and never says a word."""
    import socket
    import threading

    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen(8)
    held, stop = [], threading.Event()

    def serve():
        srv.settimeout(0.2)
        while not stop.is_set():
            try:
                held.append(srv.accept()[0])
            except OSError:
                continue

    t = threading.Thread(target=serve, daemon=True)
    t.start()
    yield f"tcp://127.0.0.1:{srv.getsockname()[1]}"
    stop.set()
    t.join()
    for c in held:
        c.close()
    srv.close()


def test_a_scheduler_address_that_is_not_dask_is_refused_in_time(tmp_path, monkeypatch, not_dask):
    """It waited for ever (killed at 400 s)."""
    import time

    import tiseg.apps.sweep as S

    monkeypatch.setattr(S.runner, "CONNECT_TIMEOUT", 1.0)
    t0 = time.monotonic()
    with pytest.raises(InputError, match="no answer as a Dask scheduler within 1 s"):
        S.run_sweep(S.load_sweep("tiny"), tmp_path, scheduler=not_dask, echo=None)
    assert time.monotonic() - t0 < 10


def test_a_scheduler_without_workers_says_so_and_gives_up(tmp_path, monkeypatch):
    """It waited for ever without a word."""
    import distributed

    import tiseg.apps.sweep as S

    monkeypatch.setattr(S.runner, "WORKER_TIMEOUT", 1.0)
    lines: list[str] = []
    with distributed.LocalCluster(n_workers=0, processes=False, dashboard_address=":0") as c:
        with pytest.raises(InputError, match="has no workers .*dask worker"):
            S.run_sweep(
                S.load_sweep("tiny"), tmp_path, scheduler=c.scheduler_address, echo=lines.append
            )
    assert any("has no workers yet; waiting up to 1 s" in s for s in lines), lines


def test_a_malformed_scheduler_address_is_one_line_and_nothing_later(tmp_path):
    """The one-line error was followed 20 s later by a TimeoutError traceback (the half-made
    Dask client closing itself at exit)."""
    import subprocess
    import sys
    import time

    code = "import sys; from tiseg.apps.cli import main; sys.exit(main())"
    argv = ["sweep", "tiny", "--out", str(tmp_path / "sw"), "--scheduler", "tcp://127.0.0.1:x"]
    t0 = time.monotonic()
    res = subprocess.run(
        [sys.executable, "-c", code, *argv], capture_output=True, text=True, timeout=120
    )
    assert res.returncode == 2, res.stderr
    err = res.stderr.strip().splitlines()
    assert len(err) == 2 and "cannot connect to the Dask scheduler" in err[1], res.stderr
    assert time.monotonic() - t0 < 8


# ------------------------------------------------------------------ 8: SIGTERM to a sweep
SLOW_SWEEP = """
import sys, time
import tiseg.apps.sweep.runner as R
from tiseg.output.atomic import replacing

def slow(sweep, out, pending, records, *a, **k):  # a sweep busy writing its table
    with replacing(out / "sweep.csv") as tmp:
        tmp.write_text("half a table")
        print("ready", flush=True)
        time.sleep(60)

R._run_on_dask = slow
from tiseg.apps.cli import main
sys.exit(main([{argv}]))
"""


@pytest.mark.parametrize("command", ["sweep", "calibrate"])
def test_sigterm_stops_a_sweep_in_one_line_without_temporaries(tmp_path, command):
    """A real SIGTERM while the sweep (or calibration) writes a file: it died at once with no
    message, leaving the file's temporary behind."""
    import signal
    import subprocess
    import sys

    out = tmp_path / "out"
    if command == "sweep":
        argv = f"'sweep', 'tiny', '--out', {str(out)!r}"
        code = SLOW_SWEEP.format(argv=argv)
    else:  # the calibration's first member is slow to run: the signal comes while it waits
        argv = f"'calibrate', 'dam-break', '--out', {str(out)!r}, '--set', 'effects.friction="
        argv += "coulomb', '--param', 'effects.coulomb_mu=0.1:0.3', '--target', 'runout=0.2'"
        code = SLOW_SWEEP.replace("R._run_on_dask = slow", "").format(argv=argv)
        code = code.replace(
            "from tiseg.apps.cli import main",
            "import tiseg.apps.calibration\n"
            "C = sys.modules['tiseg.apps.calibration.search']\n"
            "C.Evaluator._run = lambda self, runs: slow(None, self.out, runs, None)\n"
            "from tiseg.apps.cli import main",
        )
    proc = subprocess.Popen(
        [sys.executable, "-c", code], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    try:
        assert proc.stdout.readline().strip() == "ready", proc.stderr.read()
        proc.send_signal(signal.SIGTERM)
        # the stop includes the Dask cluster's shutdown: over 60 s once at load 5 on 2 cores
        _, err = proc.communicate(timeout=180)
    finally:
        proc.kill()
    assert proc.returncode == 128 + signal.SIGTERM, err
    last = err.strip().splitlines()[-1]
    assert "stopped by SIGTERM" in last and "run the same command again" in last, err
    assert "Traceback" not in err
    assert not list(out.glob(".*.tmp")), list(out.iterdir())


def test_a_killed_writers_old_temporaries_are_removed(tmp_path, monkeypatch):
    """A sweep killed (SIGKILL) while writing left `.sweep.csv.*.tmp`; the next one removes
    such temporaries once no writer can be filling them (untouched for STALE_AFTER_S)."""
    import os
    import time

    import tiseg.apps.sweep as S
    from tiseg.output.atomic import STALE_AFTER_S

    old = tmp_path / ".sweep.nc.x1.tmp"
    young = tmp_path / ".sweep.csv.x2.tmp"  # another process may be writing it right now
    chart = tmp_path / ".sensitivity-nu-0.01.png.x3.tmp"
    for p in (old, young, chart):
        p.write_text("half")
    then = time.time() - STALE_AFTER_S - 5
    os.utime(old, (then, then))
    os.utime(chart, (then, then))
    monkeypatch.setattr(S.runner, "_run_on_dask", lambda *a, **k: None)
    monkeypatch.setattr(S.runner, "write_results", lambda *a: [])
    S.run_sweep(S.load_sweep("tiny"), tmp_path, echo=None)
    assert not old.exists() and not chart.exists() and young.exists()


# ------------------------------------------------------------------ 11: read-only and full disks
@pytest.fixture
def mount(tmp_path):
    """``mount(target, *options)``: a real mount, undone after the test (root only: a test
    in a container without the right is skipped, saying so)."""
    import subprocess

    done = []

    def do(target: Path, *options: str) -> Path:
        target.mkdir(parents=True, exist_ok=True)
        res = subprocess.run(["mount", *options, str(target)], capture_output=True, text=True)
        if res.returncode:
            pytest.skip(f"cannot mount here: {res.stderr.strip()}")
        done.append(target)
        return target

    yield do
    for target in reversed(done):
        subprocess.run(["umount", "-l", str(target)], check=False)


def _one_line(capsys, *words) -> str:
    err = capsys.readouterr().err.strip()
    assert "Traceback" not in err, err
    last = err.splitlines()[-1]
    assert all(w in last for w in words), err
    return last


def test_a_finished_calibration_on_a_read_only_mount_is_one_line(
    tmp_path, monkeypatch, capsys, mount
):
    from test_calibration import Model, run_out_of_mu

    src = tmp_path / "cal"
    assert _calibrate(src, monkeypatch, Model(run_out_of_mu)) == 0
    ro = mount(tmp_path / "ro", "--bind", "-o", "ro", str(src))
    with pytest.raises(OSError):  # a real read-only file system: root cannot write either
        (ro / "probe").write_text("x")
    capsys.readouterr()
    assert _calibrate(ro, monkeypatch, Model(run_out_of_mu)) == 2
    _one_line(capsys, "cannot write in", "Read-only file system", "run the same command again")


def test_a_finished_sweep_on_a_read_only_mount_is_one_line(tmp_path, capsys, mount):
    import tiseg.apps.sweep as S
    from tiseg.apps.cli import main
    from tiseg.post.analysis.fingers import ANALYSIS_VERSION

    sw = S.load_sweep("tiny")
    src = tmp_path / "sw"
    metrics = {"analysis_version": ANALYSIS_VERSION, "time": [0.5], "deposit": {}}
    for run in sw.runs:
        _finished_member(src / run.name, run.scene, metrics=metrics)
    S.table._write_outputs(sw, src, {})
    ro = mount(tmp_path / "ro", "--bind", "-o", "ro", str(src))
    assert main(["sweep", "tiny", "--out", str(ro)]) == 2
    _one_line(capsys, "cannot write in", "Read-only file system", "finished runs are kept")


def test_a_calibration_on_a_full_disk_is_one_line(tmp_path, monkeypatch, capsys, mount):
    from test_calibration import Model, run_out_of_mu

    full = mount(tmp_path / "full", "-t", "tmpfs", "-o", "size=64k", "tmpfs")
    with pytest.raises(OSError):  # fill it: a real ENOSPC
        (full / "fill").write_bytes(b"\0" * 100_000)
    assert _calibrate(full / "cal", monkeypatch, Model(run_out_of_mu)) == 2
    _one_line(capsys, "cannot write in", "No space left on device")


# ------------------------------------------------------------------ 14: --workers
@pytest.mark.parametrize("command", ["sweep", "calibrate"])
def test_more_workers_than_cores_are_refused_before_anything_starts(tmp_path, capsys, command):
    """--workers 10000 started a local cluster of as many processes (each a Taichi runtime)."""
    from tiseg.apps.cli import main
    from tiseg.backend import available_cores

    out = tmp_path / "out"
    argv = ["sweep", "tiny"]
    if command == "calibrate":
        argv = ["calibrate", "dam-break", "--set", "effects.friction=coulomb", "--target"]
        argv += ["runout=0.2", "--param", "effects.coulomb_mu=0.1:0.3"]
    cores = available_cores()
    assert main([*argv, "--out", str(out), "--workers", str(cores + 1)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert f"--workers={cores + 1}: this machine offers {cores} core(s)" in err
    assert f"use at most {cores}" in err
    assert not out.exists()
