"""Erosion-deposition waves (Edwards & Gray 2015): the static-layer initial state, its
thresholds and its errors, and the `erosion-deposition` scene at a tiny resolution.

The wave is checked against what must hold whatever its numbers: the mass that came in
through the inlet is all there (up to round-off), the layer ahead of the wave has not moved
by a single bit, the material behind it is at rest again at h_stop of the law, the erosion
front moves at one speed, and that speed is the one the mass balance across a front into
material at rest demands, c = h u / (h - h_l) (Rankine-Hugoniot of (3.1))."""

from __future__ import annotations

import logging
import math

import numpy as np
import pytest

from tiseg.errors import InputError
from tiseg.model.material import Material
from tiseg.model.physics.friction import layer_thresholds
from tiseg.post.analysis.erosion_deposition import front_speeds, wave_profile
from tiseg.run.simulation import Simulation
from tiseg.setup.scene import load_scene

LAYER = 1.05e-3  # [m]


# ------------------------------------------------------------------------------ thresholds
@pytest.mark.parametrize("zeta", [21.5, 22.0, 24.0])
def test_layer_thresholds_are_those_of_the_extended_law(zeta):
    """For the fines alone, written out from the law: h_stop where tan(zeta) = mu_D(h, beta*),
    h_start where tan(zeta) = mu_S(h) = mu3 + (mu2 - mu1) / (1 + h / L)."""
    m = Material(zeta_deg=zeta)
    sp, t = m.small, math.tan(math.radians(zeta))
    want_stop = sp.L * m.beta_star / sp.beta * (sp.mu2 - t) / (t - sp.mu1)
    want_start = sp.L * ((sp.mu2 - sp.mu1) / (t - sp.mu3) - 1.0)
    h_stop, h_start = layer_thresholds(m, 1.0)
    assert h_stop == pytest.approx(want_stop, rel=1e-10)
    assert h_start == pytest.approx(want_start, rel=1e-10)
    assert h_stop < h_start
    # the rougher coarse grains (3.4) hold thicker layers and leave thicker deposits
    mix = layer_thresholds(m, 0.9)
    assert mix[0] > h_stop and mix[1] > h_start


def test_nothing_is_held_on_a_slope_steeper_than_the_start_angle():
    m = Material(zeta_deg=31.0)  # above zeta2 of the fines
    assert layer_thresholds(m, 1.0) == (0.0, 0.0)


# ------------------------------------------------------------------------------ scene keys
def _scene(**initial):
    sc = load_scene("erosion-deposition")
    return sc.with_overrides({f"initial.{k}": v for k, v in initial.items()})


def test_layer_keys_and_their_errors(caplog):
    sc = _scene()
    assert sc.initial.kind == "layer" and sc.initial.layer_h == 1.2e-3
    assert sc.initial.phi == sc.flow.phi0
    with pytest.raises(InputError, match=r"initial\.layer_h=0\.0025: must be thinner than h_start"):
        _scene(layer_h=2.5e-3)
    with pytest.raises(InputError, match="layer_h"):
        _scene(layer_h=-1e-3)
    with caplog.at_level(logging.WARNING, logger="tiseg"):
        _scene(layer_h=5e-4)
    assert "h_stop" in caplog.text
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="tiseg"):
        sc.with_overrides({"effects.friction": "pouliquen-mixture"})
    assert "only the extended law" in caplog.text
    d = sc.to_dict()
    d["initial"] = {"kind": "release", "x0": 0.0, "x1": 0.1, "layer_h": 1e-3}
    from tiseg.setup.scene import scene_from_dict

    with pytest.raises(InputError, match="layer_h"):
        scene_from_dict(d, name="bad")


# ------------------------------------------------------------------------------ the wave
@pytest.fixture(scope="module")
def wave(ti_cpu):
    """The scene on 150 cells of 4 mm over 0.6 m, snapshots every 0.25 s to 4 s."""
    sc = load_scene("erosion-deposition").with_overrides(
        {"domain.Lx": 0.6, "domain.nx": 150, "initial.layer_h": LAYER, "time.t_end": 4.0}
    )
    sim = Simulation(sc)
    x = sc.domain.cell_centres()[0]
    q0 = sim.conserved()
    m0 = sim.totals()["mass"]
    shots = []
    for t in np.arange(0.25, 4.001, 0.25):
        sim.advance(float(t))
        f = sim.fields()
        shots.append((float(t), sim.conserved(), f["h"].ravel().copy(), f["u"].ravel().copy()))
    return dict(sc=sc, sim=sim, x=x, q0=q0, m0=m0, shots=shots)


def test_mass_is_what_came_in(wave):
    sim, m0 = wave["sim"], wave["m0"]
    came_in = sim.budget()["mass_in"]
    sc = wave["sc"]
    pulse = sc.inflow.h * sc.inflow.u * sc.inflow.stop_time  # 0.5 s of 2 mm at u0
    assert 0.9 < came_in / pulse < 1.15
    assert abs(sim.totals()["mass"] - (m0 + came_in)) <= 1e-12 * m0


def test_the_layer_ahead_of_the_wave_has_not_moved_a_bit(wave):
    x, q0 = wave["x"], wave["q0"]
    for t, q, h, u in wave["shots"]:
        p = wave_profile(x, h, u)
        # the cell just ahead of the last moving one may have been filled a little
        ahead = np.nonzero(x > p.x_e + 1.5 * wave["sc"].dx)[0]
        assert ahead.size > 10, t  # the front is still on the chute
        # bit for bit the initial layer: thickness and (zero) momentum
        assert np.array_equal(q[:, ahead], q0[:, ahead]), t
        assert np.all(h[ahead] == LAYER) and np.all(u[ahead] == 0.0)


def test_behind_the_wave_the_deposit_is_at_rest_at_h_stop(wave):
    sc, x = wave["sc"], wave["x"]
    h_stop, _ = layer_thresholds(sc.material, sc.flow.phi0)
    t, _, h, u = wave["shots"][-1]
    p = wave_profile(x, h, u)
    behind = (x > 0.03) & (x < p.x_d)
    assert behind.sum() >= 5
    assert np.all(u[behind] == 0.0)
    assert np.all(np.abs(h[behind] / h_stop - 1.0) < 0.03), h[behind] / h_stop
    # and stays exactly as it is while the wave moves on
    _, q_before, _, _ = wave["shots"][-3]
    t_b = wave["shots"][-3][0]
    p_b = wave_profile(x, wave["shots"][-3][2], wave["shots"][-3][3])
    both = (x > 0.03) & (x < p_b.x_d - 5 * sc.dx)  # the tail's neighbours still drain
    assert both.sum() >= 3, t_b
    h_b = wave["shots"][-3][2]
    assert np.array_equal(h[both], h_b[both])


def test_bounds(wave):
    h_in = wave["sc"].inflow.h
    for t, _, h, u in wave["shots"]:
        assert np.all(h > 0.0) and np.all(h <= h_in * (1 + 1e-12)), t
        assert np.all(u >= 0.0), t  # nothing flows back up the slope
        assert np.all(h >= 0.95 * layer_thresholds(wave["sc"].material, 1.0)[0]), t


def test_the_erosion_front_moves_at_one_speed_set_by_the_mass_balance(wave):
    """Over 1.5-4 s the front's speed in each half of the stretch is within 3 % of the whole;
    and it equals h u / (h - h_l) of the flow just behind the front (within 5 %, the front
    being smeared over a few cells)."""
    x = wave["x"]
    late = [s for s in wave["shots"] if s[0] >= 1.5]
    ts = np.array([s[0] for s in late])
    profiles = [wave_profile(x, s[2], s[3]) for s in late]
    c, spread = front_speeds(ts, profiles)["erosion"]
    assert 0.05 < c < 0.5
    assert spread < 0.03, spread
    for _, _, h, u in late[-4:]:
        i_e = int(np.nonzero(u)[0][-1])
        j = slice(i_e - 12, i_e - 6)  # the plateau behind the front
        hp, up = h[j].mean(), u[j].mean()
        c_rh = hp * up / (hp - LAYER)
        assert abs(c_rh / c - 1.0) < 0.05, (c_rh, c)
