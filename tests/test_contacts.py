"""Sharp contacts: the ``channel`` scene, a straight fine channel between coarse levees whose
exact concentration never changes (no mass crosses the contacts), and whose steady speed
profile u(y) solves the cross-slope boundary-value problem of :mod:`tiseg.post.problems.steady_channel`."""

import numpy as np
import pytest

from tiseg.setup.scene import load_scene
from tiseg.run.simulation import Simulation
from tiseg.post.problems.steady_channel import channel_profile


def channel(res=250, t_end=1.0, **over):
    """The channel scene at ``res`` cells/m, 4 cells downslope (the flow is x-independent)."""
    over = {
        "domain.resolution": res,
        "domain.Lx": 4.0 / res,
        "time.t_end": t_end,
        "output.interval": t_end,
        **over,
    }
    return load_scene("channel", over)


def masks(sc):
    """Cells wholly inside the channel and wholly inside the levees (rows of (ny, nx))."""
    y = (np.arange(sc.domain.ny) + 0.5) * sc.dy
    half = 0.5 * sc.initial.width
    d = np.abs(y - 0.5 * sc.domain.Ly)
    return d < half - 0.5 * sc.dy, d > half + 0.5 * sc.dy


@pytest.mark.parametrize(
    "flux,rec,phis",
    [
        ("kt", "weno", (1.0, 0.0)),
        ("kt", "weno", (0.9, 0.15)),
        ("kt", "minmod", (1.0, 0.0)),
        ("central-upwind", "minmod", (0.9, 0.15)),
        ("central-upwind", "weno", (1.0, 0.0)),
    ],
    ids=["kt-weno-pure", "kt-weno-mixed", "kt-minmod-pure", "cu-minmod-mixed", "cu-weno-pure"],
)
def test_upwind_phi_flux_keeps_a_contact_no_mass_crosses(ti_cpu, flux, rec, phis):
    """With numerics.phi_flux = "upwind" phi stays phi_channel in the channel and phi_levee in
    the levees to round-off, while u(y) develops a shear layer across each contact (the flow
    is not trivial). The mixed case keeps phi off the bounds 0 and 1, where the stage
    limiter's clip could hide a leak."""
    sc = channel(
        **{
            "numerics.phi_flux": "upwind",
            "numerics.flux": flux,
            "numerics.reconstruction": rec,
            "initial.phi_channel": phis[0],
            "initial.phi_levee": phis[1],
        }
    )
    sim = Simulation(sc)
    sim.advance(sc.t_end)
    f = sim.fields()
    inside, outside = masks(sc)
    # round-off only: the RKC stages combine equal values with coefficients that sum to 1 in
    # floating point (1e-14 after the run's few hundred steps); a smeared contact loses 1e-2
    np.testing.assert_allclose(f["phi"][inside], phis[0], rtol=0, atol=1e-12)
    np.testing.assert_allclose(f["phi"][outside], phis[1], rtol=0, atol=1e-12)
    assert np.all(f["v"] == 0.0)
    u = f["u"][:, 0]
    assert u[inside].min() > 0.1 and u[0] < 0.01 * u[inside].max()  # u[0]: the levee centre


def test_central_phi_flux_smears_the_contact(ti_cpu):
    """The same case with the scheme's own h phi flux: the KT dissipation (1/2) a (q_r - q_l)
    mixes phi across the contacts though no mass crosses them (what phi_flux = "upwind"
    removes). At 250 cells/m the channel centre loses several per cent in 1 s."""
    sc = channel(**{"numerics.phi_flux": "central"})
    sim = Simulation(sc)
    sim.advance(sc.t_end)
    phi = sim.fields()["phi"]
    inside, outside = masks(sc)
    centre = phi[sc.domain.ny // 2, 0]
    assert centre < 0.97
    assert phi[outside].max() > 0.03


@pytest.mark.slow
def test_channel_speed_converges_to_the_cross_slope_solution(ti_cpu):
    """u(y) at t = 3 s (steady to 1e-3) against the cell averages of the boundary-value
    problem's solution: the relative L1 error falls with the grid at second order or better
    (measured 5.7 % at 250 cells/m, 2.3 % at 375: a factor 2.5 for 1.5x the cells)."""
    errs = []
    for res in (250, 375):
        sc = channel(res, 3.0, **{"numerics.phi_flux": "upwind"})
        prof = channel_profile(sc)
        sim = Simulation(sc)
        sim.advance(sc.t_end)
        u = sim.fields()["u"][:, 0]
        y = (np.arange(sc.domain.ny) + 0.5) * sc.dy
        exact = prof.cell_averages(y, sc.dy)
        errs.append(np.abs(u - exact).mean() / np.abs(exact).mean())
    assert errs[1] < 0.03, errs
    assert errs[0] / errs[1] > 1.5**2 * 0.9, errs  # order 2 would give 2.25


def test_channel_profile_balances_friction_and_viscosity():
    """The boundary-value solution itself: far from the contacts u is the local balance of
    gravity and friction (the steady uniform speed of pure fines, from section 4's quadratic,
    where tan zeta = mu_S(Fr)), and without viscosity the profile is that balance, piecewise
    constant."""
    import math

    from tiseg.model.steady import velocity

    sc = channel(**{"domain.Ly": 2.0, "initial.width": 1.0})  # centres 0.5 m from contacts
    prof = channel_profile(sc)
    u_fine = velocity(sc.initial.h, 1.0, sc.material)
    assert prof.u_channel == pytest.approx(u_fine, rel=1e-5)
    # the coarse levee (zeta < zeta_1 of the large grains) creeps at the regularised balance
    # u = u_eps tan(zeta) / mu_L(Fr -> 0) = u_eps tan(zeta) / tan(zeta_1^L), to first order
    creep = sc.numerics.u_eps * sc.material.tan_zeta / math.tan(math.radians(29.0))
    assert prof.u_levee == pytest.approx(creep, rel=0.02)
    inviscid = channel_profile(channel(**{"flow.nu": 0.0}))
    y = np.linspace(0, sc.domain.Ly, 7)
    assert set(np.round(inviscid.u(y), 12)) <= {
        round(inviscid.u_channel, 12),
        round(inviscid.u_levee, 12),
    }
