"""Fronts arrive on time: moving fronts with and without friction against exact solutions
(tiseg.model.exact_friction, tiseg.model.exact_dambreak), for the split sweeps (the scenes'
default) and the unsplit RKC scheme, at the default h_min.

What could fail: a friction impulse that acts on more mass than the gravity of the same step
(the split sweeps' front lagged 8 m in 97 m), and films thinner than h_min that neither move
nor pass their mass on (every front ran a quarter slow at h_min / h0 = 1/30)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tiseg.model.exact_dambreak import cell_averages
from tiseg.model.exact_friction import (
    ParabolicCap,
    coulomb_dam_break,
    dam_break_arrival,
    dam_break_contour,
    sliding_layer,
    stopping_time,
)
from tiseg.post.problems import load_problem
from tiseg.run.simulation import Simulation
from tiseg.setup.scene import load_scene

RKC = {"stepper": "rkc", "cfl": 0.5}  # the unsplit scheme at its positivity cfl (1D)
ZETA, DELTA = math.radians(22.0), math.radians(21.0)


def _x(sim) -> np.ndarray:
    return np.asarray(sim.scene.domain.cell_centres()[0], dtype=float).ravel()


def _contour(h, x, level) -> float:
    """Where h falls through ``level`` downslope of its last cell above it, interpolated
    linearly between cell centres."""
    k = int(np.nonzero(h >= level)[0].max())
    if k + 1 >= len(h):
        return float(x[k])
    return float(x[k] + (x[k + 1] - x[k]) * (h[k] - level) / (h[k] - h[k + 1]))


def _tail(h, x, level) -> float:
    """Where h first falls below ``level`` from the left (the rarefaction's tail)."""
    k = int(np.nonzero(h < level)[0].min())
    return float(x[k - 1] + (x[k] - x[k - 1]) * (h[k - 1] - level) / (h[k - 1] - h[k]))


# ---------------------------------------------------------------------- the exact solutions
def test_the_closed_forms_satisfy_the_equations():
    """Independent of the solver: finite differences of the closed forms satisfy mass and
    momentum of (6.1)-(6.4) with Coulomb friction (h_t + (hu)_x = 0 and
    u_t + u u_x + g cos(zeta) h_x = m) at points inside the fan and the cap."""
    g = 9.81
    e = 1e-6
    m = g * math.cos(ZETA) * (math.tan(ZETA) - math.tan(DELTA))
    gc = g * math.cos(ZETA)

    def residuals(f, x, t, gc):
        h, u = f(x, t)
        ht = (f(x, t + e)[0] - f(x, t - e)[0]) / (2 * e)
        ut = (f(x, t + e)[1] - f(x, t - e)[1]) / (2 * e)
        hx = (f(x + e, t)[0] - f(x - e, t)[0]) / (2 * e)
        ux = (f(x + e, t)[1] - f(x - e, t)[1]) / (2 * e)
        return ht + h * ux + u * hx, ut + u * ux + gc * hx

    def dam(x, t):
        return coulomb_dam_break(x, t, 1.0, ZETA, DELTA, 60.0)

    xs = np.linspace(
        dam_break_contour(0.9, 10.0, 1.0, ZETA, DELTA, 60.0),
        dam_break_contour(0.01, 10.0, 1.0, ZETA, DELTA, 60.0),
        7,
    )
    mass, mom = residuals(dam, xs, 10.0, gc)
    assert np.abs(mass).max() < 1e-6 and np.abs(mom - m).max() < 1e-5
    cap = ParabolicCap(0.1, 0.05, 0.002, 0.4, math.radians(27), math.radians(20))
    m_cap = cap.m
    xs = np.linspace(*cap.margins(0.1), 9)[1:-1]
    mass, mom = residuals(cap, xs, 0.1, g * math.cos(cap.zeta))
    assert np.abs(mass).max() < 1e-8 and np.abs(mom - m_cap).max() < 1e-5
    # the cap of NUMERICS.md T4b at 0.2 s: a = 62.89 mm, x_c = 205.45 mm, h_c = 1.590 mm
    a, _ = cap.half_width(0.2)
    assert abs(a - 0.06289) < 1e-5 and abs(sum(cap.margins(0.2)) / 2 - 0.20545) < 1e-5
    # the arrival time inverts the contour
    t = dam_break_arrival(110.0, 0.01, 1.0, ZETA, DELTA, 60.0)
    assert abs(dam_break_contour(0.01, t, 1.0, ZETA, DELTA, 60.0) - 110.0) < 1e-9


# ---------------------------------------------------------------------- the dam break
def _mangeney(nx, numerics=None):
    """(h, x, relative L1 error of h) of the Mangeney problem at nx cells, t = 15 s."""
    sim = Simulation(load_problem("mangeney").build(nx, numerics))
    sim.advance(15.0)
    h = sim.fields()["h"][0]
    x = _x(sim)
    he = cell_averages(
        lambda p: coulomb_dam_break(p, 15.0, 1.0, ZETA, DELTA, 60.0)[0], x, sim.scene.dx
    )
    return h, x, float(np.abs(h - he).sum() / he.sum())


@pytest.mark.parametrize("stepper", ["hancock", "rkc"])
def test_coulomb_dam_break_front_and_tail_on_time(ti_cpu, stepper):
    """Mangeney et al. (2000) at 1000 cells on 200 m, t = 15 s: the 1 cm front within 1 m of
    the exact one 97 m below the dam with the split sweeps (8.2 m behind before their
    friction acted on the thickness their gravity did) and 1.5 m with RKC, the tail (99 % of
    h0) within 1 m, and the split sweeps' L1 error no worse than 1.5x the unsplit scheme's."""
    h, x, l1 = _mangeney(1000, RKC if stepper == "rkc" else None)
    front = _contour(h, x, 0.01)
    exact = dam_break_contour(0.01, 15.0, 1.0, ZETA, DELTA, 60.0)
    assert abs(front - exact) < (1.0 if stepper == "hancock" else 1.5), (front, exact)
    tail = _tail(h, x, 0.99)
    assert abs(tail - dam_break_contour(0.99, 15.0, 1.0, ZETA, DELTA, 60.0)) < 1.0, tail
    if stepper == "hancock":
        _, _, l1_rkc = _mangeney(1000, RKC)
        assert l1 <= 1.5 * l1_rkc, (l1, l1_rkc)


@pytest.mark.slow  # a long run: the slow set (README), which CI runs after the suite
def test_coulomb_dam_break_converges_at_first_order(ti_cpu):
    """The split sweeps' L1 error of h falls at order >= 0.85 from 250 to 1000 cells (it
    stalled at order 0.3 while thin films could not move)."""
    errs = [_mangeney(n)[2] for n in (250, 500, 1000)]
    orders = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert orders.min() > 0.85, (errs, orders)


@pytest.mark.slow  # a long run: the slow set (README), which CI runs after the suite
def test_arrival_at_a_gauge_on_time(ti_cpu):
    """The flow reaches h = 1 cm at a gauge 50 m below the dam within 1 % of the exact time
    (each step's thickness there, interpolated in time), and the arrival_time peak field
    (h >= h_min) converges to the exact arrival of h_min: its error falls with the grid."""
    sc = load_problem("mangeney").build(1000)
    sim = Simulation(sc)
    x = _x(sim)
    k = int(np.argmin(np.abs(x - 110.0)))
    t0, h0, arrived = 0.0, 0.0, None
    while arrived is None and sim.t < 12.0:
        sim.step()
        h = sim.fields()["h"][0][k]
        if h >= 0.01:
            arrived = t0 + (0.01 - h0) / (h - h0) * (sim.t - t0)
        t0, h0 = sim.t, h
    exact = dam_break_arrival(x[k], 0.01, 1.0, ZETA, DELTA, 60.0)
    assert abs(arrived / exact - 1) < 0.01, (arrived, exact)
    errors = []
    for nx in (500, 1000):
        sim = Simulation(load_problem("mangeney").build(nx))
        sim.advance(9.0)
        x = _x(sim)
        k = int(np.argmin(np.abs(x - 110.0)))
        got = sim.peak_fields()["arrival_time"][0][k]
        hmin = sim.scene.numerics.h_min
        errors.append(abs(got / dam_break_arrival(x[k], hmin, 1.0, ZETA, DELTA, 60.0) - 1))
    assert errors[1] < 0.7 * errors[0] and errors[1] < 0.06, errors


# ---------------------------------------------------------------------- thin fronts
def _ritter(nx, **over):
    """The 3 mm frictionless dam break onto a dry bed (h_min = 1e-4 m = h0 / 30) at 0.25 s:
    (position of the last cell with h >= h_min, its exact position)."""
    o = {"domain.nx": nx, "initial.h_left": 0.003, "initial.x0": 0.1, "time.t_end": 0.25}
    o.update({f"numerics.{k}": v for k, v in over.items()})
    sim = Simulation(load_scene("dam-break", o))
    sim.advance(0.25)
    h = sim.fields()["h"][0]
    x = _x(sim)
    hmin = sim.scene.numerics.h_min
    k = int(np.nonzero(h >= hmin)[0].max())
    c0 = math.sqrt(9.81 * 0.003)
    return x[k] + 0.5 * sim.scene.dx, 0.1 + (2 * c0 - 3 * math.sqrt(9.81 * hmin)) * 0.25


def test_a_thin_front_runs_at_the_exact_speed(ti_cpu):
    """Ritter at 600 cells on 0.3 m with the split sweeps: the h >= h_min front within 3 % of
    the exact h = h_min point's distance from the dam (it was 23 % behind, the lag growing
    with time, while films thinner than h_min could neither move nor pass their mass on),
    and within 1.5 % at 1200 cells. (The unsplit scheme keeps the paper's cut-off:
    Physics.acts.)"""
    for nx, tol in ((600, 0.03), (1200, 0.015)):
        got, exact = _ritter(nx)
        assert abs(got - exact) / (exact - 0.1) < tol, (nx, got, exact)


def test_a_thin_front_on_a_slope_runs_at_the_exact_speed(ti_cpu):
    """The same 3 mm dam break on a 22 degree slope with Coulomb friction tan 21 degrees, with
    the split sweeps at 600 cells: the h >= h_min front within 3 % of the exact h = h_min
    point's distance from the dam at 0.25 s (Mangeney's solution)."""
    mu = math.tan(DELTA)
    over = {"material.zeta_deg": 22.0, "effects.friction": "coulomb", "effects.coulomb_mu": mu}
    sim = Simulation(
        load_scene(
            "dam-break",
            {"domain.nx": 600, "initial.h_left": 0.003, "initial.x0": 0.1, **over},
        )
    )
    sim.advance(0.25)
    h, x = sim.fields()["h"][0], _x(sim)
    hmin = sim.scene.numerics.h_min
    got = x[np.nonzero(h >= hmin)[0].max()] + 0.5 * sim.scene.dx
    exact = dam_break_contour(hmin / 0.003, 0.25, 0.003, ZETA, DELTA, 0.1)
    assert abs(got - exact) / (exact - 0.1) < 0.03, (got, exact)


def test_the_parabolic_cap_keeps_both_margins_on_time(ti_cpu):
    """Savage & Hutter's cap with the split sweeps: the L1 error of h falls at order >= 1
    from 250 to 1000 cells, and at 1000 cells the h >= h_min extent lies within two cells of
    the exact h = h_min points at the advancing front and at the receding rear. (The unsplit
    scheme keeps the paper's cut-off, under which the receding rear stalls: its L1 error is
    31 % at every grid, docs/verification.md, "Fronts".)"""
    p = load_problem("parabolic-cap")
    cap = ParabolicCap(0.1, 0.05, 0.002, 0.4, math.radians(27), math.radians(20))
    errs = []
    for nx in (250, 1000):
        sc = p.build(nx)
        sim = Simulation(sc)
        raw = p.run(sim)
        errs.append(p.score(raw, sc)[1])
    assert math.log2(errs[0] / errs[1]) / 2 >= 1.0, errs
    h, x = raw["h"], _x(sim)
    hmin = sim.scene.numerics.h_min
    wet = np.nonzero(h >= hmin)[0]
    a, _ = cap.half_width(0.2)
    xc = sum(cap.margins(0.2)) / 2
    s = math.sqrt(1 - hmin * a / (0.002 * 0.05))  # h = h_min inside the cap
    dx = sim.scene.dx
    assert abs(x[wet.min()] - 0.5 * dx - (xc - s * a)) < 2 * dx
    assert abs(x[wet.max()] + 0.5 * dx - (xc + s * a)) < 2 * dx


# ---------------------------------------------------------------------- coming to rest
@pytest.mark.parametrize("stepper", ["hancock", "rkc"])
def test_a_sliding_layer_stops_at_the_exact_time_and_stays(ti_cpu, stepper):
    """A uniform layer sliding at 0.5 m/s on a slope its friction holds: u = u0 + m t to
    round-off while it slides, u = 0 exactly from the step that crosses t* = 0.53 s on, and
    every bit of the state unchanged after that."""
    p = load_problem("sliding-layer")
    sc = p.build(20, RKC if stepper == "rkc" else None)
    sim = Simulation(sc)
    ts = stopping_time(0.5, math.radians(20), math.atan(0.46630765815499858))
    zeta, delta = math.radians(20), math.atan(0.46630765815499858)
    while sim.t < 0.8 * ts:
        sim.step()
        u = sim.fields()["u"][0]
        assert np.allclose(u, sliding_layer(sim.t, 0.5, zeta, delta)[0], rtol=0, atol=1e-12)
    t_before = sim.t
    while sim.t < ts:
        t_before = sim.t
        sim.step()
    assert t_before < ts <= sim.t and np.all(sim.fields()["u"] == 0.0)
    frozen = sim.conserved().copy()
    for _ in range(10):
        sim.step()
    assert np.array_equal(sim.conserved(), frozen)
