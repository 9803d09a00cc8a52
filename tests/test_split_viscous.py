"""The split MUSCL-Hancock step with viscosity (numerics.stepper = "hancock"): two half steps
of sweeps (x, y and y, x, over dt/2 each) around the viscous term of (6.2) as the sub-step V
over the whole dt, integrated by RKC stages (tiseg.solver.timestepping.split,
ViscousSubstep.viscous_stage).

What must hold: the kernels equal their NumPy twin (tiseg.solver.reference.split.hancock_pair);
V changes only the momenta (h and h phi keep their bits); the step is second order in time on
a smooth coupled problem and the shear wave decays at the exact viscous rate with
second-order convergence; mass to round-off, h >= 0 and 0 <= phi <= 1 at the largest stable
step; the lake at rest, a stopped block and the steady uniform flow (4.3), in a periodic box
and fed by the inflow, kept with viscosity on; a resumed run ends on the bits of the
uninterrupted one; the skipping of resting regions and parallel loops stay exact; the scene
takes hancock with viscosity.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from solver_helpers import make_config, random_state
from test_solver_physics import assert_kept_to_round_off, uniform_scene
from tiseg.errors import InputError
from tiseg.run import checkpoint
from tiseg.run.simulation import Simulation
from tiseg.setup.scene import load_scene
from tiseg.solver.reference import ReferenceOperator
from tiseg.solver.reference.split import hancock_pair, hancock_step, viscous_substep
from tiseg.solver.timestepping import make_stepper
from tiseg.solver.timestepping import split as split_stepping

DT = 0.01


def _config(nx, ny, **kw):
    base = dict(
        viscous=True,
        nu=0.01,
        friction="pouliquen-mixture",
        friction_scheme="projected",
        split=True,
        zeta=0.3,
        flux="central-upwind",
    )
    base.update(kw)
    return make_config(nx, ny, **base)


def _resting_patch(cfg, q):
    """q with the cells of x indices 5..8 at rest and those of 10..11 slow (mm/s)."""
    lay = cfg.layout
    q = q.copy()
    for c in (lay.HU,) if lay.is_1d else (lay.HU, lay.HV):
        q[c, 5:9] = 0.0
        q[c, 10:12] *= 1e-2
    return q


def _operator(cfg):
    from tiseg.solver.numerics.operator import TaichiOperator

    return TaichiOperator(cfg, nslots=4)


def _taichi_steps(cfg, q, stages, dt=DT, t=0.05, n=1, op=None):
    """n steps of the split stepper with viscosity from q, each with ``stages`` viscous
    stages: (state, budget)."""
    op = op or _operator(cfg)
    op.set(0, q)
    op.reset_budget()
    dims = 1 if cfg.layout.is_1d else 2
    st = make_stepper("hancock", dims=dims, viscous=True)
    for k in range(n):
        st.index = k
        st.step(op, t + k * dt, dt, 2 * dims + stages)
    return op.get(0), op.budget(0)


def _rel(cfg, a, b):
    ix, iy = cfg.layout.interior()
    diff = np.abs(a - b)[:, ix, iy].max(axis=(1, 2))
    scale = np.abs(b)[:, ix, iy].max(axis=(1, 2))
    return diff / np.where(scale > 0, scale, 1.0)


# -------------------------------------------------------------------------------- the twin
@pytest.mark.parametrize(
    "ny,rows", [(9, None), (9, (0, 4)), (1, None)], ids=["2d", "2d-localised-inlet", "1d"]
)
def test_viscous_split_step_matches_the_twin(ti_cpu, ny, rows):
    """A step (x, y | V | y, x; in 1D x | V | x) from a wet-dry state with a patch at rest,
    friction, segregation and an inflow (in 2D across the whole width or on rows at one
    side), with 2 and 4 viscous stages: the kernels equal the twin to 1e-12, and the viscous
    sub-step did change the result (against the same halves without it)."""
    rng = np.random.default_rng(11)
    bc = ("inflow", "outflow", "periodic", "periodic") if ny > 1 else ("wall", "outflow")
    cfg = _config(14, ny, bc=bc + ("periodic",) * (4 - len(bc)), inflow_rows=rows)
    q = _resting_patch(cfg, random_state(cfg.layout, rng, wet_dry=True))
    dirs = (0,) if ny == 1 else (0, 1)
    op = _operator(cfg)  # (one operator: its kernels are compiled once)
    for s in (2, 4):
        a, bud = _taichi_steps(cfg, q, s, op=op)
        b = q.copy()
        books = hancock_pair(ReferenceOperator(cfg), b, 0.05, DT, dirs, visc_stages=s)
        assert _rel(cfg, a, b).max() < 1e-12, s
        assert abs(bud[0] + bud[2] - books["mass"]) <= 1e-12 * max(abs(books["mass"]), 1e-9)
    inviscid = q.copy()
    hancock_step(ReferenceOperator(cfg), inviscid, 0.05, DT / 2, dirs)
    hancock_step(ReferenceOperator(cfg), inviscid, 0.05 + DT / 2, DT / 2, dirs[::-1])
    assert _rel(cfg, a, inviscid)[1] > 1e-6  # (the momentum felt the viscosity)


def test_viscous_substep_changes_only_the_momenta(ti_cpu):
    """V alone (kernels and twin) leaves h and h phi bit for bit, changes hu and hv, and
    equals its twin."""
    rng = np.random.default_rng(3)
    cfg = _config(12, 8, friction="none", bc=("wall", "outflow", "periodic", "periodic"))
    q = random_state(cfg.layout, rng, wet_dry=True)
    op = _operator(cfg)
    op.set(0, q)
    split_stepping.viscous_substep(op, 0.0, DT, 3)
    a = op.get(0)
    b = q.copy()
    viscous_substep(ReferenceOperator(cfg), b, 0.0, DT, 3)
    lay = cfg.layout
    ix, iy = lay.interior()
    for c in (lay.H, lay.HPHI):
        assert np.array_equal(a[c][ix, iy], q[c][ix, iy]), c
        assert np.array_equal(b[c][ix, iy], q[c][ix, iy]), c
    assert _rel(cfg, a, b).max() < 1e-12
    assert _rel(cfg, a, q)[lay.HU] > 1e-6 and _rel(cfg, a, q)[lay.HV] > 1e-6


# ------------------------------------------------------------------------------ the scene
def test_scene_takes_hancock_with_viscosity_and_the_stepper_its_stages():
    """The fingers scene (nu = 0.01) loads with the split stepper, which then has a viscous
    sub-step and 4 slots; its plan makes the step two convective limits (one per half) and
    takes the RKC stage count of dt rho_visc on top of the 4 sweeps (at least 2), and a
    fixed count below 4 + 2 is refused in one line."""
    sc = load_scene("fingers", {"numerics.stepper": "hancock"})
    assert sc.viscous and sc.numerics.stepper == "hancock"
    st = make_stepper("hancock", dims=2, viscous=True)
    assert st.slots == 4
    assert st.plan(0.01, 0.0, 1.0) == (0.02, 6)
    assert st.plan(0.005, 1000.0, 1.0) == (0.01, 4 + 5)  # dt rho = 10: 5 RKC stages
    assert st.plan(0.01, 0.0, 0.015) == (0.015, 6)  # (a stop time inside the pair)
    dt, s = make_stepper("hancock", dims=2, viscous=True, max_stages=3).plan(0.01, 1e4, 1.0)
    assert s == 7 and dt * 1e4 <= 0.653 * 9  # the cap shortens the step to fit 3 stages
    with pytest.raises(InputError, match="at least 2 viscous stages") as e:
        st.plan(0.01, 0.0, 1.0, stages=5)
    assert "\n" not in str(e.value)
    assert make_stepper("hancock", dims=2).slots == 1  # without viscosity: as before


# ------------------------------------------------------------------ runs: rest, bounds, order
def test_uniform_flow_with_viscosity_stays_uniform_to_round_off(ti_cpu):
    """T1, the steady uniform flow of section 4 with viscosity on (nu = 0.01): a uniform
    velocity has no viscous stress, so the step keeps it to round-off as without."""
    sim = Simulation(
        uniform_scene(
            nu=0.01,
            t_end=0.1,
            numerics__stepper="hancock",
            numerics__flux="central-upwind",
            effects__friction="pouliquen-mixture",
        )
    )
    assert sim.stepper.viscous
    q0 = sim.conserved().copy()
    sim.advance(0.1)
    assert sim.stats.steps > 5 and sim.stats.stages >= 6 * sim.stats.steps  # (> 10 halves)
    assert_kept_to_round_off(q0, sim.conserved())


@pytest.mark.slow  # two 2D runs: CI runs it after the main set
def test_lake_and_deposit_at_rest_keep_their_bits_with_viscosity(ti_cpu):
    """On flat ground with friction, segregation and viscosity (2D): still material of
    uniform depth and a deposit whose surface slopes, held by the friction, keep every bit
    (the viscous force on material at rest is zero, and the projection sees the sweeps'
    driving with V's share of it)."""
    for h_right in (0.002, 0.001):
        o = {
            "material.zeta_deg": 0.0,
            "effects.friction": "pouliquen-mixture",
            "effects.segregation": True,
            "effects.viscosity": True,
            "flow.nu": 0.01,
            "initial.h_left": 0.002,
            "initial.h_right": h_right,
            "domain.nx": 40,
            "domain.ny": 6,
            "domain.Ly": 0.03,
            "boundary.y_lo": "wall",
            "boundary.y_hi": "wall",
            "numerics.stepper": "hancock",
            "time.t_end": 0.3,
        }
        sim = Simulation(load_scene("dam-break", o), check_every=1)
        assert sim.stepper.viscous
        if h_right != 0.002:  # a smooth ramp: the friction holds its gentle slope
            x, y = sim.scene.domain.cell_centres()
            X, _ = np.meshgrid(x, y)
            h = 0.0015 + 0.0005 * np.tanh((X - 0.2) / 0.05)
            sim.set_state(h, phi=np.full_like(h, 0.6))
        q0 = sim.conserved().copy()
        sim.advance(0.3)
        assert sim.stats.steps > 5  # (> 10 halves)
        assert np.array_equal(sim.conserved(), q0), h_right


def _chute(**over):
    """The fingers scene, small and short, with its viscosity, on the split sweeps."""
    o = {
        "domain.Lx": 0.3,
        "domain.Ly": 0.06,
        "domain.resolution": 100,
        "numerics.stepper": "hancock",
        "time.t_end": 0.6,
        "output.interval": 0.6,
    }
    o.update(over)
    return Simulation(load_scene("fingers", o), check_every=1)


@pytest.mark.slow
def test_chute_at_the_largest_stable_step_conserves_and_keeps_bounds(ti_cpu):
    """The fingers scene's physics with viscosity at Courant 1 per sweep (the largest the
    sweeps allow): mass and h phi in the cells equal what entered to round-off, h >= 0 and
    0 <= phi <= 1 after every step, and the viscous sub-step took its stages."""
    sim = _chute(**{"numerics.cfl": 1.0, "numerics.step_rule": "max"})
    assert sim.stepper.viscous
    lay = sim.layout
    tot0 = sim.totals()
    while sim.t < 0.6 - 1e-12:
        sim.step()
        q = sim.conserved()
        assert q[lay.H].min() >= 0.0
        assert np.all(q[lay.HPHI] >= 0.0) and np.all(q[lay.HPHI] <= q[lay.H])
    assert sim.stats.stages >= 4 * sim.stats.steps
    tot, bud = sim.totals(), sim.budget()
    assert bud["mass_in"] > 0
    assert abs(tot["mass"] - tot0["mass"] - bud["mass_in"]) <= 1e-13 * tot["mass"]
    assert abs(tot["small_mass"] - tot0["small_mass"] - bud["small_mass_in"]) <= 1e-13 * tot["mass"]
    phi = sim.fields()["phi"]
    assert 0.0 <= phi.min() and phi.max() <= 1.0


@pytest.mark.slow  # a long regression run: CI runs it after the main set
def test_resumed_viscous_run_ends_on_the_bits_of_the_uninterrupted_one(ti_cpu, tmp_path):
    """The chute with viscosity and the extended law (the hold and the rest mask), saved
    after 7 steps and restored into a fresh simulation: the run ends on the bits of the run
    that never stopped."""
    over = {"effects.friction": "pouliquen-extended", "time.t_end": 0.3}
    whole = _chute(**over)
    for _ in range(7):
        whole.step()
    ck = checkpoint.save(tmp_path / "ck.npz", whole)
    for _ in range(8):
        whole.step()
    again = _chute(**over)
    checkpoint.restore(again, checkpoint.load(ck))
    for _ in range(8):
        again.step()
    assert again.t == whole.t
    assert np.array_equal(again.conserved(), whole.conserved())


def _smooth_run(n, L=0.16, T=0.24, nu=0.05):
    """The smooth periodic 2D problem of the order test on n x n cells in steps of
    dt = 0.192 / n (halves of Courant about 0.5 per sweep), flat, frictionless, with
    viscosity nu. Returns the interior state."""
    from tiseg.solver.timestepping.rkc import stages_for

    dx = L / n
    cfg = make_config(
        n,
        n,
        segregation=False,
        nu=nu,
        friction="none",
        friction_scheme="projected",
        split=True,
        zeta=0.0,
        flux="central-upwind",
        bc=("periodic",) * 4,
        dx=dx,
        dy=dx,
        Ly=L,
    )
    lay = cfg.layout
    op = _operator(cfg)
    x = (np.arange(lay.NX) - lay.gx + 0.5) * dx
    X, Y = np.meshgrid(x, x, indexing="ij")
    k = 2 * math.pi / L
    h = 0.002 * (1 + 0.2 * np.sin(k * X) * np.cos(k * Y))
    q = np.stack([h, h * (0.1 + 0.05 * np.cos(k * Y)), h * 0.03 * np.sin(k * X + 0.3)])
    op.set(0, q)
    dt = 0.192 / n
    s = stages_for(1.2 * dt * op.stability(0, 0.0).rho_visc)
    st = make_stepper("hancock", dims=2, viscous=True)
    for m in range(int(round(T / dt))):
        st.index = m
        st.step(op, m * dt, dt, 4 + s)
    ix, iy = lay.interior()
    return op.get(0)[:, ix, iy]


def _coarsened(a, f):
    c, nx, ny = a.shape
    return a.reshape(c, nx // f, f, ny // f, f).mean(axis=(2, 4))


@pytest.mark.slow
def test_split_step_with_viscosity_is_second_order(ti_cpu):
    """A smooth periodic 2D flow (h, u, v all varying, nu = 0.05 so that the viscous and the
    convective rates are alike) on 16, 32 cells against 128 cells, dt refined with dx: the
    L1 errors of h, hu, hv fall by 2^1.8 or more per halving (Strang's symmetric pair of
    halves around V)."""
    ref = _smooth_run(128)
    e16, e32 = (
        np.abs(_smooth_run(n) - _coarsened(ref, 128 // n)).mean(axis=(1, 2)) for n in (16, 32)
    )
    assert np.all(np.log2(e16 / e32) > 1.8), np.log2(e16 / e32)


@pytest.mark.slow  # a long run: the slow set (README), which CI runs after the suite
def test_shear_wave_decays_at_the_viscous_rate(ti_cpu):
    """A shear wave u = U sin(k y) on uniform h over flat ground (periodic, no friction)
    decays as exp(-nu h^{1/2}/2 k^2 t) (the x-momentum equation of (6.2) for it); on 16 and 32
    cells (WENO slopes, dt refined with dy) the L1 error against the exact cell averages
    falls by 2^1.8 or more and is below 1 % of U at 32 cells."""
    from tiseg.solver.timestepping.rkc import stages_for

    L, U, h0, nu, T = 0.1, 0.05, 0.002, 0.05, 0.2
    k = 2 * math.pi / L
    errs = []
    for ny in (16, 32):
        dy = L / ny
        cfg = make_config(
            4,
            ny,
            segregation=False,
            nu=nu,
            friction="none",
            friction_scheme="projected",
            split=True,
            zeta=0.0,
            flux="central-upwind",
            bc=("periodic",) * 4,
            dx=dy,
            dy=dy,
            Ly=L,
            reconstruction="weno",
        )
        lay = cfg.layout
        op = _operator(cfg)
        yl = (np.arange(lay.NY) - lay.gy) * dy
        avg = (np.cos(k * yl) - np.cos(k * (yl + dy))) / (k * dy)  # cell means of sin(k y)
        q = np.zeros((lay.nc, lay.NX, lay.NY))
        q[lay.H] = h0
        q[lay.HU] = h0 * U * avg[None, :]
        op.set(0, q)
        dt = 0.16 / ny
        s = stages_for(dt * op.stability(0, 0.0).rho_visc)
        st = make_stepper("hancock", dims=2, viscous=True)
        for m in range(int(round(T / dt))):
            st.index = m
            st.step(op, m * dt, dt, 4 + s)
        decay = math.exp(-nu * math.sqrt(h0) / 2 * k * k * T)
        ix, iy = lay.interior()
        exact = h0 * U * decay * avg[iy]
        errs.append(np.abs(op.get(0)[lay.HU][ix, iy] - exact[None, :]).mean() / (h0 * U))
    assert math.log2(errs[0] / errs[1]) > 1.8, errs
    assert errs[1] < 0.01


@pytest.mark.slow
def test_serial_and_parallel_viscous_steps_give_the_same_bits(ti_cpu):
    """Split steps with viscosity, friction with hysteresis, segregation, an
    inflow and a partial active range, with every loop on one thread and with parallel loops:
    the same bits (each cell's stage writes its own cells)."""
    from tiseg.solver.numerics.operator import TaichiOperator

    rng = np.random.default_rng(5)
    cfg = _config(
        40, 11, friction="pouliquen-extended", bc=("inflow", "outflow", "wall", "periodic")
    )
    q = _resting_patch(cfg, random_state(cfg.layout, rng, wet_dry=True))
    out = {}
    for serial in (True, False):
        op = TaichiOperator(cfg, nslots=4, serial=serial)
        op.set(0, q)
        op.set_active(op.gx + 3, op.gx + 30)
        st = make_stepper("hancock", dims=2, viscous=True)
        for k in range(3):
            st.index = k
            st.step(op, 0.05 + k * 1e-3, 1e-3, 4 + 3)
        out[serial] = (op.get(0), op.budget(0))
    assert np.array_equal(out[True][0], out[False][0])
    assert np.array_equal(out[True][1], out[False][1])
    assert not np.array_equal(out[True][0], q)


@pytest.mark.slow
def test_skipped_resting_columns_get_the_bits_of_a_full_computation_with_viscosity(ti_cpu):
    """The finite release with the extended law and its viscosity on the split step: from the
    same state, steps of the same length with and without the skipping of regions held at
    rest give the same bits while the rear of the release stops and the skipping leaves
    columns out (a held cell ends each step projected to rest, and V moves no mass)."""
    over = {
        "domain.resolution": 50,
        "time.t_end": 120.0,
        "output.times": [],
        "numerics.stepper": "hancock",
        "numerics.step_rule": "max",
    }
    skip = Simulation(load_scene("finite-release-deposit", over))
    full = Simulation(load_scene("finite-release-deposit", over), skip_rest=False)
    assert skip.stepper.viscous and skip.op.skip_rest and not full.op.skip_rest
    skip.advance(25.0)
    full.op.set(0, skip.op.get(0))
    full.op.reset_budget(skip.op.budget(0))
    full.t, full.stats.steps = skip.t, skip.stats.steps
    narrowest = 1.0
    while skip.t < 30.0:
        p, pf = skip.plan(), full.plan()
        dt, s = min(p.dt, pf.dt), max(p.stages, pf.stages)
        for sim in (skip, full):
            sim.stepper.index = sim.stats.steps
            sim.stepper.step(sim.op, sim.t, dt, s)
            sim.t += dt
            sim.stats.steps += 1
        (a, b), (wa, wb) = skip.op.active, skip.op.wet_range
        narrowest = min(narrowest, (b - a) / (wb - wa))
    np.testing.assert_array_equal(skip.conserved(), full.conserved())
    np.testing.assert_array_equal(skip.op.budget(0), full.op.budget(0))
    assert np.any(skip.conserved()[1] != 0)  # still flowing at the front
    assert narrowest < 0.75, narrowest


@pytest.mark.slow  # a long run: the slow set (README), which CI runs after the suite
def test_steady_inflow_into_the_uniform_flow_is_kept(ti_cpu):
    """The fingers scene's chute without segregation, filled with the steady uniform state
    that its inflow (no ramp) prescribes: the split step with viscosity keeps h and u to
    round-off, the inlet cells too. V after the sweeps acts on their state before the
    friction, so a viscous stress through the inlet against the prescribed (frictioned)
    velocity would slow the inlet cells every other step; through a running inlet V takes
    none."""
    o = {
        "domain.Lx": 0.2,
        "domain.Ly": 0.04,
        "domain.resolution": 100,
        "effects.segregation": False,
        "inflow.ramp_rate": 0.0,
        "numerics.stepper": "hancock",
        "numerics.step_rule": "max",
        "time.t_end": 0.3,
        "output.interval": 0.3,
    }
    sim = Simulation(load_scene("fingers", o))
    assert sim.stepper.viscous and sim.scene.boundary.x_lo == "inflow"
    h0, u0 = sim.cfg.inflow_h, sim.cfg.inflow_u
    shape = (sim.layout.ny, sim.layout.nx)
    sim.set_state(np.full(shape, h0), u=np.full(shape, u0))
    sim.advance(0.3)
    assert sim.stats.steps > 5  # (> 10 halves)
    f = sim.fields()
    assert np.abs(f["h"] / h0 - 1.0).max() < 1e-12
    assert np.abs(f["u"] / u0 - 1.0).max() < 1e-12


@pytest.mark.slow
def test_coulomb_block_with_viscosity_stops_and_keeps_its_bits_in_1d(ti_cpu):
    """The Coulomb block of tests/test_split_full_model.py (1D, mu = 0.47 on 21 degrees) with
    viscosity: it slumps, stops exactly (u = 0 everywhere by 1.5 s), and then every step,
    x, V and V, x in turn, leaves every bit as it was."""
    o = {
        "material.zeta_deg": 21.0,
        "effects.friction": "coulomb",
        "effects.coulomb_mu": 0.47,
        "initial.h_left": 0.006,
        "domain.nx": 60,
        "numerics.stepper": "hancock",
        "time.t_end": 3.0,
        "effects.viscosity": True,
        "flow.nu": 0.01,
    }
    sim = Simulation(load_scene("dam-break", o), check_every=1)
    assert sim.stepper.viscous and sim.layout.is_1d
    sim.advance(0.1)
    assert np.abs(sim.fields()["u"]).max() > 1e-3
    sim.advance(1.5)
    assert np.all(sim.fields()["u"] == 0.0)
    before = sim.conserved().copy()
    steps = sim.stats.steps
    sim.advance(3.0)
    assert sim.stats.steps > steps + 20
    assert np.array_equal(sim.conserved(), before)
