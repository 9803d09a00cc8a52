"""The split scheme's sweeps (tiseg.numerics.split) equal their NumPy twin
(tiseg.reference.split) to round-off: the predictor, its dry-edge fallback, the face fluxes,
the draining-time scaling, the source at mid-step, the limiter and the boundary budget."""

import numpy as np
import pytest

from solver_helpers import make_config, random_state
from tiseg.reference import ReferenceOperator
from tiseg.reference.split import hancock_sweep

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
    from tiseg.numerics.operator import TaichiOperator

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
    a, b, bud, (mass, small) = _sweeps(cfg, q, (0, 1, 1, 0))
    assert _rel(cfg, a, b).max() < 1e-12
    assert np.all(a[0] >= 0.0)
    assert abs((bud[0] + bud[2]) - mass) <= 1e-12 * max(abs(mass), 1e-9)
    assert abs((bud[1] + bud[3]) - small) <= 1e-12 * max(abs(small), 1e-9)
    # and the budget closes the books: what the cells gained entered through the faces
    ix, iy = cfg.layout.interior()
    gained = (a[0][ix, iy].sum() - q[0][ix, iy].sum()) * cfg.dx * cfg.dy
    assert abs(gained - mass) <= 1e-12 * max(abs(q[0][ix, iy]).sum() * cfg.dx * cfg.dy, 1e-12)


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
    # two sweeps: they drain cells to h = 0 in the twin and to a few ulps in the kernels (the
    # same formulas, contracted differently by the compiler), and a third sweep's draining
    # decision at such a cell is then a coin toss of round-off
    a, b, _, _ = _sweeps(cfg, q, (0, 0))
    assert _rel(cfg, a, b).max() < 1e-12


def test_draining_keeps_h_nonnegative_where_the_plain_update_would_not(ti_cpu):
    """On the wet-dry states the unscaled update (no draining, no limiter) empties cells below
    zero; with the draining factor the sweep keeps h >= 0 before any limiter, and the kernels
    agree with that twin."""
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
