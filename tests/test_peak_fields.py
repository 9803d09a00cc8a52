"""Peak fields (tiseg.run.peaks): exact per step, observers only, resumable, free when off.

The reference of every check is computed here in NumPy from the step states a callback
records after each step (or from the snapshots in fields.nc), never from the peak fields'
own code."""

from __future__ import annotations

import math

import netCDF4
import numpy as np
import pytest

from tiseg.errors import InputError
from tiseg.output import read_diagnostics
from tiseg.run import checkpoint
from tiseg.run.callbacks import Callback
from tiseg.run.schedules import IterationInterval, TimeInterval
from tiseg.run.simulation import Simulation

# the frictionless dam break onto a dry bed (Ritter), 1D, 150 cells: 35 steps to 0.2 s
DAM = {"domain.nx": 150, "time.t_end": 0.2, "output.interval": 0.1}
# a small 2D fingers run (48 x 16 cells: inflow, segregation, viscosity, the split sweeps)
FINGERS = {
    "domain.resolution": 80,
    "domain.Lx": 0.6,
    "domain.Ly": 0.2,
    "time.t_end": 0.3,
    "output.times": [],
    "output.interval": 0.1,
    "output.checkpoint_interval": 0.05,
}
# a dam break with Coulomb friction that comes to rest by t = 0.3 s (run-out 0.115 m)
STOPPING = {
    "domain.nx": 150,
    "time.t_end": 0.4,
    "output.interval": 0.05,
    "effects.friction": "coulomb",
    "effects.coulomb_mu": 0.1,
    "numerics.stepper": "ssprk4_2",
}


def _record_steps(sim):
    """Record (t, fields) of the initial state and of every step state of ``sim``'s run."""
    states = [(sim.t, sim.fields())]
    sim.add_callback(lambda s: states.append((s.t, s.fields())), IterationInterval(1), "rec")
    return states


def _expected(states, h_min):
    """h_max, speed_max, arrival_time over step states, in NumPy (NaN where never wet)."""
    h_max = np.zeros_like(states[0][1]["h"])
    speed = np.full_like(h_max, np.nan)
    arrival = np.full_like(h_max, np.nan)
    for t, f in states:
        h = f["h"]
        s = np.hypot(f["u"], f.get("v", 0.0 * h))
        wet = h >= h_min
        h_max = np.maximum(h_max, h)
        speed = np.where(wet, np.fmax(speed, s), speed)
        arrival = np.where(wet & np.isnan(arrival), t, arrival)
    return h_max, speed, arrival


@pytest.mark.slow  # a long run: the slow set (README), which CI runs after the suite
@pytest.mark.parametrize("scene, sets", [("dam-break", DAM), ("fingers", FINGERS)])
def test_peaks_are_the_running_extremes_of_the_step_states(ti_cpu, tmp_path, scene, sets):
    """h_max is the largest h of any step state bit for bit, speed_max the largest |u| where
    wet (to round-off: |(hu, hv)| / h against hypot(hu / h, hv / h)), arrival_time the time
    of the first wet step state; in fields.nc h_max is never below a snapshot's h."""
    sim = Simulation.from_scene(scene, sets)
    states = _record_steps(sim)
    sim.run(out_dir=tmp_path, progress=False)
    h_min = sim.scene.numerics.h_min
    h_max, speed, arrival = _expected(states, h_min)
    p = sim.peak_fields()
    np.testing.assert_array_equal(p["h_max"], h_max)
    np.testing.assert_array_equal(np.isnan(p["speed_max"]), np.isnan(speed))
    np.testing.assert_allclose(p["speed_max"], speed, rtol=1e-13, atol=1e-300)
    np.testing.assert_array_equal(p["arrival_time"], arrival)
    assert np.isfinite(arrival).sum() > np.isfinite(_expected(states[:1], h_min)[2]).sum()
    with netCDF4.Dataset(tmp_path / "fields.nc") as ds:
        snaps = np.ma.filled(ds["h"][:], np.nan)
        assert snaps.shape[0] >= 3
        stored = np.ma.filled(ds["h_max"][:], np.nan)
        np.testing.assert_array_equal(stored, h_max)
        assert np.all(stored >= snaps.max(axis=0))
        np.testing.assert_array_equal(np.ma.filled(ds["arrival_time"][:], np.nan), arrival)
        assert float(ds["peak_time"][...]) == sim.scene.t_end
        assert ds["speed_max"].units == "m s-1" and ds["arrival_time"].units == "s"
        assert ("deposit_phi" in ds.variables) == sim.layout.segregation


def test_sparse_output_gives_the_arrival_of_dense_output(ti_cpu, tmp_path):
    """Output only at t_end and output every 0.005 s give the same peak fields (the steps are
    the same); and the first dense snapshot with h >= h_min lies within one output spacing
    (plus the step the arrival is resolved to) of arrival_time, on every cell reached."""
    spacing = 0.01
    runs = {}
    for label, interval in (("sparse", 0.2), ("dense", spacing)):
        sim = Simulation.from_scene("dam-break", {**DAM, "output.interval": interval})
        sim.run(out_dir=tmp_path / label, progress=False)
        runs[label] = sim
    a, b = runs["sparse"].peak_fields(), runs["dense"].peak_fields()
    for name in a:
        np.testing.assert_array_equal(a[name], b[name], err_msg=name)
    h_min = runs["dense"].scene.numerics.h_min
    with netCDF4.Dataset(tmp_path / "dense" / "fields.nc") as ds:
        t = ds["time"][:]
        h = ds["h"][:]
        assert len(t) == 21
    wet = h >= h_min
    first = np.where(wet.any(axis=0), t[np.argmax(wet, axis=0)], np.nan)
    dt_max = np.diff(read_diagnostics(tmp_path / "dense" / "diagnostics.csv")["time"]).max()
    arrival = b["arrival_time"]
    reached = np.isfinite(arrival)
    np.testing.assert_array_equal(reached, np.isfinite(first))
    assert np.all(np.abs(first[reached] - arrival[reached]) <= spacing + dt_max)


def test_dry_dam_break_arrival_follows_the_front(ti_cpu):
    """Onto the dry bed the arrival time grows downstream, and the wet front of every step
    state (the furthest cell with h >= h_min, x_f^+ of (6.10)) is exactly the furthest cell
    that arrival_time says was reached by then. The front runs at the speed of the h = h_min
    point of Ritter's solution, x0 + (2 c0 - 3 sqrt(g h_min)) t, within 5 % at 300 cells
    (films thinner than h_min flow in the split sweeps; when they did not, it ran at 0.76 of
    that speed at 150 to 600 cells), and below Ritter's tip 2 c0."""
    sim = Simulation.from_scene("dam-break", {**DAM, "domain.nx": 300})
    states = _record_steps(sim)
    sim.run(progress=False)
    sc = sim.scene
    x = sc.domain.cell_centres()[0]
    arrival = sim.peak_fields()["arrival_time"][0]
    ahead = x > sc.initial.x0
    reached = ahead & np.isfinite(arrival)
    assert reached.sum() > 20
    assert np.all(np.diff(arrival[reached]) >= 0)
    h_min = sc.numerics.h_min
    for t, f in states:
        front = x[f["h"][0] >= h_min].max()
        assert front == x[np.nan_to_num(arrival, nan=np.inf) <= t].max()
    late = reached & (arrival > 0.25 * sc.t_end)
    speed = np.polyfit(arrival[late], x[late], 1)[0]
    c0 = math.sqrt(sc.material.g * sc.initial.h_left)
    contour = 2 * c0 - 3 * math.sqrt(sc.material.g * h_min)
    assert abs(speed / contour - 1) < 0.05 and speed < 2 * c0, (speed, contour)


@pytest.mark.slow  # a long regression run: CI runs it in the slow set
def test_peak_fields_change_nothing_and_cost_nothing_when_off(ti_cpu, tmp_path, monkeypatch):
    """With peak fields on or off the steps and the final state are the same bits. Off, the
    simulation has no PeakFields (none is built: building one fails here), fields.nc and the
    checkpoint hold none, and asking for them is a one-line error. On, the kernel runs once
    per step and once for the initial state."""
    on = Simulation.from_scene("fingers", FINGERS)
    on.run(out_dir=tmp_path / "on", progress=False, t_end=0.05)
    assert on.peaks.launches == on.stats.steps + 1

    from tiseg.run import peaks

    def refuse(*args, **kwargs):
        raise AssertionError("a PeakFields was built with output.peak_fields = false")

    monkeypatch.setattr(peaks.PeakFields, "__init__", refuse)
    off = Simulation.from_scene("fingers", {**FINGERS, "output.peak_fields": False})
    assert off.peaks is None
    off.run(out_dir=tmp_path / "off", progress=False, t_end=0.05)
    np.testing.assert_array_equal(on.op.get(0), off.op.get(0))
    da = read_diagnostics(tmp_path / "on" / "diagnostics.csv")
    db = read_diagnostics(tmp_path / "off" / "diagnostics.csv")
    for col in ("time", "dt", "stages", "mass"):
        np.testing.assert_array_equal(da[col], db[col], err_msg=col)
    with netCDF4.Dataset(tmp_path / "off" / "fields.nc") as ds:
        assert not {"h_max", "speed_max", "arrival_time", "peak_time"} & set(ds.variables)
    ck = checkpoint.load(tmp_path / "off" / checkpoint.CHECKPOINT_NAME)
    assert not [k for k in ck if k.startswith("peak_")]
    with pytest.raises(InputError, match="peak_fields = false"):
        off.peak_fields()
    with pytest.raises(InputError, match="output.peak_fields"):
        on.set_parameters({"output.peak_fields": False})


@pytest.mark.parametrize(
    "scene, sets, cut",
    [
        ("dam-break", {**DAM, "output.interval": 0.05, "output.checkpoint_interval": 0.05}, 0.12),
        # the fingers' first wet step ends at 0.13 s (the ramped inflow admits nothing before)
        pytest.param("fingers", FINGERS, 0.18, marks=pytest.mark.slow),
    ],
)
def test_resume_continues_the_peak_fields_bit_for_bit(ti_cpu, tmp_path, scene, sets, cut):
    """A run stopped after its checkpoint past t = cut and resumed from it by a new
    Simulation ends with the fields.nc of the uninterrupted run, peak fields included, bit
    for bit; the checkpoint holds the peaks (without them every arrival time before the
    checkpoint would be lost)."""
    ref = Simulation.from_scene(scene, sets)
    ref.run(out_dir=tmp_path / "ref", progress=False)

    class Killed(Exception):
        pass

    def kill(sim):
        if sim.t > cut:
            raise Killed

    first = Simulation.from_scene(scene, sets)
    first.add_callback(Callback(kill, TimeInterval(0.05), name="kill", order=1000))
    with pytest.raises(Killed):
        first.run(out_dir=tmp_path / "cut", progress=False)
    ck = checkpoint.load(tmp_path / "cut" / checkpoint.CHECKPOINT_NAME)
    assert cut < ck["t"] < cut + 0.08
    assert ck["peak_arrival"].shape == (first.layout.nx, first.layout.ny)
    resumed = Simulation.resume(tmp_path / "cut")
    resumed.run(out_dir=tmp_path / "cut", progress=False)
    assert resumed.stats.steps == ref.stats.steps
    with netCDF4.Dataset(tmp_path / "ref" / "fields.nc") as A:
        with netCDF4.Dataset(tmp_path / "cut" / "fields.nc") as B:
            assert set(A.variables) == set(B.variables)
            for name in A.variables:
                np.testing.assert_array_equal(A[name][...], B[name][...], err_msg=name)
    early = resumed.peak_fields()["arrival_time"]
    assert np.nanmin(early) < ck["t"] < np.nanmax(early)


def test_deposit_is_the_material_at_rest_and_matches_the_analysis(ti_cpu, tmp_path):
    """A dam break with Coulomb friction comes to rest: deposit_h is the final h on the wet
    cells at rest, and the run-out, volume and largest thickness that `tiseg fingers`
    reports for it (a run without phi) are those of deposit_h."""
    from tiseg.post.analysis.fingers import analyse_run

    sim = Simulation.from_scene("dam-break", STOPPING)
    sim.run(out_dir=tmp_path, progress=False)
    f = sim.fields()
    dep = sim.peak_fields()["deposit_h"]
    wet = f["h"] >= sim.scene.numerics.h_min
    assert np.all(f["u"][wet] == 0.0)  # the projected friction stops cells exactly
    np.testing.assert_array_equal(np.isfinite(dep), wet)
    np.testing.assert_array_equal(dep[wet], f["h"][wet])
    res = analyse_run(tmp_path)
    d = res["deposit"]
    assert d["stopped"] and d["basis"] == "rest"
    x = sim.scene.domain.cell_centres()[0]
    assert d["run_out"] == pytest.approx(x[np.isfinite(dep[0])].max())
    assert d["volume"] == pytest.approx(np.nansum(dep) * sim.scene.dx)  # per metre (1D)
    assert d["thickness_max"] == pytest.approx(np.nanmax(dep))


def test_a_new_state_starts_the_peak_fields_again(ti_cpu):
    """set_state replaces the run's state: the peaks start from it at the current time (the
    mass balance does too), so nothing of the state before is left in them."""
    sim = Simulation.from_scene("dam-break", DAM)
    sim.advance(0.05)
    h = np.zeros((1, sim.layout.nx))
    h[0, 100:110] = 0.001
    sim.set_state(h)
    p = sim.peak_fields()
    np.testing.assert_array_equal(p["h_max"], h)
    np.testing.assert_array_equal(np.isfinite(p["arrival_time"]), h > 0)
    assert np.all(p["arrival_time"][h > 0] == sim.t)


def test_a_checkpoint_without_peak_fields_resumes_with_a_warning(ti_cpu, tmp_path, caplog):
    """A checkpoint that holds no peak fields (written by a tiseg that kept none) still
    resumes: the peaks start again from its state, and a warning says so."""
    sets = {**DAM, "output.interval": 0.05, "output.checkpoint_interval": 0.05}
    sim = Simulation.from_scene("dam-break", sets)

    class Killed(Exception):
        pass

    def kill(s):
        if s.t > 0.12:
            raise Killed

    sim.add_callback(Callback(kill, TimeInterval(0.05), name="kill", order=1000))
    with pytest.raises(Killed):
        sim.run(out_dir=tmp_path, progress=False)
    path = tmp_path / checkpoint.CHECKPOINT_NAME
    with np.load(path) as z:
        arrays = {k: z[k] for k in z.files if not k.startswith("peak_")}
    checkpoint.write_npz_atomic(path, arrays)
    resumed = Simulation.resume(tmp_path)
    assert "holds no peak fields" in caplog.text
    t = resumed.t
    arrival = resumed.peak_fields()["arrival_time"]
    assert np.nanmin(arrival) == t  # (the reservoir was wet from t = 0)


def test_a_truncated_fields_file_keeps_its_peak_fields(tmp_path):
    """Resuming trims records written after the checkpoint by copying the file: the 2D peak
    variables, their CF attributes and peak_time come along; NaN is stored as missing."""
    from tiseg.output.netcdf import STATIC_ATTRS, FieldsWriter, peak_variables

    x, y = np.arange(4) + 0.5, np.arange(3) + 0.5
    path = tmp_path / "fields.nc"
    names = peak_variables(segregation=False)
    assert "deposit_phi" not in names and "deposit_phi" in peak_variables(segregation=True)
    peaks = {n: np.full((3, 4), 1.0 + k) for k, n in enumerate(names)}
    peaks["arrival_time"][0, 0] = np.nan
    with FieldsWriter(path, x, y, fields=("h", "u"), static=names) as w:
        for t in (0.0, 1.0, 2.0):
            w.write(t, h=np.full((3, 4), t), u=np.zeros((3, 4)))
        w.write_static(2.0, **peaks)
    FieldsWriter.append(path, keep=2).close()
    with netCDF4.Dataset(path) as ds:
        assert ds.dimensions["time"].size == 2
        assert float(ds["peak_time"][...]) == 2.0
        for n in names:
            assert ds[n].dimensions == ("y", "x")
            assert ds[n].units == STATIC_ATTRS[n]["units"] and ds[n].coordinates == "peak_time"
            np.testing.assert_array_equal(np.ma.filled(ds[n][:], np.nan), peaks[n])
        assert ds["arrival_time"][:].mask[0, 0]


def test_the_deposit_uses_the_rest_speed_of_the_analysis():
    """deposit_h is at rest by the same rule as `tiseg fingers`' deposit, and fields.nc says
    which."""
    from tiseg.output.netcdf import STATIC_ATTRS
    from tiseg.post.analysis.deposit import DEFAULT_REST_SPEED
    from tiseg.run.peaks import REST_SPEED, deposit

    assert REST_SPEED == DEFAULT_REST_SPEED
    assert f"{REST_SPEED:.0e}" in STATIC_ATTRS["deposit_h"]["comment"]
    h = np.array([[0.0, 5e-5, 1e-3, 1e-3, 1e-3]])
    u = np.array([[0.0, 0.0, 0.0, 2e-6, 0.0]])
    v = np.array([[0.0, 0.0, 0.0, 0.0, -2e-6]])
    d = deposit({"h": h, "u": u, "v": v, "phi": np.full_like(h, 0.3)}, h_min=1e-4)
    np.testing.assert_array_equal(d["deposit_h"], [[np.nan, np.nan, 1e-3, np.nan, np.nan]])
    np.testing.assert_array_equal(d["deposit_phi"], [[np.nan, np.nan, 0.3, np.nan, np.nan]])
    assert "deposit_phi" not in deposit({"h": h, "u": u}, h_min=1e-4)
