"""Probability maps of a sweep (``[probability]``, ``probability.nc``): the table's validation,
the maps of real dam-break members checked against NumPy on the members' own fields.nc, the
rewrite of a resumed sweep without duplicated members, the CF check and the figure.

The members run in this process on the test session's Taichi runtime (no Dask cluster: the
cluster is `tests/test_sweep.py`'s subject), one compile for the three of them."""

from __future__ import annotations

import json
import math
from pathlib import Path

import netCDF4
import numpy as np
import pytest

from tiseg.apps.sweep import execute_run, load_sweep, run_sweep, scene_fingerprint
from tiseg.apps.sweep import sweep_from_dict, write_results
from tiseg.apps.sweep.probability import QUANTILES
from tiseg.errors import InputError

from test_sweep_sample import _cf_check, _fields_file

ROOT = Path(__file__).resolve().parents[1]
H_THR = [0.0005, 0.001, 0.0015]
S_THR = [0.02, 0.05, 0.1]
# A 1D dam break (40 cells, to 0.15 s) with the dam's height drawn from a Latin hypercube: the
# members differ in how far and how fast the front runs, so the maps have cells of every
# probability between 0 and 1.
BASE = {
    "scene": "dam-break",
    "set": {
        "domain": {"nx": 40},
        "time": {"t_end": 0.15},
        "output": {"interval": 0.15},
        "numerics": {"precision": "f64"},
    },
    "sample": {"method": "lhs", "n": 3, "seed": 3, "initial.h_left": [0.001, 0.003]},
    "probability": {"h_thresholds": H_THR, "speed_thresholds": S_THR},
}


def _sweep(**changes):
    d = json.loads(json.dumps(BASE))
    for key, value in changes.items():
        if value is None:
            d.pop(key, None)
        else:
            d[key] = value
    return sweep_from_dict(d, source="s.toml")


# ------------------------------------------------------------------ validation
@pytest.mark.parametrize(
    "table, message",
    [
        (
            {"h_thresholds": [0.001, -0.002]},
            "h_thresholds lists -0.002: thresholds must be above 0",
        ),
        ({"speed_thresholds": [0.0]}, "speed_thresholds lists 0.0: thresholds must be above 0"),
        ({"h_thresholds": [math.nan]}, "h_thresholds lists nan: thresholds are finite numbers"),
        ({"h_thresholds": [math.inf]}, "h_thresholds lists inf: thresholds are finite numbers"),
        ({"h_thresholds": ["1 mm"]}, "h_thresholds lists '1 mm': thresholds are finite"),
        ({"h_thresholds": [True]}, "h_thresholds lists True: thresholds are finite"),
        ({"h_thresholds": 0.001}, "h_thresholds = 0.001: give a non-empty list"),
        ({"speed_thresholds": []}, "speed_thresholds = []: give a non-empty list"),
        ({"h_thresholds": [0.001, 0.001]}, "h_thresholds lists 0.001 more than once"),
        ({"h_threshold": [0.001]}, "unknown key 'h_threshold' (did you mean 'h_thresholds'?)"),
        ({}, "[probability] needs h_thresholds [m] or speed_thresholds [m/s]"),
        ([0.001], "[probability] must be a table"),
    ],
)
def test_bad_probability_tables_are_one_line_errors(table, message):
    with pytest.raises(InputError) as err:
        _sweep(probability=table)
    assert message in str(err.value) and "\n" not in str(err.value)


def test_a_probability_table_from_toml(tmp_path, capsys):
    f = tmp_path / "p.toml"
    f.write_text(
        'scene = "dam-break"\n[set]\n"domain.nx" = 40\n[grid]\n"initial.h_left" = [0.001, 0.002]\n'
        "[probability]\nh_thresholds = [0.002, 0.001]\n"
    )
    sw = load_sweep(f)
    assert sw.probability.h_thresholds == (0.001, 0.002)  # sorted
    assert sw.probability.speed_thresholds == ()
    assert sw.to_dict()["probability"]["h_thresholds"] == [0.001, 0.002]
    from tiseg.apps.cli import main

    assert main(["sweep", str(f), "--check", "--out", str(tmp_path / "o")]) == 0
    assert "2 runs, probability maps of h_max > 0.001, 0.002 m, valid" in capsys.readouterr().out
    f.write_text(f.read_text().replace("0.002, 0.001]", "0.002, nan]"))
    with pytest.raises(InputError, match="h_thresholds lists nan"):
        load_sweep(f)
    assert _sweep(probability=None).probability is None


def test_probability_needs_one_grid_and_the_peak_fields():
    over_resolution = {
        "scene": "fingers",
        "set": {"domain.Lx": 0.3, "domain.Ly": 0.1, "time.t_end": 0.5, "output.times": []},
        "grid": {"domain.resolution": [40, 60]},
        "probability": {"h_thresholds": [0.001]},
    }
    with pytest.raises(InputError) as err:  # refused before any run
        sweep_from_dict(over_resolution, source="s.toml")
    msg = str(err.value)
    assert (
        "their grids differ (domain.nx = 12 in run 'resolution-40', 18 in run "
        "'resolution-60')" in msg
    )
    assert "\n" not in msg
    with pytest.raises(InputError, match="grids differ .domain.Lx"):
        _sweep(sample={"method": "lhs", "n": 2, "domain.Lx": [0.3, 0.4]})
    off = json.loads(json.dumps(BASE["set"]))
    off["output"]["peak_fields"] = False
    with pytest.raises(InputError, match="has output.peak_fields = false"):
        _sweep(set=off)
    # the same grid in every member: fine, also with a grid beside the sample
    assert len(_sweep(grid={"initial.x0": [0.1, 0.12]}).runs) == 6


def test_adding_probability_keeps_a_finished_sweep_folder(tmp_path):
    """[probability] changes no run: a folder of the same sweep without it is taken up (its
    members reused), and one with other thresholds too."""
    from tiseg.apps.sweep import check_sweep_folder
    from tiseg.apps.sweep.table import _write_outputs

    _write_outputs(_sweep(probability=None), tmp_path, {})
    check_sweep_folder(_sweep(), tmp_path)
    _write_outputs(_sweep(), tmp_path, {})
    check_sweep_folder(_sweep(probability={"speed_thresholds": [0.3]}), tmp_path)
    with pytest.raises(InputError, match="holds another sweep"):
        check_sweep_folder(_sweep(sample={**BASE["sample"], "seed": 4}), tmp_path)


def test_members_that_cannot_be_stacked_give_no_maps(tmp_path, caplog):
    """Fields files made here: a member without peak fields is left out (one line naming it);
    members whose files have different grids give no probability.nc (one line saying why)."""
    from tiseg.apps.sweep.probability import write_probability

    sw = _sweep()
    records = {r.name: {"status": "reused"} for r in sw.runs}
    names = [r.name for r in sw.runs]
    _fields_file(tmp_path / names[0] / "fields.nc", 1.0)
    _fields_file(tmp_path / names[1] / "fields.nc", 2.0)
    _fields_file(tmp_path / names[2] / "fields.nc", 3.0, names=("h_max",))
    path = write_probability(sw, tmp_path, records)
    assert "member member-0002 is left out: its fields.nc has no speed_max" in caplog.text
    import xarray as xr

    with xr.open_dataset(path) as ds:
        assert ds.run.values.tolist() == names[:2]
        # h_max = scale * [[0, 1, 2], [3, 4, 5]] m: above 0.001 m everywhere but cell 0
        assert ds.p_h_max_above.isel(y=0, x=0).values.tolist() == [0, 0, 0]
        assert ds.p_h_max_above.isel(y=1, x=2).values.tolist() == [1, 1, 1]
        assert float(ds.h_max_mean.isel(y=1, x=2)) == 7.5
    path.unlink()
    caplog.clear()
    _fields_file(tmp_path / names[2] / "fields.nc", 3.0, nx=4)
    assert write_probability(sw, tmp_path, records) is None and not path.exists()
    assert "no probability.nc: the members' grids differ (member member-0002)" in caplog.text
    assert write_probability(_sweep(probability=None), tmp_path, records) is None


# ------------------------------------------------------------------ the maps of real members
def _in_process(calls, limit):
    """A stand-in for the Dask submission: run the pending members here, one after another,
    at most ``limit[0]`` of them (None: all; the others left unfinished, as by a kill)."""

    def run(sweep, out, pending, records, *args, **kwargs):
        for r in pending[: limit[0]]:
            calls.append(r.name)
            spec = {
                "name": r.name,
                "dir": str((out / r.name).resolve()),
                "scene_toml": r.scene.to_toml(),
                "scene_name": r.scene.name,
                "fingerprint": scene_fingerprint(r.scene),
                "report": False,
            }
            records[r.name] = execute_run(spec)

    return run


def _expected(out: Path, names) -> dict:
    """The maps computed here from the members' fields.nc, as the docs define them."""
    h, s, a = [], [], []
    for name in names:
        with netCDF4.Dataset(out / name / "fields.nc") as ds:
            h.append(np.ma.filled(ds["h_max"][:], np.nan))
            s.append(np.ma.filled(ds["speed_max"][:], np.nan))
            a.append(np.ma.filled(ds["arrival_time"][:], np.nan))
    h, s, a = np.array(h), np.array(s), np.array(a)
    n = len(names)
    exp = {
        "p_h_max_above": np.array(
            [[np.count_nonzero(h[:, j, i] > t) / n for j, i in _cells(h)] for t in H_THR]
        ),
        "p_speed_max_above": np.array(
            [[sum(1 for m in range(n) if s[m, j, i] > t) / n for j, i in _cells(h)] for t in S_THR]
        ),
        "h_max_mean": np.array([h[:, j, i].sum() / n for j, i in _cells(h)]),
        "p_arrival": np.array([np.isfinite(a[:, j, i]).sum() / n for j, i in _cells(h)]),
    }
    qs, means = [], []
    for j, i in _cells(h):
        got = np.sort(a[:, j, i][np.isfinite(a[:, j, i])])
        means.append(got.mean() if got.size else np.nan)
        qs.append([_type7(got, q) for q in QUANTILES])
    exp["arrival_time_mean"] = np.array(means)
    exp["arrival_time_quantile"] = np.array(qs).T
    exp["h_max_quantile"] = np.array(
        [[_type7(np.sort(h[:, j, i]), q) for j, i in _cells(h)] for q in QUANTILES]
    )
    return exp, h


def _cells(h):
    return [(j, i) for j in range(h.shape[1]) for i in range(h.shape[2])]


def _type7(sorted_values, q):
    """Hyndman and Fan's quantile 7 of sorted values: linear between order statistics."""
    n = sorted_values.size
    if n == 0:
        return np.nan
    pos = q * (n - 1)
    lo = int(math.floor(pos))
    hi = min(lo + 1, n - 1)
    return sorted_values[lo] + (pos - lo) * (sorted_values[hi] - sorted_values[lo])


def _check_maps(path: Path, out: Path, names):
    import xarray as xr

    exp, h = _expected(out, names)
    with xr.open_dataset(path) as ds:
        assert sorted(ds.run.values.tolist()) == sorted(names)  # each member once
        assert ds.attrs["members"] == len(names) and ds.attrs["Conventions"] == "CF-1.8"
        assert ds.h_threshold.values.tolist() == H_THR and ds.h_threshold.attrs["units"] == "m"
        assert ds.speed_threshold.attrs["units"] == "m s-1"
        assert ds.quantile_level.values.tolist() == [0.05, 0.5, 0.95]
        assert ds.x.attrs["axis"] == "X" and ds.y.attrs["axis"] == "Y"  # GDAL places the maps
        assert ds.x.attrs["units"] == "m" and ds.x.attrs["long_name"] == "downslope distance"
        for name, var in ds.data_vars.items():
            assert "long_name" in var.attrs, name
            if name != "run":
                assert "units" in var.attrs, name
        for name in ("p_h_max_above", "p_speed_max_above", "p_arrival"):
            assert ds[name].attrs["units"] == "1"
        for name, want in exp.items():
            got = ds[name].values.reshape(want.shape)
            np.testing.assert_allclose(got, want, rtol=1e-12, atol=0, equal_nan=True, err_msg=name)
        p = ds.p_h_max_above.values
        assert p.min() == 0 and p.max() == 1 and np.all((p >= 0) & (p <= 1))
        # a cell of every kind: certain, impossible and in between (the sample spreads the front)
        assert np.any((p > 0) & (p < 1))
        assert np.all(np.diff(p, axis=0) <= 0)  # the higher the threshold, the less likely
        assert np.all(np.diff(ds.p_speed_max_above.values, axis=0) <= 0)
        for q in ("h_max_quantile", "arrival_time_quantile"):
            v = ds[q].values
            ok = np.isfinite(v).all(axis=0)
            assert np.all(np.diff(v[:, ok], axis=0) >= 0), q  # q05 <= q50 <= q95
        # arrival statistics only where some member's flow came
        never = ds.p_arrival.values == 0
        assert never.any() and np.isnan(ds.arrival_time_mean.values[never]).all()
        assert np.isfinite(ds.arrival_time_mean.values[~never]).all()
    return exp


@pytest.fixture
def members_here(ti_cpu, monkeypatch):
    """run_sweep with the members run in this process on the session's runtime."""
    import tiseg.apps.sweep.members as members
    import tiseg.apps.sweep.runner as runner

    calls: list[str] = []
    limit = [None]
    monkeypatch.setattr(runner, "_run_on_dask", _in_process(calls, limit))
    monkeypatch.setattr(members.backend, "init", lambda *a, **k: None)
    return calls, limit


@pytest.mark.slow  # a long run: the slow set (README), which CI runs after the suite
def test_maps_of_dam_break_members_then_resume(members_here, tmp_path, capsys):
    calls, limit = members_here
    out = tmp_path / "sweep"
    sw = _sweep()
    names = [r.name for r in sw.runs]
    # an interrupted sweep: two of the three members finished; the maps are theirs
    limit[0] = 2
    res = run_sweep(sw, out, echo=None)
    assert calls == names[:2] and res.count("done") == 2 and res.count("missing") == 1
    assert [p.name for p in res.results] == ["sweep.nc", "probability.nc"]
    path = out / "probability.nc"
    _check_maps(path, out, names[:2])

    # resumed: the third member runs alone, and probability.nc is written again from the
    # three finished members, none twice
    calls.clear()
    limit[0] = None
    res = run_sweep(_sweep(), out, echo=None)
    assert calls == [names[2]] and res.count("reused") == 2 and res.count("done") == 1
    _check_maps(path, out, names)

    # a failed member is left out: the maps of the two others
    records = {r.name: {"status": "reused"} for r in sw.runs}
    records[names[1]] = {"status": "failed", "error": "x"}
    write_results(sw, out, records)
    _check_maps(path, out, [n for n in names if n != names[1]])

    # the figure: a panel per threshold and the quantiles, by folder or by file
    from tiseg.apps.cli import main

    assert main(["render", str(path), "--panels", str(tmp_path / "p.png")]) == 0
    png = tmp_path / "p.png"
    assert png.stat().st_size > 10_000 and png.read_bytes()[:4] == b"\x89PNG"
    assert main(["render", str(out), "--movie", str(tmp_path / "m.mp4")]) != 0
    assert "--movie: not for probability maps" in capsys.readouterr().err
    assert not (tmp_path / "m.mp4").exists()
    _cf_check(path, tmp_path)  # last: skipped where the checker is not installed


def test_maps_of_a_2d_sample_render_as_maps(tmp_path):
    """A 2D probability.nc (made here, not run) is drawn as maps, missing cells in grey."""
    from tiseg.apps.sweep.probability import Probability, probability_maps
    from tiseg.post.render.probability import plot_probability
    import xarray as xr

    rng = np.random.default_rng(1)
    h = rng.uniform(0, 0.003, (5, 6, 9))
    s = np.where(h > 0.001, rng.uniform(0, 0.3, h.shape), np.nan)
    a = np.where(h > 0.001, rng.uniform(0, 1, h.shape), np.nan)
    maps = probability_maps(h, s, a, Probability((0.001, 0.002), (0.1,)))
    dims = {
        "p_h_max_above": ("h_threshold", "y", "x"),
        "p_speed_max_above": ("speed_threshold", "y", "x"),
    }
    data = {
        k: (dims.get(k, ("quantile_level", "y", "x") if v.ndim == 3 else ("y", "x")), v)
        for k, v in maps.items()
    }
    ds = xr.Dataset(
        data,
        coords={
            "x": 0.01 * np.arange(9) + 0.005,
            "y": 0.01 * np.arange(6) + 0.005,
            "h_threshold": [0.001, 0.002],
            "speed_threshold": [0.1],
            "quantile_level": list(QUANTILES),
        },
        attrs={"members": 5},
    )
    fig = plot_probability(ds, tmp_path / "maps.png")
    titles = [ax.get_title() for ax in fig.axes if ax.get_visible() and ax.get_title()]
    assert titles[:3] == ["P(h_max > 1 mm)", "P(h_max > 2 mm)", "P(flow arrives)"]
    assert "95 % quantile of arrival time" in titles
    assert any(ax.get_xlabel() == "x [m]" for ax in fig.axes)
    assert (tmp_path / "maps.png").stat().st_size > 10_000
    # two columns: the same maps in more rows, none with more than two
    narrow = plot_probability(ds, columns=2, width=7.0)
    shown = [ax for ax in narrow.axes if ax.get_visible() and ax.get_title()]
    assert [ax.get_title() for ax in shown] == titles
    assert max(sum(ax.get_position().y0 == a.get_position().y0 for a in shown) for ax in shown) == 2


def test_the_builtin_gate_probability_sweep_is_valid():
    sw = load_sweep("gate-probability")
    assert len(sw.runs) == 6 and sw.probability.h_thresholds == (0.0005, 0.001, 0.002)
    assert {(r.scene.domain.nx, r.scene.domain.ny) for r in sw.runs} == {(50, 30)}


@pytest.mark.slow
def test_the_builtin_gate_probability_sweep_on_dask(tmp_path):
    """The built-in example of docs/probability.md on a local Dask cluster (about a minute on
    two cores): probability.nc beside sweep.nc, the flow certain at the gate, never in the
    plane's corners, a margin of probabilities between; a re-run reuses every member and
    writes the same maps."""
    import xarray as xr

    out = tmp_path / "gate"
    res = run_sweep(load_sweep("gate-probability"), out, workers=2, threads_per_task=1, echo=None)
    assert res.count("done") == 6 and [p.name for p in res.results][:2] == [
        "sweep.nc",
        "probability.nc",
    ]
    with xr.open_dataset(out / "probability.nc") as ds:
        first = ds.load()
    p = first.p_arrival.values
    assert p[15, 0] == 1 and p[0, -1] == 0 and np.any((p > 0) & (p < 1))
    assert first.attrs["members"] == 6
    res = run_sweep(load_sweep("gate-probability"), out, workers=2, echo=None)
    assert res.count("reused") == 6
    with xr.open_dataset(out / "probability.nc") as ds:
        xr.testing.assert_identical(ds.drop_attrs(), first.drop_attrs())


def _docs_script(name: str):
    import importlib.util

    spec = importlib.util.spec_from_file_location(name, ROOT / "docs" / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_the_docs_sweep_over_terrain_draws_its_pictures(members_here, tmp_path):
    """docs/probability.md "Over terrain", tiny: the page's scene and sweep files (as
    docs/relief_pictures.py writes them) at 50 cells/m to 0.2 s with two friction values, run
    here; probability.nc holds the members' bed and walls, and the script draws the page's two
    pictures from the sweep folder, over the relief (and without it where the beds differ)."""
    import tomllib

    import xarray as xr

    from tiseg.apps.sweep.probability import probability_dataset
    from tiseg.post.render.probability import plot_probability

    pics = _docs_script("relief_pictures")
    assert set(pics.page_files()) == {"bump-hollow.toml", pics.SWEEP}
    path = pics.write_files(tmp_path)
    data = tomllib.loads(path.read_text())
    data["set"] = {"domain.resolution": 50, "time.t_end": 0.2, "output.interval": 0.2}
    data["grid"] = {"effects.coulomb_mu": [0.46, 0.5]}
    sw = sweep_from_dict(data, source=str(path), base_dir=tmp_path)
    out = tmp_path / "sweep"
    assert run_sweep(sw, out, echo=None).count("done") == 2
    b, solid = sw.runs[0].scene.bed_arrays()
    assert solid.any() and np.abs(b).max() > 0.002
    with xr.open_dataset(out / "probability.nc") as ds:
        np.testing.assert_array_equal(ds["b"].values, b.T)
        np.testing.assert_array_equal(ds["solid"].values, solid.T)
        assert ds["b"].attrs["units"] == "m" and ds["solid"].dtype == np.int8
        with_relief = plot_probability(ds, rows="probability")
        flat = plot_probability(ds.drop_vars(["b", "solid"]), rows="probability")
    img = [ax.get_images()[0].get_array() for ax in with_relief.axes if ax.get_images()]
    assert len(img) == 3 and img[0].shape == (*b.T.shape, 3)  # RGB, the relief blended in
    assert all(ax.get_images()[0].get_array().ndim == 2 for ax in flat.axes if ax.get_images())
    paths = pics.draw(out, tmp_path / "images", member=sw.runs[1].name)
    assert [p.name for p in paths] == list(pics.PICTURES)
    assert all(p.read_bytes()[:4] == b"\x89PNG" and p.stat().st_size < pics.LIMIT for p in paths)
    with pytest.raises(InputError, match="choose some of probability, speed"):
        plot_probability(out, rows=["p"])

    # members on different beds: no bed in the file, a line saying so
    records = {r.name: {"status": "reused"} for r in sw.runs}
    with netCDF4.Dataset(out / sw.runs[1].name / "fields.nc", "a") as ds:
        ds["b"][0, 0] = 1e-3
    assert "b" not in probability_dataset(sw, records, out)
