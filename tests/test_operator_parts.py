"""The operator's state object and its collaborators, each on its own (issue 49).

`OperatorState` owns every field, slot and range; the collaborators (`GhostCells`,
`RestRules`, `FiniteVolume`, `SlotAlgebra`, `SplitSweeps`, `StepReductions`) receive it and hold
no field of their own, so a feature that adds a field (a bed height, a member axis) adds it in
one place. The run's `StateArrays` works on the state and the reductions alone."""

import numpy as np
import pytest
from solver_helpers import make_config


def _field_attrs(obj) -> list[str]:
    import taichi as ti

    return [k for k, v in vars(obj).items() if isinstance(v, (ti.Field, ti.MatrixField))]


def _state(cfg, nslots=3):
    from tiseg.solver.numerics.reductions import StepReductions
    from tiseg.solver.numerics.state import OperatorState

    st = OperatorState(cfg, nslots, None)
    red = StepReductions(st)
    st.finalize()
    st.set_active(st.gx, st.gx + st.nx)
    st.set_params(cfg)
    return st, red


def test_the_state_alone_holds_slots_params_and_caches(ti_cpu):
    cfg = make_config(8, 6)
    st, _ = _state(cfg)
    q = np.random.default_rng(0).random((st.nc, st.NX, st.NY))
    st.set(1, q)
    assert np.array_equal(st.get(1), q.astype(st.np_fp))
    assert st.active == (st.gx, st.gx + st.nx) and st.wet_range == st.active
    # what the scratch fields hold follows the writes
    st.prepared = (1, st.times(0.0), st.active)  # the key: each member's time
    assert st.fresh(1, 0.0) == 2 and st.fresh(1, 0.5) == 1 and st.fresh(0, 0.0) == 0
    st.written(1)
    assert st.prepared is None and st.fresh(1, 0.0) == 0
    st.written(2, primitives=True)
    assert st.interior == (2, st.active) and st.fresh(2, 0.3) == 1 and st.rest_stale is True
    st.reset_budget([1.0, 2.0, 3.0, 4.0])
    assert list(st.budget(0)) == [1.0, 2.0, 3.0, 4.0]


def test_the_reductions_alone_sum_a_state_in_a_fixed_order(ti_cpu):
    cfg = make_config(8, 6)
    st, red = _state(cfg)
    rng = np.random.default_rng(1)
    q = rng.random((st.nc, st.NX, st.NY))
    st.set(0, q)
    ix, iy = cfg.layout.interior()
    h, hphi = red.totals(0, serial=True)
    assert h == pytest.approx(q[st.H][ix, iy].sum(), rel=1e-14)
    assert hphi == pytest.approx(q[st.HPHI][ix, iy].sum(), rel=1e-14)
    assert (h, hphi) == red.totals(0, serial=False)  # the same bits on any thread count


def test_the_state_arrays_alone_round_trip_primitive_fields(ti_cpu):
    from tiseg.run.state_access import StateArrays

    cfg = make_config(8, 6)
    st, red = _state(cfg)
    arrays = StateArrays(st, lambda slot: red.totals(slot, True), st.budget, cfg.dx, cfg.dy)
    lay = cfg.layout
    rng = np.random.default_rng(2)
    h = rng.random((lay.ny, lay.nx)) + 0.1
    u, v, phi = rng.random(h.shape), rng.random(h.shape), rng.random(h.shape)
    arrays.set_conserved(arrays.from_primitives(h, u, v, phi, 0.5))
    f = arrays.fields()
    for name, a in (("h", h), ("u", u), ("v", v), ("phi", phi)):
        assert np.allclose(f[name], a, rtol=1e-13), name
    assert arrays.totals()["mass"] == pytest.approx(h.sum() * cfg.dx * cfg.dy, rel=1e-13)
    assert arrays.budget() == {"mass_in": 0.0, "small_mass_in": 0.0}


@pytest.mark.parametrize("split", [False, True])
def test_the_state_is_the_one_owner_of_fields(ti_cpu, split):
    from tiseg.solver.numerics.operator import TaichiOperator

    kw = dict(split=True, friction_scheme="projected", phi_flux="upwind") if split else {}
    op = TaichiOperator(make_config(8, 6, **kw), nslots=3)
    assert op.state.split == split and (op.state.rest is not None) == split
    parts = (op.ghosts, op.rules, op.fv, op.slots, op.sweeps, op.reduce)
    assert all(p.state is op.state for p in parts)
    assert [(type(p).__name__, _field_attrs(p)) for p in (op, *parts)] == [
        (type(p).__name__, []) for p in (op, *parts)
    ]
    # the state's names stay reachable from the operator, read-only
    assert op.q is op.state.q and op.par is op.state.par and op.cfg is op.state.cfg
    with pytest.raises(AttributeError):
        op.q = None
