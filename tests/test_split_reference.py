"""The split scheme's sweeps (tiseg.solver.numerics.split) equal their NumPy twin
(tiseg.solver.reference.split) to round-off: the predictor, its dry-edge fallback, the face fluxes,
the draining-time scaling, the source at mid-step, the limiter and the boundary budget."""

import numpy as np
import pytest

from solver_helpers import make_config, random_state
from tiseg.solver.reference import ReferenceOperator
from tiseg.solver.reference.split import hancock_sweep

BOUNDARIES = [
    ("inflow", "outflow", "periodic", "periodic"),
    ("wall", "wall", "wall", "wall"),
    ("periodic", "periodic", "outflow", "wall"),
]
# dt large enough that the draining factor and the predictor's fallback both act on the wet-dry
# states (a_x ~ 0.35 m/s with h ~ 2 mm: lambda a ~ 0.9 at dt = 0.025 s and dx = 1 cm)
DT = 0.025


def _split_config(nx, ny, **kw):
    base = dict(viscous=False, friction="none", feedback=False, split=True, zeta=0.5)
    base.update(kw)
    return make_config(nx, ny, **base)


def _sweeps(cfg, q, dirs, t=0.05, dt=DT):
    """Both implementations through the same sweeps: (taichi state, reference state,
    taichi budget, reference budget totals)."""
    from tiseg.solver.numerics.operator import TaichiOperator

    op = TaichiOperator(cfg, nslots=2)
    ref = ReferenceOperator(cfg)
    op.set(0, q)
    op.reset_budget()
    qr = q.copy()
    mass = small = 0.0
    for d in dirs:
        op.sweep(d, t, dt)
        b = hancock_sweep(ref, qr, t, dt, d)
        mass += b["mass"]
        small += b["small_mass"]
    return op.get(0), qr, op.budget(0), (mass, small)


def _rel(cfg, a, b):
    ix, iy = cfg.layout.interior()
    diff = np.abs(a - b)[:, ix, iy].max(axis=(1, 2))
    scale = np.abs(b)[:, ix, iy].max(axis=(1, 2))
    return diff / np.where(scale > 0, scale, 1.0)


@pytest.mark.parametrize(
    "rec,bc,state",
    [
        ("minmod", BOUNDARIES[0], "wet-dry"),
        ("minmod", BOUNDARIES[1], "smooth"),
        ("minmod", BOUNDARIES[2], "wet-dry"),
        ("weno", BOUNDARIES[1], "wet-dry"),
        ("weno", BOUNDARIES[2], "smooth"),
    ],
)
def test_sweeps_match_reference_2d(ti_cpu, rec, bc, state):
    rng = np.random.default_rng(7)
    cfg = _split_config(14, 9, reconstruction=rec, bc=bc, flux="central-upwind")
    q = random_state(cfg.layout, rng, wet_dry=state == "wet-dry", smooth=state == "smooth")
    # a step of each order from the same state (the wet-dry states drain cells to h = 0 in
    # the twin and to a few ulps in the kernels; a later sweep's draining decision at such a
    # cell is a coin toss of round-off, so longer chains test round-off, not the scheme)
    for dirs in ((0, 1), (1, 0)):
        a, b, bud, (mass, small) = _sweeps(cfg, q, dirs)
        assert _rel(cfg, a, b).max() < 1e-12
        assert abs((bud[0] + bud[2]) - mass) <= 1e-12 * max(abs(mass), 1e-9)
        assert abs((bud[1] + bud[3]) - small) <= 1e-12 * max(abs(small), 1e-9)
        # and the budget closes the books: what the cells gained entered through the faces
        ix, iy = cfg.layout.interior()
        gained = (a[0][ix, iy].sum() - q[0][ix, iy].sum()) * cfg.dx * cfg.dy
        total = abs(q[0][ix, iy]).sum() * cfg.dx * cfg.dy
        assert abs(gained - mass) <= 1e-12 * max(total, 1e-12)


@pytest.mark.parametrize(
    "flux,phi_flux,bc",
    [
        ("kt", "central", BOUNDARIES[0]),
        ("central-upwind", "upwind", BOUNDARIES[1]),
        ("central-upwind", "central", BOUNDARIES[2]),
    ],
)
def test_sweep_matches_reference_1d(ti_cpu, flux, phi_flux, bc):
    rng = np.random.default_rng(8)
    bc = bc[:2] + ("periodic",) * 2
    cfg = _split_config(16, 1, reconstruction="minmod", flux=flux, phi_flux=phi_flux, bc=bc)
    q = random_state(cfg.layout, rng, wet_dry=True)
    # two sweeps (see the 2D test: longer chains test round-off)
    a, b, _, _ = _sweeps(cfg, q, (0, 0))
    assert _rel(cfg, a, b).max() < 1e-12


def test_sweeps_from_a_stability_pass_on_a_partial_active_range_match_reference(ti_cpu):
    """The paths a run takes and the tests above do not: the first sweep of a step reuses the
    primitives of the stability pass (no ghosts or primitives recomputed), and the active
    range covers only the wet part of the chute (the budget then books no x faces). Walls on
    a slope: the ghost cells' mirrored source."""
    from tiseg.solver.numerics.operator import TaichiOperator

    rng = np.random.default_rng(11)
    cfg = _split_config(20, 6, reconstruction="minmod", bc=BOUNDARIES[1], flux="central-upwind")
    q = random_state(cfg.layout, rng, wet_dry=True)
    lay = cfg.layout
    q[:, : lay.gx + 6] = 0.0  # dry outside x index [gx + 6, gx + 12)
    q[:, lay.gx + 12 :] = 0.0
    op = TaichiOperator(cfg, nslots=2)
    op.set(0, q)
    op.reset_budget()
    op.set_active(lay.gx + 2, lay.gx + 16)
    t = 0.05
    op.stability(0, t)
    assert op._prepared == (0, op.state.times(t), op.active)  # the sweep's "fresh" path
    ref = ReferenceOperator(cfg)
    qr = q.copy()
    for d in (0, 1):
        op.sweep(d, t, DT)
        hancock_sweep(ref, qr, t, DT, d)
    a = op.get(0)
    assert _rel(cfg, a, qr).max() < 1e-12
    assert np.abs(a[0]).sum() > 0 and np.abs(op.budget(0)).max() == 0.0


def test_draining_keeps_h_nonnegative_where_the_plain_update_would_not(ti_cpu):
    """On the wet-dry states the unscaled update (no draining, no limiter) of the twin empties
    cells below zero along x; with the draining factor the sweeps keep h >= 0 before any
    limiter, along x and along y (the kernels follow the twin: tests above)."""
    rng = np.random.default_rng(7)
    cfg = _split_config(14, 9, reconstruction="minmod", bc=BOUNDARIES[1], flux="central-upwind")
    q = random_state(cfg.layout, rng, wet_dry=True)
    ref = ReferenceOperator(cfg)
    ix, iy = cfg.layout.interior()
    plain = q.copy()
    hancock_sweep(ref, plain, 0.05, DT, 0, drain=False, limit=False)  # (u >> v: along x)
    assert plain[0][ix, iy].min() < -1e-4, "no cell overdrains: the test lost its point"
    for d in (0, 1):
        drained = q.copy()
        hancock_sweep(ref, drained, 0.05, DT, d, limit=False)
        # h >= 0 up to the round-off of h - h theta / theta
        assert drained[0][ix, iy].min() >= -1e-18


def test_predictor_fallback_is_exercised(ti_cpu):
    """Some predicted edges of the wet-dry states would be negative: the fallback changes the
    result there (and the kernels follow the twin with it, test above)."""
    rng = np.random.default_rng(7)
    cfg = _split_config(14, 9, reconstruction="minmod", bc=BOUNDARIES[1], flux="central-upwind")
    q = random_state(cfg.layout, rng, wet_dry=True)
    ref = ReferenceOperator(cfg)
    a, b = q.copy(), q.copy()
    hancock_sweep(ref, a, 0.05, DT, 0)
    hancock_sweep(ref, b, 0.05, DT, 0, fallback=False)
    assert np.abs(a - b).max() > 1e-6 * np.abs(a).max()
