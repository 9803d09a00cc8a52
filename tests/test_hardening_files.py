"""Hardening of the files of a run folder: files tiseg did not write are never overwritten, a
damaged or half-written file gives one line (or is read without its half-written record), a
resume never undoes the work of another run, and a sweep never replaces another sweep."""

from __future__ import annotations

import errno
import json
import shutil
import subprocess
import sys

import netCDF4
import numpy as np
import pytest

from tiseg.run import checkpoint
from tiseg.apps.cli import main
from tiseg.errors import InputError
from tiseg.output.netcdf import FieldsWriter, read_fields
from tiseg.output.paths import HOLDER_NAME
from tiseg.setup.scene import load_scene
from tiseg.run.simulation import Simulation

SETS = {
    "domain.resolution": 80,
    "domain.Lx": 0.3,
    "domain.Ly": 0.1,
    "time.t_end": 0.1,
    "output.times": [],
    "output.interval": 0.025,
}


def scene(**over):
    return load_scene("fingers", {**SETS, **over})


def cli_run(*args) -> list[str]:
    out = ["run", "fingers", "--no-progress"]
    for k, v in SETS.items():
        out += ["--set", f"{k}={v}"]
    return out + list(args)


def one_line_error(capsys, word: str) -> str:
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    assert word in err, err
    return err


@pytest.fixture(scope="module")
def runs(tmp_path_factory, ti_cpu):
    """{"done": a finished run, "part": a run stopped at t = 0.075 s with its checkpoint}
    (the ramped inflow has wetted the first cells by then)."""
    base = tmp_path_factory.mktemp("files")
    Simulation(scene()).run(out_dir=base / "done", progress=False)
    Simulation(scene()).run(out_dir=base / "part", progress=False, t_end=0.075)
    assert (base / "part" / checkpoint.CHECKPOINT_NAME).is_file()
    return base


def copy(runs, name, tmp_path):
    shutil.copytree(runs / name, tmp_path / name)
    return tmp_path / name


def damage_a_data_block(path) -> None:
    """Overwrite the middle of one zlib-compressed chunk of a fields file."""
    data = bytearray(path.read_bytes())
    starts = [i for i in range(len(data) - 1) if data[i : i + 2] == b"\x78\x5e"]
    o = starts[len(starts) // 2]
    data[o + 2 : o + 40] = b"\xff" * 38
    path.write_bytes(bytes(data))


# ------------------------------------------------------------------ 0: foreign files
def test_a_foreign_file_with_the_name_of_a_run_file_is_not_overwritten(ti_cpu, tmp_path, capsys):
    out = tmp_path / "mine"
    out.mkdir()
    (out / "scene.toml").write_text("keep\n")
    assert main(cli_run("--out", str(out))) == 2
    one_line_error(capsys, "scene.toml")
    assert (out / "scene.toml").read_text() == "keep\n"
    assert sorted(p.name for p in out.iterdir()) == ["scene.toml"]


@pytest.mark.slow  # a long run: the slow set (README), which CI runs after the suite
def test_tiseg_lists_what_it_wrote_and_a_finished_run_still_needs_overwrite(runs, capsys):
    from tiseg.output.manifest import Manifest

    m = Manifest.read(runs / "done")
    assert m.saved and {"scene.toml", "fields.nc", "diagnostics.csv"} <= m.files
    assert main(cli_run("--out", str(runs / "done"))) == 2
    one_line_error(capsys, "earlier run")


@pytest.mark.slow  # a long run: the slow set (README), which CI runs after the suite
def test_after_a_full_disk_at_the_first_write_the_run_may_simply_run_again(
    ti_cpu, tmp_path, monkeypatch, capsys
):
    """ "make room and run again" is what the message says: the folder holds only tiseg's own
    partial output, so no --overwrite is needed."""
    out = tmp_path / "run"

    def full(self, t, **arrays):
        raise OSError(errno.ENOSPC, "No space left on device")

    with monkeypatch.context() as m:
        m.setattr(FieldsWriter, "write", full)
        assert main(cli_run("--out", str(out))) == 2
    assert "make room and run again" in capsys.readouterr().err
    assert main(cli_run("--out", str(out))) == 0
    assert len(read_fields(out / "fields.nc").time) == 5


# ------------------------------------------------------------------ 3: a half-written record
def test_a_half_written_last_record_is_not_a_snapshot(runs, tmp_path, capsys):
    d = copy(runs, "done", tmp_path)
    with netCDF4.Dataset(d / "fields.nc", "a") as ds:  # fields written, the time not
        n = ds.dimensions["time"].size
        for f in ("h", "u", "v", "phi"):
            ds[f][n] = ds[f][n - 1]
    with read_fields(d / "fields.nc") as ds:
        assert ds.sizes["time"] == n and float(ds.time.max()) == pytest.approx(0.1)
    assert main(["fingers", str(d), "--json"]) == 0
    times = json.loads(capsys.readouterr().out)["time"]
    assert len(times) == n and max(times) == pytest.approx(0.1)


# ------------------------------------------------------------------ 2: diagnostics.csv
def _lose_a_row(lines) -> None:
    """A middle row gone, and a row the killed run wrote after its checkpoint."""
    del lines[2]
    lines.append("0.1" + lines[-1][lines[-1].index(",") :])


@pytest.mark.parametrize(
    "spoil, word",
    [
        (lambda lines: lines.__setitem__(2, lines[2][:10] + "\n"), "line 3 is damaged"),
        (lambda lines: lines.insert(2, lines[2]), "row 3 repeats"),
        (_lose_a_row, "rows were lost or repeated"),
        # issue 48: a renamed column failed the first row written after the resume (traceback)
        (
            lambda lines: lines.__setitem__(0, lines[0].replace(",dt,", ",renamed,")),
            "no column 'dt'",
        ),
    ],
)
def test_resume_refuses_a_damaged_row_of_the_diagnostics(runs, tmp_path, capsys, spoil, word):
    d = copy(runs, "part", tmp_path)
    lines = (d / "diagnostics.csv").read_text().splitlines(keepends=True)
    spoil(lines)
    text = "".join(lines)
    (d / "diagnostics.csv").write_text(text)
    fields = (d / "fields.nc").read_bytes()
    assert main(["run", "--resume", str(d)]) == 2
    one_line_error(capsys, word)
    assert (d / "diagnostics.csv").read_text() == text  # nothing was repaired silently
    assert (d / "fields.nc").read_bytes() == fields


def test_resume_refuses_diagnostics_that_are_not_utf8(runs, tmp_path, capsys):
    d = copy(runs, "part", tmp_path)
    with open(d / "diagnostics.csv", "ab") as fh:
        fh.write(b"\xff\xfe\n")
    assert main(["run", "--resume", str(d)]) == 2
    one_line_error(capsys, "UTF-8")


# ------------------------------------------------------------------ 4: one line, no traceback
@pytest.mark.slow  # a long run: the slow set (README), which CI runs after the suite
def test_resume_refuses_a_fields_file_of_another_grid(runs, tmp_path, capsys):
    d = copy(runs, "part", tmp_path)
    Simulation(scene(**{"domain.resolution": 60})).run(out_dir=tmp_path / "other", progress=False)
    shutil.copy(tmp_path / "other" / "fields.nc", d / "fields.nc")
    assert main(["run", "--resume", str(d)]) == 2
    one_line_error(capsys, "18 x 6 grid")


@pytest.mark.parametrize("command", [["fingers"], ["render", "--gif", "{tmp}/x.gif"]])
def test_a_damaged_data_block_is_one_line(runs, tmp_path, capsys, command):
    d = copy(runs, "done", tmp_path)
    damage_a_data_block(d / "fields.nc")
    argv = [a.replace("{tmp}", str(tmp_path)) for a in command]
    assert main([argv[0], str(d), *argv[1:]]) == 2
    one_line_error(capsys, "damaged")


@pytest.mark.slow  # a long run: the slow set (README), which CI runs after the suite
def test_resume_keeps_a_fields_file_with_a_damaged_block_aside(runs, tmp_path):
    d = copy(runs, "part", tmp_path)
    damage_a_data_block(d / "fields.nc")
    damaged = (d / "fields.nc").read_bytes()
    assert main(["run", "--resume", str(d), "--no-progress"]) == 0
    assert (d / "fields.damaged-1.nc").read_bytes() == damaged


def test_fingers_of_a_fields_file_without_records(runs, tmp_path, capsys):
    d = copy(runs, "done", tmp_path)
    with netCDF4.Dataset(runs / "done" / "fields.nc") as src:
        x, y = src["x"][:], src["y"][:]
        attrs = {"scene": src.getncattr("scene")}
    FieldsWriter(d / "fields.nc", x, y, attrs=attrs).close()
    assert main(["fingers", str(d)]) == 2
    one_line_error(capsys, "no snapshot")


def _rewrite_checkpoint(path, **changes) -> None:
    with np.load(path) as z:
        arrays = {k: z[k] for k in z.files}
    arrays.update(changes)
    with open(path, "wb") as fh:
        np.savez(fh, **arrays)


def test_a_checkpoint_with_a_complex_scalar_is_one_line(runs, tmp_path, capsys):
    d = copy(runs, "part", tmp_path)
    _rewrite_checkpoint(d / checkpoint.CHECKPOINT_NAME, t=np.array(0.05 + 1j))
    assert main(["run", "--resume", str(d)]) == 2
    one_line_error(capsys, "complex")


def test_a_checkpoint_header_with_a_huge_shape_is_one_line(runs, tmp_path, capsys, monkeypatch):
    d = copy(runs, "part", tmp_path)

    def no_memory(*a, **k):  # what reading a header of (10**16,) float64 does
        raise MemoryError("Unable to allocate 71.1 PiB")

    monkeypatch.setattr(np.lib.format, "read_array", no_memory)
    assert main(["run", "--resume", str(d)]) == 2
    one_line_error(capsys, "damaged")


# ------------------------------------------------------------------ 5: resume and the lock
@pytest.mark.slow  # a long run: the slow set (README), which CI runs after the suite
def test_a_resume_never_undoes_a_run_that_went_on_meanwhile(runs, tmp_path):
    """Two resumes read the same checkpoint; the first finishes the run; the second, which
    takes the lock only then, is refused before it writes anything."""
    d = copy(runs, "part", tmp_path)
    late = Simulation.resume(d)
    Simulation.resume(d).run(out_dir=d, progress=False)
    finished = (d / "fields.nc").read_bytes(), (d / "diagnostics.csv").read_bytes()
    with pytest.raises(InputError, match="went on since this resume"):
        late.run(out_dir=d, progress=False)
    assert ((d / "fields.nc").read_bytes(), (d / "diagnostics.csv").read_bytes()) == finished


def test_a_signal_during_cleanup_leaves_no_holder_file(ti_cpu, tmp_path, monkeypatch):
    import signal

    from tiseg.output.diagnostics import DiagnosticsWriter

    closing = DiagnosticsWriter.close

    def interrupted_close(self):
        signal.raise_signal(signal.SIGINT)  # Ctrl-C while the files are being closed
        closing(self)

    monkeypatch.setattr(DiagnosticsWriter, "close", interrupted_close)
    # Python's own Ctrl-C handler, as in a terminal: a test process started in the background
    # by a shell without job control inherits SIGINT ignored, and nothing would be raised
    before = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        with pytest.raises(KeyboardInterrupt):
            Simulation(scene()).run(out_dir=tmp_path / "r", progress=False, t_end=0.025)
    finally:
        signal.signal(signal.SIGINT, before)
    assert not (tmp_path / "r" / HOLDER_NAME).exists()


HOLD_AND_WRITE = """
import sys, netCDF4
from tiseg.output.paths import RunLock
lock = RunLock(sys.argv[1]).acquire()
ds = netCDF4.Dataset(sys.argv[1] + "/fields.nc", "a")
print("held", flush=True)
sys.stdin.read()
"""


def test_a_file_a_running_run_writes_is_not_called_damaged(runs, tmp_path):
    d = copy(runs, "done", tmp_path)
    p = subprocess.Popen(
        [sys.executable, "-c", HOLD_AND_WRITE, str(d)],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert p.stdout.readline().strip() == "held"
        with pytest.raises(
            InputError, match=f"being written by a running tiseg run \\(pid {p.pid}"
        ):
            read_fields(d / "fields.nc")
    finally:
        p.kill()
        p.wait()


# ------------------------------------------------------------------ 6: the right reason
def test_a_damaged_checkpoint_is_called_damaged_not_a_broken_mass_balance(runs, tmp_path, capsys):
    d = copy(runs, "part", tmp_path)
    with np.load(d / checkpoint.CHECKPOINT_NAME) as z:
        q = z["q"] * 1.5  # finite numbers, but not the run's state
    _rewrite_checkpoint(d / checkpoint.CHECKPOINT_NAME, q=q)
    assert main(["run", "--resume", str(d)]) == 2
    err = one_line_error(capsys, "checkpoint.npz is damaged")
    assert not (d / "failure").exists(), err


# ------------------------------------------------------------------ 1 and 5: sweeps
def test_a_sweep_member_whose_fields_are_gone_is_not_finished(tmp_path):
    from tiseg.apps.sweep import DONE_MARKER, MARKER_VERSION, read_marker

    (tmp_path / DONE_MARKER).write_text(json.dumps({"marker_version": MARKER_VERSION}))
    assert read_marker(tmp_path) is None
    netCDF4.Dataset(tmp_path / "fields.nc", "w").close()
    assert read_marker(tmp_path) is not None


def _spec(d, sc, **more) -> dict:
    return {"name": d.name, "dir": str(d), "scene_toml": sc.to_toml(), "fingerprint": "x", **more}


def test_a_sweep_member_never_overwrites_a_foreign_file_and_is_not_retried(ti_cpu, tmp_path):
    from tiseg.apps.sweep import execute_run

    d = tmp_path / "member"
    d.mkdir()
    (d / "scene.toml").write_text("keep\n")
    rec = execute_run(_spec(d, scene()))  # returns: a raised error would be retried by Dask
    assert rec["status"] == "failed" and "scene.toml" in rec["error"], rec
    assert "\n" not in rec["error"]
    assert (d / "scene.toml").read_text() == "keep\n"


def test_sweep_overwrite_reaches_its_members(tmp_path, monkeypatch):
    """run_sweep(overwrite=True) hands the permission on to the members it submits (each
    member's spec), which may then replace files that tiseg did not write."""
    import tiseg.apps.sweep as S

    seen = {}
    monkeypatch.setattr(S.runner, "_run_on_dask", lambda *a, **kw: seen.update(kw))
    S.run_sweep(S.load_sweep("tiny"), tmp_path / "sw", echo=None, overwrite=True)
    assert seen.get("overwrite") is True


def test_another_sweep_into_the_same_out_is_refused(tmp_path):
    from tiseg.apps.sweep import _write_outputs, check_sweep_folder, load_sweep, run_sweep

    first = load_sweep("tiny")
    out = tmp_path / "sw"
    out.mkdir()
    _write_outputs(first, out, {})
    check_sweep_folder(load_sweep("tiny"), out)  # the same sweep again: resumed
    other = load_sweep("tiny", extra_overrides={"flow.h0": 0.0021})
    table = (out / "sweep.csv").read_text()
    with pytest.raises(InputError, match="another sweep .*set differ.*--overwrite"):
        run_sweep(other, out, echo=None)
    assert (out / "sweep.csv").read_text() == table
    (out / "sweep.json").unlink()  # a table that no sweep.json of tiseg's accounts for
    with pytest.raises(InputError, match="no readable sweep.json"):
        run_sweep(first, out, echo=None)
