"""Every built-in scene runs, tiny, with its own physics checked: finite state, h >= 0,
0 <= phi <= 1, mass = initial mass + what entered through the boundaries, and the front speed
against the theory that applies (u0 for an inflow onto an empty chute, Ritter's 2 sqrt(g h)
for a dam break). Parametrised over the scene list: a new scene is tested from the day it
ships."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tiseg.setup.scene import list_builtin_scenes, load_scene
from tiseg.run.simulation import Simulation

SCENES = list_builtin_scenes()
T_INFLOW = 1.0  # [s] of an inflow scene: the front is well inside even a short chute


def tiny(name: str):
    """The scene at a few hundred cells and a short time, as the tests run it."""
    sc = load_scene(name)
    over = {}
    if sc.initial.kind == "channel":
        over["domain.resolution"] = 250  # 4 x 20 cells: the chute is a few cm wide
        over["time.t_end"] = 0.5
    elif sc.domain.resolution is not None:
        over["domain.resolution"] = 40
    else:
        over["domain.nx"] = min(sc.domain.nx, 120)
    if sc.has_inflow or sc.initial.kind == "uniform":
        over["time.t_end"] = min(sc.t_end, T_INFLOW)
    return sc.with_overrides(over)


def front(h: np.ndarray, dx: float, h_min: float) -> float:
    """Downslope position [m] of the furthest cell with h >= h_min (any row)."""
    wet = np.nonzero((h >= h_min).any(axis=0))[0]
    return (wet[-1] + 1) * dx if wet.size else 0.0


def test_the_scene_list_is_not_empty():
    assert {"fingers", "dam-break", "uniform-flow"} <= set(SCENES)


@pytest.mark.parametrize("name", SCENES)
def test_builtin_scene_runs_tiny(name, ti_cpu, tmp_path):
    sc = tiny(name)
    sim = Simulation(sc)
    m0 = sim.totals()["mass"]
    dev0 = np.max(np.abs(sim.fields()["h"] / sc.flow.h0 - 1.0))
    sim.run(out_dir=tmp_path, progress=False)
    assert sim.t == sc.t_end
    f = sim.fields()
    for k, v in f.items():
        assert np.all(np.isfinite(v)), k
    assert f["h"].min() >= 0.0
    if "phi" in f:
        assert f["phi"].min() >= 0.0 and f["phi"].max() <= 1.0
    mass, bud = sim.totals()["mass"], sim.budget()
    assert mass > 0
    assert abs(mass - m0 - bud["mass_in"]) <= 1e-11 * mass

    h_min = sc.numerics.h_min
    if sc.has_inflow and sc.initial.kind == "empty":
        # the head runs at about u0 (0.8 u0 measured with segregation, u0 without)
        x_f = front(f["h"], sc.dx, h_min)
        assert 0.5 * sc.flow.u0 * sc.t_end < x_f < 1.3 * sc.flow.u0 * sc.t_end, x_f
    if sc.initial.kind == "dam-break" and sc.initial.h_right == 0.0:
        # Ritter: h = (2c - x/t)^2 / (9 g') reaches the dry bed at x0 + 2c t, and drops below
        # h_min at x0 + (2c - 3 sqrt(g' h_min)) t: where the scheme's wet tip must be, give
        # or take a few cells of numerical spreading
        g = sc.material.g * math.cos(sc.material.zeta)
        c = math.sqrt(g * sc.initial.h_left)
        x_f = front(f["h"], sc.dx, h_min)
        tip = sc.initial.x0 + (2.0 * c - 3.0 * math.sqrt(g * h_min)) * sc.t_end
        assert tip - 4 * sc.dx < x_f <= sc.initial.x0 + 2.0 * c * sc.t_end + sc.dx, (x_f, tip)
    if sc.segregation and sc.flow.phi0 == 1.0 and sc.has_inflow:
        wet = f["h"] >= h_min  # monodisperse stays monodisperse
        np.testing.assert_allclose(f["phi"][wet], 1.0, atol=1e-12)
    if sc.initial.kind == "channel":
        # nothing varies downslope and nothing moves across: v stays exactly 0
        for k, v in f.items():
            assert np.all(v == v[:, :1]), k
        assert np.all(f["v"] == 0.0)
    if sc.initial.kind == "uniform":
        # the steady uniform state (a small perturbation on top, growing at most a few times
        # in the short run: e^(1.8 / s x 1 s) for the roll waves) stays where it is
        # (a forced inflow adds its modulation, a few times larger downstream)
        dev = np.max(np.abs(f["h"] / sc.flow.h0 - 1.0))
        forced = sc.inflow.forcing_amplitude if sc.has_inflow else 0.0
        assert dev < max(1e-3, 10.0 * dev0, 5.0 * forced), (dev, dev0, forced)
