"""Friction as a projection (numerics.friction_scheme = "projected", issue 15 part 2).

The friction leaves the explicit stages and acts after each stage's limiter: momentum shrinks
by the friction impulse tau g cos(zeta) mu_b h along itself, and a cell stops exactly where
that impulse can cancel it. Checked here against exact answers: a layer sliding on a slope
gentler than its friction stops at t = u0 / (g cos(zeta) (mu - tan(zeta))) and then stays at
rest bit for bit; a released block stops in finite time and stays at rest; and the Taichi
projection and rates equal their NumPy twins. The Coulomb dam break with RKC, which the
regularised friction fails, is in tests/test_hard_cases.py.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from solver_helpers import (
    OPEN,
    PERIODIC,
    coulomb_scene,
    make_config,
    projected_stage_equals_reference,
    random_state,
    rates_equal_reference,
    table1_friction,
)
from tiseg.run.simulation import Simulation

G = 9.81


# ------------------------------------------------------------------- twins of the NumPy reference
@pytest.mark.parametrize(
    "effects",
    [
        dict(segregation=True, friction="pouliquen-mixture", feedback=True),
        dict(segregation=False, friction="coulomb"),
        dict(segregation=True, friction="pouliquen-small", feedback=False),
    ],
)
def test_projection_and_rates_equal_the_numpy_twin(ti_cpu, effects):
    """A limited combination with tau equals the reference limiter + project_friction; the rates
    (no friction in the source, no mass across faces between cells at rest) equal the
    reference's. Half the cells are at rest, some so slow that they stop, so both branches of
    the projection and the rest faces are exercised."""

    rng = np.random.default_rng(7)
    seg = effects.pop("segregation")
    cfg = make_config(
        12,
        8,
        segregation=seg,
        reconstruction="minmod",
        bc=("periodic",) * 4,
        friction_scheme="projected",
        **effects,
    )
    lay = cfg.layout
    q = random_state(lay, rng, wet_dry=True)
    rest = rng.random((lay.NX, lay.NY)) < 0.5
    slow = rng.random((lay.NX, lay.NY)) < 0.2
    for c in (lay.HU, lay.HV):
        q[c] = np.where(rest, 0.0, np.where(slow, 1e-4 * q[lay.H], q[c]))
    op, ref, r_ti = rates_equal_reference(cfg, q)
    ix, iy = lay.interior()
    # the h rate vanishes wherever a cell and its four neighbours are at rest
    still = rest[1:-1, 1:-1] & rest[:-2, 1:-1] & rest[2:, 1:-1] & rest[1:-1, :-2] & rest[1:-1, 2:]
    assert still.any() and np.all(r_ti[lay.H, 1:-1, 1:-1][still] == 0.0)
    # one Euler stage with the projection, over a tau long enough that the slow cells stop
    # whatever their neighbours push into them
    a = projected_stage_equals_reference(op, ref, q, r_ti, 2e-3, 5e-2)
    stopped = (a[lay.HU][ix, iy] == 0) & (a[lay.H][ix, iy] >= cfg.h_min)
    moving = (a[lay.HU][ix, iy] != 0) & (a[lay.H][ix, iy] >= cfg.h_min)
    assert stopped.sum() >= 3 and moving.sum() >= 3


# ------------------------------------------------------------------------- exact answers, 1D
@pytest.mark.parametrize("stepper", ["rkc", "ssprk3", "ssprk4_2", "euler"])
def test_sliding_layer_stops_at_the_exact_time_and_stays_at_rest(ti_cpu, stepper):
    """A uniform layer sliding at u0 on a periodic slope with tan(zeta) < mu decelerates at
    g cos(zeta) (mu - tan(zeta)) and stops at t_stop = u0 / that; from then on every step
    leaves the state bit for bit unchanged."""
    zeta, mu, u0 = 20.0, 0.5, 0.3
    sc = coulomb_scene(
        zeta,
        mu,
        {"kind": "release", "x0": 0.0, "x1": 0.1, "h": 0.002},
        PERIODIC,
        stepper,
        nx=16,
        Lx=0.1,
        t_end=1.0,
        friction_scheme="projected",
    )
    sim = Simulation(sc, check_every=1)
    q = sim.op.get(0)
    q[0] = 0.002  # uniform, ghost cells included: no edge whose pressure could move it
    q[1] = u0 * q[0]
    sim.op.set(0, q)
    dec = G * math.cos(math.radians(zeta)) * (mu - math.tan(math.radians(zeta)))
    t_stop = u0 / dec
    for t in (0.25 * t_stop, 0.5 * t_stop, 0.9 * t_stop):
        sim.advance(t)
        u = sim.fields()["u"]
        assert np.allclose(u, u0 - dec * t, rtol=1e-10), (t, u.mean(), u0 - dec * t)
    sim.advance(1.05 * t_stop)
    assert np.all(sim.fields()["u"] == 0.0)
    before = sim.conserved()  # interior cells
    steps = sim.stats.steps
    sim.advance(1.05 * t_stop + 0.2)
    assert sim.stats.steps > steps + 3
    assert np.array_equal(sim.conserved(), before)


@pytest.mark.parametrize("stepper", ["rkc", "ssprk4_2"])
def test_released_block_comes_to_rest_and_stays_there(ti_cpu, stepper):
    """A block released at rest on a 20 deg slope with mu = tan 30 deg spreads at its steep ends
    (the pressure beats the friction there), stops in finite time with every cell at u = 0,
    and then stays exactly at rest; mass is conserved throughout and h >= 0."""
    sc = coulomb_scene(
        20.0,
        math.tan(math.radians(30.0)),
        {"kind": "release", "x0": 0.08, "x1": 0.12, "h": 0.004},
        OPEN,
        stepper,
        nx=200,
        Lx=0.2,
        t_end=1.0,
        friction_scheme="projected",
    )
    sim = Simulation(sc, check_every=1)
    m0 = sim.totals()["mass"]
    t, stopped_at = 0.0, None
    while t < 1.0 and stopped_at is None:
        t += 0.02
        sim.advance(t)
        if np.all(sim.fields()["u"] == 0.0):
            stopped_at = t
    assert stopped_at is not None and stopped_at < 0.5, "the block never came to rest"
    h = sim.fields()["h"]
    x, _ = sc.domain.cell_centres()
    wet = h[0] >= 1e-2 * 0.004
    assert 0.04 < x[wet].max() - x[wet].min() < 0.2  # it spread, and not for ever
    assert h.min() >= 0.0
    assert abs(sim.totals()["mass"] - m0) <= 1e-13 * m0
    before = sim.conserved()
    steps = sim.stats.steps
    sim.advance(stopped_at + 0.3)
    assert sim.stats.steps > steps + 3
    assert np.array_equal(sim.conserved(), before)


# ------------------------------------------------- a mover flowing into a cell at rest or slow
@pytest.mark.parametrize("axis", [0, 1])
@pytest.mark.parametrize("sign", [1.0, -1.0])
@pytest.mark.parametrize("slow", [0.0, 1e-3])
def test_a_film_flowing_into_a_resting_or_slow_cell_feeds_it(ti_cpu, axis, sign, slow):
    """Where a moving cell flows into a neighbour that does not move against it, at least
    f_u - f_d^2 / f_u of mass crosses (f_u the mover's own flux h u_n, f_d the neighbour's).
    Here a 1 mm layer at 0.05 m/s flows into a 2 mm layer at rest or creeping the same way at
    1e-3 m/s (piecewise constant, so the minmod edges are the cells). The central flux,
    (f_u + f_d)/2 - a/2 (2 - 1) mm < 0, drew mass out of the thicker layer against the flow;
    now the fed cell gains (f_u - f_d^2 / f_u - f_d) / dx exactly, f_u / dx into a cell at
    rest. A face between two resting cells carries no mass, faces inside either layer carry
    its own flux, and the face the movers leave keeps the central flux. Taichi equals the
    NumPy reference."""
    cfg = make_config(
        8 if axis == 0 else 4,
        4 if axis == 0 else 8,
        segregation=True,
        reconstruction="minmod",
        viscous=False,
        bc=("periodic",) * 4,
        friction_scheme="projected",
        friction="coulomb",
        fric=table1_friction(coulomb_mu=0.6),
    )
    lay = cfg.layout
    ix, iy = lay.interior()
    k = np.arange(8)
    mover = (k < 4) if sign > 0 else (k >= 4)  # the movers flow towards the other half
    h = np.where(mover, 1e-3, 2e-3)
    shape = (8, 1) if axis == 0 else (1, 8)
    q = np.zeros((lay.nc, lay.NX, lay.NY))
    q[lay.H][ix, iy] = h.reshape(shape)
    speed = sign * np.where(mover, 0.05, slow)
    q[lay.HU if axis == 0 else lay.HV][ix, iy] = (h * speed).reshape(shape)
    q[lay.HPHI][ix, iy] = 0.5 * q[lay.H][ix, iy]
    _, _, r = rates_equal_reference(cfg, q)  # fills the periodic ghosts itself
    rate = r[lay.H][ix, iy][:, 0] if axis == 0 else r[lay.H][ix, iy][0, :]
    d = cfg.dx if axis == 0 else cfg.dy
    fu, fd = 1e-3 * 0.05, 2e-3 * slow
    fed, feeder = (4, 3) if sign > 0 else (3, 4)
    assert rate[fed] == pytest.approx((fu - fd * fd / fu - fd) / d, rel=1e-12)
    assert rate[feeder] == pytest.approx(fd * fd / fu / d, rel=1e-9, abs=1e-12 * fu / d)
    inside = [1, 2, 5, 6]  # within the movers or the other layer
    assert np.all(np.abs(rate[inside]) <= 1e-12 * fu / d)
    if slow == 0.0:  # faces between two cells at rest carry no mass at all
        assert np.all(rate[[1, 2] if sign < 0 else [5, 6]] == 0.0)
    # across the periodic face the movers leave the other layer: the central flux draws mass
    # out of it, as before
    assert rate[7 if sign > 0 else 0] < 0.0


# ------------------------------------------------- a face wet at the step's start, all its stages
@pytest.mark.parametrize("axis", [0, 1])
def test_a_face_wet_at_the_step_start_keeps_its_flux_through_the_step(ti_cpu, axis):
    """A film just above h_min flows into a dry cell at the step's start; at a later stage of
    the step it has thinned below h_min and the dry cell holds a trace. Their face still
    carries mass in that stage: switched off mid-step, the face's flux lived on in the step's
    first rate alone, which RKC's last stage weighs negatively, and the fed cell went below
    zero (the clip then made mass: the levees scene at 150 cells/m). The Taichi stage rate
    equals the NumPy reference's given the step's initial state, and the fed cell gains mass;
    the next step, from a state whose cells are all below h_min, moves none."""
    from tiseg.solver.numerics.operator import TaichiOperator
    from tiseg.solver.reference import ReferenceOperator

    cfg = make_config(
        6 if axis == 0 else 4,
        4 if axis == 0 else 6,
        segregation=False,
        reconstruction="weno",
        bc=("periodic",) * 4,
        friction_scheme="projected",
        friction="pouliquen-extended",
    )
    lay = cfg.layout
    g = lay.gx
    normal = lay.HU if axis == 0 else lay.HV
    film, fed = ((g + 2, g + 1), (g + 3, g + 1)) if axis == 0 else ((g + 1, g + 2), (g + 1, g + 3))
    start = np.zeros((lay.nc, lay.NX, lay.NY))
    start[lay.H][film] = 1.05 * cfg.h_min
    start[normal][film] = 1e-3 * start[lay.H][film]  # towards the dry cell
    later = np.zeros_like(start)
    later[lay.H][film] = 0.95 * cfg.h_min  # the limiter took its momentum below h_min
    later[lay.H][fed] = 1e-7
    op = TaichiOperator(cfg, nslots=4)
    op.set(0, start)
    op.rhs(0, 1, 0.0)  # the step's first evaluation: the step's wet cells
    op.set(2, later)
    op.rhs(2, 3, 0.0)  # a later stage of the same step
    r_ti = op.get(3)
    ref = ReferenceOperator(cfg)
    r_np = ref.rhs(later.copy(), 0.0, start=start.copy())
    ix, iy = lay.interior()
    assert r_ti[lay.H][fed] > 0.0 and r_ti[lay.H][film] < 0.0
    # the film feeds its four neighbours (its faces were wet at the step's start), no others
    fi, fj = film
    near = [(fi - 1, fj), (fi + 1, fj), (fi, fj - 1), (fi, fj + 1)]
    assert all(r_ti[lay.H][c] > 0.0 for c in near)
    rest = r_ti[lay.H][ix, iy].copy()
    for c in near + [film]:
        rest[c[0] - g, c[1] - g] = 0.0
    assert np.all(rest == 0.0)
    rates = [r_ti[lay.H][c] for c in near]
    assert sum(rates) == pytest.approx(-r_ti[lay.H][film], rel=1e-12)  # no mass made
    scale = np.abs(r_np[lay.H]).max()
    assert np.all(np.abs(r_ti - r_np)[:, ix, iy] <= 1e-12 * scale)
    op.set(0, later)  # the next step starts below h_min everywhere: no face carries mass
    op.rhs(0, 1, 0.0)
    assert np.all(op.get(1)[lay.H] == 0.0)
    assert np.all(ref.rhs(later.copy(), 0.0)[lay.H] == 0.0)
