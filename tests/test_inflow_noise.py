"""inflow.noise and inflow.seed: a random cross-slope perturbation of the inflow concentration
added to (6.9), so that runs differing only in the seed are physically different realisations.
"""

import math

import numpy as np
import pytest

from solver_helpers import exit_code
from tiseg.errors import InputError
from tiseg.solver.numerics.config import NOISE_MIN_WAVELENGTH, inflow_noise, noise_modes
from tiseg.setup.scene import load_scene


def test_profile_has_unit_rms_zero_mean_and_is_periodic():
    Ly = 0.5
    y = np.linspace(0.0, Ly, 4001)[:-1]  # exact quadrature of the modes n <= 25
    for seed in (0, 1, 12345):
        r = inflow_noise(y, Ly, seed)
        assert np.sqrt(np.mean(r**2)) == pytest.approx(1.0, abs=1e-12)
        assert abs(r.mean()) < 1e-12
        assert np.abs(r).max() <= math.sqrt(2 * noise_modes(Ly)) + 1e-12
        assert inflow_noise([0.0], Ly, seed)[0] == pytest.approx(
            inflow_noise([Ly], Ly, seed)[0], abs=1e-12
        )


def test_profile_is_band_limited_to_2_cm():
    """Its spectrum holds the modes n = 1..Ly / 2 cm and nothing else, each with an equal share."""
    Ly = 0.5
    y = np.arange(1000) * Ly / 1000
    power = np.abs(np.fft.rfft(inflow_noise(y, Ly, 5))) ** 2
    n_max = int(Ly / NOISE_MIN_WAVELENGTH)
    assert power[0] < 1e-20 and power[n_max + 1 :].max() < 1e-18 * power.max()
    np.testing.assert_allclose(power[1 : n_max + 1], power[1], rtol=1e-9)


def test_same_seed_same_profile_on_any_grid_other_seed_another():
    Ly = 0.5
    coarse = (np.arange(125) + 0.5) * Ly / 125
    fine = (np.arange(375) + 0.5) * Ly / 375
    a, b = inflow_noise(coarse, Ly, 2), inflow_noise(fine, Ly, 2)
    np.testing.assert_array_equal(a, b[1::3])  # coarse centres are every third fine centre
    c = inflow_noise(coarse, Ly, 3)
    assert np.corrcoef(a, c)[0, 1] < 0.5


def test_scene_keys_defaults_and_concentration():
    # the fingers scene seeds its instability itself (its inflow noise, seed 1)
    assert load_scene("fingers").inflow.noise == 1e-4 and load_scene("fingers").inflow.seed == 1
    assert load_scene("levees").inflow.noise == 0.0  # (the key's default: no noise)
    s = load_scene("fingers", {"inflow.noise": 0.0, "inflow.seed": 0})
    n = load_scene("fingers", {"inflow.noise": 1e-3, "inflow.seed": 4})
    y = (np.arange(375) + 0.5) * 0.5 / 375
    d = n.inflow.concentration(y, 0.5) - s.inflow.concentration(y, 0.5)
    np.testing.assert_allclose(d, 1e-3 * 0.8 * inflow_noise(y, 0.5, 4), atol=1e-15)
    # the resolved scene keeps them (a sweep's reuse check compares resolved scenes)
    from tiseg.setup.scene import scene_from_text

    back = scene_from_text(n.to_toml())
    assert back.inflow.noise == 1e-3 and back.inflow.seed == 4


@pytest.mark.parametrize(
    "over, words",
    [
        ({"inflow.noise": -1e-4}, "inflow.noise"),
        ({"inflow.noise": 0.5}, "outside [0, 1]"),
        ({"inflow.seed": -1}, "inflow.seed"),
        ({"inflow.seed": 1.5}, "inflow.seed"),
        ({"inflow.noise": float("nan")}, "inflow.noise"),
    ],
)
def test_bad_noise_keys_are_one_line_errors(over, words):
    with pytest.raises(InputError) as err:
        load_scene("fingers", over)
    assert words in str(err.value) and "\n" not in str(err.value)


@pytest.mark.slow  # a long regression run: CI runs it in the slow set
def test_seeds_give_different_runs_and_a_seed_reproduces(ti_cpu, tmp_path):
    """Three tiny runs of the fingers scene: the same seed gives bitwise the same fields, another
    seed other fields."""
    import netCDF4

    base = [
        "--set",
        "domain.resolution=60",
        "--set",
        "domain.Lx=0.4",
        "--set",
        "domain.Ly=0.2",
        "--set",
        "time.t_end=0.3",
        "--set",
        "output.times=[]",
        "--set",
        "output.interval=0.3",
        "--set",
        "inflow.noise=1e-3",
        "--no-progress",
    ]
    for name, seed in (("a", 1), ("b", 1), ("c", 2)):
        assert (
            exit_code(
                [
                    "run",
                    "fingers",
                    "--out",
                    str(tmp_path / name),
                    *base,
                    "--set",
                    f"inflow.seed={seed}",
                ]
            )
            == 0
        )

    def last(name, var):
        with netCDF4.Dataset(tmp_path / name / "fields.nc") as nc:
            return np.asarray(nc[var][-1])

    np.testing.assert_array_equal(last("a", "phi"), last("b", "phi"))
    assert np.abs(last("a", "phi") - last("c", "phi")).max() > 1e-5
