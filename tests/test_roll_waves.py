"""Roll waves (the `roll-waves` scenes): the solver's linear growth of a monodisperse uniform
flow against the package's own stability analysis (`tiseg.model.stability.monodisperse`, the
(H, U) block of (5.21)), growth below and decay above the viscous cut-off; and the forced
inflow (``inflow.forcing_frequency``, ``inflow.forcing_amplitude``).

The growth rate is measured as in T7 (docs/verification.md): the eigenmode of one wavenumber
with a relative amplitude of 1e-6 on a periodic domain of one wavelength; the log of the
modulus of the first Fourier coefficient of h is fitted by a line after the first quarter of
the run (the other, damped, mode that the discrete initial state excites has died out by
then). Measured with the scene's numerics (WENO, RKC; 1 s of flow), the relative error of
the rate at 32 / 64 / 128 cells per wavelength is:

    k = 0.1:   +1.0 %   +0.80 %  +0.40 %
    k = 0.2:   -0.84 %  +0.32 %  +0.23 %
    k = 0.4:   -4.8 %   -0.23 %  +0.12 %
    k = 1.0:   -14 %    -1.5 %   -0.09 %   (above the cut-off k_c = 0.760: decay)

The 2 % target at 128 cells runs in the slow test (k = 0.1, 0.2, 0.4, 1.0); the main suite
checks k = 0.2 and 1.0 at 64 cells (0.6 s and 0.3 s of flow, the same errors as over 1 s),
with 1 % for the growing mode and 3 % for the decaying one, twice the measured error, which is
spatial (it falls by 10-16x per halving of dx at k = 0.4 and 1.0).
"""

from __future__ import annotations

import numpy as np
import pytest

from tiseg.errors import InputError
from tiseg.model.stability import monodisperse as mono
from tiseg.model.stability.base import base_state
from tiseg.run.simulation import Simulation
from tiseg.setup.scene import load_scene


def mode_scene(k: float, nx: int, t_end: float):
    """The roll-waves flow with one eigenmode of wavenumber k (5.1) on one wavelength."""
    return load_scene(
        "roll-waves",
        {
            "initial.mode": "eigen",
            "initial.amplitude": 1e-6,
            "initial.k": k,
            "initial.wavelengths": 1,
            "domain.Lx": None,
            "domain.nx": nx,
            "time.t_end": t_end,
        },
    )


def theory(sc, k: float) -> complex:
    """The fastest monodisperse mode's sigma at k, in 1/s (sigma u0 / h0, (5.1))."""
    bs = base_state(sc.flow.h0, sc.flow.phi0, sc.flow.nu, sc.material)
    lam = mono.bulk_roots(bs, np.array([k]))[0][0]
    return complex(lam) * sc.flow.u0 / sc.flow.h0


def measured(sc, n: int = 31) -> tuple[float, float]:
    """(rate, angular frequency) [1/s] of the first Fourier coefficient of h."""
    sim = Simulation(sc)
    ts, amp, ph = [], [], []
    for j in range(n):
        sim.advance(sc.t_end * j / (n - 1))
        c = np.fft.rfft(sim.conserved()[0, :, 0])[1]
        ts.append(sim.t), amp.append(abs(c)), ph.append(np.angle(c))
    ts = np.array(ts)
    late = slice(n // 4, None)
    rate = np.polyfit(ts[late], np.log(amp[late]), 1)[0]
    omega = np.polyfit(ts[late], np.unwrap(ph[late]), 1)[0]
    return float(rate), float(omega)


def test_the_scene_is_above_the_roll_wave_threshold_and_has_a_cutoff():
    sc = load_scene("roll-waves")
    bs = base_state(sc.flow.h0, sc.flow.phi0, sc.flow.nu, sc.material)
    # F_rw = mu_u / |mu_h| = 2/3 for the law (3.7): mu_h = -(3/2) mu_u by (5.15), (5.16)
    assert abs(mono.threshold_froude(bs) - 2.0 / 3.0) < 1e-12
    assert sc.flow.F > 2.0 * mono.threshold_froude(bs)
    k_M, s_M = mono.most_unstable(bs)
    k_c = mono.cutoff(bs)
    assert s_M > 0 and 0 < k_M < k_c
    assert mono.bulk_growth(bs, np.array([0.5 * k_c]))[0] > 0
    assert mono.bulk_growth(bs, np.array([1.5 * k_c]))[0] < 0
    # without viscosity nothing is damped: no cut-off
    assert mono.cutoff(base_state(sc.flow.h0, 1.0, 0.0, sc.material)) is None
    # below the threshold nothing grows
    low = base_state(0.3 * sc.flow.h0, 1.0, sc.flow.nu, sc.material)
    assert low.F < 2.0 / 3.0 and mono.cutoff(low) is None
    assert mono.bulk_growth(low, np.array([1e-3, 0.1, 1.0])).max() < 0


def test_growth_rate_of_a_mode_matches_the_stability_analysis(ti_cpu):
    k = 0.2
    sc = mode_scene(k, 64, 0.6)
    sigma = theory(sc, k)
    assert sigma.real > 0
    rate, omega = measured(sc)
    assert abs(rate - sigma.real) < 0.01 * sigma.real, (rate, sigma)
    assert abs(omega - sigma.imag) < 0.01 * abs(sigma.imag), (omega, sigma)


@pytest.mark.slow  # a long run: the slow set (README), which CI runs after the suite
def test_a_mode_above_the_viscous_cutoff_decays_at_the_predicted_rate(ti_cpu):
    k = 1.0
    sc = mode_scene(k, 64, 0.3)
    bs = base_state(sc.flow.h0, 1.0, sc.flow.nu, sc.material)
    assert k > mono.cutoff(bs)
    sigma = theory(sc, k)
    rate, _ = measured(sc)
    assert rate < 0
    assert abs(rate - sigma.real) < 0.03 * abs(sigma.real), (rate, sigma)


@pytest.mark.slow
@pytest.mark.parametrize("k", [0.1, 0.2, 0.4, 1.0])
def test_growth_rate_within_two_percent_at_128_cells_per_wavelength(ti_cpu, k):
    sc = mode_scene(k, 128, 1.0)
    sigma = theory(sc, k)
    rate, _ = measured(sc)
    assert abs(rate - sigma.real) < 0.02 * abs(sigma.real), (rate, sigma)


# ------------------------------------------------------------------ the forced inflow
def test_forced_inflow_modulates_the_inflow_thickness_and_the_flow():
    sc = load_scene("roll-waves-forced")
    f, a, h = sc.inflow.forcing_frequency, sc.inflow.forcing_amplitude, sc.inflow.h
    assert f > 0 and 0 < a < 1
    t = np.linspace(0.0, 1.0, 401)
    hin = np.array([sc.inflow.thickness(s) for s in t])
    np.testing.assert_allclose(hin, h * (1 + a * np.sin(2 * np.pi * f * t)), rtol=1e-14)
    plain = sc.with_overrides({"inflow.forcing_amplitude": 0.0, "inflow.forcing_frequency": 0})
    assert all(plain.inflow.thickness(s) == h for s in t)  # bit for bit the unforced inflow


def test_forced_waves_travel_downslope_at_the_forcing_frequency(ti_cpu):
    """A 0.15 m chute at 2.5 mm cells for 1 s: the thickness 7.5 cm downstream oscillates at
    the forcing frequency, and the mass budget closes with the modulated inflow."""
    sc = load_scene(
        "roll-waves-forced",
        {"domain.Lx": 0.15, "domain.resolution": 400, "time.t_end": 1.0},
    )
    sim = Simulation(sc)
    m0 = sim.totals()["mass"]
    i = sc.domain.nx // 2
    ts, hs = [], []
    for j in range(101):
        sim.advance(sc.t_end * j / 100)
        ts.append(sim.t), hs.append(sim.conserved()[0, i, 0])
    ts, hs = np.array(ts), np.array(hs)
    late = ts >= 0.4  # the signal has arrived (speed ~ 1.6 u0 = 0.25 m/s)
    dev = hs[late] - hs[late].mean()
    assert np.abs(dev).max() > 0.2 * sc.inflow.forcing_amplitude * sc.flow.h0
    spec = np.abs(np.fft.rfft(dev * np.hanning(dev.size)))
    freqs = np.fft.rfftfreq(dev.size, ts[1] - ts[0])
    assert abs(freqs[np.argmax(spec)] - sc.inflow.forcing_frequency) <= 1.7  # 1.7 Hz bins
    mass, bud = sim.totals()["mass"], sim.budget()
    assert abs(mass - m0 - bud["mass_in"]) <= 1e-11 * mass
    # the forcing is a run-time number: it changes without a new build
    sim.set_parameters({"inflow.forcing_frequency": 8.0, "inflow.forcing_amplitude": 0.02})
    assert sim.scene.inflow.forcing_frequency == 8.0
    sim.advance(sc.t_end + 0.05)
    assert np.all(np.isfinite(sim.conserved()))


@pytest.mark.parametrize(
    "over, words",
    [
        ({"inflow.forcing_amplitude": 1.0}, "below 1"),
        ({"inflow.forcing_amplitude": -0.1}, "forcing_amplitude"),
        ({"inflow.forcing_frequency": -2.0}, "forcing_frequency"),
        ({"inflow.forcing_frequency": 0.0}, "forcing_frequency > 0"),
        ({"initial.mode": "noise"}, "h-noise"),
    ],
)
def test_bad_forcing_and_perturbation_are_one_line_errors(over, words):
    name = "roll-waves" if "initial.mode" in over else "roll-waves-forced"
    with pytest.raises(InputError, match=words) as err:
        load_scene(name, over)
    assert "\n" not in str(err.value)


def test_h_noise_is_the_same_long_wave_profile_on_every_grid():
    from tiseg.setup.initial import thickness_noise

    coarse_x = (np.arange(200) + 0.5) / 200
    fine_x = (np.arange(800) + 0.5) / 800
    a = thickness_noise(coarse_x, 1 / 200, 1.0, 3)
    b = thickness_noise(fine_x, 1 / 800, 1.0, 3)
    assert abs(np.sqrt(np.mean(a**2)) - 1.0) < 0.1  # unit RMS (cell averages: slightly less)
    # the coarse grid's modes are the fine grid's first ones, with the same phases
    modes = np.arange(1, 200 // 8 + 1)

    def coefficients(r, x):  # of exp(2 pi i n x), n = 1..25, on the cell centres x
        return (r[None, :] * np.exp(-2j * np.pi * modes[:, None] * x[None, :])).mean(axis=1)

    ua, ub = coefficients(a, coarse_x), coefficients(b, fine_x)
    np.testing.assert_allclose(ua / abs(ua), ub / abs(ub), atol=1e-9)


def test_wave_diagnostics_on_a_known_train():
    """Three sawtooth waves of crest 2 h0 and trough 0.5 h0 with small ripples on their backs,
    shifted by 37.3 cells: three crests (the ripples are not waves), spacing L / 3, and the
    shift recovered to a fraction of a cell."""
    from tiseg.post.analysis.roll_waves import train_speed, wave_train

    n, h0, dx = 600, 1e-3, 1e-3
    x = np.arange(n) * dx
    phase = (x / (n * dx / 3)) % 1.0
    h = h0 * (0.5 + 1.5 * phase**2) + 0.01 * h0 * np.sin(2 * np.pi * 40 * x / (n * dx))
    w = wave_train(h, dx, h0)
    assert w["waves"] == 3
    assert abs(w["spacing"] - n * dx / 3) < 1e-12
    assert abs(w["crest"] - 2.0) < 0.02 and abs(w["trough"] - 0.5) < 0.02
    shift = 37.3
    k = np.fft.rfftfreq(n, 1.0)
    moved = np.fft.irfft(np.fft.rfft(h) * np.exp(-2j * np.pi * k * shift), n=n)
    # within a tenth of a cell (the nearest whole cell alone would be 0.3 cells off)
    assert abs(train_speed(h, moved, dx, 0.1, 1.0) - shift * dx / 0.1) < 0.1 * dx / 0.1
