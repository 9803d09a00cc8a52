"""A bed under the flow (tiseg.solver.numerics.bed): the hydrostatic reconstruction keeps a
lake at rest with emerged islands to round-off, and the kernels equal their NumPy twin
(tiseg.solver.reference.bed) on random wet-dry states over a random bed."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from tests.solver_helpers import assert_equals_twin, make_config, random_state, stage_and_twin

WALLS = ("wall", "wall", "periodic", "periodic")


def _bed(lay, dx, dy, rng=None):
    """A smooth bed with a bump that rises 2 mm above a 3 mm lake, and ripples."""
    x = (np.arange(lay.nx) + 0.5) * dx
    y = (np.arange(lay.ny) + 0.5) * dy
    X, Y = np.meshgrid(x, y, indexing="ij")
    b = 0.005 * np.exp(-(((X - 0.2) / 0.05) ** 2)) + 0.001 * np.sin(30 * X) + 5e-4 * np.cos(50 * Y)
    if rng is not None:
        b = b + 2e-4 * rng.standard_normal(b.shape)
    return b


def _lake(cfg, b, level=0.003):
    lay = cfg.layout
    q = np.zeros((lay.nc, lay.NX, lay.NY))
    ix, iy = lay.interior()
    h = np.maximum(level - b, 0.0)
    q[0][ix, iy] = h
    if lay.segregation:
        q[lay.HPHI][ix, iy] = 0.7 * h
    return q, h


@pytest.mark.parametrize(
    "ny, rec", [(1, "first-order"), (1, "minmod"), (1, "weno"), (6, "minmod"), (6, "weno")]
)
def test_a_lake_with_islands_stays_at_rest(ti_cpu, ny, rec):
    """eta = h + b constant, u = 0, emerged islands: every rate vanishes to round-off, in
    front of g cos(zeta) h |grad b| ~ 1e-3 m/s^2 per unit h."""
    from tiseg.solver.numerics.operator import TaichiOperator
    from tiseg.solver.reference import ReferenceOperator

    cfg = make_config(40, ny, bed=True, friction="none", zeta=0.0, bc=WALLS, reconstruction=rec)
    b = _bed(cfg.layout, cfg.dx, cfg.dy)
    q, h = _lake(cfg, b)
    assert (h == 0).sum() >= 7 * ny  # islands
    op = TaichiOperator(cfg, nslots=2)
    op.set_bed(b)
    op.set(0, q)
    op.rhs(0, 1, 0.0)
    r = op.get(1)
    assert np.abs(r).max() < 1e-15
    r_np = ReferenceOperator(cfg, bed=b).rhs(q.copy(), 0.0)
    assert np.abs(r_np).max() < 1e-15


def test_without_the_reconstruction_the_lake_would_move(ti_cpu):
    """The same lake with the bed's source as a plain centred gradient (no hydrostatic
    reconstruction) is not at rest: what the test above checks is not trivially zero."""
    cfg = make_config(40, 1, bed=True, friction="none", zeta=0.0, bc=WALLS)
    b = _bed(cfg.layout, cfg.dx, cfg.dy)
    lay = cfg.layout
    _, h = _lake(cfg, b)
    hh = h[:, 0]
    wet = hh[1:-1] > 0.002
    # pressure gradient against the bed's pull, cell by cell, both centred
    grad_p = 0.5 * cfg.g_cos * (hh[2:] ** 2 - hh[:-2] ** 2) / (2 * cfg.dx)
    pull = -cfg.g_cos * hh[1:-1] * (b[2:, 0] - b[:-2, 0]) / (2 * cfg.dx)
    assert np.abs((pull - grad_p)[wet]).max() > 1e-7
    assert lay.nc == 3


@pytest.mark.parametrize(
    "ny, scheme, rec",
    [
        (1, "regularised", "weno"),
        (1, "projected", "first-order"),
        (5, "regularised", "minmod"),
        (5, "projected", "weno"),
    ],
)
def test_the_kernels_equal_the_twin_over_a_bed(ti_cpu, ny, scheme, rec):
    from tiseg.solver.numerics.operator import TaichiOperator
    from tiseg.solver.reference import ReferenceOperator

    rng = np.random.default_rng(5)
    cfg = make_config(12, ny, bed=True, friction_scheme=scheme, reconstruction=rec)
    b = _bed(cfg.layout, cfg.dx, cfg.dy, rng)
    q = random_state(cfg.layout, rng, wet_dry=True)
    op = TaichiOperator(cfg, nslots=2)
    op.set_bed(b)
    op.set(0, q)
    op.rhs(0, 1, 0.0)
    r_ti = op.get(1)
    r_np = ReferenceOperator(cfg, bed=b).rhs(q.copy(), 0.0)
    ix, iy = cfg.layout.interior()
    scale = np.abs(r_np)[:, ix, iy].max(axis=(1, 2))
    err = np.abs(r_ti - r_np)[:, ix, iy].max(axis=(1, 2))
    assert np.all(err <= 1e-12 * scale), (rec, err, scale)
    # and the bed did act: the rates differ from a flat operator's
    flat = ReferenceOperator(make_config(12, ny, friction_scheme=scheme, reconstruction=rec))
    assert np.abs(flat.rhs(q.copy(), 0.0) - r_np)[1].max() > 1e-3 * scale[1]


SPLIT = dict(split=True, friction_scheme="projected", phi_flux="upwind", viscous=False)


@pytest.mark.parametrize("ny, rec", [(1, "minmod"), (6, "weno")])
def test_a_lake_with_islands_stays_at_rest_under_the_split_sweeps(ti_cpu, ny, rec):
    """Twenty steps of sweeps in both orders: h does not change at all, the momenta stay at
    round-off (1e-19 against the 1e-5 a unbalanced bed would give in one step)."""
    from tiseg.solver.numerics.operator import TaichiOperator

    cfg = make_config(
        40, ny, bed=True, friction="none", zeta=0.0, bc=WALLS, reconstruction=rec, **SPLIT
    )
    b = _bed(cfg.layout, cfg.dx, cfg.dy)
    q, _ = _lake(cfg, b)
    op = TaichiOperator(cfg, nslots=2)
    op.set_bed(b)
    op.set(0, q)
    for k in range(20):
        for d in (0,) if ny == 1 else ((0, 1) if k % 2 == 0 else (1, 0)):
            op.sweep(d, 0.0, 2e-3)
    ix, iy = cfg.layout.interior()
    change = np.abs(op.get(0) - q)[:, ix, iy]
    assert change[0].max() == 0.0
    assert change.max() < 1e-17


@pytest.mark.parametrize(
    "ny, rec, bc",
    [
        (1, "minmod", ("inflow", "outflow", "periodic", "periodic")),
        (9, "minmod", ("wall", "wall", "wall", "wall")),
        (9, "weno", ("periodic", "periodic", "outflow", "wall")),
    ],
)
def test_the_sweeps_equal_the_twin_over_a_bed(ti_cpu, ny, rec, bc):
    from tiseg.solver.numerics.operator import TaichiOperator
    from tiseg.solver.reference import ReferenceOperator
    from tiseg.solver.reference.split import hancock_sweep

    rng = np.random.default_rng(11)
    cfg = make_config(
        14, ny, bed=True, reconstruction=rec, bc=bc, flux="central-upwind", zeta=0.5, **SPLIT
    )
    b = _bed(cfg.layout, cfg.dx, cfg.dy, rng)
    q = random_state(cfg.layout, rng, wet_dry=True)
    ref = ReferenceOperator(cfg, bed=b)
    for dirs in ((0,),) if ny == 1 else ((0, 1), (1, 0)):
        op = TaichiOperator(cfg, nslots=2)
        op.set_bed(b)
        op.set(0, q)
        qr = q.copy()
        for d in dirs:
            op.sweep(d, 0.05, 0.01)
            hancock_sweep(ref, qr, 0.05, 0.01, d)
        ix, iy = cfg.layout.interior()
        a = op.get(0)
        diff = np.abs(a - qr)[:, ix, iy].max(axis=(1, 2))
        scale = np.abs(qr)[:, ix, iy].max(axis=(1, 2))
        assert np.all(diff <= 1e-12 * scale), (dirs, diff, scale)
        flat = q.copy()  # and the bed did act
        for d in dirs:
            hancock_sweep(
                ReferenceOperator(dataclasses.replace(cfg, bed=False)), flat, 0.05, 0.01, d
            )
        assert np.abs(flat - qr)[1].max() > 1e-3 * scale[1]


def _post(lay, dx, dy):
    """Solid cells: a square post in the middle of the grid and a strip along one side."""
    s = np.zeros((lay.nx, lay.ny), dtype=bool)
    s[lay.nx // 2 - 2 : lay.nx // 2 + 2, lay.ny // 2 - 1 : lay.ny // 2 + 2] = True
    s[:, 0] = True
    return s


@pytest.mark.parametrize("split", [False, True])
def test_a_lake_around_walls_stays_at_rest(ti_cpu, split):
    """A lake over a bed with emerged islands around a solid post: the walls keep it at rest
    to round-off too, and no material enters the post."""
    from tiseg.solver.numerics.operator import TaichiOperator

    kw = dict(SPLIT) if split else {}
    cfg = make_config(
        30,
        9,
        bed=True,
        solid=True,
        friction="none",
        zeta=0.0,
        bc=WALLS,
        reconstruction="weno",
        **kw,
    )
    b = _bed(cfg.layout, cfg.dx, cfg.dy)
    solid = _post(cfg.layout, cfg.dx, cfg.dy)
    b = np.where(solid, 0.0, b)
    q, h = _lake(cfg, b)
    ix, iy = cfg.layout.interior()
    q[:, ix, iy] = np.where(solid[None], 0.0, q[:, ix, iy])
    op = TaichiOperator(cfg, nslots=2)
    op.set_bed(b, solid)
    op.set(0, q)
    if split:
        for k in range(10):
            for d in (0, 1) if k % 2 == 0 else (1, 0):
                op.sweep(d, 0.0, 2e-3)
        change = np.abs(op.get(0) - q)[:, ix, iy]
    else:
        op.rhs(0, 1, 0.0)
        change = np.abs(op.get(1))[:, ix, iy]
    assert change.max() < 1e-15
    assert np.all(op.get(0)[:, ix, iy][:, solid] == 0.0)


@pytest.mark.parametrize("split, rec", [(False, "minmod"), (False, "weno"), (True, "minmod")])
def test_walls_equal_the_twin(ti_cpu, split, rec):
    """Random wet-dry states over a random bed with random solid cells: the kernels against
    the twin, the unsplit rates or a sweep of each direction."""
    from tiseg.solver.numerics.operator import TaichiOperator
    from tiseg.solver.reference import ReferenceOperator

    rng = np.random.default_rng(13)
    kw = dict(SPLIT, zeta=0.5) if split else dict(friction_scheme="projected")
    cfg = make_config(14, 9, bed=True, solid=True, reconstruction=rec, **kw)
    b = _bed(cfg.layout, cfg.dx, cfg.dy, rng)
    solid = rng.random(b.shape) < 0.15
    q = random_state(cfg.layout, rng, wet_dry=True)
    ix, iy = cfg.layout.interior()
    q[:, ix, iy] = np.where(solid[None], 0.0, q[:, ix, iy])
    op = TaichiOperator(cfg, nslots=2)
    op.set_bed(b, solid)
    op.set(0, q)
    ref = ReferenceOperator(cfg, bed=b, solid=solid)
    a, r = stage_and_twin(op, ref, q, split, 0.05 if split else 0.0)
    assert_equals_twin(a, r, cfg.layout)
    if split:  # nothing entered a solid cell
        assert np.all(a[:, ix, iy][:, solid] == 0.0)
