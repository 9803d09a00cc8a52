"""A scene that switches an effect off pays nothing for it: no field, no kernel code.

"No kernel code" is proven by poisoning: the run-time parameters that only a switched-off term
would read are set to NaN. If any code of that term were still compiled in (even multiplied by
zero) the NaN would reach the result; with the term compiled out (``ti.static``) the result stays
finite and unchanged. The same poisoning with the effect on must reach the result, which shows
the test can fail.
"""

import math

import numpy as np
import pytest

from solver_helpers import make_config, random_state
from tiseg.model.physics.pointwise import Params, slot_bases


def _rhs(cfg, q, poison=(), value=math.nan):
    from tiseg.solver.numerics.operator import TaichiOperator

    op = TaichiOperator(cfg, nslots=2)
    for idx in poison:
        op.par[0, idx] = value
    op.set(0, q)
    op.rhs(0, 1, 0.05)
    ix, iy = cfg.layout.interior()
    return op.get(1)[:, ix, iy], op


def _state(cfg, seed=0):
    return random_state(cfg.layout, np.random.default_rng(seed), smooth=True)


POISONS = (math.nan, math.inf)  # a number that reaches a result makes it non-finite


def _friction_slots(cfg):
    """Indices of the friction law's own numbers in the parameter field."""
    b = slot_bases(cfg)
    return list(range(b["friction"], b["end"]))


def test_viscosity_off_has_no_viscous_code(ti_cpu):
    """Without viscosity the parameter field has no nu slot (nothing the kernels could read);
    with it, nu is one slot and nu = inf makes every viscous face coefficient inf/inf = NaN."""
    off = make_config(8, 6, viscous=False, bc=("periodic",) * 4)
    assert "viscosity" not in slot_bases(off)
    r, _ = _rhs(off, _state(off))
    assert np.isfinite(r).all()
    on = make_config(8, 6, viscous=True, bc=("periodic",) * 4)
    assert slot_bases(on)["friction"] == slot_bases(off)["friction"] + 1
    r_on, _ = _rhs(on, _state(on), poison=[slot_bases(on)["viscosity"]], value=math.inf)
    assert not np.isfinite(r_on).all()


@pytest.mark.slow  # a long run: the slow set (README), which CI runs after the suite
def test_friction_none_has_no_friction_code(ti_cpu):
    """Without friction the parameter field has no friction numbers at all; with a law, each
    of its numbers reaches the result (poisoned with NaN, one at a time)."""
    off = make_config(8, 6, friction="none", bc=("periodic",) * 4)
    r, op = _rhs(off, _state(off))
    # the common numbers, the linear transport function's 1 - alpha and nu, nothing else
    assert np.isfinite(r).all() and op.par.shape == (1, Params.COUNT + 2)
    for law in ("pouliquen-mixture", "pouliquen-extended", "coulomb", "pouliquen-small"):
        on = make_config(8, 6, friction=law, bc=("periodic",) * 4)
        q = _state(on)
        lay = on.layout
        q[lay.HU, :, ::2] *= 1e-3  # slow cells too: the extended law's intermediate regime
        _, op = _rhs(on, q)
        ix, iy = lay.interior()
        for k in _friction_slots(on):
            # NaN, or inf where a NaN would only fail a comparison (beta*: max(Fr, NaN) = Fr)
            reach = []
            keep = op.par[0, k]
            for v in POISONS:
                op.par[0, k] = v
                op.set(0, q)
                op.rhs(0, 1, 0.05)
                reach.append(not np.isfinite(op.get(1)[:, ix, iy]).all())
            op.par[0, k] = keep
            assert any(reach), (law, k)


def test_one_friction_law_compiles_no_other(ti_cpu):
    """A scene's law reads only its own slots: the extended law's numbers (start angles, beta*,
    kappa) are not in a mixture run's parameter field, and the mixture's rhs is the same
    whatever numbers sit in the slots after its own."""
    mix = make_config(8, 6, friction="pouliquen-mixture", bc=("periodic",) * 4)
    ext = make_config(8, 6, friction="pouliquen-extended", bc=("periodic",) * 4)
    assert len(_friction_slots(mix)) == 8 and len(_friction_slots(ext)) == 12
    q = _state(mix)
    r_mix, op = _rhs(mix, q)
    assert op.par.shape == (1, Params.COUNT + 2 + 8)
    # the extended law in its dynamic regime (every Froude number above beta*) is (3.4), (3.7)
    r_ext, _ = _rhs(ext, q)
    w_fr = _froude(mix, q)
    if (w_fr >= ext.fric.beta_star).all():
        assert np.allclose(r_ext, r_mix, rtol=1e-13, atol=1e-15)
    else:
        assert not np.array_equal(r_ext, r_mix)


@pytest.mark.parametrize("transport", ["linear", "bagnold"])
def test_segregation_off_has_no_transport_code(ti_cpu, transport):
    """Without segregation there is no phi field and no transport slot; with it, the linear
    function's 1 - alpha reaches the result (poisoned with NaN) and the Bagnold function has
    no slot at all (the friction law's numbers follow the common ones directly)."""
    kw = dict(transport=transport, viscous=False, bc=("periodic",) * 4)
    off = make_config(8, 6, segregation=False, **kw)
    b = slot_bases(off)
    assert "transport" not in b and b["friction"] == Params.COUNT
    on = make_config(8, 6, **kw)
    b = slot_bases(on)
    assert b["friction"] - b["transport"] == (1 if transport == "linear" else 0)
    if transport == "linear":
        r, _ = _rhs(on, _state(on), poison=[b["transport"]])
        assert not np.isfinite(r).all()
        r_clean, _ = _rhs(on, _state(on))
        assert np.isfinite(r_clean).all()


def _froude(cfg, q):
    lay = cfg.layout
    ix, iy = lay.interior()
    h = q[lay.H][ix, iy]
    spd = np.hypot(q[lay.HU][ix, iy], q[lay.HV][ix, iy]) / h
    return spd / np.sqrt(cfg.g_cos * h)


def test_feedback_off_friction_ignores_phi(ti_cpu):
    """Without mobility feedback the momentum equations do not depend on the local phi."""
    cfg = make_config(8, 6, feedback=False, bc=("periodic",) * 4)
    q = _state(cfg)
    r1, _ = _rhs(cfg, q)
    q2 = q.copy()
    q2[cfg.layout.HPHI] = q[cfg.layout.H] * 0.1  # a very different concentration
    r2, _ = _rhs(cfg, q2)
    lay = cfg.layout
    for c in (lay.H, lay.HU, lay.HV):
        assert np.array_equal(r1[c], r2[c])
    cfg_on = make_config(8, 6, feedback=True, bc=("periodic",) * 4)
    r3, _ = _rhs(cfg_on, q)
    r4, _ = _rhs(cfg_on, q2)
    assert not np.array_equal(r3[lay.HU], r4[lay.HU])


def test_disabled_effects_allocate_no_fields(ti_cpu):
    # segregation off: three components, no phi anywhere
    _, op = _rhs(make_config(8, 6, segregation=False, bc=("periodic",) * 4), np.zeros((3, 12, 10)))
    assert op.q.n == 3 and op.w.n == 3 and op.HPHI == -1
    # 1D: no v component, no y slopes or y fluxes
    cfg1 = make_config(8, 1, bc=("periodic",) * 4)
    _, op1 = _rhs(cfg1, _state(cfg1))
    assert op1.q.n == 3 and not hasattr(op1, "fy") and not hasattr(op1, "sy")
    assert op1.q.shape[2] == 1  # no ghost rows in y
    # first order: no slope fields at all
    cfg0 = make_config(8, 6, reconstruction="first-order", bc=("periodic",) * 4)
    _, op0 = _rhs(cfg0, _state(cfg0))
    assert op0.sx is None and op0.sy is None


def test_1d_run_equals_y_independent_2d_run(ti_cpu):
    """T11: a y-independent 2D state evolves exactly like the 1D run (no cross-slope work
    is needed to get the same answer)."""
    cfg1 = make_config(12, 1, bc=("inflow", "outflow", "periodic", "periodic"), inflow_delta=0.0)
    cfg2 = make_config(12, 5, bc=("inflow", "outflow", "periodic", "periodic"), inflow_delta=0.0)
    q1 = _state(cfg1, 3)
    lay2 = cfg2.layout
    q2 = np.zeros((lay2.nc, lay2.NX, lay2.NY))
    q2[lay2.H] = q1[0][:, :1]
    q2[lay2.HU] = q1[1][:, :1]
    q2[lay2.HPHI] = q1[2][:, :1]
    r1, _ = _rhs(cfg1, q1)
    r2, _ = _rhs(cfg2, q2)
    for c1, c2 in ((0, lay2.H), (1, lay2.HU), (2, lay2.HPHI)):
        for j in range(r2.shape[2]):
            assert np.allclose(r2[c2][:, j], r1[c1][:, 0], rtol=1e-13, atol=1e-300)
    assert np.abs(r2[lay2.HV]).max() == 0.0
