"""Sampling sweeps (`[sample]`): the designs, their validation, the Sobol' estimator on an
analytic function, ``sensitivity.csv`` and ``sweep.nc`` from fabricated member records, and one
end-to-end sample sweep on Dask (the built-in ``tiny-sample``, marked slow) with its re-run."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from tiseg.errors import InputError
from tiseg.apps.sweep import (
    check_sweep_folder,
    load_sweep,
    member_outputs,
    read_table,
    refresh_metrics,
    run_sweep,
    sensitivity_rows,
    sobol_analysis,
    sweep_dataset,
    sweep_from_dict,
    table_rows,
    write_dataset,
    write_results,
)
from tiseg.apps.sweep.design import parse_sample

ROOT = Path(__file__).resolve().parents[1]
TINY_SAMPLE = ROOT / "tiseg" / "data" / "sweeps" / "tiny-sample.toml"
BASE = {
    "scene": "fingers",
    "set": {
        "domain": {"Lx": 0.3, "Ly": 0.1, "resolution": 40},
        "time": {"t_end": 0.5},
        "output": {"interval": 0.25, "times": [0.25, 0.5]},
    },
}


def _fail(msg):
    raise InputError(msg)


def _sweep(**changes):
    d = json.loads(json.dumps(BASE))
    d.update(changes)
    return sweep_from_dict(d, source="s.toml")


# ------------------------------------------------------------------ designs
def test_latin_hypercube_is_stratified_and_seeded():
    table = {
        "method": "lhs",
        "n": 10,
        "seed": 4,
        "flow.nu": {"range": [0.005, 0.05], "log": True},
        "flow.h0": [0.001, 0.003],
    }
    s = parse_sample(table, _fail)
    pts = s.points()
    assert len(pts) == s.size == 10
    nu = np.array([p["flow.nu"] for p in pts])
    h0 = np.array([p["flow.h0"] for p in pts])
    assert nu.min() >= 0.005 and nu.max() <= 0.05 and h0.min() >= 0.001 and h0.max() <= 0.003
    # one point in each of the 10 strata of each axis: of log(nu) (log-uniform) and of h0
    u_nu = (np.log(nu) - math.log(0.005)) / (math.log(0.05) - math.log(0.005))
    u_h0 = (h0 - 0.001) / 0.002
    assert sorted(np.floor(u_nu * 10).astype(int)) == list(range(10))
    assert sorted(np.floor(u_h0 * 10).astype(int)) == list(range(10))
    assert parse_sample(table, _fail).points() == pts  # same seed, same design
    assert parse_sample({**table, "seed": 5}, _fail).points() != pts


def test_saltelli_design_blocks():
    s = parse_sample(
        {"method": "sobol", "n": 8, "seed": 2, "a.x": [0.0, 1.0], "a.y": [10.0, 20.0]}, _fail
    )
    u = s.unit_points()
    assert u.shape == (8 * 4, 2) == (s.size, 2)
    a, b, ab0, ab1 = u[:8], u[8:16], u[16:24], u[24:32]
    assert np.array_equal(ab0[:, 0], b[:, 0]) and np.array_equal(ab0[:, 1], a[:, 1])
    assert np.array_equal(ab1[:, 1], b[:, 1]) and np.array_equal(ab1[:, 0], a[:, 0])
    assert not np.array_equal(a, b)
    # a Sobol' net: each column of A and of B has one point in each eighth of [0, 1)
    for col in (*a.T, *b.T):
        assert sorted(np.floor(col * 8).astype(int)) == list(range(8))
    assert [s.block(i) for i in (0, 7, 8, 16, 31)] == ["A", "A", "B", "AB1", "AB2"]
    r = parse_sample({"method": "random", "n": 5, "a.x": [1.0, 2.0]}, _fail)
    assert r.seed == 0 and len(r.points()) == 5
    assert all(1.0 <= p["a.x"] <= 2.0 for p in r.points())


def test_sample_with_grid_runs_the_design_at_every_grid_point():
    sw = _sweep(
        grid={"flow.h0": [0.002, 0.0025]},
        sample={"method": "lhs", "n": 3, "seed": 1, "flow.nu": [0.01, 0.02]},
    )
    assert [r.name for r in sw.runs] == [
        "h0-0.002_member-0000",
        "h0-0.002_member-0001",
        "h0-0.002_member-0002",
        "h0-0.0025_member-0000",
        "h0-0.0025_member-0001",
        "h0-0.0025_member-0002",
    ]
    assert sw.axes == ["flow.h0", "flow.nu"]
    first, second = sw.runs[:3], sw.runs[3:]
    assert [r.values["flow.nu"] for r in first] == [r.values["flow.nu"] for r in second]
    assert all(r.scene.flow.nu == r.values["flow.nu"] for r in sw.runs)
    assert [r.member for r in sw.runs] == [0, 1, 2, 0, 1, 2]


# ------------------------------------------------------------------ validation
@pytest.mark.parametrize(
    "changes, message",
    [
        ({"sample": {"method": "lhs", "n": 4, "flow.nu": [0.05, 0.005]}}, "LO must be below HI"),
        ({"sample": {"method": "lhs", "n": 4, "flow.nu": [0.01, 0.01]}}, "LO must be below HI"),
        ({"sample": {"method": "lhs", "n": 1, "flow.nu": [0.01, 0.02]}}, "n=1: give a whole"),
        (
            {"sample": {"method": "sobol", "n": 6, "flow.nu": [0.01, 0.02]}},
            "takes a power of 2",
        ),
        (
            {"sample": {"method": "sobel", "n": 4, "flow.nu": [0.01, 0.02]}},
            "method='sobel' (did you mean 'sobol'?)",
        ),
        (
            {"sample": {"method": "lhs", "n": 4, "flow.nuu": [0.01, 0.02]}},
            "unknown key 'flow.nuu' in section [flow] (did you mean 'flow.nu'?)",
        ),
        (
            {
                "grid": {"flow.nu": [0.01]},
                "sample": {"method": "lhs", "n": 4, "flow.nu": [0.01, 0.02]},
            },
            "'flow.nu' is both in [grid] and in [sample]",
        ),
        (
            {"sample": {"method": "lhs", "n": 4, "domain.resolution": [30.0, 50.0]}},
            "'domain.resolution' is both in [set] and in [sample]",
        ),
        (
            {"sample": {"method": "lhs", "n": 4, "numerics.reconstruction": [0.0, 1.0]}},
            "'numerics.reconstruction' is a str scene key",
        ),
        (
            {"sample": {"method": "lhs", "n": 4, "effects.viscosity": [0.0, 1.0]}},
            "'effects.viscosity' is a true/false scene key",
        ),
        (
            {"sample": {"method": "lhs", "n": 4, "inflow.seed": [0, 10]}},
            "'inflow.seed' takes whole numbers",
        ),
        (
            {"sample": {"method": "lhs", "n": 4, "flow.nu": {"range": [0.0, 0.1], "log": True}}},
            "the range must be positive",
        ),
        ({"sample": {"method": "lhs", "n": 4, "flow.nu": [0.01]}}, "give a range [LO, HI]"),
        ({"sample": {"method": "lhs", "n": 4}}, "names no key to vary"),
        ({"sample": {"method": "lhs", "n": 4, "nu": [0.01, 0.02]}}, "must be a dotted scene"),
        (
            {"sample": {"method": "lhs", "n": 4, "flow.nu": {"range": [0.01, 0.02], "lg": 1}}},
            "unknown entry 'lg'",
        ),
    ],
)
def test_bad_samples_are_one_line_errors(changes, message):
    with pytest.raises(InputError) as err:
        _sweep(**changes)
    text = str(err.value)
    assert message in text, text
    assert text.startswith("sweep file 's.toml': ") and "\n" not in text


def test_a_sampled_key_the_scene_needs():
    """flow.u0 must be given with a Coulomb friction law (no derived steady velocity): the
    base scene alone is not valid, each member is; with the fingers scene's own friction law
    it may not be given, and the error names the key."""
    sw = _sweep(
        set={**BASE["set"], "effects": {"friction": "coulomb"}},
        sample={"method": "random", "n": 2, "flow.u0": [0.15, 0.25]},
    )
    assert all(0.15 <= r.scene.flow.u0 <= 0.25 for r in sw.runs)
    with pytest.raises(
        InputError, match=r"^sweep file 's.toml': \[sample\] 'flow.u0' = 0.15: .*remove flow.u0"
    ):
        _sweep(sample={"method": "random", "n": 2, "flow.u0": [0.15, 0.25]})


# ------------------------------------------------------------------ the estimator
def _ishigami(x, a=7.0, b=0.1):
    return np.sin(x[:, 0]) + a * np.sin(x[:, 1]) ** 2 + b * x[:, 2] ** 4 * np.sin(x[:, 0])


def test_sobol_indices_of_the_ishigami_function():
    """Exact indices of Ishigami's function (a = 7, b = 0.1; Sobol' & Levitan 1999) lie within
    the bootstrap intervals; a fourth input that the function ignores has S1 = ST = 0 within
    its interval; the estimates are scipy.stats.sobol_indices'."""
    pi = math.pi
    s = parse_sample(
        {"method": "sobol", "n": 1024, "seed": 3, **{f"x.{k}": [-pi, pi] for k in "abc"}}
        | {"x.d": [0.0, 1.0]},
        _fail,
    )
    x = np.array([[p[k] for k in s.keys] for p in s.points()])
    y = _ishigami(x)
    res = sobol_analysis(s, y)

    a, b = 7.0, 0.1
    v1 = 0.5 * (1 + b * pi**4 / 5) ** 2
    v2 = a**2 / 8
    v13 = b**2 * pi**8 * (1 / 18 - 1 / 50)
    var = v1 + v2 + v13
    exact_s1 = [v1 / var, v2 / var, 0.0, 0.0]
    exact_st = [(v1 + v13) / var, v2 / var, v13 / var, 0.0]
    for i in range(4):
        assert res["S1_low"][i] <= exact_s1[i] <= res["S1_high"][i], (i, res)
        assert res["ST_low"][i] <= exact_st[i] <= res["ST_high"][i], (i, res)
    assert res["ST"][3] == 0 and res["ST_low"][3] <= 0 <= res["ST_high"][3]
    assert np.argmax(res["ST"]) == 0 and res["ST_high"][3] < res["ST_low"][2]

    again = sobol_analysis(s, y)  # the intervals are reproducible (seeded by the sample)
    assert all(np.array_equal(res[k], again[k]) for k in res)
    other = sobol_analysis(s, y, seed=4)  # ... and drawn: another seed, other intervals
    assert not np.array_equal(res["ST_low"], other["ST_low"])
    # 1024 rows: the 95 % intervals are a few hundredths wide, not vacuous
    assert np.all(res["S1_high"] - res["S1_low"] < 0.15)


# ------------------------------------------------------------------ fabricated members
def _record(x_front: float | None, speed: float = 0.2, run_out=None) -> dict:
    return {
        "status": "done",
        "wall_s": 1.5,
        "steps": 10,
        "rhs_evaluations": 20,
        "metrics": {
            "time": [0.25, 0.5],
            "finger_count": [0, 0],
            "wavelength": [None, None],
            "x_front_max": [0.05, x_front],
            "front_speed": [speed, speed],
            "deposit": {"run_out": run_out, "thickness_mean": None},
        },
    }


def _sobol_sweep(n=4, **extra):
    return _sweep(
        times=[0.25],
        set={**BASE["set"], "effects": {"viscosity": False}},
        sample={
            "method": "sobol",
            "n": n,
            "seed": 7,
            "material.zeta_deg": [26.0, 29.0],
            "flow.nu": {"range": [0.005, 0.05], "log": True},
        },
        **extra,
    )


def test_sensitivity_rows_from_member_records():
    """x_front_max depends on the slope only, so nu's total index is 0 within its interval and
    the slope's is the largest; an output undefined in a member or the same in all has rows
    saying so and no numbers."""
    sw = _sobol_sweep()
    assert len(sw.runs) == 4 * (2 + 2)
    records = {}
    for i, r in enumerate(sw.runs):
        zeta = r.values["material.zeta_deg"]
        run_out = None if i == 3 else 0.1 * zeta
        records[r.name] = _record(0.02 * (zeta - 25.0) ** 2, run_out=run_out)
    rows = sensitivity_rows(sw, records)
    by = {(r["output"], r["parameter"]): r for r in rows}
    front = by["x_front_max", "flow.nu"], by["x_front_max", "material.zeta_deg"]
    assert front[0]["ST"] == 0 and front[0]["ST_low"] <= 0 <= front[0]["ST_high"]
    assert front[1]["ST"] > 0.9 and front[1]["S1"] > 0.5 and front[1]["note"] is None
    assert by["deposit_run_out", "flow.nu"]["note"] == "undefined in 1 of 16 members"
    assert by["deposit_run_out", "flow.nu"].get("S1") is None
    assert by["front_speed", "material.zeta_deg"]["note"].startswith("the same in every member")
    assert by["wavelength", "flow.nu"]["members"] == 0
    # no sensitivity for a design that is not Saltelli's
    lhs = _sweep(sample={"method": "lhs", "n": 3, "flow.nu": [0.01, 0.02]})
    assert sensitivity_rows(lhs, {}) == []


def test_sensitivity_per_grid_point(tmp_path):
    """A sample at each grid point: indices per grid point, and a chart for each."""
    from tiseg.apps.sweep.sensitivity import plot_sensitivity

    sw = _sobol_sweep(n=2, grid={"flow.h0": [0.002, 0.0025]})
    assert len(sw.runs) == 2 * 8
    records = {}
    for r in sw.runs:  # at h0 = 0.0025 the front ignores the slope and follows nu
        v = r.values
        x = v["material.zeta_deg"] if v["flow.h0"] == 0.002 else 100 * v["flow.nu"]
        records[r.name] = _record(x)
    rows = [r for r in sensitivity_rows(sw, records) if r["output"] == "x_front_max"]
    st = {(r["flow.h0"], r["parameter"]): r["ST"] for r in rows}
    assert st[0.002, "flow.nu"] == 0 and st[0.002, "material.zeta_deg"] > 0
    assert st[0.0025, "material.zeta_deg"] == 0 and st[0.0025, "flow.nu"] > 0
    paths = plot_sensitivity(sw, sensitivity_rows(sw, records), tmp_path, dpi=30)
    assert [p.name for p in paths] == ["sensitivity-h0-0.002.png", "sensitivity-h0-0.0025.png"]


def test_table_and_outputs_hold_the_deposit():
    sw = _sweep(grid={"flow.nu": [0.01]})
    rec = _record(0.1, run_out=0.42)
    assert member_outputs(rec)["deposit_run_out"] == 0.42
    assert member_outputs({**rec, "status": "failed"})["x_front_max"] is None
    (row,) = table_rows(sw, {"nu-0.01": rec})
    assert row["deposit_run_out"] == 0.42 and row["deposit_thickness_mean"] is None


def test_dataset_of_a_grid(tmp_path):
    import xarray as xr

    sw = _sweep(times=[0.25], grid={"flow.nu": [0.01, 0.02, 0.03], "flow.h0": [0.002, 0.0025]})
    records = {}
    for r in sw.runs:
        records[r.name] = _record(100 * r.values["flow.nu"] + r.values["flow.h0"])
    records["nu-0.03_h0-0.0025"] = {"status": "failed", "error": "x"}
    path = write_dataset(sw, tmp_path, records)
    with xr.open_dataset(path) as ds:
        assert ds.wavelength.dims == ("flow_nu", "flow_h0")
        assert ds.flow_nu.attrs["scene_key"] == "flow.nu"
        # the keys' units, as their declarations give them (nu [m^(3/2)/s], h0 [m])
        assert ds.flow_nu.attrs["units"] == "m1.5 s-1" and ds.flow_h0.attrs["units"] == "m"
        assert float(ds.x_front_max.sel(flow_nu=0.02, flow_h0=0.0025)) == pytest.approx(2.0025)
        assert math.isnan(float(ds.x_front_max.sel(flow_nu=0.03, flow_h0=0.0025)))
        assert ds.x_front_max.attrs["units"] == "m" and ds.front_speed.attrs["units"] == "m s-1"
        assert ds.x_front_max_at_time.sel(output_time=0.25, flow_nu=0.01).values.tolist() == [
            0.05,
            0.05,
        ]
        flags = ds.status.attrs["flag_meanings"].split()
        assert [flags[v] for v in ds.status.values.ravel()] == ["done"] * 5 + ["failed"]
        assert str(ds.run.sel(flow_nu=0.01, flow_h0=0.002).values) == "nu-0.01_h0-0.002"
        assert ds.attrs["Conventions"] == "CF-1.8"
        assert "h_max" not in ds  # the members have no fields.nc: no peak fields, no error


def _cf_check(path: Path, tmp_path: Path) -> None:
    """The IOOS compliance checker finds nothing to fix in ``path`` against CF-1.8: the checker
    of this environment if installed, else the one named by TISEG_CF_CHECKER (CI installs it in
    a venv of its own, whose dependencies clash with the test extra's, and names it)."""
    import os
    import subprocess

    exe = os.environ.get("TISEG_CF_CHECKER")
    if exe:
        out = subprocess.run(
            [exe, "--test", "cf:1.8", str(path)], capture_output=True, text=True, timeout=300
        )
        assert out.returncode == 0, out.stdout[-3000:] + out.stderr[-2000:]
        return
    pytest.importorskip("compliance_checker.runner", reason="no CF checker here (CI has one)")
    from compliance_checker.runner import CheckSuite, ComplianceChecker

    CheckSuite.load_all_available_checkers()
    report = tmp_path / "cf.txt"
    ok, errors = ComplianceChecker.run_checker(
        str(path), ["cf:1.8"], 0, "normal", output_filename=str(report)
    )
    assert ok and not errors, report.read_text()


def _fields_file(path: Path, scale: float, names=("h_max", "speed_max", "arrival_time"), nx=3):
    import netCDF4

    path.parent.mkdir(parents=True, exist_ok=True)
    with netCDF4.Dataset(path, "w") as ds:
        ds.createDimension("y", 2)
        ds.createDimension("x", nx)
        ds.createVariable("y", "f8", ("y",))[:] = [0.025, 0.075]
        ds["y"].setncatts({"long_name": "cross-slope distance", "units": "m"})
        ds.createVariable("x", "f8", ("x",))[:] = 0.05 * np.arange(nx) + 0.025
        ds["x"].setncatts({"long_name": "downslope distance", "units": "m"})
        ds.createVariable("peak_time", "f8", ())[:] = 0.5 * scale
        for name in names:
            v = ds.createVariable(name, "f8", ("y", "x"), fill_value=np.nan)
            v.setncatts({"long_name": name, "units": "s" if name == "arrival_time" else "m"})
            v[:] = scale * np.arange(2 * nx).reshape(2, nx)


def test_dataset_of_a_sample_stacks_the_peak_fields(tmp_path):
    import xarray as xr

    sw = _sweep(sample={"method": "lhs", "n": 3, "seed": 2, "flow.nu": [0.01, 0.02]})
    records = {r.name: _record(r.values["flow.nu"]) for r in sw.runs}
    _fields_file(tmp_path / "member-0000" / "fields.nc", 1.0)
    _fields_file(tmp_path / "member-0001" / "fields.nc", 2.0, names=("h_max",))
    # member 2 has no fields.nc: its fields are missing
    path = write_dataset(sw, tmp_path, records)
    with xr.open_dataset(path) as ds:
        assert ds.x_front_max.dims == ("member",)
        assert ds.flow_nu.dims == ("member",)
        assert ds.x_front_max.values.tolist() == ds.flow_nu.values.tolist()
        assert ds.h_max.dims == ("member", "y", "x") and ds.h_max.attrs["units"] == "m"
        assert ds.h_max.isel(member=1, y=1, x=2) == 10.0
        assert ds.h_max.isel(member=2).isnull().all()
        assert ds.speed_max.isel(member=1).isnull().all()
        assert float(ds.arrival_time.isel(member=0, y=0, x=1)) == 1.0
        assert ds.peak_time.values[:2].tolist() == [0.5, 1.0] and ds.peak_time.attrs["units"] == "s"
        assert math.isnan(ds.peak_time.values[2]) and "deposit_h" not in ds
        assert ds.flow_nu.attrs["sample_range"].tolist() == [0.01, 0.02]
        assert ds.flow_nu.attrs["units"] == "m1.5 s-1"
    # members on different grids cannot be stacked: left out, no error
    _fields_file(tmp_path / "other" / "member-0002" / "fields.nc", 1.0, nx=4)
    for name in ("member-0000", "member-0001"):
        _fields_file(tmp_path / "other" / name / "fields.nc", 1.0)
    assert "h_max" not in sweep_dataset(sw, records, tmp_path / "other")
    _cf_check(path, tmp_path)  # last: skipped where the checker is not installed


def test_refresh_fills_the_deposit_from_fingers_json(tmp_path):
    from tiseg.post.analysis.fingers import ANALYSIS_VERSION

    rec = {"status": "reused", "metrics": {"analysis_version": ANALYSIS_VERSION, "time": [0.5]}}
    stored = {
        "analysis_version": ANALYSIS_VERSION,
        **{k: [None] for k in ("time", "x_front_max")},
        "deposit": {"run_out": 0.3},
    }
    from tiseg.post.analysis.fingers import RUN_KEYS

    stored.update({k: [None] for k in RUN_KEYS if k not in stored})
    (tmp_path / "fingers.json").write_text(json.dumps(stored))
    new = refresh_metrics(tmp_path, rec)
    assert new["metrics"]["deposit"]["run_out"] == 0.3
    assert json.loads((tmp_path / "done.json").read_text())["metrics"]["deposit"]["run_out"] == 0.3


def test_folder_of_another_sample_is_refused(tmp_path):
    sw = _sobol_sweep()
    write_results(sw, tmp_path, {})
    from tiseg.apps.sweep.table import _write_outputs

    _write_outputs(sw, tmp_path, {})
    check_sweep_folder(sw, tmp_path)  # the same sweep: fine
    other = _sweep(sample={"method": "lhs", "n": 3, "flow.nu": [0.01, 0.02]})
    with pytest.raises(InputError, match=r"another sweep \('sweep', its .*sample.* differ"):
        check_sweep_folder(other, tmp_path)
    # a grid sweep's sweep.json of before samples existed has no "sample" entry
    grid = _sweep(grid={"flow.nu": [0.01]})
    _write_outputs(grid, tmp_path, {})
    stored = json.loads((tmp_path / "sweep.json").read_text())
    del stored["sweep"]["sample"]
    (tmp_path / "sweep.json").write_text(json.dumps(stored))
    check_sweep_folder(grid, tmp_path)


# ------------------------------------------------------------------ end to end
@pytest.mark.slow
def test_tiny_sample_sweep_on_dask_then_reuse(tmp_path):
    """The built-in tiny-sample (8 members) on a local cluster: sweep.csv, sweep.nc and
    sensitivity.csv; nu does nothing (viscosity off), so its total index of the front position
    is 0 and the slope's is the largest. A re-run draws the same design and reuses every
    member without starting a cluster or adding a folder."""
    import xarray as xr

    out = tmp_path / "ts"
    lines: list[str] = []
    sw = load_sweep(TINY_SAMPLE)
    res = run_sweep(sw, out, workers=2, threads_per_task=1, echo=lines.append)
    assert res.count("done") == 8 and res.count("failed") == 0, lines
    rows = read_table(out / "sweep.csv")
    assert [r["member"] for r in rows] == list(range(8))
    assert [r["block"] for r in rows] == ["A", "A", "B", "B", "AB1", "AB1", "AB2", "AB2"]
    with xr.open_dataset(out / "sweep.nc") as ds:
        assert ds.sizes["member"] == 8
        zeta = ds.material_zeta_deg.values
        assert 26.5 <= zeta.min() and zeta.max() <= 28.5
        # a steeper slope runs further (figure 1's set-up: friction falls with the slope)
        order = np.argsort(zeta)
        xf = ds.x_front_max.values[order]
        assert np.all(np.diff(xf) >= 0) and xf[-1] > xf[0]
    sens = {(r["output"], r["parameter"]): r for r in read_table(out / "sensitivity.csv")}
    nu, zeta_row = sens["x_front_max", "flow.nu"], sens["x_front_max", "material.zeta_deg"]
    assert nu["ST"] == 0 and nu["ST_low"] <= 0 <= nu["ST_high"]
    assert zeta_row["ST"] > nu["ST"]
    assert (out / "sensitivity.png").stat().st_size > 1000
    assert [p.name for p in res.results] == ["sweep.nc", "sensitivity.csv", "sensitivity.png"]
    assert res.as_dict()["results"][0] == str(out / "sweep.nc")

    folders = sorted(p.name for p in out.iterdir() if p.is_dir())
    lines.clear()
    res2 = run_sweep(load_sweep(TINY_SAMPLE), out, workers=2, echo=lines.append)
    assert res2.count("reused") == 8 and res2.count("done") == 0
    assert not any("Dask cluster" in s for s in lines), lines
    assert sorted(p.name for p in out.iterdir() if p.is_dir()) == folders


def test_check_lists_the_drawn_values(capsys, tmp_path):
    from tiseg.apps.cli import main

    assert main(["sweep", str(TINY_SAMPLE), "--check", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "8 runs (sobol sample of n = 2, seed 1), valid" in out
    lines = [ln for ln in out.splitlines() if "member-" in ln]
    assert len(lines) == 8 and all("material.zeta_deg = " in ln for ln in lines)
    sw = load_sweep(TINY_SAMPLE)
    assert f"flow.nu = {sw.runs[3].values['flow.nu']:.4g}" in lines[3]


def test_dataset_of_a_single_run():
    """A sweep without grid and sample has one run: its outputs are scalars."""
    sw = _sweep()
    ds = sweep_dataset(sw, {"base": _record(0.07)})
    assert ds.x_front_max.dims == () and float(ds.x_front_max) == 0.07
