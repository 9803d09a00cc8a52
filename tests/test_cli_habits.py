"""Command-line habits: --version, -q / -v, JSON on stdout and messages on stderr."""

from __future__ import annotations

import pytest

import json
import subprocess
import sys

from solver_helpers import tiny_fingers

from tiseg import __version__
from tiseg.apps.cli import main


def test_version(capsys):
    try:
        main(["--version"])
    except SystemExit as exc:
        assert exc.code == 0
    assert capsys.readouterr().out.strip() == f"tiseg {__version__}"


def test_version_is_written_once():
    from importlib.metadata import version

    assert version("tiseg") == __version__


RUN = [*tiny_fingers(0.05), "--overwrite"]


@pytest.mark.slow  # a long run: the slow set (README), which CI runs after the suite
def test_quiet_hides_notes_and_keeps_results(ti_cpu, tmp_path, capsys):
    assert main(["-q"] + RUN + ["--out", str(tmp_path / "a")]) == 0
    cap = capsys.readouterr()
    assert "note:" not in cap.err and "t = 0.05 s" in cap.out
    assert main(RUN + ["--out", str(tmp_path / "b"), "-q"]) == 0  # after the command
    assert "note:" not in capsys.readouterr().err
    assert main(RUN + ["--out", str(tmp_path / "c")]) == 0  # default: the note
    assert "tiseg: note: output.times" in capsys.readouterr().err


def test_no_progress_bar_into_a_redirected_stderr(tmp_path):
    """tqdm switches itself off when stderr is not a terminal (here: a pipe)."""
    p = subprocess.run(
        [sys.executable, "-m", "tiseg.apps.cli"]
        + [a for a in RUN if a != "--no-progress"]
        + ["--out", str(tmp_path / "r")],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert p.returncode == 0, p.stderr
    assert "\r" not in p.stderr and "%|" not in p.stderr


@pytest.mark.slow  # a long run: the slow set (README), which CI runs after the suite
def test_sweep_json_on_stdout_progress_on_stderr(tmp_path, capsys):
    out = tmp_path / "sw"
    rc = main(
        ["sweep", "tiny", "--out", str(out), "--workers", "1", "--threads-per-task", "1", "--json"]
    )
    cap = capsys.readouterr()
    assert rc == 0, cap.err
    summary = json.loads(cap.out)  # stdout is the JSON alone
    assert summary["counts"] == {"done": 2} and len(summary["runs"]) == 2
    assert "Dask dashboard: http" in cap.err and "[2/2]" in cap.err


@pytest.mark.slow  # a long run: the slow set (README), which CI runs after the suite
def test_a_second_command_starts_on_a_fresh_runtime_unless_fields_are_held(tmp_path):
    """Taichi's kernel cache keys hold SNode ids, which only a reset numbers from the start
    again: a command after one that made simulations starts on a fresh runtime (its kernels
    then load from the cache instead of compiling), but never while something holds fields.
    In a process of its own: what other tests leave alive must not decide it."""
    script = f"""
import sys
from tiseg import backend
from tiseg.apps.cli import main
from tiseg.solver import field_tree
run = {RUN!r} + ["-q", "--out"]
out = {str(tmp_path)!r}
assert main(run + [out + "/a"]) == 0 and field_tree.made_since_init() > 0
g = backend.generation()
assert main(run + [out + "/b"]) == 0
renewed = backend.generation() - g
class Holder:  # stands for a renderer or a window with plain Taichi fields
    pass
held = Holder()
field_tree.track(held)
g = backend.generation()
assert main(run + [out + "/c"]) == 0
print(renewed, backend.generation() - g)
"""
    p = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    assert p.stdout.split()[-2:] == ["1", "0"], p.stdout  # renewed once; held: kept


def test_python_dash_m_tiseg_is_the_command():
    out = subprocess.run(
        [sys.executable, "-m", "tiseg", "--version"], capture_output=True, text=True, timeout=120
    )
    assert out.returncode == 0 and out.stdout.strip() == f"tiseg {__version__}", out.stderr


def test_set_with_a_space_gets_a_hint(capsys):
    """`--set KEY VALUE` (a space for the =): one line that shows the KEY=VALUE form."""
    import pytest

    with pytest.raises(SystemExit) as exc:  # argparse's own error
        main(["run", "fingers", "--set", "domain.resolution", "40"])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert "did you mean --set domain.resolution=40?" in err and err.count("\n") == 1
    assert main(["run", "fingers", "--set", "domain.resolution"]) == 2
    err = capsys.readouterr().err
    assert "--set domain.resolution=VALUE" in err and err.count("\n") == 1


@pytest.mark.slow  # a long run: the slow set (README), which CI runs after the suite
def test_run_json_shape_is_the_arrays_order(ti_cpu, tmp_path, capsys):
    """shape is (ny, nx) as the fields in fields.nc; grid, its older name, stays (nx, ny)."""
    import xarray as xr

    out = tmp_path / "r"
    argv = [a if a != "domain.Lx=0.3" else "domain.Lx=0.5" for a in tiny_fingers(0.05)]
    assert main([*argv, "--out", str(out), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    with xr.open_dataset(out / "fields.nc") as ds:
        assert summary["shape"] == list(ds["h"].shape[-2:]) == [4, 20]  # 0.1 x 0.5 m at 40/m
    assert summary["grid"] == [20, 4]
