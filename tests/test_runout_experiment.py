"""A release on a chute with a run-out (benchmarks/runout_experiment.py, docs/validation.md
"A release on a chute with a run-out") against what laboratory landslides on a slope meeting
a horizontal plane show: their apparent friction (Heim's ratio, the drop over the horizontal
travel) is almost the bed's friction at low slope angles, and their runout decreases as the
slope steepens (Wu, Duan, Peng & Zhang 2024, Granular Matter 26, abstract). No measured positions could be
read from the sources at hand, so this holds tiseg to that statement, on a coarse grid."""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parents[1] / "benchmarks" / "runout_experiment.py"


@pytest.fixture(scope="module")
def bench():
    spec = importlib.util.spec_from_file_location("runout_experiment", BENCH)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_apparent_friction_is_the_bed_friction_on_gentle_chutes_and_grows_on_steep_ones(
    ti_cpu, bench
):
    """The cap released 0.5 m above the pad on a 30 and a 60 degree chute, 250 cells/m
    (25 across the release), Coulomb mu = tan 25 degrees:

    * both deposits come to rest with their mass kept;
    * at 30 degrees the centre of mass's Heim ratio lies within 10 % above mu. The abstract's
      "almost identical" gives no number; the 10 % is the model's own: the point mass with the
      bend's kappa u^2 term, the loss of the mass meeting the pad that the abstract invokes,
      gives +7 % here (0.499), and the deposit's spreading over the bend adds 1.6 % (0.507 at
      250 and 500 cells/m); the sliding block without that term stops at mu exactly (Heim).
      The band's ceiling catches a flow cut short: the unsplit RKC scheme with its default
      h_min = 1e-4 m, whose thin margins stop feeling gravity, leaves the centre 0.21 m short
      and gives 0.529 (+13 %);
    * the ratio at 60 degrees exceeds 1.5 times the one at 30 (0.819 / 0.507 = 1.62; the point
      mass 1.64): the apparent friction grows with the slope angle, as the abstract implies, and
      the centre's horizontal travel shrinks (0.99 to 0.61 m);
    * at both slopes the flow's ratio stays within 3 % of the point mass's (0.1-1.6 % here).
    """
    mu = math.tan(math.radians(bench.MU_DEG))
    low, steep = bench.run_one(30.0, 250), bench.run_one(60.0, 250)
    for r in (low, steep):
        assert math.isfinite(r["t_rest"]), r
        assert abs(r["mass_change"]) < 1e-12
        assert abs(r["tan_alpha_centre"] / r["point_mass_tan_alpha"] - 1.0) < 0.03, r
    assert mu <= low["tan_alpha_centre"] <= 1.10 * mu, (low["tan_alpha_centre"], mu)
    assert steep["tan_alpha_centre"] > 1.5 * low["tan_alpha_centre"]
    assert steep["travel_centre"] < low["travel_centre"]
