"""The stiffness estimates that choose RKC's stage count really bound the operator's spectrum.

The viscous part of the operator is linear in the momenta (hu, hv) for frozen h, so its Jacobian
is assembled exactly by finite differences of the NumPy reference; its spectral radius must not
exceed the Gershgorin estimate computed by the Taichi stability kernel, on uniform and on wet/dry
states (where the harmonic face coefficients matter: an arithmetic mean divided by a tiny
neighbouring h makes the viscous operator far stiffer at margins). The same holds for the
viscous and friction terms together (the estimate RKC's stage count uses), on states with slow
margins where the friction is stiffest.
"""

import dataclasses

import numpy as np
import pytest

from solver_helpers import make_config, random_state
from tiseg.solver.reference import ReferenceOperator


def _viscous_jacobian(cfg, q, friction=False):
    """Jacobian in (hu[, hv]) of the viscous term (and with ``friction`` the friction term too):
    the operator less the same operator without them (fluxes and gravity cancel)."""
    lay = cfg.layout
    on = ReferenceOperator(cfg)
    off = ReferenceOperator(
        dataclasses.replace(cfg, viscous=False, **({"friction": "none"} if friction else {}))
    )
    ix, iy = lay.interior()
    comps = [lay.HU] + ([] if lay.is_1d else [lay.HV])
    cells = [
        (c, i, j) for c in comps for i in range(ix.start, ix.stop) for j in range(iy.start, iy.stop)
    ]

    def visc(qq):
        return on.rhs(qq.copy(), 0.0) - off.rhs(qq.copy(), 0.0)

    base = visc(q)
    J = np.zeros((len(cells), len(cells)))
    for col, (c, i, j) in enumerate(cells):
        e = 1e-9 * max(abs(q[lay.H, i, j]), 1e-3)
        qp = q.copy()
        qp[c, i, j] += e
        d = (visc(qp) - base) / e
        J[:, col] = [d[c2, i2, j2] for (c2, i2, j2) in cells]
    return J


@pytest.mark.parametrize("ny,wet_dry", [(1, False), (1, True), (6, False), (6, True)])
def test_gershgorin_bounds_viscous_spectrum(ti_cpu, ny, wet_dry):
    from tiseg.solver.numerics.operator import TaichiOperator

    cfg = make_config(
        8, ny, bc=("periodic",) * 4, friction="none", nu=0.01, dx=0.002, dy=0.0025, Ly=ny * 0.0025
    )
    rng = np.random.default_rng(7)
    q = random_state(cfg.layout, rng, wet_dry=wet_dry)
    J = _viscous_jacobian(cfg, q)
    rho_true = np.abs(np.linalg.eigvals(J)).max()
    op = TaichiOperator(cfg, nslots=2)
    op.set(0, q)
    est = op.stability(0, 0.0).rho_visc
    assert rho_true > 0
    assert est >= rho_true * (1 - 1e-6), (est, rho_true)
    # and it is not wastefully loose on a uniform state (RKC stages grow like sqrt(rho))
    if not wet_dry:
        assert est <= 3.0 * rho_true, (est, rho_true)


@pytest.mark.parametrize("ny", [1, 6])
def test_gershgorin_bounds_viscous_and_friction_spectrum(ti_cpu, ny):
    """Slow margins (|u| below and just above u_eps: the stiffest friction) beside fast thick
    cells (the stiffest viscosity): the per-cell sum bounds the joint spectrum and is clearly
    below the sum of the two separate maxima, which it replaces in the stage count."""
    from tiseg.solver.numerics.operator import TaichiOperator

    cfg = make_config(10, ny, bc=("periodic",) * 4, nu=0.01, dx=0.0015, dy=0.0015, Ly=ny * 0.0015)
    lay = cfg.layout
    rng = np.random.default_rng(11)
    q = random_state(lay, rng)
    ix, iy = lay.interior()
    slow = slice(ix.start, ix.start + 3)  # a thin, nearly static levee ...
    q[lay.H, slow] = 6e-4
    speed = np.array([4e-4, 2e-3, 8e-4])[:, None] * (1 + 0.2 * rng.random((3, lay.NY)))
    q[lay.HU, slow] = q[lay.H, slow] * speed
    if not lay.is_1d:
        q[lay.HV, slow] = q[lay.H, slow] * 0.3 * speed
    thick = slice(ix.start + 5, ix.stop - 2)  # ... and a thick channel, not next to it
    for c in range(lay.nc):
        q[c, thick] *= 2.0
    J = _viscous_jacobian(cfg, q, friction=True)
    rho_true = np.abs(np.linalg.eigvals(J)).max()
    op = TaichiOperator(cfg, nslots=2)
    op.set(0, q)
    st = op.stability(0, 0.0)
    assert st.rho_stiff >= rho_true * (1 - 1e-6), (st.rho_stiff, rho_true)
    assert st.rho_stiff < 0.9 * (st.rho_visc + st.rho_fric), st  # 0.80-0.83 here
    assert st.rho_stiff >= max(st.rho_visc, st.rho_fric)
