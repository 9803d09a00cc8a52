"""The bow shock ahead of a circular cylinder (tiseg.post.analysis.bow_shock; docs/validation.md,
"Flow around an obstacle"): the jump stands off further at a lower Froude number, as the
experiments and the shallow-water theory have it (Cui & Gray 2013; Cui 2019: the stand-off
shrinks towards zero as F grows), and the stagnation depth behind it is the exact one of the
normal jump and Bernoulli's relation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tiseg.model.exact_oblique_shock import jump_depth_ratio, stagnation_depth_ratio
from tiseg.post.analysis.bow_shock import BowShockCase, run_to_steady


def test_the_stagnation_depth_joins_the_critical_state_and_grows_like_the_jump():
    """At F -> 1 there is no jump and the stagnation head is that of critical flow, 1.5 h; for
    large F, h_s / h_2 -> 1 (the flow behind a strong jump is slow)."""
    assert stagnation_depth_ratio(1.0 + 1e-12) == pytest.approx(1.5, abs=1e-9)
    assert stagnation_depth_ratio(3.0) == pytest.approx(4.0883, abs=1e-4)
    big = 1e4
    assert stagnation_depth_ratio(big) / jump_depth_ratio(big) == pytest.approx(1.0, abs=1e-3)
    with pytest.raises(ValueError):
        stagnation_depth_ratio(0.9)


def test_the_case_puts_the_face_on_a_cell_face_and_the_centre_on_a_cell_row():
    c = BowShockCase(3.0, 10)
    nx, ny = c.grid()
    assert ny % 2 == 1
    assert c.face_x / c.dx == pytest.approx(round(c.face_x / c.dx), abs=1e-9)
    assert c.centre[1] == pytest.approx((ny // 2 + 0.5) * c.dx)
    with pytest.raises(ValueError):
        BowShockCase(0.8, 10)
    with pytest.raises(ValueError):
        BowShockCase(3.0, 10, friction="coulomb", zeta_deg=0.0)


def test_the_bow_shock_stands_closer_at_a_higher_froude_number(ti_cpu):
    """Shallow water (no friction, flat), 10 cells per radius, a small domain (3 radii of
    inflow, 4 either side: the stand-off at F = 3 is that of 8 to 6e-4 D). Measured: stand-off
    0.410 D at F = 3 and 0.226 D at F = 5 (benchmarks/bow_shock: 0.385 and 0.202 at 20 cells
    per radius, 0.363 and 0.188 at 40); the cell against the face holds h / h0 = 4.03 and
    6.71, the exact stagnation depths being 4.088 and 6.877. About 9 s."""
    out = {}
    for f in (3.0, 5.0):
        c = BowShockCase(f, 10, upstream=3.0, half_width=4.0)
        r = run_to_steady(c, tol=1e-3, t_min=40.0, t_max=50.0)
        out[f] = (c, r)
    r3, (c5, r5) = out[3.0][1], out[5.0]
    assert r3["standoff_D"] > r5["standoff_D"] + 0.1
    assert 0.0 < r5["standoff_D"] < 0.3
    # 20 % either side of the 40 cells-per-radius value at F = 3 (0.363)
    assert 0.29 < r3["standoff_D"] < 0.44
    # Bernoulli behind the normal jump, to 3 % (first order at the face: the cell's centre is
    # dx / 2 from it)
    for r in (r3, r5):
        assert r["stagnation"] == pytest.approx(r["stagnation_exact"], rel=0.03)
    assert math.isfinite(r3["last_change_D"]) and r3["last_change_D"] < 1e-3
    # the stream a radius ahead of the jump is untouched
    x, row = c5.centreline(r5["h"])
    ahead = x < c5.face_x - 2.0 * c5.radius * r5["standoff_D"] - c5.radius
    assert ahead.sum() > 5
    assert np.abs(row[ahead] / c5.h0 - 1.0).max() < 1e-3
