"""Source terms and auxiliary fields registered by user code (`tiseg.model.physics.sources`).

Two components are defined in this file, outside the package, and registered at run time:

* ``test-drag``: a linear drag -k (h u, h v) with one constant, ``effects.drag_rate`` k
  [1/s] (pointwise, stiff: its stiffness bound is k);
* ``test-tilt``: the pressure of a tilted bed b(x, y) = -s x + a sin(2 pi y / Ly), an
  auxiliary field ``test-bed`` with the constants ``bed_tilt`` s and ``bed_ripple`` a, read by
  a term -g cos(zeta) h grad b from centred differences (it reads its neighbours).

Each runs through the scene (its keys, their checks and the written scene), the kernels of
both schemes, the NumPy twin and the run folder, and an absent term compiles nothing. The
truth is independent of the code under test: a uniform layer without friction accelerates at
g sin(zeta) + g cos(zeta) s under the tilt, and its speed decays as exp(-k t) under the drag.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from tiseg.errors import InputError
from tiseg.model.physics import sources
from tiseg.model.physics.constants import Constant
from tiseg.model.physics.params import Params
from tiseg.model.physics.sources import AuxField, SourceTerm
from tiseg.setup.scene import load_scene, scene_from_text


class LinearDrag(SourceTerm):
    """-k (h u, h v): momentum relaxes at the rate k."""

    name = "test-drag"
    doc = "a linear drag on the momentum"
    constants = (Constant("drag_rate", 1.0, "drag rate k [1/s]", nonneg=True),)

    def taichi(self, ti, ctx):
        par, base, w = ctx.par, ctx.base, ctx.w

        @ti.func
        def rate(e, i, j):
            c = w[i, j, e]
            r = ti.Vector.zero(ctx.fp, ctx.nc)
            r[ctx.HU] = -par[e, base] * c[0] * c[ctx.HU]
            if ti.static(not ctx.is_1d):
                r[ctx.HV] = -par[e, base] * c[0] * c[ctx.HV]
            return r

        return rate

    def stiffness_taichi(self, ti, ctx):
        par, base = ctx.par, ctx.base

        @ti.func
        def stiffness(e, i, j):
            return par[e, base] + 0.0 * i

        return stiffness

    def rate_np(self, ctx):
        lay, w = ctx.cfg.layout, ctx.w
        out = np.zeros_like(w)
        out[lay.HU] = -ctx.values["drag_rate"] * w[0] * w[lay.HU]
        if not lay.is_1d:
            out[lay.HV] = -ctx.values["drag_rate"] * w[0] * w[lay.HV]
        return out


class TiltedBed(AuxField):
    """b = -s x + a sin(2 pi y / Ly) [m]."""

    name = "test-bed"
    doc = "a tilted, rippled bed"
    constants = (
        Constant("bed_tilt", 0.0, "downslope tilt s of the bed"),
        Constant("bed_ripple", 0.0, "cross-slope ripple a of the bed [m]"),
    )
    Ly = 0.072  # the width of the twin's grid

    def values_np(self, x, y, values):
        return -values["bed_tilt"] * x + values["bed_ripple"] * np.sin(2 * np.pi * y / self.Ly)


class BedPressure(SourceTerm):
    """-g cos(zeta) h grad b, centred differences of the auxiliary field test-bed."""

    name = "test-tilt"
    doc = "the pressure of the bed test-bed"
    aux = ("test-bed",)
    stencil = 1

    def taichi(self, ti, ctx):
        par, w, aux = ctx.par, ctx.w, ctx.aux
        k = ctx.aux_index["test-bed"]

        @ti.func
        def rate(e, i, j):
            h = w[i, j, e][0]
            gc = par[e, Params.G_COS]
            r = ti.Vector.zero(ctx.fp, ctx.nc)
            r[ctx.HU] = (
                -gc * h * (aux[i + 1, j, e][k] - aux[i - 1, j, e][k]) * 0.5 * par[e, Params.INV_DX]
            )
            if ti.static(not ctx.is_1d):
                r[ctx.HV] = (
                    -gc
                    * h
                    * (aux[i, j + 1, e][k] - aux[i, j - 1, e][k])
                    * 0.5
                    * par[e, Params.INV_DY]
                )
            return r

        return rate

    def rate_np(self, ctx):
        cfg, w, b = ctx.cfg, ctx.w, ctx.aux["test-bed"]
        lay = cfg.layout
        out = np.zeros_like(w)
        out[lay.HU, 1:-1] = -cfg.g_cos * w[0, 1:-1] * (b[2:] - b[:-2]) / (2 * cfg.dx)
        if not lay.is_1d:
            out[lay.HV, :, 1:-1] = (
                -cfg.g_cos * w[0, :, 1:-1] * (b[:, 2:] - b[:, :-2]) / (2 * cfg.dy)
            )
        return out


@pytest.fixture
def registered():
    """The two terms and the field, registered as user code would, removed afterwards."""
    sources.SOURCES["test-drag"] = LinearDrag()
    sources.SOURCES["test-tilt"] = BedPressure()
    sources.AUX_FIELDS["test-bed"] = TiltedBed()
    yield
    for reg, name in (
        (sources.SOURCES, "test-drag"),
        (sources.SOURCES, "test-tilt"),
        (sources.AUX_FIELDS, "test-bed"),
    ):
        reg.pop(name, None)


# a uniform layer on a periodic plane, no friction, no viscosity: every cell alike
UNIFORM = {
    "effects.friction": "none",
    "effects.viscosity": False,
    "flow.u0": 0.2,
    "initial.mode": "h",
    "initial.amplitude": 0.0,
    "time.t_end": 0.05,
    "output.interval": 0.05,
}


def _uniform(stepper: str, ny: int = 1, **more):
    over = dict(UNIFORM, **{"domain.nx": 16, "domain.ny": ny, **more})
    if ny > 1:
        over["domain.Ly"] = 0.04
    if stepper == "hancock":
        over.update(
            {
                "numerics.stepper": "hancock",
                "numerics.friction_scheme": "projected",
                "numerics.phi_flux": "upwind",
                "numerics.cfl": 0.9,
            }
        )
    return load_scene("uniform-flow", over)


# ---- the scene ----------------------------------------------------------------------------------
def test_a_registered_term_brings_its_keys_into_the_scene(registered):
    sc = _uniform("rkc", **{"effects.sources": ["test-drag"], "effects.drag_rate": 3.0})
    assert sc.effects.sources == ("test-drag",) and sc.effects.drag_rate == 3.0
    # the default when the key is left out; written back and read as the same scene
    assert _uniform("rkc", **{"effects.sources": ["test-drag"]}).effects.drag_rate == 1.0
    again = scene_from_text(sc.to_toml(), name=sc.name)
    assert again == sc
    # its constant is checked as the term declares it
    with pytest.raises(InputError, match=r"effects\.drag_rate=-1.*must not be negative"):
        _uniform("rkc", **{"effects.sources": ["test-drag"], "effects.drag_rate": -1.0})
    # a constant of a term that is off would do nothing: an error, not silence
    with pytest.raises(InputError, match=r"effects\.drag_rate=2.*'test-drag'.*effects\.sources"):
        _uniform("rkc", **{"effects.drag_rate": 2.0})
    # a scene without the term writes none of its keys
    assert "drag_rate" not in _uniform("rkc").to_toml()


def test_unknown_or_repeated_terms_are_one_line_errors(registered):
    with pytest.raises(InputError, match=r"effects\.sources\[0\]='drag'.*'test-drag'"):
        _uniform("rkc", **{"effects.sources": ["drag"]})
    with pytest.raises(InputError, match="named twice"):
        _uniform("rkc", **{"effects.sources": ["test-drag", "test-drag"]})
    with pytest.raises(InputError, match="expected an array of names"):
        _uniform("rkc", **{"effects.sources": "test-drag"})


def test_a_term_that_is_not_registered_is_refused(registered):
    sc = _uniform("rkc", **{"effects.sources": ["test-drag"]})
    text = sc.to_toml()
    sources.SOURCES.pop("test-drag")
    # (its constant is the first thing the scene no longer knows)
    with pytest.raises(InputError, match=r"unknown key 'effects\.drag_rate'"):
        scene_from_text(text, name="x")
    with pytest.raises(InputError, match=r"effects\.sources\[0\]='test-drag'"):
        scene_from_text(text.replace("drag_rate = 1.0\n", ""), name="x")


# ---- the kernels against the twin and against exact answers ----------------------------------
@pytest.mark.parametrize("stepper", ["rkc", "hancock"])
def test_the_tilt_accelerates_a_uniform_layer_exactly(registered, ti_cpu, stepper):
    """No friction, uniform h on a periodic plane: du/dt = g sin(zeta) + g cos(zeta) s in
    every cell, to round-off in both schemes (a constant rate); nothing moves across the
    slope and no mass moves."""
    from tiseg.run.simulation import Simulation

    s = 0.05
    sc = _uniform(stepper, ny=4, **{"effects.sources": ["test-tilt"], "effects.bed_tilt": s})
    sim = Simulation(sc)
    f0 = sim.fields()
    sim.run(progress=False, t_end=0.05)
    f = sim.fields()
    m = sc.material
    a = m.g * math.sin(m.zeta) + m.g * math.cos(m.zeta) * s
    np.testing.assert_allclose(f["u"] - f0["u"], a * 0.05, rtol=1e-9)
    assert np.all(f["v"] == 0.0)
    np.testing.assert_allclose(f["h"], f0["h"], rtol=1e-14)


@pytest.mark.parametrize("stepper, rtol", [("rkc", 1e-4), ("hancock", 2e-2)])
def test_the_drag_decays_the_speed_at_its_rate(registered, ti_cpu, stepper, rtol):
    """Gravity balanced by the tilt (s = -tan zeta), so only the drag acts on the uniform
    layer: u(t) = u0 exp(-k t). RKC integrates the term to second order; the split sweeps
    take it as one Euler step a sweep, first order (k dt = 0.07 here: 1.4 % after k t = 0.4)."""
    from tiseg.run.simulation import Simulation

    zeta = load_scene("uniform-flow").material.zeta
    sc = _uniform(
        stepper,
        **{
            "effects.sources": ["test-drag", "test-tilt"],
            "effects.drag_rate": 8.0,
            "effects.bed_tilt": -math.tan(zeta),
        },
    )
    sim = Simulation(sc)
    sim.run(progress=False, t_end=0.05)
    u = sim.fields()["u"]
    np.testing.assert_allclose(u, 0.2 * math.exp(-8.0 * 0.05), rtol=rtol)
    assert np.ptp(u) <= 1e-14  # every cell alike


def test_kernels_equal_the_twin_on_a_random_state(registered, ti_cpu):
    """The Taichi rates of both terms against the NumPy twin's, wet and dry cells, 2D."""
    from tests.solver_helpers import make_config, random_state, rates_equal_reference

    cfg = make_config(
        10,
        6,
        sources=("test-drag", "test-tilt"),
        constants=(("drag_rate", 7.0), ("bed_tilt", 0.3), ("bed_ripple", 2e-3)),
    )
    q = random_state(cfg.layout, np.random.default_rng(3), wet_dry=True)
    _, _, with_terms = rates_equal_reference(cfg, q)
    _, _, without = rates_equal_reference(make_config(10, 6), q)
    assert np.abs(with_terms - without).max() > 0  # the terms did act


def test_a_missing_constant_of_a_hand_built_config_is_an_input_error(registered):
    from tests.solver_helpers import make_config

    with pytest.raises(InputError, match=r"'test-drag' needs the constants \['drag_rate'\]"):
        make_config(8, 1, sources=("test-drag",))


# ---- the run folder ------------------------------------------------------------------------------
def test_a_run_with_a_term_writes_and_resumes_its_scene(registered, ti_cpu, tmp_path):
    from tiseg.run.simulation import Simulation

    sc = _uniform("rkc", **{"effects.sources": ["test-drag"], "effects.drag_rate": 2.0})
    sim = Simulation(sc)
    sim.run(tmp_path / "run", progress=False)
    written = load_scene(str(tmp_path / "run" / "scene.toml"))
    assert written.effects.sources == ("test-drag",) and written.effects.drag_rate == 2.0
    import xarray as xr

    with xr.open_dataset(tmp_path / "run" / "fields.nc") as ds:
        u = ds["u"].isel(time=-1).values
    np.testing.assert_array_equal(u, sim.fields()["u"])
