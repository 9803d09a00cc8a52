"""The Taichi operator equals the plain NumPy reference of the same semi-discrete operator.

With fast_math off and f64, both evaluate the same formulas; they may differ only by the order
of floating-point operations, so the relative difference must be at round-off level (~1e-12).
"""

import itertools

import numpy as np
import pytest

from solver_helpers import local_rate_twin, make_config, random_state
from tiseg.solver.reference import ReferenceOperator

RECONSTRUCTIONS = ("first-order", "minmod", "weno")
BOUNDARIES = [
    ("inflow", "outflow", "periodic", "periodic"),
    ("wall", "wall", "wall", "wall"),
    ("periodic", "periodic", "outflow", "wall"),
]


def _compare(cfg, q, t=0.05):
    from tiseg.solver.numerics.operator import TaichiOperator

    op = TaichiOperator(cfg, nslots=2)
    ref = ReferenceOperator(cfg)
    op.set(0, q)
    op.rhs(0, 1, t)
    a = op.get(1)
    b = ref.rhs(q.copy(), t)
    ix, iy = cfg.layout.interior()
    diff = np.abs(a - b)[:, ix, iy].max(axis=(1, 2))
    scale = np.abs(b)[:, ix, iy].max(axis=(1, 2))
    return diff / np.where(scale > 0, scale, 1.0), scale


@pytest.mark.parametrize("rec", RECONSTRUCTIONS)
@pytest.mark.parametrize("state", ["smooth", "wet-dry"])
def test_taichi_matches_reference_2d(ti_cpu, rec, state):
    rng = np.random.default_rng(1)
    cfg = make_config(14, 9, reconstruction=rec, bc=BOUNDARIES[0])
    q = random_state(cfg.layout, rng, wet_dry=state == "wet-dry", smooth=state == "smooth")
    rel, scale = _compare(cfg, q)
    assert np.all(scale > 0), "every component must be exercised"
    assert rel.max() < 1e-12, rel


@pytest.mark.parametrize("rec,bc", list(itertools.product(RECONSTRUCTIONS, BOUNDARIES)))
def test_taichi_matches_reference_boundaries_1d(ti_cpu, rec, bc):
    rng = np.random.default_rng(2)
    cfg = make_config(16, 1, reconstruction=rec, bc=bc)
    q = random_state(cfg.layout, rng, wet_dry=True)
    rel, _ = _compare(cfg, q)
    assert rel.max() < 1e-12, rel


@pytest.mark.parametrize(
    "effects",
    [
        dict(segregation=False, viscous=False, friction="coulomb"),
        dict(segregation=True, viscous=False, friction="none", feedback=False),
        dict(segregation=True, viscous=True, friction="pouliquen-small", feedback=False),
        dict(segregation=True, viscous=True, friction="pouliquen-large", feedback=False),
    ],
)
def test_taichi_matches_reference_effects(ti_cpu, effects):
    rng = np.random.default_rng(3)
    seg = effects.pop("segregation")
    cfg = make_config(
        10,
        8,
        segregation=seg,
        reconstruction="minmod",
        bc=("periodic", "periodic", "wall", "outflow"),
        **effects,
    )
    q = random_state(cfg.layout, rng, wet_dry=True)
    rel, _ = _compare(cfg, q)
    assert rel.max() < 1e-12, rel


def test_inflow_noise_reaches_the_inflow_cells_as_in_the_reference(ti_cpu):
    """inflow.noise: the Taichi operator's inflow ghost cells carry the same random profile as
    the reference (both from tiseg.solver.numerics.config.inflow_concentration), and it changes the
    rates: the inflow column's h phi rate differs from the run without noise."""
    rng = np.random.default_rng(4)
    cfg = make_config(
        12,
        16,
        reconstruction="weno",
        bc=BOUNDARIES[0],
        Ly=0.2,
        dy=0.2 / 16,
        inflow_noise=0.05,
        inflow_seed=11,
    )
    q = random_state(cfg.layout, rng, smooth=True)
    rel, _ = _compare(cfg, q)
    assert rel.max() < 1e-12, rel
    quiet = make_config(12, 16, reconstruction="weno", bc=BOUNDARIES[0], Ly=0.2, dy=0.2 / 16)
    ref = ReferenceOperator(cfg)
    a, b = ref.rhs(q.copy(), 0.05), ReferenceOperator(quiet).rhs(q.copy(), 0.05)
    gx = cfg.layout.gx
    assert np.abs(a[cfg.layout.HPHI, gx] - b[cfg.layout.HPHI, gx]).max() > 1e-6


@pytest.mark.parametrize(
    "flux,phi_flux",
    [("kt", "central"), ("central-upwind", "central"), ("central-upwind", "upwind")],
)
@pytest.mark.parametrize("rec", ("minmod", "weno"))
@pytest.mark.parametrize("state", ["smooth", "wet-dry"])
def test_taichi_matches_reference_flux_options(ti_cpu, flux, phi_flux, rec, state):
    """numerics.flux and numerics.phi_flux: the central-upwind flux and the h phi flux upwinded
    by the mass flux equal their NumPy twins to round-off, 2D with an inflow, and in 1D."""
    rng = np.random.default_rng(5)
    cfg = make_config(14, 9, reconstruction=rec, bc=BOUNDARIES[0], flux=flux, phi_flux=phi_flux)
    q = random_state(cfg.layout, rng, wet_dry=state == "wet-dry", smooth=state == "smooth")
    rel, scale = _compare(cfg, q)
    assert np.all(scale > 0)
    assert rel.max() < 1e-12, rel
    cfg1 = make_config(16, 1, reconstruction=rec, bc=BOUNDARIES[1], flux=flux, phi_flux=phi_flux)
    rel, _ = _compare(cfg1, random_state(cfg1.layout, rng, wet_dry=state == "wet-dry"))
    assert rel.max() < 1e-12, rel


def test_flux_options_change_the_rates():
    """The options are real: on the same smooth state the central-upwind flux changes every
    component and the upwind h phi flux changes the h phi rate alone (the reference operator's
    mass and momentum fluxes are the scheme's own)."""
    import dataclasses

    rng = np.random.default_rng(6)
    base = make_config(14, 9, reconstruction="weno", bc=BOUNDARIES[0], phi_flux="central")
    q = random_state(base.layout, rng, smooth=True)
    r0 = ReferenceOperator(base).rhs(q.copy(), 0.05)
    rel = lambda r: [
        float(np.abs(r[k] - r0[k]).max() / np.abs(r0[k]).max())  # noqa: E731
        for k in range(base.layout.nc)
    ]
    up = rel(ReferenceOperator(dataclasses.replace(base, phi_flux="upwind")).rhs(q.copy(), 0.05))
    assert up[:3] == [0.0, 0.0, 0.0] and up[3] > 1e-2
    cu = rel(
        ReferenceOperator(dataclasses.replace(base, flux="central-upwind")).rhs(q.copy(), 0.05)
    )
    assert min(cu) > 1e-2


@pytest.mark.parametrize(
    "flux,phi_flux", [("kt", "central"), ("central-upwind", "upwind")], ids=["kt", "cu-upwind"]
)
@pytest.mark.parametrize("state", ["smooth", "wet-dry"])
def test_bagnold_transport_matches_reference(ti_cpu, flux, phi_flux, state):
    """material.transport = "bagnold" (2.18): the Taichi G, G' (c sqrt(c) with c = 1 - phi
    clamped at 0) equal the NumPy twin to round-off, in the flux, the wave speeds and the
    upwinded h phi flux, 2D with an inflow and 1D between walls; states with phi at 0 and 1
    exactly (wet-dry) are included."""
    rng = np.random.default_rng(7)
    kw = dict(reconstruction="weno", flux=flux, phi_flux=phi_flux, transport="bagnold")
    cfg = make_config(14, 9, bc=BOUNDARIES[0], **kw)
    q = random_state(cfg.layout, rng, wet_dry=state == "wet-dry", smooth=state == "smooth")
    lay = cfg.layout
    q[lay.HPHI, :, ::3] = q[lay.H, :, ::3]  # pure small grains: phi = 1, G = 0, G' = -2/3
    q[lay.HPHI, ::4] = 0.0  # pure large grains: phi = 0, G = 0, G' = 1
    rel, scale = _compare(cfg, q)
    assert np.all(scale > 0)
    assert rel.max() < 1e-12, rel
    cfg1 = make_config(16, 1, bc=BOUNDARIES[1], **kw)
    rel, _ = _compare(cfg1, random_state(cfg1.layout, rng, wet_dry=state == "wet-dry"))
    assert rel.max() < 1e-12, rel


def test_transport_function_changes_the_phi_rate():
    """The transport function is a real choice: on the same smooth state the Bagnold G changes
    the h phi rate by more than 1 % of its largest value (the other rates change only through
    the segregation wave speed in the KT dissipation, where it exceeds |u| + c)."""
    import dataclasses

    rng = np.random.default_rng(8)
    base = make_config(14, 9, reconstruction="weno", bc=BOUNDARIES[0], phi_flux="upwind")
    q = random_state(base.layout, rng, smooth=True)
    r0 = ReferenceOperator(base).rhs(q.copy(), 0.05)
    r1 = ReferenceOperator(dataclasses.replace(base, transport="bagnold")).rhs(q.copy(), 0.05)
    lay = base.layout
    assert np.abs(r1[lay.HPHI] - r0[lay.HPHI]).max() > 1e-2 * np.abs(r0[lay.HPHI]).max()


@pytest.mark.parametrize("bc", [BOUNDARIES[0], BOUNDARIES[1]])
@pytest.mark.parametrize("state", ["smooth", "wet-dry"])
def test_local_step_rate_matches_reference(ti_cpu, bc, state):
    """The stability pass's rate of step_rule "local" equals its NumPy twin: over the rows of
    the interior and the columns it scans (the interior and the first ghost column either side),
    the largest max(a_x over i-1..i+1) / dx + max(a_y over j-1..j+1) / dy, with the reference's
    ghost cells, primitives and characteristic speeds (segregation speed included); the x and y
    maxima, which it now reads from the same stored speeds, stay those of the reference."""
    from tiseg.solver.numerics.operator import TaichiOperator

    rng = np.random.default_rng(4)
    cfg = make_config(14, 9, bc=bc, local_step_rate=True)
    q = random_state(cfg.layout, rng, wet_dry=state == "wet-dry", smooth=state == "smooth")
    op = TaichiOperator(cfg, nslots=2)
    op.set(0, q)
    stab = op.stability(0, 0.05)
    ref = ReferenceOperator(cfg)
    qr = q.copy()
    ref.fill_ghosts(qr, 0.05)
    w = ref.primitives(qr)
    ax, ay = ref.speed(w, 0), ref.speed(w, 1)
    lay = cfg.layout
    i = slice(lay.gx - 1, lay.gx + lay.nx + 1)
    j = slice(lay.gy, lay.gy + lay.ny)
    around = (slice(i.start - 1, i.stop + 1), slice(j.start - 1, j.stop + 1))
    twin = local_rate_twin(ax[around], ay[around], cfg.dx, cfg.dy)
    assert stab.rate_local == pytest.approx(twin, rel=1e-12)
    assert stab.ax == pytest.approx(ax[i, j].max(), rel=1e-12)
    assert stab.ay == pytest.approx(ay[i, j].max(), rel=1e-12)
    # not the sum of the global maxima: the test would pass a rule that ignored locality
    assert twin < 0.999 * (stab.ax / cfg.dx + stab.ay / cfg.dy)
