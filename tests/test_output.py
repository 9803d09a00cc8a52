"""Output files: NetCDF snapshots read back by xarray, diagnostics CSV, atomic writes."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap

import netCDF4
import numpy as np

import tiseg
import pytest
import xarray as xr

from tiseg.output import (
    DiagnosticsWriter,
    FieldsWriter,
    read_diagnostics,
    read_fields,
    write_json_atomic,
    write_text_atomic,
)
from tiseg.setup.scene import load_scene

NX, NY = 7, 4
X = (np.arange(NX) + 0.5) * 0.01
Y = (np.arange(NY) + 0.5) * 0.02


def _snapshot(t, fields=("h", "u", "v", "phi")):
    """Distinct, time-dependent values per field so mix-ups show."""
    base = np.arange(NY * NX, dtype=float).reshape(NY, NX)
    return {name: base * (i + 1) + 100.0 * t for i, name in enumerate(fields)}


def test_fields_round_trip_with_xarray(tmp_path):
    path = tmp_path / "fields.nc"
    times = [0.0, 0.25, 1.5]
    scene_toml = load_scene("fingers").to_toml()
    with FieldsWriter(path, X, Y, {"scene": scene_toml, "scene_name": "fingers"}) as w:
        for t in times:
            w.write(t, **_snapshot(t))
    ds = xr.open_dataset(path, decode_times=False)
    try:
        assert ds.attrs["Conventions"] == "CF-1.8"
        for key in ("title", "source", "history", "references"):
            assert ds.attrs[key]
        assert "10.1017/jfm.2016.653" in ds.attrs["references"]
        assert (
            tiseg.__version__ in ds.attrs["source"] and tiseg.__version__ in ds.attrs["references"]
        )
        assert ds.attrs["scene"] == scene_toml and ds.attrs["scene_name"] == "fingers"
        assert ds["h"].dims == ("time", "y", "x")
        np.testing.assert_array_equal(ds["time"].values, times)
        assert ds["time"].dtype == np.float64  # decode_times=False: plain seconds
        # model time: a duration in seconds, no reference date; CF 4.4 tells a time
        # coordinate by units "<unit> since <date>", so no standard_name, axis or calendar
        # that would claim one (tiseg.output.netcdf)
        assert ds["time"].attrs["units"] == "s"
        assert not {"standard_name", "axis", "calendar"} & set(ds["time"].attrs)
        np.testing.assert_array_equal(ds["x"].values, X)
        np.testing.assert_array_equal(ds["y"].values, Y)
        # axis: GDAL's netCDF driver places the rasters in metres (a geotransform); the
        # projection_*_coordinate names keep CF checkers from reading them as lon / lat
        assert ds["x"].attrs == {
            "standard_name": "projection_x_coordinate",
            "long_name": "downslope distance",
            "units": "m",
            "axis": "X",
        }
        assert ds["y"].attrs == {
            "standard_name": "projection_y_coordinate",
            "long_name": "cross-slope distance",
            "units": "m",
            "axis": "Y",
        }
        units = {"h": "m", "u": "m s-1", "v": "m s-1", "phi": "1"}
        for name, unit in units.items():
            assert ds[name].attrs["units"] == unit
            assert ds[name].attrs["long_name"]
        for i, t in enumerate(times):
            for name, arr in _snapshot(t).items():
                np.testing.assert_array_equal(ds[name].isel(time=i).values, arr)
        # the stored scene is a loadable scene
        assert ds.attrs["scene"].count("[domain]") == 1
    finally:
        ds.close()
    # zlib compression is on for the data variables
    with netCDF4.Dataset(path) as nc:
        assert nc["h"].filters()["zlib"] is True
        assert nc.dimensions["time"].isunlimited()
    ds2 = read_fields(path)
    try:
        np.testing.assert_array_equal(ds2["phi"].values[-1], _snapshot(1.5)["phi"])
        np.testing.assert_array_equal(ds2["time"].values, times)
    finally:
        ds2.close()
    # a plain xarray open keeps the time in seconds, so a time can be selected by its value
    with xr.open_dataset(path) as ds3:
        assert ds3["time"].dtype == np.float64
        np.testing.assert_array_equal(ds3["time"].values, times)
        np.testing.assert_array_equal(ds3.sel(time=1.5)["h"].values, _snapshot(1.5)["h"])


def test_phi_is_missing_where_there_is_no_material(tmp_path):
    """phi = 0 would read as pure coarse grains: where h < h_min it is _FillValue (NaN after
    decoding), elsewhere it is stored as given."""
    path = tmp_path / "f.nc"
    snap = _snapshot(0.0)
    snap["h"] = np.where(np.arange(NX)[None, :] < 3, 0.0, 1e-3) + 0.0 * snap["h"]
    snap["phi"] = np.full((NY, NX), 0.25)
    with FieldsWriter(path, X, Y, h_min=1e-4) as w:
        w.write(0.0, **snap)
    with read_fields(path) as ds:
        phi = ds["phi"].values[0]
        assert np.isnan(phi[:, :3]).all() and (phi[:, 3:] == 0.25).all()
        assert "h_min" in ds["phi"].attrs["comment"]
        assert np.isfinite(ds["h"].values).all()
    with netCDF4.Dataset(path) as nc:
        assert nc["phi"]._FillValue == netCDF4.default_fillvals["f8"]


def test_f4_and_quantised_output_are_smaller(tmp_path):
    """output.precision = "f4" and output.significant_digits: the same smooth snapshot takes
    less room, and reads back within the promised digits."""
    yy, xx = np.meshgrid(Y, X, indexing="ij")
    smooth = {
        "h": 2e-3 * (1 + 0.3 * np.sin(7 * xx) * np.cos(5 * yy)),
        "u": 0.2 + 0.01 * xx,
        "v": 0.01 * np.sin(3 * yy),
        "phi": 0.5 + 0.4 * np.cos(4 * xx),
    }
    sizes = {}
    for label, kw in (("f8", {}), ("f4", {"dtype": "f4"}), ("q3", {"significant_digits": 3})):
        path = tmp_path / f"{label}.nc"
        with FieldsWriter(path, X, Y, **kw) as w:
            for k in range(4):
                w.write(0.1 * k, **smooth)
        sizes[label] = path.stat().st_size
        with read_fields(path) as ds:
            back = ds["h"].values[-1]
        rel = np.abs(back / smooth["h"] - 1).max()
        assert rel < {"f8": 1e-15, "f4": 1e-7, "q3": 1e-3}[label], (label, rel)
    assert sizes["f4"] < sizes["f8"] and sizes["q3"] < sizes["f8"], sizes


def test_only_named_fields_exist(tmp_path):
    path = tmp_path / "noseg.nc"
    with FieldsWriter(path, X, [0.5], {"segregation": False}, fields=("h", "u"), dtype="f4") as w:
        w.write(0.0, h=np.ones(NX), u=np.zeros((1, NX)))  # a 1D run: (nx,) or (1, nx)
        with pytest.raises(ValueError, match="phi"):
            w.write(0.1, h=np.ones(NX), u=np.zeros(NX), phi=np.zeros(NX))
        with pytest.raises(ValueError, match="missing"):
            w.write(0.2, h=np.ones(NX))
        with pytest.raises(ValueError, match="shape"):
            w.write(0.3, h=np.ones((2, NX)), u=np.ones((2, NX)))
        with pytest.raises(ValueError, match="after"):
            w.write(0.0, h=np.ones(NX), u=np.ones(NX))
    ds = read_fields(path)
    try:
        assert set(ds.data_vars) == {"h", "u"}
        assert ds["h"].dtype == np.float32 and ds.sizes["time"] == 1
        assert ds.attrs["segregation"] == 0
    finally:
        ds.close()


def test_killed_writer_keeps_snapshots(tmp_path):
    """A process killed (SIGKILL, no close) after 2 snapshots leaves 2 readable snapshots."""
    path = tmp_path / "killed.nc"
    script = textwrap.dedent(f"""
        import os, signal
        import numpy as np
        from tiseg.output import FieldsWriter
        w = FieldsWriter({str(path)!r}, np.arange(5.0), np.arange(3.0), {{"note": "killed"}})
        for t in (0.0, 0.5):
            a = np.full((3, 5), 1.0 + t)
            w.write(t, h=a, u=2 * a, v=3 * a, phi=a / 4)
        os.kill(os.getpid(), signal.SIGKILL)
    """)
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True)
    assert proc.returncode == -9, proc.stderr  # really killed, not closed
    with netCDF4.Dataset(path, "r") as nc:
        assert nc.dimensions["time"].size == 2
        np.testing.assert_array_equal(nc["time"][:], [0.0, 0.5])
    ds = xr.open_dataset(path)
    try:
        assert ds.sizes["time"] == 2
        np.testing.assert_array_equal(ds["u"].isel(time=1).values, np.full((3, 5), 3.0))
        np.testing.assert_array_equal(ds["phi"].isel(time=0).values, np.full((3, 5), 0.25))
    finally:
        ds.close()


def test_diagnostics_round_trip(tmp_path):
    path = tmp_path / "diag.csv"
    rows = [
        dict(
            time=0.0,
            dt=1e-4,
            stages=3,
            mass=0.0,
            small_mass=0.0,
            max_speed=0.0,
            wall_time_cumulative=0.01,
            front=0.1,
        ),
        dict(
            time=0.1 + 1e-17,
            dt=1.2345678901234567e-4,
            stages=17,
            mass=1e-3,
            small_mass=8e-4,
            max_speed=0.208,
            wall_time_cumulative=0.5,
            front=0.12,
        ),
    ]
    with DiagnosticsWriter(path, extra=("front",)) as w:
        for r in rows:
            w.write(**r)
        w.write(time=0.2)  # missing values -> NaN
        with pytest.raises(ValueError, match="unknown"):
            w.write(time=0.3, bogus=1)
        # flushed per row: readable while the writer is still open
        assert read_diagnostics(path)["time"].size == 3
    d = read_diagnostics(path)
    assert list(d) == [
        "time",
        "dt",
        "stages",
        "mass",
        "small_mass",
        "max_speed",
        "wall_time_cumulative",
        "front",
        "wall_time",
    ]  # + the old name
    np.testing.assert_array_equal(d["wall_time"], d["wall_time_cumulative"])
    for key in rows[0]:
        np.testing.assert_array_equal(d[key][:2], [r[key] for r in rows])  # exact floats
    assert np.isnan(d["dt"][2]) and d["time"][2] == 0.2
    with open(path) as fh:
        assert fh.readline().strip() == (
            "time,dt,stages,mass,small_mass,max_speed,wall_time_cumulative,front"
        )


def test_custom_columns(tmp_path):
    path = tmp_path / "c.csv"
    with DiagnosticsWriter(path, columns=("step", "energy")) as w:
        w.write(step=1, energy=2.5)
    d = read_diagnostics(path)
    assert set(d) == {"step", "energy"} and d["energy"][0] == 2.5


def test_write_text_atomic(tmp_path):
    path = tmp_path / "sub" / "scene.toml"
    write_text_atomic(path, "a = 1\n")
    write_text_atomic(path, "a = 2\n")
    assert path.read_text() == "a = 2\n"
    assert sorted(os.listdir(path.parent)) == ["scene.toml"]  # no temporary left behind
    j = write_json_atomic(
        tmp_path / "summary.json", {"u0": 0.208, "bad": float("nan"), "arr": np.arange(3)}
    )
    assert json.loads(j.read_text()) == {"u0": 0.208, "bad": None, "arr": [0, 1, 2]}


def test_scene_output_precision_reaches_the_file(ti_cpu, tmp_path):
    """output.precision and output.significant_digits of a scene set the stored type and the
    quantisation of fields.nc; a bad value is a one-line InputError."""
    from tiseg.errors import InputError
    from tiseg.run.simulation import Simulation

    sc = load_scene(
        "channel",
        {
            "time.t_end": 0.05,
            "output.interval": 0.05,
            "domain.resolution": 250,
            "output.precision": "f4",
            "output.significant_digits": 4,
        },
    )
    (tmp_path / "s.toml").write_text(sc.to_toml())
    assert load_scene(str(tmp_path / "s.toml")) == sc  # the keys round-trip
    Simulation(sc).run(out_dir=tmp_path / "run", progress=False)
    with netCDF4.Dataset(tmp_path / "run" / "fields.nc") as nc:
        assert nc["phi"].dtype == np.float32 and nc["h"].dtype == np.float32
        assert nc["h"].quantization()[0] == 4
    for key, bad in (
        ("output.precision", "f2"),
        ("output.significant_digits", 20),
        ("output.significant_digits", 0),
    ):
        with pytest.raises(InputError, match=key.split(".")[1]):
            load_scene("channel", {key: bad})


def test_cf_xarray_finds_the_axes(tmp_path):
    """cf_xarray reads the CF attributes: x and y are the X and Y axes. Model time carries no
    ``axis``/``standard_name`` (CF would then want a reference date, tiseg.output.netcdf), so
    cf_xarray finds it as the T axis and the time coordinate by its name, once asked to guess."""
    import cf_xarray  # noqa: F401  (registers the .cf accessor)

    path = tmp_path / "f.nc"
    with FieldsWriter(path, X, Y) as w:
        for t in (0.0, 0.5):
            w.write(t, **_snapshot(t))
    with xr.open_dataset(path) as ds:
        assert ds.cf.axes == {"X": ["x"], "Y": ["y"]}
        guessed = ds.cf.guess_coord_axis()
        assert guessed.cf.axes == {"T": ["time"], "X": ["x"], "Y": ["y"]}
        assert guessed.cf.coordinates == {"time": ["time"]}
        assert guessed.cf["time"].size == 2 and guessed["time"].dtype == np.float64


def test_velocity_of_films_thinner_than_h_eps_is_the_solvers(ti_cpu):
    """The written velocity of a film thinner than numerics.h_eps is the solver's
    desingularised one, sqrt(2) h (hu) / sqrt(h^4 + h_eps^4), not hu/h (1e7 m/s for a film of
    1e-19 m carrying a round-off momentum of 1e-12 m^2/s); thicker cells keep hu/h bit for bit."""
    from tiseg.run.simulation import Simulation

    sim = Simulation(load_scene("fingers", {"domain.resolution": 40, "time.t_end": 0.1}))
    lay = sim.layout
    q = np.zeros((lay.nc, lay.nx, lay.ny))
    q[lay.H] = 2e-3
    q[lay.HU] = 2e-3 * 0.2071
    q[lay.HV] = -2e-3 * 0.013
    q[lay.H, 5, 3], q[lay.HU, 5, 3], q[lay.HV, 5, 3] = 1e-19, 1e-12, -1e-12
    q[lay.H, 6, 3], q[lay.HU, 6, 3] = 0.0, 0.0
    if lay.segregation:
        q[lay.HPHI] = 0.8 * q[lay.H]
    sim.arrays.set_conserved(q)
    f = sim.fields()
    h_eps = sim.scene.numerics.h_eps
    want = np.sqrt(2.0) * 1e-19 * 1e-12 / np.sqrt(1e-76 + h_eps**4)
    assert f["u"][3, 5] == pytest.approx(want, rel=1e-12) and abs(f["u"][3, 5]) < 1e-16
    assert f["v"][3, 5] == pytest.approx(-want, rel=1e-12)
    assert f["u"][3, 6] == 0.0
    thick = np.ones(f["h"].shape, bool)
    thick[3, 5] = thick[3, 6] = False
    np.testing.assert_array_equal(
        f["u"][thick], (q[lay.HU] / np.where(q[lay.H] > 0, q[lay.H], 1)).T[thick]
    )
