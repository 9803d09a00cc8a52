"""The localised inlet (inflow.width, inflow.y0) and the `levees` scene, at tiny resolution:
the inlet's mass flux is width x h x u of the inflow, nothing enters outside it, a centred
inlet gives a flow symmetric about y0, h stays >= 0, and a misplaced inlet is refused."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tiseg.run.simulation import Simulation
from tiseg.setup.scene import load_scene
from tiseg.errors import InputError

T = 0.3  # [s]


def tiny(**over):
    o = {"domain.resolution": 100, "time.t_end": T, "inflow.ramp_rate": 0.0}
    o.update(over)
    return load_scene("levees").with_overrides(o)


def test_inlet_mass_flux_is_width_h_u(ti_cpu, tmp_path):
    sc = tiny()
    sim = Simulation(sc)
    sim.run(out_dir=tmp_path, progress=False)
    f = sim.fields()
    assert np.all(np.isfinite(f["h"])) and f["h"].min() >= 0.0
    expect = sc.inflow.width * sc.inflow.h * sc.inflow.u * T  # sudden inflow: constant flux
    mass = sim.totals()["mass"]
    assert abs(mass - sim.budget()["mass_in"]) <= 1e-11 * mass
    assert sim.budget()["mass_in"] == pytest.approx(expect, rel=0.1)
    # nothing entered outside the gate: the edge cells far from it stay dry
    y = (np.arange(sc.domain.ny) + 0.5) * sc.dy
    far = np.abs(y - sc.inflow.y0) > sc.inflow.width / 2 + 0.06
    assert np.all(f["h"][far, :] == 0.0)
    # a centred inlet on a symmetric plane: h is symmetric about y0 = Ly/2
    assert np.allclose(f["h"], f["h"][::-1, :], rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize(
    "over, word",
    [
        ({"inflow.width": 0.2, "inflow.y0": 0.25}, "leaves the domain"),
        ({"inflow.width": 0.001}, "covers no cell"),
    ],
)
def test_a_misplaced_inlet_is_refused(over, word):
    with pytest.raises(InputError, match=word):
        tiny(**over)


def test_y0_needs_width():
    with pytest.raises(InputError, match="needs inflow.width"):
        load_scene("fingers").with_overrides({"inflow.y0": 0.1})


def test_full_width_has_no_rows():
    sc = load_scene("fingers")
    assert sc.inflow.width is None and sc.inflow.rows(sc.domain.ny, sc.dy) is None
    assert math.isclose(tiny().inflow.width, 0.04)


@pytest.mark.slow  # a long run: the slow set (README), which CI runs after the suite
def test_gate_with_viscosity_keeps_the_mass_budget(ti_cpu):
    """At 150 cells/m the viscous flow from the gate spreads sideways in films near h_min: a
    face between two such cells that was wet at the step's start must keep its flux for the
    whole RKC step, or the last stage (which weighs the step's first rate negatively) empties
    a cell below zero and the clip to h = 0 makes mass. The domain's mass must equal what
    entered through the gate, step after step, to round-off."""
    t_end = 0.6
    sc = load_scene("levees").with_overrides({"domain.resolution": 150, "time.t_end": t_end})
    assert sc.effects.viscosity and sc.inflow.width < sc.domain.Ly
    sim = Simulation(sc, mass_tol=0)  # measured here, not stopped by the guard
    worst = 0.0
    while sim.t < t_end:
        sim.step(t_end)
        mass, inflow = sim.totals()["mass"], sim.budget()["mass_in"]
        if mass > 0.0:  # (the ramp starts from h = 0)
            worst = max(worst, abs(mass - inflow) / mass)
        else:
            assert inflow == 0.0
    assert sim.totals()["mass"] > 0.0
    assert worst < 1e-10
