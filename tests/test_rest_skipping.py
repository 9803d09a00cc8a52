"""Regions held at rest cost nothing: with the projected friction and a law with hysteresis,
columns whose cells the static friction holds, far from every moving cell, are left out of
the active x range (RestRules._quiescent, Simulation._set_active). For the same steps
that must change no bit, and a resumed run must skip what the run it continues skipped."""

from __future__ import annotations

import numpy as np
import pytest

from tiseg.run import checkpoint
from tiseg.setup.scene import load_scene
from tiseg.run.simulation import Simulation

# the finite release that comes to rest, on a coarse grid: 75 x 25 cells, at rest by ~60 s
DEPOSIT = {"domain.resolution": 50, "time.t_end": 120.0, "output.times": []}


def _deposit(**kw) -> Simulation:
    return Simulation(load_scene("finite-release-deposit", DEPOSIT), **kw)


# stage counts for the twin steps, in turn: rises by up to 7 within one plan (a step reaches
# 2 cells per stage, and the skipping's margin grows with the stages)
STAGES = (2, 5, 3, 9, 2, 7, 4, 8, 6)


def _twin_step(a: Simulation, b: Simulation, stages: int) -> None:
    """One step of both simulations with ``stages`` stages and the same dt, the smaller of the
    two they plan; each plans once, as a run does, which sets its active range."""
    pa, pb = a.plan(stages=stages), b.plan(stages=stages)
    dt = min(pa.dt, pb.dt)
    for sim in (a, b):
        sim.stepper.step(sim.op, sim.t, dt, stages)
        sim.t += dt


@pytest.mark.slow  # a long run: the slow set (README), which CI runs after the suite
def test_skipped_columns_get_the_bits_a_full_computation_gives(ti_cpu):
    """From the same state, steps of the same length and stage count with and without
    skipping give the same state bit for bit through the arrest of the rear of the deposit,
    while the skipping one leaves a good part of the deposit's columns out. (The step size and the stage count a run
    chooses follow the cells it computes, so the two runs themselves take different steps:
    see the next test.)"""
    skip, full = _deposit(), _deposit(skip_rest=False)
    assert skip.op.skip_rest and not full.op.skip_rest
    skip.advance(25.0)  # the rear has begun to stop (the inflow's stop: the next test)
    full.op.set(0, skip.op.get(0))
    full.op.reset_budget(skip.op.budget(0))
    full.t = skip.t
    narrowest, n = 1.0, 0
    while skip.t < 40.0:
        _twin_step(skip, full, STAGES[n % len(STAGES)])
        n += 1
        (a, b), (wa, wb) = skip.op.active, skip.op.wet_range
        narrowest = min(narrowest, (b - a) / (wb - wa))
    np.testing.assert_array_equal(skip.conserved(), full.conserved())
    np.testing.assert_array_equal(skip.op.budget(0), full.op.budget(0))
    assert np.any(skip.conserved()[1] != 0)  # still flowing at the front
    assert narrowest < 0.75, narrowest  # a good part of the deposit left out


@pytest.mark.slow  # a long regression run: CI runs it in the slow set
def test_a_deposit_at_rest_costs_nothing_until_something_wakes_it(ti_cpu):
    """The whole run with and without skipping: the same deposit up to the truncation error of
    the different steps they take, and once nothing moves (by ~65 s) the skipping run
    computes nothing and reaches each report in one step, where the full one keeps stepping.

    Then a second surge, the inflow opened again for 0.6 s from the same state in both: it
    runs into skipped columns, and when it stops the rest mask is cleared while columns are
    skipped; a range that then grows within a plan (more stages) must mark the cells it takes
    in again, or they count as moving and exchange mass (a review found that case). Last, a
    slope steeper than the start angle sets the whole deposit moving again."""
    skip, full = _deposit(), _deposit(skip_rest=False)
    for t in (20.0, 40.0, 60.0, 75.0, 90.0):
        n_skip, n_full = skip.stats.steps, full.stats.steps
        skip.advance(t)
        full.advance(t)
    qs, qf = skip.conserved(), full.conserved()
    assert not np.any(qs[1] != 0) and not np.any(qf[1] != 0)  # both at rest
    assert skip.op.active[0] == skip.op.active[1]  # nothing to compute
    assert skip.stats.steps - n_skip == 1 and full.stats.steps - n_full > 50
    # 3.7e-6 when written: the truncation error of the different steps
    assert np.abs(qs[0] - qf[0]).sum() <= 1e-4 * qf[0].sum(), np.abs(qs[0] - qf[0]).sum()

    full.op.set(0, skip.op.get(0))
    full.op.reset_budget(skip.op.budget(0))
    for sim in (skip, full):
        sim.set_parameters({"inflow.stop_time": 90.6})
    n, stopped = 0, False
    while skip.t < 91.6:
        # 2 stages while the surge runs, 9 in the first step after it stopped, then in turn
        if skip.t <= 90.6:
            stages = 2
        elif not stopped:
            stages, stopped = 9, True
        else:
            stages = STAGES[n % len(STAGES)]
        _twin_step(skip, full, stages)
        n += 1
    np.testing.assert_array_equal(skip.conserved(), full.conserved())
    np.testing.assert_array_equal(skip.op.budget(0), full.op.budget(0))

    skip.set_parameters({"material.zeta_deg": 40.0})
    skip.advance(91.8)
    q = skip.conserved()
    wet = q[0] >= skip.cfg.h_min
    # all of it slides downslope, but for a few films just over h_min at its edges
    assert np.mean(q[1][wet] != 0) > 0.97 and q[1][wet].sum() > 0


@pytest.mark.slow  # a long regression run: CI runs it in the slow set
def test_a_resumed_run_skips_what_the_run_it_continues_skipped(ti_cpu, tmp_path):
    """A checkpoint taken while the rear of the deposit is skipped keeps the rest mask and the
    ranges: the resumed run takes the same steps to the same bits."""
    ref = _deposit()
    ref.advance(25.0)
    a, b = ref.op.active
    assert b - a < ref.op.wet_range[1] - ref.op.wet_range[0]  # some columns are skipped
    path = checkpoint.save(tmp_path / "checkpoint.npz", ref)
    ck = checkpoint.load(path)
    assert ck["rest_mask"].shape == (ref.op.NX, ref.op.NY)
    n0 = ref.stats.steps
    ref.advance(30.0)

    again = _deposit()
    checkpoint.restore(again, ck)
    assert again.op.active == (a, b)
    again.advance(30.0)
    assert again.stats.steps - n0 == ref.stats.steps - n0
    np.testing.assert_array_equal(again.conserved(), ref.conserved())


def test_only_steppers_that_keep_rest_bitwise_skip(ti_cpu):
    """SSPRK(10,4) keeps a resting cell's h to round-off only (its mixing stage is not a
    limited combination), so skipping would not be exact: it skips nothing. Nor does a law
    without hysteresis, nor the regularised friction."""
    assert _deposit().op.skip_rest
    for over in (
        {"numerics.stepper": "ssprk10_4"},
        {"effects.friction": "pouliquen-mixture"},
        {"numerics.friction_scheme": "regularised", "numerics.stepper": "ssprk3"},
    ):
        sc = load_scene("finite-release-deposit", {**DEPOSIT, **over})
        assert not Simulation(sc).op.skip_rest, over
