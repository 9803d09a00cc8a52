"""The extended Pouliquen-Forterre law with hysteresis (effects.friction = "pouliquen-extended").

Checked against exact answers: the law's regimes against its formulas (Pouliquen & Forterre
2002 in the form of Edwards & Gray 2015), the Taichi law and projection against their NumPy
twins, the start criterion tan(zeta) > mu_S(h) of a layer at rest, and the deposit a steady
flow leaves when its supply is cut off, against h_stop of the law.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from solver_helpers import (
    PERIODIC,
    make_config,
    projected_stage_equals_reference,
    random_state,
    rates_equal_reference,
)
from tiseg.errors import InputError
from tiseg.model.material import Material
from tiseg.model.physics.friction import FRICTION_LAWS, h_stop
from tiseg.setup.scene import scene_from_dict
from tiseg.run.simulation import Simulation

EXT = FRICTION_LAWS["pouliquen-extended"]


# ------------------------------------------------------------------------------ the law itself
def _cfg(**kw):
    return make_config(8, 4, friction="pouliquen-extended", **kw)


def test_regimes_follow_the_formulas_of_the_extended_law():
    """Dynamic: (3.7) itself; at Fr = beta*: continuous; intermediate: (Fr/beta*)^kappa between
    mu_D(h, beta*) and mu_S(h); at rest: mu_S(h) = tan zeta3 + (tan zeta2 - tan zeta1) /
    (1 + h / L). Written out here from the papers, for the fines alone (phi = 1)."""
    c = _cfg()
    m = Material()
    sp = m.small
    g_cos = c.g_cos
    h = np.array([2e-4, 1e-3, 3e-3])
    speed = lambda fr: fr * np.sqrt(g_cos * h)  # noqa: E731
    mu1, mu2 = math.tan(math.radians(20.0)), math.tan(math.radians(30.0))
    mu3 = math.tan(math.radians(21.0))  # default zeta3 = zeta1 + 1 degree
    bstar, kappa = 0.136, 1e-3

    def dyn(fr):
        return mu1 + (mu2 - mu1) / (sp.beta * h / (sp.L * fr) + 1.0)

    mu_s = mu3 + (mu2 - mu1) / (1.0 + h / sp.L)
    one = np.ones_like(h)
    for fr in (0.2, 1.0, 3.0):  # dynamic
        assert np.allclose(EXT.mu_np(c, h, speed(fr), one), dyn(fr), rtol=1e-14)
    for fr in (1e-6, 1e-3, 0.05, 0.13):  # intermediate
        want = (fr / bstar) ** kappa * (dyn(bstar) - mu_s) + mu_s
        assert np.allclose(EXT.mu_np(c, h, speed(fr), one), want, rtol=1e-14)
    assert np.allclose(EXT.mu_np(c, h, 0 * h, one), mu_s, rtol=1e-14)  # at rest
    assert np.allclose(EXT.mu_start_np(c, h, one), mu_s, rtol=1e-14)
    # continuous at beta*, and friction grows as the flow slows below it
    lo = EXT.mu_np(c, h, speed(bstar * (1 - 1e-9)), one)
    assert np.allclose(lo, dyn(bstar), rtol=1e-9)
    slow = EXT.mu_np(c, h, speed(1e-4), one)
    assert np.all(slow > dyn(bstar)) and np.all(slow < mu_s)
    # the coarse grains weigh in by (3.4)
    half = 0.5 * one
    mix = EXT.mu_np(c, h, speed(1.0), half)
    large = c.fric.mu1_l + (c.fric.mu2_l - c.fric.mu1_l) / (
        c.fric.beta_l * h / (c.fric.L_l * 1.0) + 1.0
    )
    assert np.allclose(mix, 0.5 * dyn(1.0) + 0.5 * large, rtol=1e-14)


def test_h_stop_is_where_the_dynamic_friction_at_beta_star_balances_the_slope():
    m = Material(zeta_deg=22.0)
    sp = m.small
    hs = h_stop(m.zeta, sp.mu1, sp.mu2, sp.beta, sp.L, m.beta_star)
    mu_d = sp.mu1 + (sp.mu2 - sp.mu1) / (sp.beta * hs / (sp.L * m.beta_star) + 1.0)
    assert math.isclose(mu_d, m.tan_zeta, rel_tol=1e-13)
    assert 7e-4 < hs < 9e-4  # 0.785 mm for the fines of Table 1 at 22 degrees


@pytest.mark.parametrize("scheme", ["regularised", "projected"])
def test_taichi_law_and_projection_equal_the_numpy_twins(ti_cpu, scheme):
    """Rates (with the friction in the source when regularised) and one projected Euler stage
    equal the reference, on a state with cells in all three regimes: fast, slower than beta*,
    and at rest (some of which start and some of which hold)."""

    rng = np.random.default_rng(11)
    cfg = make_config(
        12,
        8,
        friction="pouliquen-extended",
        feedback=True,
        reconstruction="minmod",
        bc=("periodic",) * 4,
        friction_scheme=scheme,
    )
    lay = cfg.layout
    q = random_state(lay, rng, wet_dry=True)
    pick = rng.random((lay.NX, lay.NY))
    for c in (lay.HU, lay.HV):  # 30 % at rest, 30 % at Fr ~ 0.01-0.1
        q[c] = np.where(pick < 0.3, 0.0, np.where(pick < 0.6, 0.05 * q[c], q[c]))
    op, ref, r_ti = rates_equal_reference(cfg, q)
    if scheme == "regularised":
        return
    a = projected_stage_equals_reference(op, ref, q, r_ti, 2e-3, 2e-3)
    ix, iy = lay.interior()
    wet = q[lay.H][ix, iy] >= cfg.h_min
    was_rest = (pick[ix, iy] < 0.3) & wet
    starts = (a[lay.HU][ix, iy] != 0) & was_rest
    holds = (a[lay.HU][ix, iy] == 0) & was_rest
    assert starts.sum() >= 2 and holds.sum() >= 2, (starts.sum(), holds.sum())


# ------------------------------------------------------------------------------ scenes
def _layer_scene(zeta, friction="pouliquen-extended", nx=8, t_end=1.0, **material):
    return scene_from_dict(
        {
            "material": {"zeta_deg": zeta, **material},
            "flow": {"h0": 0.002, "phi0": 1.0, "nu": 0.0},
            "effects": {
                "segregation": False,
                "viscosity": False,
                "mobility_feedback": False,
                "friction": friction,
            },
            "domain": {"Lx": 0.1, "nx": nx, "ny": 1},
            "boundary": dict(PERIODIC),
            "initial": {"kind": "release", "x0": 0.0, "x1": 0.1, "h": 0.001},
            "numerics": {
                "reconstruction": "minmod",
                "stepper": "ssprk3",
                "friction_scheme": "projected",
            },
            "time": {"t_end": t_end},
        },
        name="layer",
    )


def _start_thickness(m: Material) -> float:
    """h_start: tan(zeta) = mu_S(h) of the fines."""
    sp = m.small
    return sp.L * ((sp.mu2 - sp.mu1) / (m.tan_zeta - sp.mu3) - 1.0)


@pytest.mark.parametrize("ratio, moves", [(0.9, False), (1.1, True)])
def test_a_layer_at_rest_starts_only_above_h_start(ti_cpu, ratio, moves):
    """Hysteresis: at 22 degrees a uniform layer at rest thinner than h_start (1.92 mm) stays
    at rest bit for bit, though the dynamic law (3.7) alone would let it accelerate at once
    (mu1 = tan 20 < tan 22); 10 % thicker than h_start, it starts."""
    sc = _layer_scene(22.0)
    h = ratio * _start_thickness(sc.material)
    assert 1.5e-3 < h < 2.5e-3
    sim = Simulation(sc, check_every=1)
    layer = np.full((1, sc.domain.nx), h)
    sim.set_state(layer)
    before = sim.conserved()
    sim.advance(0.2)
    assert sim.stats.steps > 5
    u = sim.fields()["u"]
    if moves:
        assert np.all(u > 0)
    else:
        assert np.array_equal(sim.conserved(), before)
    # the same layer under the mixture law (no static regime) always flows
    mix = Simulation(_layer_scene(22.0, friction="pouliquen-mixture"), check_every=1)
    mix.set_state(layer)
    mix.advance(0.05)
    assert np.all(mix.fields()["u"] > 0)


@pytest.mark.parametrize("stepper", ["ssprk3", "rkc", "ssprk4_2"])
def test_a_layer_just_past_h_start_accelerates_as_the_law_says(ti_cpu, stepper):
    """A uniform layer at rest 2 % thicker than h_start (at 22 degrees) cannot be held: it
    starts on the first step, whatever the step's length, and then accelerates as the law says:
    du/dt = g cos(zeta) (tan(zeta) - mu(h, u)), integrated by solve_ivp to 1e-10, with mu in its
    intermediate regime (Fr < beta*). Measured at t = 0.5 s, at the sum rule's full step
    (13 steps; 5 for SSPRK(4,2)): -0.2 % (SSPRK3), +0.5 % (RKC), -1.4 % (SSPRK(4,2)), and half
    of that at half the step. Before the friction coefficient lagged by a stage, it was taken
    at the speed before friction, whose dynamic regime gave an impulse that stopped this layer
    on steps this long: it never started."""
    import math

    from scipy.integrate import solve_ivp

    from tiseg.solver.numerics.config import config_from_scene
    from tiseg.model.physics.friction import FRICTION_LAWS

    sc = _layer_scene(22.0).with_overrides({"numerics.stepper": stepper, "numerics.cfl": 0.5})
    h = 1.02 * _start_thickness(sc.material)
    cfg, law = config_from_scene(sc), FRICTION_LAWS["pouliquen-extended"]
    tan_z = math.tan(sc.material.zeta)

    def accel(t, u):
        mu = law.mu_np(cfg, np.array([h]), np.array([max(u[0], 1e-300)]), 1.0)[0]
        return [cfg.g_cos * (tan_z - mu)]

    exact = solve_ivp(accel, (0.0, 0.5), [1e-300], rtol=1e-10, atol=1e-14).y[0, -1]
    sim = Simulation(sc, check_every=1)
    sim.set_state(np.full((1, sc.domain.nx), h))
    sim.step()
    assert np.all(sim.fields()["u"] > 0)  # started on the first step
    sim.advance(0.5)
    u = sim.fields()["u"].ravel()
    assert np.ptp(u) == 0.0
    assert abs(u[0] / exact - 1.0) < 0.02, (u[0], exact)


def _cut_off_flow(cfl=None):
    """A steady uniform flow of the fines (2 mm, F = 0.35 > beta*) at 22 degrees whose supply
    is cut off: a wall upstream, outflow downstream, 400 cells on 0.5 m."""
    numerics = {"reconstruction": "minmod", "stepper": "ssprk3", "friction_scheme": "projected"}
    if cfl is not None:
        numerics["cfl"] = cfl
    return scene_from_dict(
        {
            "material": {"zeta_deg": 22.0},
            "flow": {"h0": 0.002, "phi0": 1.0, "nu": 0.0},
            "effects": {
                "segregation": False,
                "viscosity": False,
                "mobility_feedback": False,
                "friction": "pouliquen-extended",
            },
            "domain": {"Lx": 0.5, "nx": 400, "ny": 1},
            "boundary": {"x_lo": "wall", "x_hi": "outflow", "y_lo": "periodic", "y_hi": "periodic"},
            "initial": {"kind": "uniform"},
            "numerics": numerics,
            "time": {"t_end": 30.0},
        },
        name="deposit",
    )


@pytest.mark.slow
def test_a_steady_flow_cut_off_leaves_a_deposit_of_h_stop(ti_cpu):
    """The flow drains and comes to rest, leaving a deposit of h_stop = 0.785 mm, where
    tan(zeta) = mu_D(h_stop, beta*): measured 0.9938 h_stop at 400 cells (0.9940 with steps
    of 0.8 of the length, 0.9944 with RKC), so the deposit does not depend on the step length.
    Before the friction coefficient lagged by a stage and the static friction decided once per
    step, it did: 1.0040 h_stop against 0.9883 at 0.8 of the step, 1.0268 with RKC.

    Every one of the 400 cells is then exactly at rest and keeps h bit for bit. Before the
    mass flux had a floor where a cell outruns its neighbour (RestRules.rest_face), 3
    cells crept on at 3e-6 to 2e-5 m/s, each just below a step of about 1.5e-5 m in the
    deposit's surface, held there by the central flux's dissipation. Mass is
    conserved up to what left through the outflow."""
    sc = _cut_off_flow()
    assert sc.flow.F > sc.material.beta_star
    m = sc.material
    hs = h_stop(m.zeta, m.small.mu1, m.small.mu2, m.small.beta, m.small.L, m.beta_star)
    sim = Simulation(sc)
    m0 = sim.totals()["mass"]
    sim.advance(20.0)
    f = sim.fields()
    h, u = f["h"].ravel(), f["u"].ravel()
    deposit = h[80:320].mean()  # x in [0.1, 0.4] m
    print(f"\ndeposit {deposit / hs:.4f} h_stop; {np.count_nonzero(u)} cells moving")
    assert abs(deposit / hs - 1.0) < 0.01, (deposit, hs)
    assert np.all(np.abs(h[40:360] / hs - 1.0) < 0.05)
    assert np.count_nonzero(u) == 0  # all 400 exactly at rest
    net_in = sim.budget()["mass_in"]  # what the outflow took, negative
    assert -0.7 * m0 < net_in < -0.5 * m0  # 2 mm drained to a deposit of ~0.8 mm
    assert abs(sim.totals()["mass"] - (m0 + net_in)) <= 1e-12 * m0
    before = sim.conserved()
    sim.advance(21.0)
    assert np.array_equal(sim.conserved(), before)
    # the same flow with steps of 0.8 of the length leaves the same deposit
    short = Simulation(_cut_off_flow(cfl=0.2))
    short.advance(20.0)
    deposit_short = short.fields()["h"].ravel()[80:320].mean()
    assert abs(deposit_short / deposit - 1.0) < 1e-3, (deposit_short, deposit)


# ------------------------------------------------------------------------------ scene keys
def test_scene_keys_of_the_extended_law_and_their_errors():
    sc = _layer_scene(22.0, beta_star=0.2, kappa=0.01, small={"zeta3_deg": 23.0})
    assert sc.material.beta_star == 0.2 and sc.material.kappa == 0.01
    assert sc.material.small.zeta3 == 23.0 and sc.material.large.zeta3 == 30.0
    assert sc.to_dict()["material"]["small"]["zeta3_deg"] == 23.0
    assert "zeta3_deg" not in sc.to_dict()["material"]["large"]  # the default stays implicit
    for bad, word in (
        (dict(small={"zeta3_deg": 19.0}), "zeta3_deg"),
        (dict(kappa=2.0), "kappa"),
        (dict(beta_star=-1.0), "beta_star"),
    ):
        with pytest.raises(InputError, match=word):
            _layer_scene(22.0, **bad)


def test_u0_is_derived_only_in_the_dynamic_regime():
    """The extended law shares (4.3) where F >= beta*; a thinner reference flow is slower than
    beta* and has no steady state of section 4, which the scene says instead of deriving u0."""
    base = _layer_scene(22.0)
    assert base.flow.u0 is not None and base.flow.F > 0.136
    mix = _layer_scene(22.0, friction="pouliquen-mixture")
    assert math.isclose(base.flow.u0, mix.flow.u0, rel_tol=1e-15)
    thin = scene_from_dict(
        {
            "material": {"zeta_deg": 22.0},
            "flow": {"h0": 0.0005, "phi0": 1.0, "nu": 0.0},
            "effects": {"segregation": False, "viscosity": False, "friction": "pouliquen-extended"},
            "domain": {"Lx": 0.1, "nx": 8, "ny": 1},
            "boundary": dict(PERIODIC),
            "time": {"t_end": 1.0},
        },
        name="thin",
    )
    assert thin.flow.u0 is None and "beta_star" in thin.flow.no_steady


def test_rest_faces_are_those_of_the_step_start(ti_cpu):
    """The rest faces (no mass across a face between two cells at rest) are those of the
    step's initial state, slot 0, for every stage of the step. A thin cell creeping between
    deposits, the rest at rest: after a first stage has stopped it, a stage rate of that
    stopped state still moves mass through its faces (they were not rest faces at the step's
    start), and only once slot 0 holds the stopped state do all h rates vanish. A finite
    release at 125 cells/m broke the mass balance after 252 s when the later RKC stage switched
    those faces off: RKC's stage weights of both signs (2.08, -1, -1.58 at 2 stages) then drove
    the thin cell's h below zero, and the limiter's clip created mass."""
    from tiseg.solver.numerics.operator import TaichiOperator

    cfg = make_config(
        12,
        8,
        friction="pouliquen-extended",
        feedback=True,
        reconstruction="weno",
        bc=("periodic",) * 4,
        friction_scheme="projected",
    )
    lay = cfg.layout
    g = lay.gx
    q = np.zeros((lay.nc, lay.NX, lay.NY))
    q[lay.H] = 2.8e-4
    q[lay.H, g + 6, g + 3 : g + 6] = (4.8e-4, 3.26e-3, 4.8e-4)
    q[lay.H, g + 7, g + 3 : g + 6] = (2.26e-3, 3.19e-3, 2.26e-3)
    q[lay.HPHI] = 0.8 * q[lay.H]
    moving = q.copy()
    moving[lay.HV, g + 6, g + 3] = -2e-3 * q[lay.H, g + 6, g + 3]
    ix, iy = lay.interior()
    op = TaichiOperator(cfg, nslots=4)
    op.set(0, moving)
    op.rhs(0, 1, 0.0)  # the step's first evaluation: its rest faces
    op.set(2, q)  # a later stage's state: the thin cell stopped
    op.rhs(2, 3, 0.0)
    r = op.get(3)[lay.H][ix, iy]
    assert r[6, 3] != 0.0
    assert np.count_nonzero(r) >= 3  # the thin cell and its neighbours exchange mass
    op.set(0, q)  # the next step starts from the stopped state: every face is a rest face
    op.rhs(0, 1, 0.0)
    assert np.all(op.get(1)[lay.H][ix, iy] == 0.0)
