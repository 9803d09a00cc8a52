"""The split MUSCL-Hancock sweeps (numerics.stepper = "hancock") with the granular model's
friction and segregation: every friction law as the projection after the step's last sweep
(tiseg.solver.numerics.split), the large-particle transport and the mobility feedback inside the
sweeps.

What must hold, as for the unsplit projected scheme: the kernels equal their NumPy twin
(tiseg.solver.reference.split.hancock_step); mass and h phi are conserved, h >= 0 and 0 <= phi <= 1;
a Coulomb block that friction must stop stops exactly and then keeps its bits, in 1D and in
2D (where the lateral slump is driven across the slope while gravity drives along it: the
friction's hold must see the whole step's driving); a lake at rest and a deposit held on flat
ground stay bit for bit; the steady uniform flow of section 4 is kept to round-off; the
effects that are off leave no code; a resumed run ends on the bits of the uninterrupted one.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from solver_helpers import make_config, random_state
from test_solver_physics import assert_kept_to_round_off, uniform_scene
from tiseg.run import checkpoint
from tiseg.errors import InputError
from tiseg.model.physics.pointwise import Params, slot_bases
from tiseg.solver.reference import ReferenceOperator
from tiseg.solver.reference.split import hancock_step
from tiseg.setup.scene import load_scene
from tiseg.run.simulation import Simulation

LAWS = ["coulomb", "pouliquen-mixture", "pouliquen-extended", "pouliquen-small"]
BCS = [
    ("inflow", "outflow", "periodic", "periodic"),
    ("wall", "wall", "wall", "wall"),
    ("periodic", "periodic", "outflow", "wall"),
]
DT = 0.01  # lambda a ~ 0.35 on the wet-dry states below (dx = 1 cm)


def _split_config(nx, ny, **kw):
    base = dict(
        viscous=False,
        friction="pouliquen-mixture",
        friction_scheme="projected",
        split=True,
        zeta=0.3,  # tan(zeta) = 0.31 below every law's least coefficient: slow cells stop
        flux="central-upwind",
    )
    base.update(kw)
    return make_config(nx, ny, **base)


def _resting_patch(cfg, q):
    """q with the cells of x indices 5..8 at rest (u = v = 0), where the face rules between
    them and the static friction's hold act, and those of 10..11 slow (mm/s), which the
    friction stops."""
    lay = cfg.layout
    q = q.copy()
    for c in (lay.HU,) if lay.is_1d else (lay.HU, lay.HV):
        q[c, 5:9] = 0.0
        q[c, 10:12] *= 1e-2
    return q


def _taichi_step(cfg, q, dirs, t=0.05, dt=DT, op=None):
    """A step of sweeps along dirs of the kernels (on ``op`` if given: its parameters as
    they are) from q: (state, budget)."""
    from tiseg.solver.numerics.operator import TaichiOperator

    op = op or TaichiOperator(cfg, nslots=2)
    op.set(0, q)
    op.reset_budget()
    for k, d in enumerate(dirs):
        op.sweep(d, t, dt, first=k == 0, last=k == len(dirs) - 1)
    return op.get(0), op.budget(0)


def _poisoned(op, q, k, value):
    """A split step of op from q with parameter slot k set to value (then restored)."""
    keep = op.par[0, k]
    op.par[0, k] = value
    out, _ = _taichi_step(op.cfg, q, (0, 1), op=op)
    op.par[0, k] = keep
    return out


def _rel(cfg, a, b):
    ix, iy = cfg.layout.interior()
    diff = np.abs(a - b)[:, ix, iy].max(axis=(1, 2))
    scale = np.abs(b)[:, ix, iy].max(axis=(1, 2))
    return diff / np.where(scale > 0, scale, 1.0)


# -------------------------------------------------------------------------------- the twin
@pytest.mark.parametrize(
    "law,bc",
    [
        (LAWS[0], BCS[0]),
        (LAWS[1], BCS[1]),
        # the other two laws and boundaries: the longer regression set (CI runs it too)
        pytest.param(LAWS[2], BCS[2], marks=pytest.mark.slow),
        pytest.param(LAWS[3], BCS[1], marks=pytest.mark.slow),
    ],
    ids=["coulomb-inflow", "mixture-walls", "extended-periodic-x", "small-walls"],
)
def test_sweeps_with_friction_and_segregation_match_the_twin(ti_cpu, law, bc):
    """A step of each sweep order (and a 1D step) from wet-dry states with a patch at rest:
    the kernels equal the twin to 1e-12, the budget equals the twin's, and the friction did
    act (some wet cells moving at the start stopped exactly)."""
    rng = np.random.default_rng(7)
    stopped = 0
    for ny in (9, 1):
        bcs = bc if ny > 1 else bc[:2] + ("periodic",) * 2
        cfg = _split_config(14, ny, friction=law, bc=bcs)
        lay = cfg.layout
        q = _resting_patch(cfg, random_state(lay, rng, wet_dry=True))
        for dirs in ((0, 1), (1, 0)) if ny > 1 else ((0,),):
            a, bud = _taichi_step(cfg, q, dirs)
            b = q.copy()
            books = hancock_step(ReferenceOperator(cfg), b, 0.05, DT, dirs)
            assert _rel(cfg, a, b).max() < 1e-12, (law, bc, dirs)
            assert abs(bud[0] + bud[2] - books["mass"]) <= 1e-12 * max(abs(books["mass"]), 1e-9)
            small = books["small_mass"]
            assert abs(bud[1] + bud[3] - small) <= 1e-12 * max(abs(small), 1e-9)
            ix, iy = lay.interior()
            moving = (q[lay.HU] != 0)[ix, iy] & (q[lay.H] >= cfg.h_min)[ix, iy]
            stopped += int((moving & (a[lay.HU][ix, iy] == 0)).sum())
    assert stopped > 0, (law, bc)


def test_friction_and_the_face_rules_change_the_twin_where_they_should(ti_cpu):
    """The twin itself: with friction the step differs from the frictionless one, and the
    resting patch's h keeps its bits where its neighbours rest as well (no mass crosses a
    face between two cells at rest), which the frictionless step does not."""
    rng = np.random.default_rng(3)
    cfg = _split_config(14, 9, bc=BCS[1])
    lay = cfg.layout
    q = _resting_patch(cfg, random_state(lay, rng, smooth=True))
    fr, free = q.copy(), q.copy()
    hancock_step(ReferenceOperator(cfg), fr, 0.05, DT, (0, 1))
    hancock_step(
        ReferenceOperator(_split_config(14, 9, bc=BCS[1], friction="none")), free, 0.05, DT, (0, 1)
    )
    inner = (slice(6, 8), slice(lay.gy, lay.gy + lay.ny))
    assert np.array_equal(fr[lay.H][inner], q[lay.H][inner])
    assert not np.array_equal(free[lay.H][inner], q[lay.H][inner])
    assert np.abs(fr[lay.HU] - free[lay.HU]).max() > 1e-3 * np.abs(free[lay.HU]).max()


# ----------------------------------------------------------------------- effects switched off
@pytest.mark.slow  # a long regression run: CI runs it after the main set
def test_friction_code_is_in_the_sweeps_and_nothing_else_is(ti_cpu):
    """Each number of the friction law, poisoned with NaN or inf, changes a split step's
    result (the projection compares the momentum with the friction impulse, so a poisoned
    impulse stops cells rather than spreading NaN); u_eps, which only the regularised source
    reads, poisoned with NaN, changes no bit. Without friction there are no friction
    numbers, no rest mask and no field of initial speeds at all."""
    from tiseg.solver.numerics.operator import TaichiOperator

    rng = np.random.default_rng(5)
    for law in ("pouliquen-mixture", "pouliquen-extended", "coulomb"):
        cfg = _split_config(10, 6, friction=law, bc=("periodic",) * 4)
        q = _resting_patch(cfg, random_state(cfg.layout, rng, smooth=True))
        q[cfg.layout.HU, :, ::2] *= 1e-3  # slow cells too: the extended law's intermediate regime
        op = TaichiOperator(cfg, nslots=2)  # one operator: its kernels compile once
        clean, _ = _taichi_step(cfg, q, (0, 1), op=op)
        assert np.isfinite(clean).all()

        b = slot_bases(cfg)
        for k in range(b["friction"], b["end"]):
            for v in (math.nan, math.inf):
                assert not np.array_equal(_poisoned(op, q, k, v), clean), (law, k, v)
        assert np.array_equal(_poisoned(op, q, Params.U_EPS, math.nan), clean)
    off = _split_config(10, 6, friction="none", bc=("periodic",) * 4)
    op = TaichiOperator(off, nslots=2)
    assert op.rest is None and op.spd0 is None
    assert slot_bases(off)["end"] == slot_bases(off)["friction"]


@pytest.mark.slow  # a long regression run: CI runs it after the main set
def test_feedback_off_the_split_friction_ignores_phi(ti_cpu):
    """Without mobility feedback the momentum after a split step does not depend on the local
    phi; with it, it does (the mixture law weights with phi inside the projection)."""
    rng = np.random.default_rng(9)
    lay = _split_config(10, 6).layout
    q = random_state(lay, rng, smooth=True)
    q2 = q.copy()
    q2[lay.HPHI] = 0.1 * q[lay.H]
    for feedback in (False, True):
        cfg = _split_config(10, 6, feedback=feedback, bc=("periodic",) * 4)
        a, _ = _taichi_step(cfg, q, (0, 1))
        b, _ = _taichi_step(cfg, q2, (0, 1))
        assert np.array_equal(a[lay.HU], b[lay.HU]) == (not feedback)


# -------------------------------------------------------------------------------- the scene
def test_scene_takes_projected_friction_and_viscosity_and_refuses_the_regularised():
    base = {
        "numerics.stepper": "hancock",
        "effects.friction": "coulomb",
        "effects.segregation": True,
    }
    assert load_scene("dam-break", base).numerics.friction_scheme == "projected"
    with pytest.raises(InputError) as e:
        load_scene("dam-break", {**base, "numerics.friction_scheme": "regularised"})
    msg = str(e.value)
    assert "\n" not in msg and "'projected'" in msg and "ssprk4_2" in msg
    # the viscosity is a sub-step of its own (tests/test_split_viscous.py)
    visc = load_scene("dam-break", {**base, "effects.viscosity": True, "flow.nu": 1e-3})
    assert visc.viscous and visc.numerics.stepper == "hancock"
    with pytest.raises(InputError, match="friction_scheme"):  # with it as without
        load_scene(
            "dam-break",
            {
                **base,
                "effects.viscosity": True,
                "flow.nu": 1e-3,
                "numerics.friction_scheme": "regularised",
            },
        )


# ------------------------------------------------------------------------- runs: rest, bounds
ZETA, MU = 21.0, 0.47  # tan(21 deg) = 0.384 < mu: the block must stop


def _block(ny=1, **over):
    """The Coulomb block of test_friction_combinations (6 mm over 0.1 m at rest on a 21 degree
    slope, mu = 0.47), 1D, or in 2D as a square block that slumps in x and y at once."""
    o = {
        "material.zeta_deg": ZETA,
        "effects.friction": "coulomb",
        "effects.coulomb_mu": MU,
        "initial.h_left": 0.006,
        "domain.nx": 60,
        "numerics.stepper": "hancock",
        "time.t_end": 3.0,
    }
    if ny > 1:
        o.update({"domain.ny": ny, "domain.Ly": ny * 0.005})
        o.update({"boundary.y_lo": "wall", "boundary.y_hi": "wall"})
    o.update(over)
    sim = Simulation(load_scene("dam-break", o), check_every=1)
    if ny > 1:
        x, y = sim.scene.domain.cell_centres()
        X, Y = np.meshgrid(x, y)
        Ly = sim.scene.domain.Ly
        block = (np.abs(X - 0.1) < 0.05) & (np.abs(Y - 0.5 * Ly) < 0.25 * Ly)
        sim.set_state(np.where(block, 0.006, 0.0))
    return sim


def _mass_rel_error(sim) -> float:
    tot, bud = sim.totals(), sim.budget()
    return abs(tot["mass"] - sim.initial_totals["mass"] - bud["mass_in"]) / tot["mass"]


@pytest.mark.parametrize("ny", [1, 12])
def test_coulomb_block_stops_exactly_and_stays_at_rest(ti_cpu, ny):
    """The block slumps (it moves at first), stops exactly by 1 s (u = v = 0 in every cell),
    and then every step leaves every bit as it was; h >= 0 and mass to round-off. In 2D the
    cells along the block's sides are driven across the slope by the slump and along it by
    gravity: a hold that saw one sweep's driving only would release them in the other."""
    sim = _block(ny)
    sim.advance(0.1)
    assert np.abs(sim.fields()["u"]).max() > 1e-3  # it slumps
    sim.advance(1.0)
    f = sim.fields()
    assert np.all(f["u"] == 0.0) and (ny == 1 or np.all(f["v"] == 0.0))
    before = sim.conserved().copy()
    steps = sim.stats.steps
    sim.advance(3.0)
    assert sim.stats.steps > steps + 20
    assert np.array_equal(sim.conserved(), before)
    assert before[0].min() >= 0.0
    assert _mass_rel_error(sim) < 1e-13
    if ny > 1:  # it spread across the slope as well
        h = sim.fields()["h"]
        wet_rows = np.flatnonzero((h >= sim.cfg.h_min).any(axis=1))
        assert len(wet_rows) > ny // 2


def test_block_on_a_slope_that_friction_cannot_hold_keeps_sliding(ti_cpu):
    """The same block with mu below tan(zeta): the projection never stops it (the test above
    is not passed by a scheme that stops everything)."""
    sim = _block(1, **{"effects.coulomb_mu": 0.3})
    sim.advance(1.0)
    f = sim.fields()
    wet = f["h"] >= sim.cfg.h_min
    assert np.all(f["u"][wet] > 0.0)
    m = 9.81 * math.cos(math.radians(ZETA)) * (math.tan(math.radians(ZETA)) - 0.3)
    # the centre of mass accelerates at g cos(zeta) (tan(zeta) - mu) (no other force on it)
    h, u = f["h"], f["u"]
    mean_u = (h * u).sum() / h.sum()
    assert abs(mean_u - m * 1.0) < 0.02 * m


def test_lake_and_deposit_at_rest_keep_their_bits(ti_cpu):
    """On flat ground (zeta = 0) with friction and segregation: still water of uniform depth,
    and a deposit whose surface slopes (its pressure held by the friction), keep every bit."""
    for h_right in (0.002, 0.001):
        sim = _block(
            1,
            **{
                "material.zeta_deg": 0.0,
                "initial.h_left": 0.002,
                "initial.h_right": h_right,
                "effects.segregation": True,
                "effects.friction": "pouliquen-mixture",
            },
        )
        if h_right != 0.002:  # a smooth ramp: the friction holds its gentle slope
            x, _ = sim.scene.domain.cell_centres()
            h = 0.0015 + 0.0005 * np.tanh((x - 0.15) / 0.05)[None, :]
            sim.set_state(h, phi=np.full_like(h, 0.6))
        q0 = sim.conserved().copy()
        sim.advance(0.3)
        assert sim.stats.steps > 10
        assert np.array_equal(sim.conserved(), q0), h_right


@pytest.mark.parametrize("friction", ["pouliquen-mixture", "pouliquen-extended"])
def test_uniform_flow_stays_uniform_to_round_off(ti_cpu, friction):
    """T1, the steady uniform flow of section 4 (h0 = 2 mm, phi0 = 0.8, Fr = 1.57) in a periodic
    2D box: the friction of the step is projected at the step's initial speed, so its impulse
    equals the gravity impulse of the x sweep at the steady speed, whichever sweep comes
    first; kept to round-off."""
    sim = Simulation(
        uniform_scene(
            nu=0.0,
            t_end=0.2,
            numerics__stepper="hancock",
            numerics__flux="central-upwind",
            effects__viscosity=False,
            effects__friction=friction,
        )
    )
    q0 = sim.conserved().copy()
    sim.advance(0.2)
    assert sim.stats.steps > 20
    assert_kept_to_round_off(q0, sim.conserved())


def _chute(**over):
    """The fingers scene, small and short, without viscosity: inflow of phi = 0.8 with noise,
    the mixture law with mobility feedback, segregation, on the split sweeps."""
    o = {
        "domain.Lx": 0.3,
        "domain.Ly": 0.06,
        "domain.resolution": 100,
        "effects.viscosity": False,
        "numerics.stepper": "hancock",
        "time.t_end": 0.6,
        "output.interval": 0.6,
    }
    o.update(over)
    return Simulation(load_scene("fingers", o), check_every=1)


@pytest.mark.slow  # a long run: the slow set (README), which CI runs after the suite
def test_chute_conserves_mass_and_small_particles_with_bounded_phi(ti_cpu):
    """The fingers scene's physics on the split sweeps: mass and h phi in the cells equal what
    entered through the inflow to round-off, h >= 0 and 0 <= phi <= 1 after every step."""
    sim = _chute()
    lay = sim.layout
    tot0 = sim.totals()
    while sim.t < 0.6 - 1e-12:
        sim.step()
        q = sim.conserved()
        assert q[lay.H].min() >= 0.0
        assert np.all(q[lay.HPHI] >= 0.0) and np.all(q[lay.HPHI] <= q[lay.H])
    tot, bud = sim.totals(), sim.budget()
    assert bud["mass_in"] > 0
    assert abs(tot["mass"] - tot0["mass"] - bud["mass_in"]) <= 1e-13 * tot["mass"]
    assert abs(tot["small_mass"] - tot0["small_mass"] - bud["small_mass_in"]) <= 1e-13 * tot["mass"]
    phi = sim.fields()["phi"]
    assert 0.0 <= phi.min() and phi.max() <= 1.0


@pytest.mark.slow  # a long regression run: CI runs it after the main set
def test_resumed_run_ends_on_the_bits_of_the_uninterrupted_one(ti_cpu, tmp_path):
    """The chute with the extended law (a law with hysteresis: the hold and the rest mask):
    saved after an odd number of steps and restored into a fresh simulation, the run ends on
    the bits of the run that never stopped."""
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


@pytest.mark.slow
def test_skipped_resting_columns_get_the_bits_of_a_full_computation(ti_cpu):
    """The finite release with the extended law on the split sweeps (no viscosity): from the
    same state, steps of the same length with and without the skipping of regions held at
    rest give the same bits from 55 to 60 s, while the release comes to rest and the skipping
    leaves a good part of its columns out (a held cell ends each step projected to rest with
    no mass across its faces, so its h keeps its bits). (With the films flowing, a film by the
    stopped inlet's wall creeps on for a long time and keeps the rear columns live.)"""
    over = {
        "domain.resolution": 50,
        "time.t_end": 120.0,
        "output.times": [],
        "effects.viscosity": False,
        "numerics.stepper": "hancock",
        "numerics.step_rule": "max",
    }
    skip = Simulation(load_scene("finite-release-deposit", over))
    full = Simulation(load_scene("finite-release-deposit", over), skip_rest=False)
    assert skip.op.skip_rest and not full.op.skip_rest
    skip.advance(55.0)
    full.op.set(0, skip.op.get(0))
    full.op.reset_budget(skip.op.budget(0))
    full.t, full.stats.steps = skip.t, skip.stats.steps
    narrowest = 1.0
    while skip.t < 60.0:
        dt = min(skip.plan().dt, full.plan().dt)
        for sim in (skip, full):
            sim.stepper.index = sim.stats.steps
            sim.stepper.step(sim.op, sim.t, dt, 2)
            sim.t += dt
            sim.stats.steps += 1
        (a, b), (wa, wb) = skip.op.active, skip.op.wet_range
        narrowest = min(narrowest, (b - a) / (wb - wa))
    np.testing.assert_array_equal(skip.conserved(), full.conserved())
    np.testing.assert_array_equal(skip.op.budget(0), full.op.budget(0))
    assert np.any(skip.conserved()[1] != 0)  # still flowing at the front
    assert narrowest < 0.75, narrowest


@pytest.mark.slow  # a long regression run: CI runs it after the main set
def test_serial_and_parallel_loops_give_the_same_bits(ti_cpu):
    """The split steps with friction (a law with hysteresis), segregation, an inflow and a
    partial active range, with every loop on one thread and with parallel loops: the same
    bits (each cell's update writes its own cells; the budget's sums run in a fixed order)."""
    from tiseg.solver.numerics.operator import TaichiOperator
    from tiseg.solver.timestepping import make_stepper

    rng = np.random.default_rng(7)
    cfg = _split_config(40, 11, friction="pouliquen-extended", bc=BCS[0][:2] + ("wall", "periodic"))
    q = _resting_patch(cfg, random_state(cfg.layout, rng, wet_dry=True))
    out = {}
    for serial in (True, False):
        op = TaichiOperator(cfg, nslots=2, serial=serial)
        op.set(0, q)
        op.set_active(op.gx + 3, op.gx + 30)
        stepper = make_stepper("hancock", dims=2)
        for k in range(3):
            stepper.index = k
            stepper.step(op, 0.05 + k * 1e-3, 1e-3, 2)
        out[serial] = (op.get(0), op.budget(0))
    assert np.array_equal(out[True][0], out[False][0])
    assert np.array_equal(out[True][1], out[False][1])
    assert not np.array_equal(out[True][0], q)
