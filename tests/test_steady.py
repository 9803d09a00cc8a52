"""Steady uniform flows, section 4: numbers printed in the paper and analytic identities."""

import math

import numpy as np
import pytest

from tiseg.errors import InputError
from tiseg.model.material import TABLE1, Material
from tiseg.model.steady import critical_froude, froude, phi0_star, steady_state, velocity

T = math.tan


def rounds_to(value, printed: str) -> bool:
    """True when `value` rounds to the decimal string `printed` (as typeset in the paper)."""
    decimals = len(printed.split(".")[1]) if "." in printed else 0
    return abs(value - float(printed)) <= 0.5 * 10**-decimals + 1e-12


def test_paper_numbers_2mm():
    # section 5.3 / figure 9: h0 = 2 mm, phi0 = 0.8 gives F = 1.57 and u0 = 0.208 m/s
    s = steady_state(0.002, 0.8)
    assert rounds_to(s.F, "1.57")
    assert rounds_to(s.u0, "0.208")


def test_paper_numbers_3mm_and_critical():
    assert rounds_to(froude(0.003, 0.8), "2.36")
    s = steady_state(0.002, 0.8)
    assert rounds_to(s.Fc, "1.94")  # (5.27), figure 9 caption
    assert rounds_to(s.h0_at_Fc * 1e3, "2.47")  # figure 10 caption: Fc reached at 2.47 mm
    assert froude(s.h0_at_Fc, 0.8) == pytest.approx(s.Fc, rel=1e-13)


def test_critical_froude_is_one_over_dG():
    # G = (6/7) phi (1 - phi) for alpha = 1/7 (2.17), so Fc = 7 / (6 |1 - 2 phi0|)
    for phi in (0.3, 0.6, 0.8, 1.0):
        assert critical_froude(phi) == pytest.approx(7.0 / (6.0 * abs(1 - 2 * phi)), rel=1e-14)
    assert critical_froude(0.5) == math.inf


def test_phi0_star_formula():
    # (4.8) from Table 1: (mu1^L - tan zeta) / (mu1^L - mu1^S)
    t1L, t1S, tz = T(math.radians(29)), T(math.radians(20)), T(math.radians(27))
    assert phi0_star() == pytest.approx((t1L - tz) / (t1L - t1S), rel=1e-14)
    assert rounds_to(phi0_star(), "0.2353")


def test_froude_linear_in_h0():
    for phi in (0.3, 0.8, 1.0):
        base = froude(1e-3, phi)
        for h0 in (1e-4, 2e-3, 3.7e-3, 0.05):
            assert froude(h0, phi) == pytest.approx(base * h0 / 1e-3, rel=1e-13)


@pytest.mark.parametrize("h0,phi", [(0.002, 0.8), (0.003, 0.8), (0.001, 0.5), (0.004, 0.3)])
def test_force_balance(h0, phi):
    # (4.2): tan(zeta) = mu_b(h0, F, phi0), with the friction (3.4), (3.7)
    F = froude(h0, phi)
    assert float(TABLE1.mu_mixture(h0, F, phi)) == pytest.approx(TABLE1.tan_zeta, abs=1e-14)
    u0 = velocity(h0, phi)
    assert u0 == pytest.approx(F * math.sqrt(9.81 * h0 * math.cos(math.radians(27))), rel=1e-14)


def test_pure_small_limit_is_4_10():
    # (4.10): F = M^S h0 (tan zeta - mu1^S) / (mu2^S - tan zeta), M^S = beta^S / L^S = 750 1/m
    tz, m1, m2 = T(math.radians(27)), T(math.radians(20)), T(math.radians(30))
    for h0 in (0.001, 0.002, 0.003):
        expected = (0.150 / 2.0e-4) * h0 * (tz - m1) / (m2 - tz)
        assert froude(h0, 1.0) == pytest.approx(expected, rel=1e-13)


@pytest.mark.parametrize(
    "h0,phi",
    [
        (0.002, 0.2),
        (0.002, 0.0),
        (0.002, phi0_star()),
        (0.0, 0.8),
        (-0.001, 0.8),
        (0.002, -0.1),
        (0.002, 1.5),
        (float("nan"), 0.8),
        (0.002, float("inf")),
    ],
)
def test_bad_input_raises(h0, phi):
    with pytest.raises(InputError):
        steady_state(h0, phi)


def test_viscosity_3_8():
    # (3.8) for the small particles (zeta1^S = 20 < 27 < zeta2^S = 30) ...
    z = math.radians(27)
    tz, m1, m2 = T(z), T(math.radians(20)), T(math.radians(30))
    expected = (
        2
        * 2.0e-4
        * math.sqrt(9.81)
        / (9 * 0.150)
        * math.sin(z)
        / math.sqrt(math.cos(z))
        * (m2 - tz)
        / (tz - m1)
    )
    assert TABLE1.nu("small") == pytest.approx(expected, rel=1e-14)
    assert TABLE1.nu("small") > 0
    # ... and is undefined for the large ones (27 < zeta1^L = 29): "undefined" in section 3
    with pytest.raises(InputError):
        TABLE1.nu("large")


def test_other_slope_changes_F():
    # a steeper slope (still in (3.10)) flows faster at the same thickness
    assert froude(0.002, 0.8, Material(zeta_deg=28.0)) > froude(0.002, 0.8)
    np.testing.assert_allclose(phi0_star(Material(zeta_deg=29.0 - 1e-9)), 0.0, atol=1e-9)
