"""The solver against independent truth: uniform flow preservation (T1), conservation,
the Ritter dam break (T2), linear growth rates of section 5 (T7), second-order convergence on a
smooth problem with an exact solution (T6b), and bounds on h and phi at dry fronts."""

import math

import numpy as np
import pytest

from tiseg.post.problems import load_problem
from tiseg.setup.scene import load_scene, scene_from_dict
from tiseg.run.simulation import Simulation

from solver_helpers import PERIODIC

# numerics.flux x numerics.phi_flux: every option must keep the properties tested here
FLUX_OPTIONS = [
    ("kt", "central"),
    ("kt", "upwind"),
    ("central-upwind", "central"),
    ("central-upwind", "upwind"),
]
FLUX_IDS = [f"{a}+{b}" for a, b in FLUX_OPTIONS]
# the costly runs take the default, the paper's scheme and the central-upwind default
COSTLY = [("kt", "upwind"), ("kt", "central"), ("central-upwind", "upwind")]
COSTLY_IDS = [f"{a}+{b}" for a, b in COSTLY]


def flux_overrides(opt) -> dict:
    return {"numerics.flux": opt[0], "numerics.phi_flux": opt[1]}


def fingers_overrides(opt) -> dict:
    """flux_overrides for the fingers scene: its split sweeps take only the upwind h phi flux
    with segregation, so the paper's central flux runs on the unsplit scheme (RKC, sum rule)."""
    unsplit = {"numerics.stepper": "rkc", "numerics.step_rule": "sum", "numerics.cfl": 0.5}
    return {**flux_overrides(opt), **(unsplit if opt[1] == "central" else {})}


def uniform_scene(
    nx=16,
    ny=8,
    nu=0.001,
    amplitude=0.0,
    mode="h",
    k=0.2399,
    stepper="rkc",
    rec="minmod",
    t_end=0.05,
    **extra,
):
    d = {
        "flow": {"h0": 0.002, "phi0": 0.8, "nu": nu},
        "domain": {"nx": nx, "ny": ny},
        "boundary": dict(PERIODIC),
        "initial": {
            "kind": "uniform",
            "amplitude": amplitude,
            "k": k,
            "mode": mode,
            "wavelengths": 1,
        },
        "numerics": {"reconstruction": rec, "stepper": stepper},
        "time": {"t_end": t_end},
    }
    if ny > 1:
        d["domain"]["Ly"] = 0.01
    for key, val in extra.items():
        sec, name = key.split("__")
        d.setdefault(sec, {})[name] = val
    return scene_from_dict(d, name="test-uniform")


# ------------------------------------------------------------------------------------------ T1
def assert_kept_to_round_off(q0, q):
    """Every component of q equals q0's to 1e-12 of its largest value; one that was zero
    everywhere (hv of a flow along x) stays exactly zero."""
    for c in range(q.shape[0]):
        scale = np.abs(q0[c]).max()
        err = np.abs(q[c] - q0[c]).max()
        assert (err / scale < 1e-12) if scale > 0 else err == 0.0, c


@pytest.mark.parametrize("opt", FLUX_OPTIONS, ids=FLUX_IDS)
@pytest.mark.parametrize("rec", ["minmod", "weno"])
def test_uniform_flow_stays_uniform_to_round_off(ti_cpu, rec, opt):
    sim = Simulation(
        uniform_scene(rec=rec, t_end=0.2, numerics__flux=opt[0], numerics__phi_flux=opt[1])
    )
    q0 = sim.conserved().copy()
    sim.advance(0.2)
    assert sim.stats.steps > 50
    assert_kept_to_round_off(q0, sim.conserved())


@pytest.mark.slow
@pytest.mark.parametrize("friction", ["pouliquen-mixture", "pouliquen-extended"])
@pytest.mark.parametrize("stepper", ["rkc", "ssprk3"])
def test_uniform_flow_stays_uniform_with_projected_friction(ti_cpu, friction, stepper):
    """T1 with the friction as a projection: its coefficient is taken at the speed of the state
    each stage starts from, so the friction impulse of a stage equals its gravity impulse at
    the steady speed, and the steady uniform flow (4.3) (Fr = 1.57, the dynamic regime of the
    extended law) is kept to round-off."""
    sim = Simulation(
        uniform_scene(
            t_end=0.2,
            numerics__friction_scheme="projected",
            numerics__stepper=stepper,
            effects__friction=friction,
        )
    )
    q0 = sim.conserved().copy()
    sim.advance(0.2)
    assert sim.stats.steps > 20
    assert_kept_to_round_off(q0, sim.conserved())


@pytest.mark.parametrize("opt", FLUX_OPTIONS, ids=FLUX_IDS)
def test_lake_at_rest_on_flat_bed(ti_cpu, opt):
    """Still water stays still: the scene's split sweeps with the upwind h phi flux (the
    only one they take with segregation), its former unsplit SSPRK(4,2) with the central."""
    over = (
        {}
        if opt[1] == "upwind"
        else {"numerics.stepper": "ssprk4_2", "numerics.step_rule": "local"}
    )
    scene = load_scene(
        "dam-break",
        {
            "initial.h_right": 0.002,
            "time.t_end": 0.05,
            "effects.segregation": True,
            **flux_overrides(opt),
            **over,
        },
    )
    sim = Simulation(scene)
    q0 = sim.conserved().copy()
    sim.advance(0.05)
    assert np.abs(sim.conserved() - q0).max() < 1e-17


# ------------------------------------------------------------------------------ conservation
@pytest.mark.parametrize("opt", FLUX_OPTIONS, ids=FLUX_IDS)
def test_mass_conserved_in_periodic_domain(ti_cpu, opt):
    """Noisy phi in a 2D periodic box: total mass and small-particle mass change only by
    round-off while the flow evolves."""
    sim = Simulation(
        uniform_scene(
            nx=24,
            ny=12,
            nu=0.01,
            amplitude=0.3,
            mode="noise",
            t_end=0.1,
            initial__seed=3,
            numerics__flux=opt[0],
            numerics__phi_flux=opt[1],
        )
    )
    m0 = sim.totals()
    sim.advance(0.1)
    m1 = sim.totals()
    assert abs(m1["mass"] - m0["mass"]) / m0["mass"] < 1e-13
    assert abs(m1["small_mass"] - m0["small_mass"]) / m0["small_mass"] < 1e-13
    assert abs(sim.budget()["mass_in"]) == 0.0


@pytest.mark.slow
@pytest.mark.parametrize("opt", COSTLY, ids=COSTLY_IDS)
def test_inflow_and_outflow_exactly_accounted(ti_cpu, opt):
    """Fingers set-up (inflow at x = 0) and a dam break leaving through x = Lx: the change of
    mass equals the accumulated boundary fluxes of the scheme to round-off."""
    sc = load_scene(
        "fingers",
        {
            "domain.resolution": 60,
            "time.t_end": 0.6,
            "output.times": [],
            "output.interval": 0.3,
            **fingers_overrides(opt),
        },
    )
    sim = Simulation(sc)
    sim.advance(0.6)
    tot, bud = sim.totals(), sim.budget()
    assert bud["mass_in"] > 0
    assert abs(tot["mass"] - bud["mass_in"]) / tot["mass"] < 1e-12
    assert abs(tot["small_mass"] - bud["small_mass_in"]) / tot["small_mass"] < 1e-12
    sc = load_scene(
        "dam-break",
        {
            "initial.x0": 0.28,
            "domain.nx": 150,
            "time.t_end": 0.2,
            "numerics.h_min": 1e-7,
            "numerics.h_eps": 1e-9,
            **flux_overrides(opt),
        },
    )
    sim = Simulation(sc)
    m0 = sim.totals()["mass"]
    sim.advance(0.2)
    out = -sim.budget()["mass_in"]
    assert out > 1e-3 * m0  # material really left the domain
    assert abs(sim.totals()["mass"] - (m0 - out)) / m0 < 1e-12


# --------------------------------------------------------------------------------------- T2
@pytest.mark.slow
def test_dam_break_converges_to_ritter(ti_cpu):
    ritter = load_problem("ritter")  # tiseg/data/problems/ritter.toml, as the bench runs it
    t_end = ritter.end(quick=False)
    errs, fronts = [], []
    for n in (100, 200, 400):
        sc = ritter.build(n)
        sim = Simulation(sc)
        raw = ritter.run(sim)
        h = raw["h"]
        x, _ = sc.domain.cell_centres()
        errs.append(ritter.score(raw, sc)[1])
        assert h.min() >= 0.0
        # positions of the h = theta h_L contours, x0 + (2 c0 - sqrt(9 theta g h_L)) t
        pos = []
        for theta in (1e-1, 1e-2):
            xs_exact = (
                0.1 + (2 * math.sqrt(9.81 * 0.002) - math.sqrt(9 * theta * 9.81 * 0.002)) * t_end
            )
            i = np.nonzero(h >= theta * 0.002)[0].max()
            pos.append((abs(x[i] - xs_exact), xs_exact - 0.1))
        fronts.append(pos)
    assert errs[0] > errs[1] > errs[2], errs
    order = math.log2(errs[0] / errs[2]) / 2
    assert order > 0.6, (errs, order)
    assert errs[2] < 6e-3
    # the 10 % contour within two cells; the 1 % contour (thin tip, smeared by the scheme's
    # numerical diffusion) within 20 % of its travel distance and closer than on the coarse grid
    assert fronts[2][0][0] <= 2 * sc.dx, fronts
    assert fronts[2][1][0] < 0.2 * fronts[2][1][1] and fronts[2][1][0] < fronts[0][1][0], fronts


# --------------------------------------------------------------------------------------- T7
@pytest.mark.parametrize(
    "h0,nu,k,nx",
    [
        (0.002, 0.01, 0.2399, 64),  # unstable, growing
        (0.003, 0.001, 3.0, 64),
    ],
)  # beyond cutoff, decaying
def test_linear_growth_rate_matches_theory(ti_cpu, h0, nu, k, nx):
    from tiseg.setup.initial import eigenmode

    sc = load_scene(
        "uniform-flow",
        {"flow.h0": h0, "flow.nu": nu, "initial.k": k, "domain.nx": nx, "domain.Lx": None},
    )
    lam, _ = eigenmode(sc)
    scale = sc.flow.u0 / sc.flow.h0
    sigma = lam.real * scale
    t_end = 12 * sc.flow.h0 / sc.flow.u0
    n_samples = 49  # dense enough that the phase moves < pi between samples
    sim = Simulation(sc)
    ts, amp, ph = [], [], []
    for j in range(n_samples):
        sim.advance(t_end * j / (n_samples - 1))
        c = np.fft.rfft(sim.conserved()[0, :, 0])[1]
        ts.append(sim.t), amp.append(abs(c)), ph.append(np.angle(c))
    ts = np.array(ts)
    late = slice(n_samples // 4, None)  # let the other (damped) modes die out first
    rate = np.polyfit(ts[late], np.log(amp[late]), 1)[0]
    omega = np.polyfit(ts[late], np.unwrap(ph[late]), 1)[0]
    assert abs(rate - sigma) < 0.02 * abs(sigma), (rate, sigma)
    assert abs(omega - lam.imag * scale) < 0.01 * abs(lam.imag * scale)


# -------------------------------------------------------------------------------------- T6b
@pytest.mark.slow
@pytest.mark.parametrize(
    "rec,opt",
    [("minmod", FLUX_OPTIONS[0]), ("weno", FLUX_OPTIONS[0])]
    + [("weno", o) for o in FLUX_OPTIONS[1:]]
    + [("minmod", FLUX_OPTIONS[3])],
    ids=["minmod", "weno"] + [f"weno-{i}" for i in FLUX_IDS[1:]] + [f"minmod-{FLUX_IDS[3]}"],
)
def test_second_order_convergence_on_smooth_transport(ti_cpu, rec, opt):
    """T6b: with a friction that exactly balances gravity (mu = tan zeta) h and u stay uniform
    and phi solves the large-particle transport equation (6.3); smooth data, t = t_break / 2."""
    transport = load_problem("transport")  # tiseg/data/problems/transport.toml
    errs = []
    for n in (50, 100, 200):
        num = {"reconstruction": rec, "stepper": "rkc", "flux": opt[0], "phi_flux": opt[1]}
        sc = transport.build(n, num)
        sim = Simulation(sc)
        errs.append(transport.score(transport.run(sim), sc)[1])  # mean |phi - phi_exact|
    orders = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert orders[-1] > 1.8, (errs, orders)


# ---------------------------------------------------------------------------- bounds, fronts
@pytest.mark.slow
@pytest.mark.parametrize("opt", COSTLY, ids=COSTLY_IDS)
def test_small_fingers_run_forms_coarse_rich_front(ti_cpu, tmp_path, opt):
    """The paper's set-up at 100 cells per metre for 2 s: finite, conserving, h >= 0,
    0 <= phi <= 1, and a coarse-rich front (phi at the front well below phi0)."""
    sc = load_scene(
        "fingers",
        {
            "domain.resolution": 100,
            "time.t_end": 2.0,
            "output.times": [1.0],
            "output.interval": 0.5,
            **fingers_overrides(opt),
        },
    )
    sim = Simulation(sc)
    sim.run(out_dir=tmp_path, progress=False)
    q = sim.conserved()
    assert np.isfinite(q).all()
    assert q[0].min() >= 0.0
    f = sim.fields()
    wet = f["h"] >= sc.numerics.h_min
    assert f["phi"][wet].min() >= 0.0 and f["phi"][wet].max() <= 1.0
    tot, bud = sim.totals(), sim.budget()
    assert abs(tot["mass"] - bud["mass_in"]) / tot["mass"] < 1e-12
    # front: the most downstream wet cell of every row
    for j in range(f["h"].shape[0]):
        i_front = np.nonzero(wet[j])[0].max()
        assert f["phi"][j, i_front] < 0.5 * sc.flow.phi0
    assert (tmp_path / "fields.nc").exists() and (tmp_path / "diagnostics.csv").exists()


@pytest.mark.slow  # a long regression run: CI runs it in the slow set
def test_active_region_is_exact(ti_cpu):
    """Skipping the dry chute ahead of the front changes nothing: the same fingers run with and
    without the active x range gives the same state to round-off."""
    sc = load_scene(
        "fingers",
        {"domain.resolution": 60, "time.t_end": 1.0, "output.times": [], "output.interval": 0.5},
    )
    runs = []
    for active in (True, False):
        sim = Simulation(sc, active_region=active)
        sim.advance(1.0)
        runs.append((sim.conserved(), sim.stats.steps, sim.op.active))
    (qa, na, act), (qf, nf, full) = runs
    assert act[1] - act[0] < full[1] - full[0]  # the range really was restricted
    assert na == nf
    assert np.abs(qa - qf).max() <= 1e-15 * np.abs(qf).max()


def test_filling_an_empty_chute_takes_cfl_steps(ti_cpu):
    """At t = 0 the chute is empty and the ramped inflow has h = 0: the step must still obey
    the CFL limit of the inflow state, not jump to the end time."""
    sc = load_scene(
        "fingers",
        {"domain.resolution": 40, "time.t_end": 1.0, "output.times": [], "output.interval": 0.5},
    )
    sim = Simulation(sc)
    info = sim.step(1.0)
    u0 = sc.flow.u0
    c = math.sqrt(9.81 * math.cos(math.radians(27)) * sc.flow.h0)
    # (each half step of a split step with viscosity)
    assert info.dt / sim.stepper.halves <= sc.numerics.cfl * sc.dx / (u0 + c) * (1 + 1e-12)
    sim.advance(1.0)
    assert sim.conserved()[0].max() < 3 * sc.flow.h0
