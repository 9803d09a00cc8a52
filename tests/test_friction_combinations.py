"""Every time stepper with every friction scheme on a block that friction must stop: it runs
clean (h >= 0, mass to round-off, the material at rest stays at rest) or the scene refuses the
combination before the run with one line that names the alternative.

The block: the dam-break scene turned into a Coulomb block, 6 mm thick over 0.1 m, released at
rest on a 21 degree slope with mu = 0.47 > tan(21 deg) = 0.384. Its downslope edge slumps under
its own pressure until friction holds it; then nothing may move again. (Before the projected
friction became the default, this scene under RKC broke the mass balance by 1.1e-6 at 0.91 s.)
"""

import math

import numpy as np
import pytest

from tiseg.errors import InputError
from tiseg.setup.scene import load_scene
from tiseg.run.simulation import Simulation
from tiseg.solver.timestepping import STEPPERS

ZETA, MU, U_EPS = 21.0, 0.47, 1e-3

UNSPLIT = sorted(name for name, cls in STEPPERS.items() if not getattr(cls, "split", False))
SSP = [s for s in UNSPLIT if s != "rkc"]


def _block(stepper: str, scheme: str | None, t_end: float = 2.0):
    over = {
        "material.zeta_deg": ZETA,
        "effects.friction": "coulomb",
        "effects.coulomb_mu": MU,
        "initial.h_left": 0.006,
        "domain.nx": 60,
        "numerics.stepper": stepper,
        "numerics.u_eps": U_EPS,
        "time.t_end": t_end,
    }
    if scheme is not None:
        over["numerics.friction_scheme"] = scheme
    return load_scene("dam-break", over)


def _mass_rel_error(sim) -> float:
    tot, bud = sim.totals(), sim.budget()
    return abs(tot["mass"] - sim.initial_totals["mass"] - bud["mass_in"]) / tot["mass"]


def test_projected_is_the_default_friction_scheme():
    assert _block("rkc", None).numerics.friction_scheme == "projected"


@pytest.mark.slow
@pytest.mark.parametrize("stepper", UNSPLIT + ["hancock"])
def test_projected_block_comes_to_rest_and_stays_there(ti_cpu, stepper):
    """The slump stops within 1 s (0.6 s at the steppers' smaller steps), after which every step leaves the state bit for bit as
    it was (SSPRK(10,4) keeps rest to round-off only: its stages are not all convex)."""
    sim = Simulation(_block(stepper, None), check_every=1)
    sim.advance(1.0)
    f = sim.fields()
    assert np.all(f["u"] == 0.0), (stepper, np.abs(f["u"]).max())
    before = sim.conserved()
    steps = sim.stats.steps
    sim.advance(2.0)
    assert sim.stats.steps > steps + 10
    after = sim.conserved()
    if sim.stepper.keeps_rest:
        assert np.array_equal(after, before), stepper
    else:
        assert np.abs(after - before).max() < 1e-15, stepper
    assert after[0].min() >= 0.0
    assert _mass_rel_error(sim) < 1e-13, stepper
    assert sim.budget()["mass_in"] == 0.0  # nothing entered through the upslope boundary


def test_regularised_friction_under_rkc_is_refused_with_the_alternatives():
    with pytest.raises(InputError) as e:
        _block("rkc", "regularised")
    msg = str(e.value)
    assert "\n" not in msg
    assert "numerics.friction_scheme='regularised'" in msg
    assert "'projected'" in msg and "ssprk3" in msg


def test_regularised_friction_without_a_law_is_allowed_under_rkc():
    sc = load_scene(
        "dam-break", {"numerics.stepper": "rkc", "numerics.friction_scheme": "regularised"}
    )
    assert sc.numerics.friction_scheme == "regularised"


@pytest.mark.slow
@pytest.mark.parametrize("stepper", SSP)
def test_regularised_block_creeps_below_u_eps_conservatively(ti_cpu, stepper, caplog):
    """Under an SSP stepper the regularised friction is stable and conservative, and says what
    it does: held material creeps, at least at the regularisation's speed u_eps tan(zeta) / mu
    (the balance of gravity and the linear friction below u_eps; the slumped edge's pressure
    adds to it), never faster than u_eps."""
    with caplog.at_level("INFO", logger="tiseg"):
        sc = _block(stepper, "regularised", t_end=1.0)
    assert any("creeps" in r.getMessage() and "projected" in r.getMessage() for r in caplog.records)
    sim = Simulation(sc, check_every=1)
    sim.advance(1.0)
    f = sim.fields()
    wet = f["h"] >= sc.numerics.h_min
    creep = U_EPS * math.tan(math.radians(ZETA)) / MU
    assert 0.95 * creep <= np.abs(f["u"][wet]).max() <= U_EPS
    assert f["h"].min() >= 0.0
    assert _mass_rel_error(sim) < 1e-13, stepper


def test_split_stepper_takes_the_projected_friction_and_refuses_the_regularised():
    assert _block("hancock", "projected").numerics.friction_scheme == "projected"
    with pytest.raises(InputError) as e:
        _block("hancock", "regularised")
    msg = str(e.value)
    assert "\n" not in msg and "numerics.friction_scheme='regularised'" in msg
    assert "'projected'" in msg and "ssprk4_2" in msg
