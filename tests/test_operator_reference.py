"""The Taichi operator equals the plain NumPy reference of the same semi-discrete operator.

With fast_math off and f64, both evaluate the same formulas; they may differ only by the order
of floating-point operations, so the relative difference must be at round-off level (~1e-12).
"""
import itertools

import numpy as np
import pytest

from solver_helpers import make_config, random_state
from tiseg.reference import ReferenceOperator

RECONSTRUCTIONS = ("first-order", "minmod", "weno")
BOUNDARIES = [("inflow", "outflow", "periodic", "periodic"), ("wall", "wall", "wall", "wall"),
              ("periodic", "periodic", "outflow", "wall")]


def _compare(cfg, q, t=0.05):
    from tiseg.numerics.operator import TaichiOperator
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


@pytest.mark.parametrize("effects", [
    dict(segregation=False, viscous=False, friction="coulomb"),
    dict(segregation=True, viscous=False, friction="none", feedback=False),
    dict(segregation=True, viscous=True, friction="pouliquen-small", feedback=False),
    dict(segregation=True, viscous=True, friction="pouliquen-large", feedback=False),
])
def test_taichi_matches_reference_effects(ti_cpu, effects):
    rng = np.random.default_rng(3)
    seg = effects.pop("segregation")
    cfg = make_config(10, 8, segregation=seg, reconstruction="minmod",
                      bc=("periodic", "periodic", "wall", "outflow"), **effects)
    q = random_state(cfg.layout, rng, wet_dry=True)
    rel, _ = _compare(cfg, q)
    assert rel.max() < 1e-12, rel


def test_inflow_noise_reaches_the_inflow_cells_as_in_the_reference(ti_cpu):
    """inflow.noise: the Taichi operator's inflow ghost cells carry the same random profile as
    the reference (both from tiseg.numerics.config.inflow_concentration), and it changes the
    rates: the inflow column's h phi rate differs from the run without noise."""
    rng = np.random.default_rng(4)
    cfg = make_config(12, 16, reconstruction="weno", bc=BOUNDARIES[0], Ly=0.2, dy=0.2 / 16,
                      inflow_noise=0.05, inflow_seed=11)
    q = random_state(cfg.layout, rng, smooth=True)
    rel, _ = _compare(cfg, q)
    assert rel.max() < 1e-12, rel
    quiet = make_config(12, 16, reconstruction="weno", bc=BOUNDARIES[0], Ly=0.2, dy=0.2 / 16)
    ref = ReferenceOperator(cfg)
    a, b = ref.rhs(q.copy(), 0.05), ReferenceOperator(quiet).rhs(q.copy(), 0.05)
    gx = cfg.layout.gx
    assert np.abs(a[cfg.layout.HPHI, gx] - b[cfg.layout.HPHI, gx]).max() > 1e-6
