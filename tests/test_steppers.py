"""Each time stepper on its own: order of accuracy on a linear ODE and on a smooth PDE
(semi-discrete heat equation with an exact solution), and RKC's stability interval."""

import numpy as np
import pytest

from tiseg.solver.timestepping import make_stepper
from tiseg.solver.timestepping.base import RATE
from tiseg.solver.timestepping.rkc import rkc_coefficients, stages_for


class ArrayOperator:
    """The stepper interface over NumPy arrays: y' = A y + forcing(t)."""

    def __init__(self, apply, forcing=None, nslots=6, n=1, dtype=float):
        self.apply, self.forcing = apply, forcing
        self.s = [np.zeros(n, dtype) for _ in range(nslots)]
        self.evals = 0

    def rhs(self, src, dst, t):
        self.evals += 1
        r = self.apply(self.s[src])
        self.s[dst] = r + (self.forcing(t) if self.forcing else 0.0)

    def combine(self, dst, terms, limit=False, tau=0.0, rates=()):
        self.s[dst] = sum(c * self.s[k] for c, k in terms)  # no limiter for a linear ODE

    def stage(self, dst, terms, src, t, limit=True, tau=None, rates=()):
        self.evals += 1
        r = self.apply(self.s[src]) + (self.forcing(t) if self.forcing else 0.0)
        self.s[dst] = sum(c * (r if k == RATE else self.s[k]) for c, k in terms)


def _integrate(stepper, op, y0, t_end, n, stages):
    op.s[0] = np.array(y0, dtype=op.s[0].dtype)
    dt = t_end / n
    for k in range(n):
        stepper.step(op, k * dt, dt, stages)
    return op.s[0]


CASES = [
    ("euler", {}, 1, 1),
    ("ssprk2", {}, 2, 2),
    ("ssprk3", {}, 3, 3),
    ("ssprk4_2", {}, 2, 4),
    ("ssprk10_2", {}, 2, 10),
    ("ssprk10_4", {}, 4, 10),
    ("ssprk9_3", {}, 3, 9),
    ("ssprk16_3", {}, 3, 16),
    ("rkc", {}, 2, 2),
    ("rkc", {}, 2, 5),
    ("rkc", {}, 2, 12),
]


@pytest.mark.parametrize("name,kw,order,stages", CASES)
def test_order_on_forced_linear_ode(name, kw, order, stages):
    # y' = lam y + cos t, y(0) = 1: exact y = C e^{lam t} + (sin t - lam cos t)/(1 + lam^2) ...
    lam = -3.0
    exact = lambda t: (
        (1 + lam / (1 + lam**2)) * np.exp(lam * t) + (np.sin(t) - lam * np.cos(t)) / (1 + lam**2)
    )
    errs = []
    for n in (20, 40, 80, 160):
        op = ArrayOperator(lambda y: lam * y, forcing=np.cos)
        y = _integrate(make_stepper(name, **kw), op, [1.0], 1.0, n, stages)
        errs.append(abs(y[0] - exact(1.0)))
    rates = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert abs(rates[-1] - order) < 0.15, rates


@pytest.mark.parametrize("name,kw,order,stages", CASES[1:])
def test_order_on_smooth_pde(name, kw, order, stages):
    """Semi-discrete periodic heat equation u_t = kappa u_xx (central differences): the exact
    solution of the ODE system is a decaying Fourier mode, so the error is the time error alone."""
    n_cells, kappa = 32, 1e-2
    dx = 1.0 / n_cells
    x = (np.arange(n_cells) + 0.5) * dx
    lap = lambda u: kappa * (np.roll(u, 1) - 2 * u + np.roll(u, -1)) / dx**2
    m = 3
    lam = -kappa * (2 - 2 * np.cos(2 * np.pi * m * dx)) / dx**2
    u0 = np.sin(2 * np.pi * m * x)
    t_end = 0.5 / abs(lam)
    errs = []
    for n in (10, 20, 40, 80):
        op = ArrayOperator(lap, n=n_cells)
        u = _integrate(make_stepper(name, **kw), op, u0, t_end, n, stages)
        errs.append(np.max(np.abs(u - u0 * np.exp(lam * t_end))))
    rates = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert abs(rates[-1] - order) < 0.2, rates


def _rkc_amplification(s, z):
    op = ArrayOperator(lambda y: z * y, dtype=complex)
    op.s[0] = np.array([1.0 + 0j])
    make_stepper("rkc").step(op, 0.0, 1.0, s)
    return abs(op.s[0][0])


@pytest.mark.parametrize("dt_rho", [0.5, 3.0, 10.0, 100.0, 1000.0])
def test_rkc_stage_rule_keeps_spectrum_stable(dt_rho):
    """With s = stages_for(dt rho), |P_s(z)| <= 1 on the whole real interval [-dt rho, 0]."""
    s = stages_for(dt_rho)
    zs = -np.linspace(0.0, dt_rho, 801)
    amp = np.array([_rkc_amplification(s, z) for z in zs])
    assert amp.max() <= 1.0 + 1e-12
    # and the damped polynomial really damps the stiff end (epsilon = 2/13)
    assert amp[-1] < 1.0


def test_rkc_stage_times_end_at_one():
    for s in (2, 3, 7, 30, 100):
        _, _, c = rkc_coefficients(s)
        assert abs(c[-1] - 1.0) < 1e-12
        assert all(0 <= a <= b + 1e-15 for a, b in zip(c, c[1:]))  # non-decreasing stage times


def test_rkc_stability_interval_grows_like_s_squared():
    """beta(s) ~ 0.653 s^2 (Sommeijer, Shampine & Verwer 1997): the amplification is <= 1 up to 0.6 s^2 and
    above 1 beyond 0.7 s^2."""
    for s in (5, 10, 20):
        assert _rkc_amplification(s, -0.60 * s * s) <= 1.0
        assert _rkc_amplification(s, -0.70 * s * s) > 1.0


SSP = [
    ("euler", 1.0),
    ("ssprk2", 1.0),
    ("ssprk3", 1.0),
    ("ssprk4_2", 3.0),
    ("ssprk10_2", 9.0),
    ("ssprk10_4", 6.0),
    ("ssprk9_3", 6.0),
    ("ssprk16_3", 12.0),
]


@pytest.mark.parametrize("name,ssp", SSP)
def test_ssp_coefficient_keeps_upwind_advection_monotone(name, ssp):
    """First-order upwind advection of a step: forward Euler is monotone (no new extrema, no
    negative values) for c = dt a / dx <= 1, so an SSP method with coefficient C is for
    c <= C. Each stepper at exactly its C stays within [0, 1]; 15 % beyond it overshoots."""
    n = 60
    up = lambda u: -(u - np.roll(u, 1))  # a / dx = 1
    u0 = np.where(np.arange(n) < n // 2, 1.0, 0.0)
    stepper = make_stepper(name)
    assert stepper.ssp == ssp
    for factor, monotone in ((1.0, True), (1.15, False)):
        op = ArrayOperator(up, n=n)
        u = _integrate(stepper, op, u0, 10 * ssp * factor, 10, stepper.stages)
        inside = u.min() >= -1e-13 and u.max() <= 1 + 1e-13
        assert inside == monotone, (factor, u.min(), u.max())


@pytest.mark.parametrize("name,ssp", SSP)
def test_ssp_plan_takes_its_coefficient_times_the_euler_step(name, ssp):
    s = make_stepper(name)
    dt, stages = s.plan(1e-3, 0.0, np.inf)
    assert dt == pytest.approx(ssp * 1e-3) and stages == s.stages
    # and the spectral radius still bounds it: dt <= 0.9 beta / rho
    dt, _ = s.plan(1e-3, 1e5, np.inf)
    assert dt == pytest.approx(min(ssp * 1e-3, 0.9 * s.beta / 1e5))


@pytest.mark.parametrize("name", [n for n, _ in SSP])
def test_explicit_rk_real_stability_interval_is_beta(name):
    """|R(z)| <= 1 on [-beta, 0] and > 1 at 1.03 beta: the interval the plan relies on."""
    s = make_stepper(name)

    def amp(z):
        op = ArrayOperator(lambda y: z * y, dtype=complex)
        op.s[0] = np.array([1.0 + 0j])
        s.step(op, 0.0, 1.0, s.stages)
        return abs(op.s[0][0])

    assert max(amp(z) for z in -np.linspace(0, s.beta, 400)) <= 1.0 + 1e-9
    assert amp(-1.03 * s.beta) > 1.0
