"""Determinism: the same scene, backend, precision and thread count give bitwise identical
output, and so do different thread counts.

Why it holds: every floating-point reduction of the solver runs in a fixed order (the mass
totals sum rows in parallel but each row serially and then the rows serially; the boundary
budget is a serial loop), and the only atomics are max/min (wave speeds, stiffness, the wet
range) and integer counts (the guard), which do not depend on the order of the threads. So
the result cannot depend on how Taichi splits the loops among threads.

Each run is its own process (`python -m tiseg.apps.cli run ... --threads N`, i.e.
``tiseg.init(threads=N)`` -> Taichi's ``cpu_max_num_threads``); the runs are started together
so that they share the machine's cores. Grids this small run their loops on one thread
(tiseg.solver.numerics.operator.SERIAL_CELLS), so the last test compares those serial loops with the
same kernels' parallel loops directly.
"""

from __future__ import annotations

import subprocess
import sys

import netCDF4
import numpy as np
import pytest

from tiseg.output import read_diagnostics

# 2D fingers set-up, 36 x 12 cells: inflow, active x range, segregation with feedback,
# viscosity, WENO, RKC, output every 0.1 s.
SETS = [
    "domain.resolution=60",
    "domain.Lx=0.6",
    "domain.Ly=0.2",
    "time.t_end=1.2",
    "output.times=[]",
    "output.interval=0.15",
]
RUNS = {
    "f64-2a": ("f64", 2),
    "f64-2b": ("f64", 2),
    "f64-1": ("f64", 1),
    "f32-2": ("f32", 2),
    "f32-1": ("f32", 1),
}


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    root = tmp_path_factory.mktemp("determinism")
    procs = {}
    for name, (precision, threads) in RUNS.items():
        cmd = [
            sys.executable,
            "-m",
            "tiseg.apps.cli",
            "run",
            "fingers",
            "--out",
            str(root / name),
            "--no-progress",
            "--precision",
            precision,
            "--threads",
            str(threads),
        ]
        for s in SETS:
            cmd += ["--set", s]
        procs[name] = subprocess.Popen(
            cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
        )
    for name, proc in procs.items():
        out, err = proc.communicate(timeout=900)
        assert proc.returncode == 0, f"{name}: {err}"
    return root


def _read(run_dir):
    with netCDF4.Dataset(run_dir / "fields.nc") as nc:
        fields = {name: np.asarray(nc[name][:]) for name in nc.variables}
        attrs = {k: nc.getncattr(k) for k in nc.ncattrs() if k != "history"}
    diag = read_diagnostics(run_dir / "diagnostics.csv")
    diag.pop("wall_time")
    diag.pop("wall_time_cumulative")
    return fields, attrs, diag


def _assert_identical(a, b) -> None:
    fa, aa, da = a
    fb, ab, db = b
    assert fa.keys() == fb.keys() and da.keys() == db.keys()
    for name in fa:
        assert fa[name].dtype == fb[name].dtype
        np.testing.assert_array_equal(fa[name], fb[name], err_msg=name)  # bitwise
    for name in da:
        np.testing.assert_array_equal(da[name], db[name], err_msg=name)
    assert aa == ab


@pytest.mark.slow  # a long run: the slow set (README), which CI runs after the suite
def test_same_settings_give_identical_output(runs):
    """Two runs with 2 threads (f64): fields and diagnostics (all but wall time) identical."""
    a, b = _read(runs / "f64-2a"), _read(runs / "f64-2b")
    assert a[0]["time"].size == 9 and a[2]["time"].size > 12
    _assert_identical(a, b)


@pytest.mark.parametrize("precision", ["f64", "f32"])
def test_thread_count_does_not_change_the_result(runs, precision):
    """1 thread against 2 threads: identical in f64 and in f32 (fixed-order sums, order-free
    max/min atomics)."""
    two = f"{precision}-2" + ("a" if precision == "f64" else "")
    one, two = _read(runs / f"{precision}-1"), _read(runs / two)
    assert one[0]["h"].dtype == (np.float64 if precision == "f64" else np.float32)
    _assert_identical(one, two)


def test_in_process_run_matches_the_subprocess(runs, ti_cpu, tmp_path):
    """The same scene run here (Taichi's default thread count, f64) gives the same bits too."""
    from tiseg.apps.cli import main

    args = ["run", "fingers", "--out", str(tmp_path / "here"), "--no-progress"]
    for s in SETS:
        args += ["--set", s]
    assert main(args) == 0
    _assert_identical(_read(tmp_path / "here"), _read(runs / "f64-2a"))


@pytest.mark.slow  # a long run: the slow set (README), which CI runs after the suite
@pytest.mark.parametrize("rec", ["weno", "minmod"])
def test_serial_and_parallel_loops_give_the_same_bits(ti_cpu, rec):
    """Small grids run their loops on one thread (operator.SERIAL_CELLS): the same kernels
    with parallel loops must give bitwise the same rates, stability numbers, wet range,
    totals and steps, on a 2D wet/dry state with every effect on and an inflow."""
    from solver_helpers import make_config, random_state
    from tiseg.solver.numerics.operator import TaichiOperator
    from tiseg.solver.timestepping import make_stepper

    rng = np.random.default_rng(7)
    cfg = make_config(40, 11, reconstruction=rec, bc=("inflow", "outflow", "wall", "periodic"))
    q = random_state(cfg.layout, rng, wet_dry=True)
    out = {}
    for serial in (True, False):
        op = TaichiOperator(cfg, nslots=5, serial=serial)
        assert op.force_serial is serial and op.serial_loops() is serial
        op.set(0, q)
        op.set_active(op.gx + 3, op.gx + 30)
        op.rhs(0, 1, 0.05)
        rates = op.get(1)
        stab = op.stability(0, 0.05)
        wet = op.wet_extent(0, 0.05)
        sums = op.sums(0)
        stepper = make_stepper("rkc")
        for k in range(3):
            stepper.step(op, 0.05 + k * 1e-4, 1e-4, 4)
        out[serial] = (rates, stab, wet, sums, op.get(0), op.budget(0))
    a, b = out[True], out[False]
    assert np.array_equal(a[0], b[0])
    assert a[1] == b[1] and a[2] == b[2] and a[3] == b[3]
    assert np.array_equal(a[4], b[4]) and np.array_equal(a[5], b[5])
    assert np.abs(a[0]).max() > 0 and a[2][1] >= a[2][0]  # the state really moves


@pytest.mark.parametrize("pieces", [1, 3, 4])
def test_reductions_over_pieces_of_rows_see_every_cell(ti_cpu, monkeypatch, pieces):
    """The stability and wet-extent passes cut each row into pieces along y (so that Taichi's
    CPU threads each get a share of a loop over a few hundred rows): one wet, moving cell
    anywhere in the interior, in any piece, must set the wave speed and the wet range alone,
    with serial and parallel loops."""
    from solver_helpers import make_config
    import tiseg.solver.numerics.operator as operator_module
    import tiseg.solver.numerics.state as state_module

    # (the operator's state decides the pieces: OperatorState.row_pieces)
    monkeypatch.setattr(state_module, "row_pieces", lambda *a: pieces)
    cfg = make_config(12, 11, segregation=False, bc=("outflow", "outflow", "wall", "wall"))
    lay = cfg.layout
    for serial in (True, False):
        op = operator_module.TaichiOperator(cfg, nslots=2, serial=serial)
        assert op.row_pieces == pieces
        for j in range(lay.gy, lay.gy + lay.ny):
            i = lay.gx + 5
            q = np.zeros((lay.nc, lay.NX, lay.NY))
            h, u = 0.003, 0.1 + 0.01 * j  # a different speed in every row
            q[0, i, j] = h
            q[1, i, j] = h * u
            op.set(0, q)
            op.set_active(lay.gx, lay.gx + lay.nx)
            assert op.wet_extent(0, 0.0)[:2] == (i, i)
            stab = op.stability(0, 0.0)
            assert stab.max_speed == pytest.approx(u, rel=1e-12)


@pytest.mark.parametrize("threads", [2, 4, 16])
@pytest.mark.parametrize("ny", [60, 250, 1000])
def test_row_pieces_give_every_thread_a_share(threads, ny):
    """Taichi's CPU backend deals a parallel loop out in chunks of at least 512 iterations:
    the smallest x range whose loops run in parallel (SERIAL_CELLS cells) must still hold
    512 iterations per thread once its rows are cut into pieces (or pieces of 4 cells)."""
    from types import SimpleNamespace

    from tiseg.solver.numerics.ranges import SERIAL_CELLS, row_pieces

    lay = SimpleNamespace(is_1d=False, ny=ny, NY=ny + 4)
    p = row_pieces(lay, threads, True)
    rows = SERIAL_CELLS // lay.NY
    assert rows * p >= 512 * threads or ny // p == 4
    assert 1 <= p <= ny // 4
    assert row_pieces(lay, threads, False) == ny // 8  # a GPU: 8 cells a piece
