"""Sweeps (`tiseg sweep`): a CI-sized sweep on a local Dask cluster, re-runs that reuse finished
runs, and strict validation of sweep files.

The sweep is the built-in ``tiny`` (``tiseg/data/sweeps/tiny.toml``: the fingers scene on a 12 x 4
grid to t = 0.5 s, two values of nu), so the shipped example is exercised too. Most of the time goes into starting the
Dask workers and compiling the Taichi kernels in them, not into the runs.
"""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest

from tiseg.errors import InputError
from tiseg.apps.sweep import (
    DONE_MARKER,
    _run_names,
    load_sweep,
    read_marker,
    read_table,
    run_sweep,
    summary_columns,
    summary_rows,
    sweep_from_dict,
    table_columns,
)

ROOT = Path(__file__).resolve().parents[1]
TINY = ROOT / "tiseg" / "data" / "sweeps" / "tiny.toml"


def _mtimes(out: Path) -> dict[str, int]:
    """Modification times (ns) of every file of the run folders."""
    return {
        str(p.relative_to(out)): p.stat().st_mtime_ns
        for p in sorted(out.glob("*/*"))
        if p.is_file()
    }


@pytest.fixture(scope="module")
def tiny_sweep(tmp_path_factory):
    """The tiny sweep run once on a local cluster of 2 workers: (folder, printed lines, result)."""
    out = tmp_path_factory.mktemp("sweep") / "tiny"
    lines: list[str] = []
    res = run_sweep(
        load_sweep(TINY),
        out,
        workers=2,
        threads_per_task=1,
        echo=lines.append,
        progress_interval=0.0,
    )
    return out, lines, res


@pytest.mark.slow
def test_tiny_sweep_on_dask_then_reuse(tiny_sweep):
    out, lines, res = tiny_sweep
    lines = list(lines)
    sweep = load_sweep(TINY)
    assert [r.name for r in sweep.runs] == ["nu-0.01", "nu-0.02"]
    assert res.count("done") == 2 and res.count("failed") == 0, lines
    assert any("2 to run" in s for s in lines)
    assert any("local Dask cluster (2 workers" in s for s in lines)

    # the table: one row per run in grid order, the grid value, metrics and costs
    with open(out / "sweep.csv", newline="") as fh:
        header = next(csv.reader(fh))
    assert header == table_columns(sweep)
    for col in (
        "run",
        "flow.nu",
        "status",
        "cells",
        "finger_count",
        "wavelength",
        "elongation",
        "x_front_max",
        "finger_count@0.25",
        "elongation@0.25",
        "wall_s",
        "steps",
        "rhs_evaluations",
    ):
        assert col in header
    rows = read_table(out / "sweep.csv")
    assert [r["run"] for r in rows] == ["nu-0.01", "nu-0.02"]
    assert [r["flow.nu"] for r in rows] == [0.01, 0.02]
    for r in rows:
        assert r["status"] == "done"
        assert r["cells"] == 12 * 4 and r["t_final"] == 0.5
        assert r["steps"] > 0 and r["rhs_evaluations"] >= r["steps"] and r["wall_s"] > 0
        assert r["finger_count"] == 0  # far too early and too coarse for fingers
        assert 0 < r["x_front_max"] < 0.3
    # every run folder is complete: outputs, finger diagnostics, then the marker
    for name in ("nu-0.01", "nu-0.02"):
        d = out / name
        for f in ("scene.toml", "fields.nc", "diagnostics.csv", "fingers.json", DONE_MARKER):
            assert (d / f).is_file(), f"{name}/{f}"
        assert read_marker(d) is not None
    full = json.loads((out / "sweep.json").read_text())
    assert [r["run"] for r in full["runs"]] == ["nu-0.01", "nu-0.02"]
    assert full["runs"][0]["metrics"]["time"][-1] == 0.5

    # the ensemble summary: no seed axis here, so one row per run
    with open(out / "summary.csv", newline="") as fh:
        assert next(csv.reader(fh)) == summary_columns(sweep)
    summ = read_table(out / "summary.csv")
    assert [(r["flow.nu"], r["n"], r["finger_count_mean"]) for r in summ] == [
        (0.01, 1, 0),
        (0.02, 1, 0),
    ]
    assert summ[0]["finger_count_std"] is None and summ[0]["wavelength_n"] == 0

    # Re-run: everything is reused, no cluster is started and no file is touched.
    before = _mtimes(out)
    lines.clear()
    res2 = run_sweep(load_sweep(TINY), out, workers=2, echo=lines.append)
    assert res2.count("reused") == 2 and res2.count("done") == 0
    assert not any("Dask cluster" in s for s in lines), lines
    assert _mtimes(out) == before
    assert [r["status"] for r in read_table(out / "sweep.csv")] == ["reused", "reused"]

    # An interrupted sweep (one marker missing) resumes: only that run is computed again,
    # here on an existing Dask cluster reached by its address (--scheduler).
    from distributed import LocalCluster

    (out / "nu-0.02" / DONE_MARKER).unlink()
    kept = {k: v for k, v in before.items() if k.startswith("nu-0.01")}
    lines.clear()
    with LocalCluster(
        n_workers=1, threads_per_worker=1, processes=True, dashboard_address=":0"
    ) as cluster:
        res3 = run_sweep(
            load_sweep(TINY),
            out,
            scheduler=cluster.scheduler_address,
            threads_per_task=1,
            echo=lines.append,
        )
    assert [r["status"] for r in res3.records] == ["reused", "done"], lines
    assert any("1 already finished, 1 to run" in s for s in lines)
    assert any("on the Dask scheduler tcp://" in s for s in lines), lines
    assert {k: v for k, v in _mtimes(out).items() if k.startswith("nu-0.01")} == kept

    # A changed scene under the same folder name is not reused.
    changed = load_sweep(TINY, extra_overrides={"flow.h0": 0.0021})
    assert read_marker(out / "nu-0.01", changed.runs[0].scene) is None
    assert read_marker(out / "nu-0.01", sweep.runs[0].scene) is not None


@pytest.mark.slow  # a long run: the slow set (README), which CI runs after the suite
def test_fingers_figures_from_sweep_results(tiny_sweep, tmp_path):
    """`tiseg figures fingers` draws from finished sweeps without running anything. The tiny
    sweep stands in for the viscosity study (no fingers, ends at 0.5 s); the grid and width
    studies are absent, so their figures (12-16, whose panels the render tests cover) are left
    out with a note, and the summary table still lists every run."""
    import shutil
    from tiseg.apps.figures.fingers import make_all

    out, _, _ = tiny_sweep
    runs = tmp_path / "runs"
    shutil.copytree(out, runs / "nu-study")
    lines: list[str] = []
    paths = make_all(tmp_path / "figs", runs, run=False, echo=lines.append, dpi=40)
    assert sorted(p.name for p in paths) == [
        "fig17_nu.png",
        "fig18_fronts.png",
        "fingers_studies.csv",
        "fingers_studies.json",
    ]
    assert any("no finished runs of the grid-study" in s for s in lines)
    rows = read_table(tmp_path / "figs" / "fingers_studies.csv")
    assert [(r["study"], r["run"], r["nu"]) for r in rows] == [
        ("nu-study", "nu-0.01", 0.01),
        ("nu-study", "nu-0.02", 0.02),
    ]
    assert all(r["finger_count"] == 0 and r["steps"] > 0 for r in rows)


def test_inviscid_limit_figure_and_nu_column(tiny_sweep, tmp_path):
    """The inviscid study is drawn beside the grid study, and a run with the viscous term
    switched off is tabulated with nu = 0, whatever flow.nu holds."""
    import shutil

    from tiseg.apps.figures.fingers import StudyRun, _nu, make_all
    from tiseg.setup.scene import load_scene

    out, _, _ = tiny_sweep
    runs = tmp_path / "runs"
    for name in ("grid-study", "inviscid-study"):
        shutil.copytree(out, runs / name)
    paths = make_all(tmp_path / "figs", runs, run=False, echo=None, dpi=40)
    assert "inviscid_limit.png" in {p.name for p in paths}
    rows = read_table(tmp_path / "figs" / "fingers_studies.csv")
    assert [r["study"] for r in rows].count("inviscid-study") == 2

    scene = load_scene("fingers", overrides={"effects.viscosity": False})
    assert scene.flow.nu == 0.01
    run_dir = tmp_path / "inviscid-run"
    run_dir.mkdir()
    (run_dir / "scene.toml").write_text(scene.to_toml())
    assert _nu(StudyRun("inviscid", {}, run_dir, {})) == 0.0
    (run_dir / "scene.toml").write_text(load_scene("fingers").to_toml())
    assert _nu(StudyRun("viscous", {}, run_dir, {})) == 0.01


# ------------------------------------------------------------------ validation
BASE = {
    "scene": "fingers",
    "set": {
        "domain": {"Lx": 0.3, "Ly": 0.1, "resolution": 40},
        "time": {"t_end": 0.5},
        "output": {"interval": 0.25, "times": [0.25, 0.5]},
    },
}


def _with(**changes) -> dict:
    d = json.loads(json.dumps(BASE))
    for k, v in changes.items():
        if v is None:
            d.pop(k, None)
        else:
            d[k] = v
    return d


@pytest.mark.parametrize(
    "data, message",
    [
        (_with(grids={"flow.nu": [0.01]}), "unknown key 'grids' (did you mean 'grid'?)"),
        (_with(scene=None), "the key 'scene' is required"),
        (_with(scene="fingerz"), "unknown built-in scene 'fingerz' (did you mean 'fingers'?)"),
        (_with(grid={"flow.nu": 0.01}), "grid key 'flow.nu' = 0.01: give a non-empty list"),
        (_with(grid={"flow.nu": []}), "give a non-empty list"),
        (_with(grid={"flow.nu": [0.01, 0.01]}), "lists the value 0.01 more than once"),
        (
            _with(grid={"domain.resolution": [40, 50]}),
            "'domain.resolution' is both in [set] and in [grid]",
        ),
        (_with(grid={"flow.nuu": [0.01, 0.02]}), "run 'nuu-0.01'"),
        (_with(grid={"domain.resolution2": [1]}), "domain.resolution2"),
        (_with(grid={"flow.nu": [0.01, -1.0]}), "run 'nu--1'"),
        (_with(grid={"nu": [0.01]}), "must be a dotted scene key"),
        (_with(times=[0.3]), "times lists 0.3 s, which is not an output time"),
        (_with(times=[2.0]), "after time.t_end"),
        (_with(times="0.25"), "must be a list of times"),
        (_with(name="a b"), "name='a b' must be 1-128 letters"),
        (_with(name=".."), "name='..' must be 1-128 letters"),
        (_with(set=[1, 2]), "[set] must be a table"),
    ],
)
def test_bad_sweeps_are_clean_input_errors(data, message):
    with pytest.raises(InputError) as err:
        sweep_from_dict(data, source="bad.toml")
    text = str(err.value)
    assert message in text, text
    assert text.startswith("sweep file 'bad.toml': ") and "\n" not in text


def test_unknown_scene_key_names_the_key_and_nothing_runs(tmp_path):
    f = tmp_path / "s.toml"
    f.write_text(
        'scene = "fingers"\n[set]\n"domain.resolution" = 40\n"domain.Lx" = 0.3\n'
        '"domain.Ly" = 0.1\n"time.t_end" = 0.5\n[grid]\n"flow.nu" = [0.01, 0.02]\n'
        '"domain.fooo" = [1]\n'
    )
    with pytest.raises(InputError, match=r"run 'nu-0.01_fooo-1': .*domain.fooo"):
        load_sweep(f)
    assert not (tmp_path / "runs").exists()


def test_file_errors_and_cli_exit_status(tmp_path, capsys):
    from tiseg.apps.cli import main

    with pytest.raises(InputError, match="not found"):
        load_sweep(tmp_path / "missing.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("scene = \n")
    with pytest.raises(InputError, match="is not valid TOML"):
        load_sweep(bad)
    bad.write_text('scene = "fingers"\ncolour = 1\n')
    assert main(["sweep", str(bad), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "unknown key 'colour'" in err[0], err
    assert main(["sweep", str(TINY), "--grid", "flow.nu=0.01", "--check"]) == 2
    assert "give a list of values" in capsys.readouterr().err


def test_check_lists_runs_and_grid_override(capsys, tmp_path):
    from tiseg.apps.cli import main

    assert (
        main(
            [
                "sweep",
                str(TINY),
                "--check",
                "--out",
                str(tmp_path),
                "--grid",
                "flow.nu=[0.01, 0.03, 0.05]",
                "--set",
                "inflow.ramp_rate=5",
            ]
        )
        == 0
    )
    out = capsys.readouterr().out
    assert "3 runs, valid" in out and "nu-0.05: 12 x 4 cells, t_end 0.5 s" in out


def test_run_names_are_stable_and_safe():
    combos = [
        {"domain.resolution": 250, "flow.nu": 0.01},
        {"domain.resolution": 375.0, "flow.nu": 1e-5},
    ]
    assert _run_names(combos) == ["resolution-250_nu-0.01", "resolution-375_nu-1e-05"]
    # keys sharing a last part are shown in full; unsafe characters are replaced
    names = _run_names(
        [
            {
                "material.small.beta": 0.1,
                "material.large.beta": 0.2,
                "numerics.reconstruction": "first order/x",
            }
        ]
    )
    assert names == ["material.small.beta-0.1_material.large.beta-0.2_reconstruction-first_order_x"]
    # values equal after formatting get a hash of the exact values: distinct, and stable
    a = _run_names([{"k.s": "a b"}, {"k.s": "a/b"}])
    assert len(set(a)) == 2 and a == _run_names([{"k.s": "a b"}, {"k.s": "a/b"}])
    assert all(n.startswith("s-a_b-") for n in a)
    assert _run_names([{}]) == ["base"]


def test_ensemble_summary_statistics():
    """summary.csv rows: one per nu, over the seeds; mean, sample sd (ddof 1) and the count of
    runs where a metric is defined, from records with known numbers."""
    sweep = sweep_from_dict(
        {**BASE, "times": [0.25], "grid": {"flow.nu": [0.01, 0.02], "inflow.seed": [1, 2, 3]}}
    )
    assert [r.name for r in sweep.runs][:3] == [
        "nu-0.01_seed-1",
        "nu-0.01_seed-2",
        "nu-0.01_seed-3",
    ]
    counts = {
        "nu-0.01_seed-1": 4,
        "nu-0.01_seed-2": 5,
        "nu-0.01_seed-3": 6,
        "nu-0.02_seed-1": 2,
        "nu-0.02_seed-2": 0,
    }  # seed 3 of nu 0.02 failed
    records = {}
    for name, c in counts.items():
        wl = 0.1 / c if c else None
        records[name] = {
            "status": "done",
            "wall_s": 10.0 + c,
            "metrics": {
                "time": [0.25, 0.5],
                "finger_count": [0, c],
                "wavelength": [None, wl],
                "elongation": [0.01, 0.02 * c],
            },
        }
    records["nu-0.02_seed-3"] = {"status": "failed", "error": "x"}
    rows = summary_rows(sweep, records)
    assert [(r["flow.nu"], r["n"]) for r in rows] == [(0.01, 3), (0.02, 2)]
    a, b = rows
    assert a["runs"] == "nu-0.01_seed-1 nu-0.01_seed-2 nu-0.01_seed-3"
    assert a["finger_count_mean"] == pytest.approx(5.0) and a["finger_count_std"] == 1.0
    assert a["wavelength_n"] == 3
    assert a["wavelength_mean"] == pytest.approx((0.025 + 0.02 + 0.1 / 6) / 3)
    assert a["elongation_std"] == pytest.approx(0.02)
    assert a["wall_s_mean"] == pytest.approx(15.0)
    assert a["finger_count@0.25_mean"] == 0 and a["elongation@0.25_std"] == 0
    # nu = 0.02: one run without fingers has no wavelength; the mean is over the defined ones
    assert b["finger_count_mean"] == 1.0 and b["wavelength_n"] == 1
    assert b["wavelength_mean"] == pytest.approx(0.05) and b["wavelength_std"] is None
    assert b["channel_phi_n"] == 0 and b["channel_phi_mean"] is None


def test_reused_run_with_old_diagnostics_is_analysed_again(tiny_sweep, tmp_path):
    """A finished run whose fingers.json predates the current definitions (analysis_version)
    is analysed again from its fields.nc when the sweep is re-run; nothing is simulated."""
    import shutil
    from tiseg.post.analysis.fingers import ANALYSIS_VERSION

    src, _, _ = tiny_sweep
    out = tmp_path / "tiny"
    shutil.copytree(src, out)
    marker = out / "nu-0.01" / DONE_MARKER
    rec = json.loads(marker.read_text())
    rec["metrics"] = {k: rec["metrics"][k] for k in ("time", "finger_count", "wavelength")}
    marker.write_text(json.dumps(rec))
    fields = (out / "nu-0.01" / "fields.nc").stat().st_mtime_ns
    lines: list[str] = []
    res = run_sweep(load_sweep(TINY), out, echo=lines.append)
    assert [r["status"] for r in res.records] == ["reused", "reused"]
    assert not any("Dask cluster" in s for s in lines)
    new = json.loads(marker.read_text())
    assert new["metrics"]["analysis_version"] == ANALYSIS_VERSION
    assert "wavelength_spectral" in new["metrics"] and new["steps"] == rec["steps"]
    assert (
        json.loads((out / "nu-0.01" / "fingers.json").read_text())["analysis_version"]
        == ANALYSIS_VERSION
    )
    assert (out / "nu-0.01" / "fields.nc").stat().st_mtime_ns == fields


def test_figure_series_are_ensemble_means_with_sd():
    """The error bars of figures 16-17: runs grouped by the study value, mean and sample sd
    over the seeds, runs without the metric (no fingers) left out and counted."""
    from tiseg.apps.figures.fingers import StudyRun, _series

    data = {(0.01, 1): 0.05, (0.01, 2): 0.06, (0.01, 3): 0.07, (0.02, 1): 0.1, (0.02, 2): None}
    runs = [
        StudyRun(
            f"nu-{nu}_seed-{s}",
            {"flow.nu": nu},
            Path("."),
            {"metrics": {"time": [7.5], "wavelength": [wl]}},
        )
        for (nu, s), wl in data.items()
    ]
    s = _series(runs, lambda r: r.values["flow.nu"], "wavelength", 7.5)
    assert list(s.x) == [0.01, 0.02] and list(s.runs) == [3, 2] and list(s.n) == [3, 1]
    assert s.mean == pytest.approx([0.06, 0.1]) and s.std == pytest.approx([0.01, 0.0])
    assert s.undefined == 1


def test_a_failed_connection_leaves_dask_as_it_was(tmp_path):
    """A scheduler address Dask cannot use is one error, and Dask's default scheduler is
    left as it was: a later sweep in the same process can still write its datasets (xarray asks
    Dask for the scheduler of every write)."""
    import dask
    import numpy as np
    import xarray as xr

    from tiseg.apps.sweep.runner import open_dask

    before = dask.config.get("scheduler", None)
    with pytest.raises(InputError, match="cannot connect to the Dask scheduler"):
        open_dask("foo", None, None, 1, lambda *a: None)
    assert dask.config.get("scheduler", None) == before
    from distributed import default_client

    try:
        left = default_client()  # the client that failed must not be the default one
    except ValueError:
        left = None
    assert left is None or left.status == "running"
    xr.Dataset({"a": ("x", np.arange(3.0))}).to_netcdf(tmp_path / "a.nc", engine="netcdf4")


def test_a_local_clusters_workers_log_no_errors_once_it_closes():
    """Before a sweep's local cluster closes, its workers stop logging errors (a heartbeat
    that meets the closing scheduler would print a traceback after a sweep that succeeded),
    and close_dask closes what it was given."""
    import logging

    from distributed import Client, LocalCluster

    from tiseg.apps.sweep import runner

    cluster = LocalCluster(
        n_workers=1, threads_per_worker=1, processes=True, dashboard_address=":0",
        silence_logs=logging.ERROR,
    )  # fmt: skip
    client = Client(cluster)

    def logs_errors():
        return logging.getLogger("distributed.worker").isEnabledFor(logging.ERROR)

    try:
        before = list(client.run(logs_errors).values())
        runner.quiet_workers(client)
        after = list(client.run(logs_errors).values())
    finally:
        runner.close_dask(client, cluster)
    assert before == [True] and after == [False]
    assert client.status == "closed" and cluster.status.name == "closed"
