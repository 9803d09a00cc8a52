"""Output as a newcomer meets it (issue 33): `xr.open_dataset` of fields.nc gives seconds, the
built-in scenes can be listed and copied, a run prints no Taichi banner and leaves no lock
file, floats in CSV and JSON carry no round-off tails, the demo says what its number is."""

from __future__ import annotations

import csv
import json
import os
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from solver_helpers import child_env, exit_code, tiny_fingers

from tiseg.data import SCENE_DIR
from tiseg.output.numbers import measured, measured_all
from tiseg.output.paths import LOCK_NAME, RunLock
from tiseg.setup.scene import list_builtin_scenes, load_scene

ROOT = Path(__file__).resolve().parents[1]

# a tiny fingers run with snapshots at 0, 0.5 and 1 s
TINY = tiny_fingers(1.0, interval=0.5)


def has_tail(text: str) -> bool:
    """Whether a number's text is a round-off tail: more than 12 significant digits, though a
    decimal of at most 12 digits lies within a few units of the last place (0.1 + 0.2 printed
    as 0.30000000000000004)."""
    x = float(text)
    if not np.isfinite(x) or x == 0:
        return False
    digits = len(re.sub(r"[^0-9]", "", text.split("e")[0].split("E")[0]).strip("0"))
    short = float(f"{x:.12g}")
    return digits > 12 and short != x and abs(short - x) <= 8 * np.spacing(abs(x))


def test_has_tail_tells_tails_from_values():
    assert has_tail(repr(0.1 + 0.2)) and has_tail("0.43600000000000005")
    assert not has_tail("0.3") and not has_tail("0.02570117621268716")  # a real 16-digit value
    assert not has_tail("nan") and not has_tail("2441")


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory):
    """The tiny run through the command line in a child process, as a user starts it (no -v):
    (run folder, stdout, stderr)."""
    out = tmp_path_factory.mktemp("front") / "run"
    p = subprocess.run(
        [sys.executable, "-m", "tiseg.apps.cli", *TINY, "--out", str(out), "--json"],
        capture_output=True,
        text=True,
        timeout=600,
        env=child_env(),
        cwd=ROOT,
    )
    assert p.returncode == 0, p.stderr
    return out, p.stdout, p.stderr


@pytest.mark.slow  # a long run: the slow set (README), which CI runs after the suite
def test_plain_xarray_reads_the_time_in_seconds(tiny_run):
    out, _, _ = tiny_run
    with xr.open_dataset(out / "fields.nc") as ds:
        assert ds["time"].dtype == np.float64
        np.testing.assert_array_equal(ds["time"].values, [0.0, 0.5, 1.0])
        snap = ds.sel(time=1.0)  # what failed when the time was decoded to dates of 2000
        assert snap["h"].shape == (ds.sizes["y"], ds.sizes["x"])
        assert float(snap["h"].max()) > 0  # the inflow has filled the first cells by 1 s
        # a plot title names the time in seconds, with no date
        title = snap["h"]._title_for_slice()
        units = ds["time"].attrs["units"]
    assert title.startswith("time = 1.0 [s]"), title
    # no reference date: a calendar-aware reader (cftime, which netCDF4 uses) reads no dates
    import cftime

    with pytest.raises(ValueError):
        cftime.num2date(1.0, units)


def test_no_taichi_banner_and_no_lock_file_after_a_run(tiny_run):
    out, stdout, stderr = tiny_run
    assert "[Taichi]" not in stdout + stderr, stderr
    assert json.loads(stdout)["steps"] > 0  # stdout is the JSON alone
    assert not (out / LOCK_NAME).exists() and not (out / ".tiseg.lock.json").exists()
    assert (out / "fields.nc").is_file()


def test_floats_in_the_run_files_have_no_round_off_tails(tiny_run):
    out, stdout, _ = tiny_run
    with open(out / "diagnostics.csv", newline="", encoding="utf-8") as fh:
        rows = list(csv.reader(fh))
    cells = [c for r in rows[1:] for c in r if c not in ("", "nan")]
    assert len(cells) > 50
    assert not [c for c in cells if has_tail(c)]
    numbers = re.findall(r"-?\d+\.\d+(?:e-?\d+)?", stdout)
    assert numbers and not [c for c in numbers if has_tail(c)], stdout


@pytest.mark.slow  # a long run: the slow set (README), which CI runs after the suite
def test_a_run_with_v_shows_taichi_and_a_busy_kernel_cache_stays_quiet_without(tmp_path):
    """Taichi's banner and its warnings (here: the kernel cache locked by another process)
    show with -v only; without it, stderr stays empty and an error stays one line."""
    cache = tmp_path / "cache"
    cache.mkdir()
    (cache / "ticache.lock").touch()  # fresh: a live holder as far as Taichi can tell
    env = child_env(TI_OFFLINE_CACHE_FILE_PATH=str(cache))
    base = [sys.executable, "-m", "tiseg.apps.cli", "run", "dam-break", "--set", "domain.nx=40"]
    quiet = subprocess.run(
        base + ["--out", str(tmp_path / "a")], capture_output=True, text=True, env=env, cwd=ROOT
    )
    assert quiet.returncode == 0 and quiet.stderr == "", quiet.stderr
    assert "[Taichi]" not in quiet.stdout
    loud = subprocess.run(
        base + ["--out", str(tmp_path / "b"), "-v"],
        capture_output=True,
        text=True,
        env=env,
        cwd=ROOT,
    )
    assert loud.returncode == 0, loud.stderr
    assert "[Taichi] Starting on arch=" in loud.stderr and "ticache.lock" in loud.stderr
    again = subprocess.run(  # a user mistake after a run: one line
        base + ["--out", str(tmp_path / "a")], capture_output=True, text=True, env=env, cwd=ROOT
    )
    assert again.returncode == 2 and again.stderr.count("\n") == 1, again.stderr


# ------------------------------------------------------------------ tiseg scenes
def test_scenes_lists_every_builtin_with_its_description(capsys):
    assert exit_code(["scenes"]) == 0
    lines = capsys.readouterr().out.splitlines()
    listed = {line.split()[0]: line.split(None, 1)[1] for line in lines if line.strip()}
    for path in sorted(SCENE_DIR.glob("*.toml")):
        description = tomllib.loads(path.read_text(encoding="utf-8"))["description"]
        assert listed[path.stem] == description
    assert len(listed) == len(list(SCENE_DIR.glob("*.toml")))


def test_scenes_show_prints_a_file_that_runs(ti_cpu, tmp_path, capsys):
    assert exit_code(["scenes", "show", "dam-break"]) == 0
    my = tmp_path / "my.toml"
    my.write_text(capsys.readouterr().out, encoding="utf-8")
    shipped = tomllib.loads((SCENE_DIR / "dam-break.toml").read_text(encoding="utf-8"))
    assert tomllib.loads(my.read_text(encoding="utf-8")) == shipped
    assert "#" in my.read_text(encoding="utf-8")  # the comments that explain the values
    out = tmp_path / "run"
    assert exit_code(["run", str(my), "--set", "domain.nx=40", "--out", str(out), "-q"]) == 0
    assert (out / "fields.nc").is_file() and not (out / LOCK_NAME).exists()


@pytest.mark.parametrize("name", list_builtin_scenes())
def test_scenes_show_resolved_loads_as_the_same_scene(name, tmp_path, capsys):
    assert exit_code(["scenes", "show", name, "--resolved"]) == 0
    path = tmp_path / "s.toml"
    path.write_text(capsys.readouterr().out, encoding="utf-8")
    a, b = load_scene(path), load_scene(name)
    assert a.name == b.name
    body = [line for line in a.to_toml().splitlines() if not line.startswith("#")]
    assert body == [line for line in b.to_toml().splitlines() if not line.startswith("#")]


def test_scenes_show_of_an_unknown_name_is_one_line(capsys):
    assert exit_code(["scenes", "show", "fingrs"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "did you mean 'fingers'" in err
    assert exit_code(["scenes", "show", "my.toml"]) == 2
    assert "not a built-in scene name" in capsys.readouterr().err


# ------------------------------------------------------------------ the lock file
def test_a_released_lock_leaves_no_file_and_the_folder_can_be_locked_again(tmp_path):
    lock = RunLock(tmp_path).acquire()
    assert (tmp_path / LOCK_NAME).exists()
    inner = RunLock(tmp_path).acquire()  # a sweep task and its run: counted, one holder
    inner.release()
    assert (tmp_path / LOCK_NAME).exists()  # still held by the outer one
    lock.release()
    assert sorted(os.listdir(tmp_path)) == []
    assert RunLock(tmp_path).busy() is None
    with RunLock(tmp_path):
        assert (tmp_path / LOCK_NAME).exists()
    assert not (tmp_path / LOCK_NAME).exists()


def test_a_lock_on_a_removed_lock_file_is_not_taken_for_the_folder(tmp_path):
    """A process that opened the lock file just before its holder removed it, and locked it
    just after, holds a lock on a file that is gone: it must not count as the folder's."""
    lock = RunLock(tmp_path).acquire()
    try:
        assert lock._locked_file_is_current()
        os.unlink(tmp_path / LOCK_NAME)
        assert not lock._locked_file_is_current()
        (tmp_path / LOCK_NAME).touch()  # someone else's new lock file
        assert not lock._locked_file_is_current()
    finally:
        lock.release()


# ------------------------------------------------------------------ the digits that matter
def test_measured_values_lose_their_round_off_tails_and_keep_their_digits():
    assert repr(measured(0.1 + 0.2)) == "0.3"
    assert repr(measured(0.43600000000000005)) == "0.436"
    assert repr(measured(2.391661738998664)) == "2.391661739"
    assert measured(1 / 3) == pytest.approx(1 / 3, rel=1e-12)
    assert measured(7) == 7 and isinstance(measured(7), int)
    assert np.isnan(measured(float("nan"))) and measured("x") == "x"
    assert measured_all({"a": [np.float64(0.1) * 3, 2], "b": np.array([1e-3 * 3])}) == {
        "a": [0.3, 2],
        "b": [0.003],
    }
    times = [0.1 * 3, 7.5 / 75 * 7]  # simulated times name snapshots: kept exactly
    assert measured_all({"time": times, "wavelength": [0.1 * 3]}) == {
        "time": times,
        "wavelength": [0.3],
    }


def test_diagnostics_keep_the_time_exact_and_round_what_was_measured(tmp_path):
    from tiseg.output import DiagnosticsWriter, read_diagnostics

    t = 0.1 + 0.2  # a time the run reached: a resume matches it bit for bit
    with DiagnosticsWriter(tmp_path / "d.csv") as w:
        w.write(time=t, dt=t, stages=2, mass=2.04e-4 + 1e-19, wall_time_cumulative=0.1 + 0.2)
    text = (tmp_path / "d.csv").read_text().splitlines()[1].split(",")
    assert text[0] == repr(t) and float(text[0]) == t
    assert text[3] == "0.000204" and text[-1] == "0.3"
    assert read_diagnostics(tmp_path / "d.csv")["time"][0] == t


# ------------------------------------------------------------------ the demo's number
def test_the_demos_converged_values_are_those_of_the_cited_table():
    """The demo's converged numbers are the mean and sd of the committed ensemble's runs (the
    split sweeps at cfl 0.9, 375 cells/m, seeds 1-5), which the cited file reports."""
    import csv
    import statistics

    from tiseg.apps.commands.demo import CONVERGED, what_the_numbers_are

    source = ROOT / CONVERGED["source"]
    if not source.is_file():
        pytest.skip("the benchmarks folder is not here (an installed wheel)")
    runs = source.parent / CONVERGED["runs_folder"] / "sweep.csv"
    with open(runs, newline="") as fh:
        rows = [
            r
            for r in csv.DictReader(fh)
            if r["status"] == "done" and float(r["domain.resolution"]) == CONVERGED["resolution"]
        ]
    assert len(rows) == CONVERGED["runs"]
    t = f"{CONVERGED['time']:g}"
    count = [float(r[f"finger_count@{t}"]) for r in rows]
    wl = [100 * float(r[f"wavelength@{t}"]) for r in rows]
    for values, (mean, sd) in (
        (count, CONVERGED["finger_count"]),
        (wl, CONVERGED["wavelength_cm"]),
    ):
        assert statistics.mean(values) == pytest.approx(mean, abs=0.005)
        assert statistics.stdev(values) == pytest.approx(sd, abs=0.005)
    text = source.read_text(encoding="utf-8")
    row = next(
        line
        for line in text.splitlines()
        if line.startswith("| **pair, cfl 0.9, films flow** | **375**")
    )
    assert f"{CONVERGED['finger_count'][0]:g} ± {CONVERGED['finger_count'][1]:g}" in row
    assert f"{CONVERGED['wavelength_cm'][0]:.2f} ± {CONVERGED['wavelength_cm'][1]:.2f}" in row
    scene = load_scene("fingers")
    # the numerics the ensemble measured
    assert scene.numerics.stepper == "hancock" and scene.numerics.cfl == 0.9
    assert scene.numerics.friction_scheme == "projected"
    lines = what_the_numbers_are(200, 7.5)
    assert (
        "one run (the scene's inflow seed) at 200 cells/m" in lines and CONVERGED["source"] in lines
    )
    assert "5.02 ± 0.36 cm" in lines and "10.0 ± 0.7 fingers" in lines
