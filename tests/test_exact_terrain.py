"""The reference solutions for the terrain verification (tiseg.model.exact_bump,
exact_oblique_shock, exact_runout) against closed forms, published values and conservation.

Every expected value here is computed independently of the module it checks: from the cubic of
Bernoulli's equation solved with numpy.roots, Belanger's conjugate depths, the weak-shock and
hypersonic limits, the jump relations written afresh in another parametrisation, the exact
speed of a Coulomb block on a circular arc, energy balances, or numbers read from the
literature (SWASHES, Delestre et al. 2013)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.optimize import minimize_scalar

from tiseg.model import exact_bump as eb
from tiseg.model import exact_oblique_shock as eo
from tiseg.model import exact_runout as er

g = 9.81
X = np.linspace(0.0, 25.0, 501)  # the Goutal & Maurel channel
bump = eb.goutal_maurel_bump


def cubic_roots(b, q, head, gc=g):
    """The positive real roots of h^3 + (b - H) h^2 + q^2 / (2 g) = 0, ascending."""
    r = np.roots([1.0, b - head, 0.0, q * q / (2 * gc)])
    return np.sort(r[(abs(r.imag) < 1e-9) & (r.real > 0)].real)


def head_of(h, u, x, gc=g):
    return u * u / (2 * gc) + h + bump(x)


# ------------------------------------------------------------------------------ the bump
def test_subcritical_bump_keeps_q_and_bernoulli_and_meets_the_cubic():
    q, hout = 4.42, 2.0
    h, u = eb.subcritical_flow(X, bump, q, hout)
    assert h[-1] == pytest.approx(hout, rel=1e-14)
    np.testing.assert_allclose(h * u, q, rtol=1e-14)
    H = head_of(h, u, X)
    assert np.ptp(H) / H.mean() < 1e-10
    assert np.all(u / np.sqrt(g * h) < 1)  # subcritical everywhere
    head = hout + q * q / (2 * g * hout * hout)
    i = np.argmin(abs(X - 10.0))
    assert h[i] == pytest.approx(cubic_roots(0.2, q, head)[-1], rel=1e-12)  # the deeper root


def test_transcritical_bump_is_critical_at_the_crest():
    q = 1.53
    h, u = eb.transcritical_flow(X, bump, q)
    H = head_of(h, u, X)
    assert np.ptp(H) / H.mean() < 1e-10
    np.testing.assert_allclose(h * u, q, rtol=1e-14)
    i = np.argmin(abs(X - 10.0))
    hc = (q * q / g) ** (1 / 3)
    assert h[i] == pytest.approx(hc, rel=1e-12)
    assert u[i] / math.sqrt(g * h[i]) == pytest.approx(1.0, abs=1e-10)
    fr = u / np.sqrt(g * h)
    assert np.all(fr[X < 9.9] < 1) and np.all(fr[X > 10.1] > 1)
    # the head is the critical one, 3/2 h_c + 0.2, at both ends
    head = 1.5 * hc + 0.2
    assert h[0] == pytest.approx(cubic_roots(0.0, q, head)[-1], rel=1e-12)
    assert h[-1] == pytest.approx(cubic_roots(0.0, q, head)[0], rel=1e-12)


def test_transcritical_bump_with_a_shock_matches_swashes():
    q, hout = 0.18, 0.33
    h, u, xs = eb.transcritical_shock_flow(X, bump, q, hout)
    # SWASHES (Delestre et al. 2013, fig. 4): the jump stands at x ~ 11.7 m, on the lee side
    assert 11.6 < xs < 11.75
    np.testing.assert_allclose(h * u, q, rtol=1e-14)
    H = head_of(h, u, X)
    up, down = X < xs, X > xs
    assert np.ptp(H[up]) / H[up].mean() < 1e-10 and np.ptp(H[down]) / H[down].mean() < 1e-10
    assert h[-1] == pytest.approx(hout, rel=1e-14)
    hc = (q * q / g) ** (1 / 3)
    assert H[up].mean() == pytest.approx(1.5 * hc + 0.2, rel=1e-12)
    # the jump: Belanger's conjugate depth of the supercritical depth at x_s is the subcritical
    b = float(bump(xs))
    h1 = cubic_roots(b, q, 1.5 * hc + 0.2)[0]
    h2 = cubic_roots(b, q, hout + q * q / (2 * g * hout**2))[-1]
    f1 = q / h1 / math.sqrt(g * h1)
    assert h2 == pytest.approx(0.5 * h1 * (math.sqrt(1 + 8 * f1 * f1) - 1), rel=1e-9)
    assert h1 < hc < h2
    i = np.searchsorted(X, xs)
    assert u[i - 1] / math.sqrt(g * h[i - 1]) > 1 > u[i] / math.sqrt(g * h[i])


def test_bump_on_a_slope_uses_g_cos_zeta():
    zeta, q = math.radians(30), 1.53
    gc = g * math.cos(zeta)
    h, u = eb.transcritical_flow(X, bump, q, zeta=zeta)
    i = np.argmin(abs(X - 10.0))
    assert u[i] / math.sqrt(gc * h[i]) == pytest.approx(1.0, abs=1e-10)
    H = head_of(h, u, X, gc)
    assert np.ptp(H) / H.mean() < 1e-10


def test_bump_refuses_impossible_flows():
    with pytest.raises(ValueError, match="choked"):  # too little head to pass subcritically
        eb.subcritical_flow(X, bump, 1.53, 0.66)
    with pytest.raises(ValueError, match="subcritical"):  # deep outflow: no jump
        eb.bump_shock_position(bump, 0.18, 2.0, 0.0, 25.0)
    # an outflow shallower than the conjugate depth (0.28 m) of the supercritical stream at
    # x = 25 m: the jump is swept out
    with pytest.raises(ValueError, match="too small"):
        eb.bump_shock_position(bump, 0.18, 0.2, 0.0, 25.0)
    with pytest.raises(ValueError, match="not subcritical"):  # below h_c = 0.149 m
        eb.transcritical_shock_flow(X, bump, 0.18, 0.1)
    with pytest.raises(ValueError, match="branch"):
        eb.bernoulli_depth(0.0, 1.0, 1.0, "both")


# ------------------------------------------------------------------------------ the oblique jump
def test_weak_jump_tends_to_the_mach_angle_with_the_weak_shock_slope():
    # small deflection: beta - asin(1/F) ~ (gamma + 1) F^2 theta / (4 (F^2 - 1)) with the
    # shallow-water gamma = 2 (Gilmore, Plesset & Crossley 1950), and the depth rises as
    # Ippen's small wave, dh = (V^2 / g) tan(beta) dtheta (Ippen 1951; Chow 1959)
    for F in (1.5, 3.0, 10.0):
        assert eo.shock_angle(F, 0.0) == pytest.approx(math.asin(1 / F), abs=1e-15)
        th = 1e-6
        j = eo.oblique_jump(F, th)
        assert (j.beta - math.asin(1 / F)) / th == pytest.approx(0.75 * F**2 / (F**2 - 1), rel=1e-5)
        assert (j.depth_ratio - 1) / th == pytest.approx(F**2 / math.sqrt(F**2 - 1), rel=1e-5)


def test_strong_jump_tends_to_the_normal_jump():
    F = 4.0
    assert eo.shock_angle(F, 0.0, "strong") == pytest.approx(math.pi / 2)
    j = eo.oblique_jump(F, 1e-7, "strong")
    assert j.depth_ratio == pytest.approx((math.sqrt(1 + 8 * F * F) - 1) / 2, rel=1e-9)


def test_hypersonic_limit():
    # F -> infinity: tan(beta - theta) = tan(beta) h1/h2 with h2/h1 ~ sqrt(2) F sin(beta)
    theta = math.radians(30)
    beta = eo.shock_angle(1e6, theta)
    assert (beta - theta) * math.sqrt(2) * 1e6 * math.cos(theta) == pytest.approx(1, rel=1e-5)
    # the jump stays attached to wedges near 90 degrees (Cui 2019, Int. J. Aeronaut. Aerosp.
    # Eng. 1, 7), unlike gas dynamics
    tmax = [eo.max_deflection(F)[0] for F in (1.5, 3, 10, 100, 1e4)]
    assert np.all(np.diff(tmax) > 0) and math.degrees(tmax[-1]) > 89


@pytest.mark.parametrize("F,theta", [(2.0, 10.0), (5.0, 20.0), (5.0, 40.0), (20.0, 60.0)])
@pytest.mark.parametrize("branch", ["weak", "strong"])
def test_mass_and_momentum_cross_the_jump(F, theta, branch):
    zeta, h1 = math.radians(25), 0.01
    gc = g * math.cos(zeta)
    u1 = F * math.sqrt(gc * h1)
    h2, u2, v2, beta = eo.downstream_state(h1, u1, math.radians(theta), branch, zeta=zeta)
    assert math.atan2(v2, u2) == pytest.approx(math.radians(theta), abs=1e-14)  # along the wall
    n, t = (math.sin(beta), -math.cos(beta)), (math.cos(beta), math.sin(beta))
    un1, ut1 = u1 * n[0], u1 * t[0]
    un2, ut2 = u2 * n[0] + v2 * n[1], u2 * t[0] + v2 * t[1]
    assert h2 * un2 == pytest.approx(h1 * un1, rel=1e-13)
    assert h2 * un2**2 + gc * h2**2 / 2 == pytest.approx(h1 * un1**2 + gc * h1**2 / 2, rel=1e-13)
    assert h2 * un2 * ut2 == pytest.approx(h1 * un1 * ut1, rel=1e-13)
    assert ut2 == pytest.approx(ut1, rel=1e-13)
    f2 = math.hypot(u2, v2) / math.sqrt(gc * h2)
    assert f2 == pytest.approx(eo.oblique_jump(F, math.radians(theta), branch).downstream_froude)
    assert un2 / math.sqrt(gc * h2) < 1  # subcritical normal to the jump


def _theta_max_by_depth_ratio(F):
    """theta_max from the jump relations parametrised by R = h2/h1: sin^2(beta) = R (R + 1) /
    (2 F^2), tan(theta) = tan(beta) (R - 1) / (R + tan^2(beta)), maximised over R."""

    def minus_tan_theta(R):
        s = R * (R + 1) / (2 * F * F)
        return -math.sqrt(s * (1 - s)) * (R - 1) / (R * (1 - s) + s)

    rmax = (math.sqrt(1 + 8 * F * F) - 1) / 2
    r = minimize_scalar(minus_tan_theta, bounds=(1, rmax), method="bounded",
                        options={"xatol": 1e-12})  # fmt: skip
    return math.atan(-r.fun)


@pytest.mark.parametrize("F", [1.2, 2.0, 3.5, 8.0, 50.0])
def test_detachment_angle_and_branches_meeting(F):
    tmax, bstar = eo.max_deflection(F)
    assert tmax == pytest.approx(_theta_max_by_depth_ratio(F), abs=1e-11)
    near = tmax * (1 - 1e-10)
    bw, bs = eo.shock_angle(F, near, "weak"), eo.shock_angle(F, near, "strong")
    assert bw < bstar < bs and bs - bw < 1e-4  # they meet as sqrt(theta_max - theta)
    assert eo.shock_angle(F, tmax, "weak") == eo.shock_angle(F, tmax, "strong") == bstar
    with pytest.raises(ValueError, match="detaches"):
        eo.shock_angle(F, tmax * (1 + 1e-6))


@pytest.mark.parametrize("theta_deg", [5.0, 20.0, 45.0, 70.0])
def test_detachment_froude_inverts_the_detachment_angle(theta_deg):
    theta = math.radians(theta_deg)
    fd = eo.detachment_froude(theta)
    assert _theta_max_by_depth_ratio(fd) == pytest.approx(theta, abs=1e-10)
    eo.shock_angle(fd * (1 + 1e-6), theta)  # attached just above
    with pytest.raises(ValueError, match="detaches"):
        eo.shock_angle(fd * (1 - 1e-6), theta)


def test_oblique_jump_refuses_subcritical_streams():
    for bad in (lambda: eo.shock_angle(0.9, 0.1), lambda: eo.max_deflection(1.0)):
        with pytest.raises(ValueError, match="supercritical"):
            bad()
    with pytest.raises(ValueError):
        eo.detachment_froude(math.pi / 2)


# ------------------------------------------------------------------------------ the run-out
d = math.radians


def test_uniform_slope_accelerates_uniformly():
    zeta, mu = d(30), 0.3
    r = er.slide(er.BedLine(zeta, zeta, 1e9), mu, t_max=5.0)
    a = g * (math.sin(zeta) - mu * math.cos(zeta))
    assert not r.stopped and r.t[-1] == pytest.approx(5.0)
    np.testing.assert_allclose(r.u, a * r.t, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(r.s, 0.5 * a * r.t**2, rtol=1e-10, atol=1e-12)


def test_a_block_on_a_slope_it_can_hold_stops_as_in_closed_form():
    zeta, mu, u0 = d(10), 0.5, 3.0
    r = er.slide(er.BedLine(zeta, zeta, 1e9), mu, u0=u0)
    dec = g * (mu * math.cos(zeta) - math.sin(zeta))
    assert r.stopped
    assert r.t_stop == pytest.approx(u0 / dec, rel=1e-10)
    assert r.s_stop == pytest.approx(u0 * u0 / (2 * dec), rel=1e-10)
    held = er.slide(er.BedLine(zeta, zeta, 1e9), mu)  # at rest and held: never moves
    assert held.stopped and held.s_stop == 0.0 and held.t_stop == 0.0


@pytest.mark.parametrize("curvature", [False, True])
def test_flat_run_out_after_a_kink(curvature):
    z1, mu, xb = d(35), 0.4, 100.0
    ub2 = 2 * g * (math.sin(z1) - mu * math.cos(z1)) * xb
    # energy: u_b^2 / (2 mu g) on the flat; the kink's centripetal impulse keeps exp(-mu dzeta)
    # of the speed (the L -> 0 limit of d ln u / ds = -mu kappa)
    factor = math.exp(-2 * mu * z1) if curvature else 1.0
    r = er.slide(er.BedLine(z1, 0.0, xb), mu, curvature=curvature)
    assert r.stopped and r.s_stop - xb == pytest.approx(factor * ub2 / (2 * mu * g), rel=1e-9)
    short = er.slide(er.BedLine(z1, 0.0, xb, 1e-4), mu, curvature=curvature)  # a short bend
    assert short.s_stop == pytest.approx(r.s_stop, rel=1e-5)


def test_frictionless_block_keeps_its_energy_over_a_bend():
    bed = er.BedLine(d(40), d(10), 50.0, 30.0)
    r = er.slide(bed, 0.0, t_max=20.0)
    _, Z = bed.coordinates(r.s)
    assert r.s[-1] > bed.x_b + bed.L
    np.testing.assert_allclose(0.5 * r.u**2, -g * Z, rtol=0, atol=1e-8 * g * -Z.min())


@pytest.mark.parametrize("L", [0.0, 20.0, 60.0])
@pytest.mark.parametrize("mu", [0.2, 0.45])
def test_travel_angle_is_atan_mu_without_the_curvature_term(L, mu):
    # Heim's Fahrboschung: the friction's work is mu g times the horizontal distance
    bed = er.BedLine(d(38), d(3), 80.0, L)
    r = er.slide(bed, mu, curvature=False)
    assert r.stopped and r.s_stop > bed.x_b + L
    assert math.tan(bed.travel_angle(0.0, r.s_stop)) == pytest.approx(mu, abs=1e-6)
    with_k = er.slide(bed, mu)
    assert with_k.s_stop < r.s_stop  # the curvature's extra load stops it sooner
    assert bed.travel_angle(0.0, with_k.s_stop) > math.atan(mu)


def test_run_out_over_a_circular_bend_matches_the_closed_form():
    # on the arc dE/dzeta = 2 mu E - (g / kappa)(sin zeta - mu cos zeta), E = u^2 / 2: linear,
    # E = A sin + B cos + C exp(2 mu zeta), A = 3 mu g / (kappa (1 + 4 mu^2)),
    # B = (1 - 2 mu^2) g / (kappa (1 + 4 mu^2))
    z1, z2, xb, L, mu = d(35), d(5), 100.0, 50.0, 0.4
    k = (z1 - z2) / L
    e1 = g * (math.sin(z1) - mu * math.cos(z1)) * xb
    A, B = 3 * mu * g / (k * (1 + 4 * mu**2)), (1 - 2 * mu**2) * g / (k * (1 + 4 * mu**2))
    ep = lambda z: A * math.sin(z) + B * math.cos(z)
    e2 = ep(z2) + (e1 - ep(z1)) * math.exp(2 * mu * (z2 - z1))
    r = er.slide(er.BedLine(z1, z2, xb, L), mu)
    expected = xb + L + e2 / (g * (mu * math.cos(z2) - math.sin(z2)))
    assert r.s_stop == pytest.approx(expected, rel=1e-9)


def test_bed_coordinates():
    bed = er.BedLine(d(35), d(5), 100.0, 50.0)
    zeta = lambda v: float(bed.inclination(v))
    for s in (-10.0, 0.0, 50.0, 100.0, 117.0, 150.0, 230.0):
        X, Z = bed.coordinates(s)
        assert X == pytest.approx(quad(lambda v: math.cos(zeta(v)), 0, s, points=[100, 150])[0],
                                  abs=1e-10)  # fmt: skip
        assert Z == pytest.approx(-quad(lambda v: math.sin(zeta(v)), 0, s, points=[100, 150])[0],
                                  abs=1e-10)  # fmt: skip
    # the bend is an arc of radius 1 / kappa about a centre above the bed
    R = 1 / bed.kappa
    xb, zb = bed.coordinates(100.0)
    cx, cz = xb + R * math.sin(bed.zeta1), zb + R * math.cos(bed.zeta1)
    X, Z = bed.coordinates(np.linspace(100, 150, 11))
    np.testing.assert_allclose(np.hypot(X - cx, Z - cz), R, rtol=1e-12)
    assert math.tan(er.BedLine(d(20), d(20), 1.0).travel_angle(0, 7)) == pytest.approx(
        math.tan(d(20)), rel=1e-14
    )


def test_a_block_that_climbs_a_counter_slope_settles_where_friction_holds():
    bed = er.BedLine(d(30), d(-40), 50.0, 30.0)
    r = er.slide(bed, 0.3)
    assert r.stopped and abs(math.tan(float(bed.inclination(r.s_stop)))) <= 0.3
    assert np.any(r.u < 0)  # it slid back at least once
    _, Z = bed.coordinates(r.s)
    e = 0.5 * r.u**2 + g * Z
    assert np.all(np.diff(e) <= 1e-9)  # friction only dissipates


def test_run_out_refuses_impossible_set_ups():
    with pytest.raises(ValueError, match="leaves the bed"):  # a convex bend taken too fast
        er.slide(er.BedLine(d(10), d(60), 5.0, 1.0), 0.1, u0=20.0)
    with pytest.raises(ValueError, match="convex kink"):
        er.slide(er.BedLine(d(10), d(40), 5.0), 0.1, u0=5.0)
    with pytest.raises(ValueError):
        er.BedLine(d(95), 0.0, 1.0)
    with pytest.raises(ValueError):
        er.BedLine(d(30), 0.0, 1.0, -1.0)
    with pytest.raises(ValueError):
        er.slide(er.BedLine(d(30), 0.0, 1.0), -0.1)
