"""Scenes: built-ins load, resolved values, TOML round trip, overrides, and strict validation."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

import tiseg
from tiseg.errors import InputError
from tiseg.model.material import Material
from tiseg.setup.scene import (
    SCENE_DIR,
    Scene,
    list_builtin_scenes,
    load_scene,
    parse_override,
    scene_from_text,
    scene_to_dict,
)
from tiseg.model.steady import steady_state

from solver_helpers import MINIMAL_SCENE

BUILTINS = [
    "fingers",
    "uniform-flow",
    "dam-break",
    "monodisperse-front",
    "finite-release",
    "channel",
]

MINIMAL = MINIMAL_SCENE  # a small valid 2D scene, the base of the malformed-text cases


def test_scenes_are_package_data():
    """The built-in scenes sit inside the package (an installed wheel has them); the paths of
    before, under assets/, name no file and say so."""
    assert SCENE_DIR == Path(tiseg.__file__).resolve().parent / "data" / "scenes"
    assert SCENE_DIR.is_dir()
    with pytest.raises(InputError, match=r"scene file 'assets/scenes/fingers.toml' not found"):
        load_scene("assets/scenes/fingers.toml")


def test_sweeps_are_package_data_and_named():
    from tiseg.apps.sweep import list_builtin_sweeps, load_sweep

    assert {"grid-study", "nu-study", "width-study", "tiny"} <= set(list_builtin_sweeps())
    with pytest.raises(InputError, match="assets/sweeps/tiny.toml"):
        load_sweep("assets/sweeps/tiny.toml")
    with pytest.raises(InputError, match="did you mean 'grid-study'"):
        load_sweep("grid-stud")


def test_builtin_list():
    assert set(BUILTINS) <= set(list_builtin_scenes())


@pytest.mark.parametrize("name", BUILTINS)
def test_builtin_loads_and_round_trips(name, tmp_path):
    scene = load_scene(name)
    assert isinstance(scene, Scene)
    assert scene.name == name
    assert scene.output_times[0] == 0.0 and scene.output_times[-1] == scene.t_end
    assert list(scene.output_times) == sorted(set(scene.output_times))
    # the resolved TOML loads back to an equal scene, and is a fixed point
    path = tmp_path / "resolved.toml"
    path.write_text(scene.to_toml())
    again = load_scene(str(path))
    assert again == scene
    assert again.to_dict() == scene.to_dict()
    # the built-in name also loads by explicit path
    assert load_scene(SCENE_DIR / f"{name}.toml") == scene


def test_fingers_resolved_values():
    s = load_scene("fingers")
    assert (s.domain.nx, s.domain.ny) == (1125, 375)
    assert s.shape == (375, 1125)
    assert s.dx == pytest.approx(1 / 750) and s.dy == pytest.approx(1 / 750)
    assert s.u0 == pytest.approx(0.208, abs=1e-3)  # figure 12
    assert s.F == pytest.approx(1.57, abs=5e-3)  # figure 12
    assert s.material == Material()  # Table 1
    assert s.viscous and s.feedback and s.segregation and not s.is_1d and s.has_inflow
    assert s.fields == ("h", "u", "v", "phi")
    assert s.inflow.h == 0.002 and s.inflow.u == s.u0 and s.inflow.phi == 0.8
    assert s.inflow.ramp_rate == 10.0 and s.inflow.perturbation == 8e-5
    assert s.inflow.modes == 1 and s.inflow.stop_time is None
    assert s.initial.kind == "empty"
    assert s.boundary.as_tuple() == ("inflow", "outflow", "periodic", "periodic")
    assert (s.numerics.reconstruction, s.numerics.stepper, s.numerics.precision) == (
        "weno",
        "hancock",
        "f64",
    )
    assert s.numerics.step_rule == "max" and s.numerics.cfl == 0.9 and s.numerics.h_min == 1e-4
    for t in (1.9, 3.3, 5.1, 6.2, 7.5):
        assert t in s.output_times  # exact figure times, not 1.9000000001
    assert len(s.output_times) == 76  # 0, 0.1, ..., 7.5
    assert s.reynolds == pytest.approx(s.u0 * math.sqrt(0.002) / 0.01)


def test_other_builtins_resolved_values():
    u = load_scene("uniform-flow")
    assert u.is_1d and u.domain.nx == 64 and u.periodic_x
    assert u.domain.Lx == pytest.approx(2 * math.pi * 0.002 / 0.2399)
    assert u.dy == pytest.approx(u.dx)  # 1D: Ly = Lx / nx
    assert u.initial.mode == "eigen" and u.initial.amplitude == 1e-6
    assert u.t_end == pytest.approx(20 * 0.002 / u.u0, rel=0.1)
    assert u.fields == ("h", "u", "phi")
    assert u.perturbation_wavenumbers[0] == pytest.approx(0.2399 / 0.002)

    d = load_scene("dam-break")
    assert d.is_1d and not d.segregation and not d.viscous and not d.feedback
    assert d.effects.friction == "none" and d.material.zeta_deg == 0.0
    assert d.u0 is None and d.inflow is None and d.fields == ("h", "u")
    assert d.initial.x0 == 0.1 and d.initial.h_left == 0.002 and d.initial.h_right == 0.0
    assert d.numerics.stepper == "hancock" and d.numerics.reconstruction == "minmod"
    assert d.numerics.step_rule == "max" and d.numerics.cfl == 0.6 and d.numerics.theta == 2.0

    m = load_scene("monodisperse-front")
    assert m.flow.phi0 == 1.0 and m.inflow.phi == 1.0
    assert m.u0 == pytest.approx(steady_state(0.002, 1.0).u0)

    f = load_scene("finite-release")
    assert f.inflow.stop_time == 3.0
    assert f.inflow.thickness(2.0) > 0 and f.inflow.thickness(3.5) == 0.0


def test_inflow_helpers_follow_6_8():
    s = load_scene("fingers", {"inflow.noise": 0.0})  # (6.9) alone
    assert s.inflow.thickness(0.0) == 0.0
    assert s.inflow.thickness(0.1) == pytest.approx((1 - math.exp(-1.0)) * 0.002)
    phi = s.inflow.concentration([s.domain.Ly / 4], s.domain.Ly)
    assert phi[0] == pytest.approx(0.8 + 8e-5)


# ---- overrides -----------------------------------------------------------------------------
@pytest.mark.parametrize(
    "text, key, value",
    [
        ("flow.nu=0.01", "flow.nu", 0.01),
        ("domain.nx=64", "domain.nx", 64),
        ("effects.viscosity=false", "effects.viscosity", False),
        ('numerics.reconstruction="weno"', "numerics.reconstruction", "weno"),
        ("numerics.reconstruction=weno", "numerics.reconstruction", "weno"),
        ("output.times=[1.9, 3.3]", "output.times", [1.9, 3.3]),
        ("material.small.zeta1_deg=21", "material.small.zeta1_deg", 21),
        (" flow.h0 = 0.003 ", "flow.h0", 0.003),
        ("name=my-run", "name", "my-run"),
    ],
)
def test_parse_override(text, key, value):
    k, v = parse_override(text)
    assert k == key and v == value and type(v) is type(value)


def test_overrides_change_values():
    s = load_scene(
        "fingers",
        [
            "domain.resolution=100",
            "time.t_end=2.0",
            "flow.nu=0",
            "material.small.zeta1_deg=21",
            "numerics.reconstruction=first_order",
            "inflow.modes=3",
            "output.times=[0.5, 1.5]",
        ],
    )
    assert (s.domain.nx, s.domain.ny) == (150, 50)
    assert s.t_end == 2.0 and not s.viscous
    assert s.material.small.zeta1_deg == 21.0
    assert s.numerics.reconstruction == "first-order"  # alias stored canonically
    assert s.inflow.modes == 3
    assert s.output_times[:3] == (0.0, 0.1, 0.2) and 1.5 in s.output_times
    assert s.output_times[-1] == 2.0
    # u0 is re-derived for the changed friction
    assert s.u0 == pytest.approx(steady_state(0.002, 0.8, s.material).u0)
    assert s.u0 != load_scene("fingers").u0


def test_dict_overrides_and_with_overrides():
    s = load_scene("fingers", {"flow.phi0": 0.9, "effects.mobility_feedback": False})
    assert s.flow.phi0 == 0.9 and s.inflow.phi == 0.9 and not s.feedback
    t = s.with_overrides(["numerics.precision=f32"])
    assert t.numerics.precision == "f32" and t.flow.phi0 == 0.9
    assert load_scene(s) is s
    # None removes a key: back to the default
    r = load_scene("fingers", {"inflow.perturbation": None, "inflow.ramp_rate": 0})
    assert r.inflow.perturbation == 8e-5 and r.inflow.ramp_rate == 0.0
    assert r.inflow.thickness(0.0) == 0.002  # no ramp: sudden inflow


def test_override_round_trip(tmp_path):
    s = load_scene(
        "uniform-flow",
        [
            "domain.ny=16",
            "domain.Ly=0.02",
            "initial.amplitude=1e-3",
            "effects.friction=pouliquen-small",
            "flow.u0=0.4",
            "boundary.y_lo=wall",
            "boundary.y_hi=wall",
        ],
    )
    assert not s.is_1d and s.u0 == 0.4 and not s.feedback
    assert s.F == pytest.approx(0.4 / math.sqrt(9.81 * 0.002 * math.cos(math.radians(27))))
    p = tmp_path / "s.toml"
    p.write_text(s.to_toml())
    assert load_scene(str(p)) == s


def test_other_friction_laws_and_kinds():
    sets = ["effects.friction=coulomb", "effects.coulomb_mu=0.3", "material.zeta_deg=25"]
    c = load_scene("dam-break", sets + ["numerics.stepper=ssprk4_2", "numerics.step_rule=local"])
    assert c.effects.coulomb_mu == 0.3 and c.material.zeta_deg == 25.0
    # the scene's split sweeps take the friction as the projection only, and say what to
    # use for the regularised one
    assert load_scene("dam-break", sets).numerics.friction_scheme == "projected"
    with pytest.raises(InputError, match="ssprk4_2"):
        load_scene("dam-break", sets + ["numerics.friction_scheme=regularised"])
    text = MINIMAL + '[initial]\nkind = "release"\nx0 = 0.01\nx1 = 0.05\ny0 = 0.01\ny1 = 0.04\n'
    text += '[boundary]\nx_lo = "wall"\nx_hi = "outflow"\n'
    r = scene_from_text(text, name="rel")
    assert r.initial.kind == "release" and r.initial.h == 0.002 and r.initial.phi == 0.8
    assert r.name == "rel" and r.inflow is None


# ---- validation: each mistake is an InputError naming the key -------------------------------
@pytest.mark.parametrize(
    "override, key",
    [
        ("flow.h00=1", "flow.h00"),  # unknown key
        ("flw.h0=1", "flw"),  # unknown section
        ("flow.h0=-0.001", "flow.h0"),  # negative size
        ("flow.h0=0", "flow.h0"),
        ("flow.h0=true", "flow.h0"),  # bool for a number
        ('flow.h0="thin"', "flow.h0"),  # string for a number
        ("flow.phi0=1.5", "flow.phi0"),  # outside [0, 1]
        ("flow.phi0=-0.1", "flow.phi0"),
        ("flow.phi0=0.1", "flow.phi0"),  # phi0 < phi0*: no steady flow
        ("flow.nu=-0.01", "flow.nu"),
        ("domain.Lx=-1.5", "domain.Lx"),
        ("domain.Ly=0", "domain.Ly"),
        ("domain.resolution=-5", "domain.resolution"),
        ("domain.nx=10.5", "domain.nx"),  # int required
        ("domain.nx=100", "domain.nx"),  # disagrees with the resolution
        ("output.times=[-1.0]", "output.times"),
        ("output.times=2.0", "output.times"),  # not a list
        ("output.interval=0", "output.interval"),
        ("boundary.x_hi=periodic", "boundary.x_hi"),  # periodic on one side
        ("boundary.y_lo=wall", "boundary.y_lo"),
        ("boundary.y_hi=inflow", "boundary.y_hi"),  # inflow not at x_lo
        ("boundary.x_lo=sideways", "boundary.x_lo"),
        ("numerics.reconstruction=wenno", "numerics.reconstruction"),
        ("numerics.stepper=rk4", "numerics.stepper"),
        ("numerics.cfl=1.5", "numerics.cfl"),
        ("numerics.theta=3", "numerics.theta"),
        ("numerics.h_eps=0.001", "numerics.h_eps"),
        ("numerics.max_stages=1", "numerics.max_stages"),
        ("effects.segregation=1", "effects.segregation"),  # number for a bool
        ("effects.friction=mohr", "effects.friction"),
        ("inflow.modes=200", "inflow.modes"),  # unresolvable perturbation
        ("inflow.modes=0", "inflow.modes"),
        ("inflow.phi=1.2", "inflow.phi"),
        ("inflow.perturbation=0.5", "inflow.perturbation"),
        ("inflow.stop_time=-1", "inflow.stop_time"),
        ("initial.kind=spiral", "initial.kind"),
        ("initial.x0=0.1", "initial.x0"),  # not used by kind = empty
        ("flow.u0=0.2", "flow.u0"),  # derived with the mixture law
        ("material.zeta_deg=95", "material.zeta_deg"),
        ("material.small.zeta1_deg=35", "material.small"),
        ("material.small.beta=-1", "material.small.beta"),
        ("material.transport=cubic", "material.transport"),
        ("time.t_end=0", "time.t_end"),
        ("time.t_end=nan", "time.t_end"),
        ("flow.h0.x=1", "flow.h0"),  # a value used as a table
        ("flow=3", "flow"),
        ("name=", "name"),
    ],
)
def test_bad_override_raises_input_error(override, key):
    with pytest.raises(InputError) as info:
        load_scene("fingers", [override])
    assert key in str(info.value)


def test_bad_override_messages_suggest_and_list():
    with pytest.raises(InputError, match=r"did you mean 'flow.h0'.*allowed: h0, phi0, nu, u0"):
        load_scene("fingers", ["flow.h00=1"])
    with pytest.raises(InputError, match=r"'weno', 'minmod', 'first-order'.*did you mean 'weno'"):
        load_scene("fingers", ["numerics.reconstruction=wenno"])
    with pytest.raises(InputError, match=r"phi0\*"):
        load_scene("fingers", ["flow.phi0=0.2"])


def test_missing_file_and_unknown_name(tmp_path):
    with pytest.raises(InputError, match="fingerz.*did you mean 'fingers'.*dam-break"):
        load_scene("fingerz")
    missing = tmp_path / "nope.toml"
    with pytest.raises(InputError, match="nope.toml.*not found.*fingers"):
        load_scene(str(missing))


def test_bad_toml_names_the_file(tmp_path):
    p = tmp_path / "broken.toml"
    p.write_text("[flow\nh0 = 0.002\n")
    with pytest.raises(InputError, match="broken.toml.*not valid TOML"):
        load_scene(str(p))
    p.write_bytes(b"\xff\xfe[flow]\n")
    with pytest.raises(InputError, match="broken.toml"):
        load_scene(str(p))
    with pytest.raises(InputError, match="broken.toml"):
        load_scene(str(tmp_path / "broken.toml") + "/")  # a path that is not a file


def test_required_keys():
    with pytest.raises(InputError, match="time.t_end"):
        scene_from_text("[domain]\nLx = 1.0\nLy = 0.5\nresolution = 10\n")
    with pytest.raises(InputError, match="domain.Lx"):
        scene_from_text("[domain]\nny = 1\nnx = 10\n[time]\nt_end = 1.0\n")
    with pytest.raises(InputError, match="domain.Ly"):
        scene_from_text("[domain]\nLx = 1.0\nnx = 10\nny = 10\n[time]\nt_end = 1.0\n")


# ---- fuzz: many malformed inputs, every one an InputError (never another exception) ---------
FUZZ_OVERRIDES = [
    "",
    "=",
    "flow",
    "flow.",
    ".h0=1",
    "flow..h0=1",
    "flow.h0",
    "flow.h0=",
    "flow.h0=[1, 2]",
    "flow.h0={a = 1}",
    "flow.h0=1979-05-27",
    "flow.h0=inf",
    "flow.h0=-inf",
    "flow.h0=1e400",
    "flow.phi0=nan",
    "flow.phi0=[0.8]",
    "flow.nu=yes",
    "domain.nx=0",
    "domain.nx=-3",
    "domain.nx=2",
    "domain.ny=2",
    "domain.ny=true",
    "domain.nx=1e3",
    "domain.resolution=1e-9",
    'domain.resolution="high"',
    "domain=[]",
    "domain.Lx={}",
    "domain.Lx.y=2",
    "boundary.x_lo=periodic",
    "boundary.x_lo=1",
    'boundary="periodic"',
    "inflow.h=0",
    "inflow.u=-0.2",
    "inflow.ramp_rate=-1",
    "inflow.modes=1.5",
    "inflow.modes=true",
    "inflow.stop_time=0",
    "inflow.phi=-0.1",
    "inflow.extra=1",
    "initial.kind=1",
    "initial.kind=uniform\nflow.h0=1",
    "initial.amplitude=0.1",
    "initial.x1=0.3",
    "numerics.precision=f16",
    "numerics.cfl=0",
    "numerics.cfl=-0.1",
    "numerics.h_min=0",
    "numerics.h_min=0.01",
    "numerics.u_eps=0",
    "numerics.max_stages=200.0",
    "numerics.theta=0.5",
    'output.times=[1, "a"]',
    "output.times=[[1.0]]",
    "output.checkpoint_interval=-1",
    "output.interval=1e-12",
    "output.extra=1",
    "time.t_end=-1",
    'time.t_end="7.5"',
    "time=7.5",
    "time.dt=0.1",
    "material.g=0",
    "material.alpha=2",
    "material.chi=2",
    "material.small.L=0",
    "material.small=1",
    "material.large.zeta2_deg=10",
    "material.large.foo=1",
    "material.zeta_deg=0",
    "effects.coulomb_mu=-1",
    'effects.viscosity="no"',
    "description=3",
    'name="a/b"',
    "name=3",
    "effects.friction=coulomb",
    "flow.u0=-1",
    "flow.u0=0.2",
]


@pytest.mark.parametrize("override", FUZZ_OVERRIDES)
def test_fuzz_overrides_raise_input_error(override):
    with pytest.raises(InputError):
        load_scene("fingers", [override])


FUZZ_TEXTS = [
    "[flow",
    "flow = ",
    "= 3",
    "[[flow]]\nh0 = 1",
    "[flow]\nh0 = 0.002\nh0 = 0.003",
    "[flow]\nh0 = 'thin'",
    "[domain]\nLx = 1\n[domain]\nLy = 1",
    "x = 1",
    "[mystery]\na = 1",
    "[time]\nt_end = 1.0",  # no domain
    "[time]\nt_end = 1.0\n[domain]\nLx = 1.0",  # no grid
    "[time]\nt_end = 1.0\n[domain]\nLx = 1.0\nnx = 100",  # no ny
    "[time]\nt_end = 1.0\n[domain]\nLx = 1.0\nnx = 100\nny = 1\n[boundary]\ny_lo = 'wall'\n"
    "y_hi = 'wall'",  # 1D with y walls
    "[time]\nt_end = 1.0\n[domain]\nLx = 1.0\nny = 1\nresolution = 100\nnx = 10",
    MINIMAL + "[initial]\nkind = 'dam-break'",  # dam-break without x0
    MINIMAL + "[initial]\nkind = 'dam-break'\nx0 = 5.0",  # x0 outside the domain
    MINIMAL + "[initial]\nkind = 'dam-break'\nx0 = 0.1\nh_left = 0.0",
    MINIMAL + "[initial]\nkind = 'release'\nx0 = 0.1\nx1 = 0.05",
    MINIMAL + "[initial]\nkind = 'release'\nx0 = 0.1\nx1 = 0.15\ny1 = 1.0",
    MINIMAL + "[initial]\nkind = 'uniform'\namplitude = 0.1\nmode = 'h'",  # no wavenumber
    MINIMAL + "[initial]\nkind = 'uniform'\namplitude = 1.5\nk = 0.2",
    MINIMAL + "[initial]\nkind = 'uniform'\nmode = 'wiggle'",
    MINIMAL + "[initial]\nkind = 'uniform'\nseed = -1",
    MINIMAL + "[initial]\nkind = 'uniform'\nk = 0.2\nwavelengths = 3",  # disagrees with Lx
    MINIMAL + "[initial]\nkind = 'uniform'\nky = 0.3",  # not periodic in Ly
    MINIMAL + "[initial]\nkind = 'uniform'\nh_left = 0.1",  # wrong kind's key
    MINIMAL + "[effects]\nsegregation = false\n[initial]\nkind = 'uniform'\nmode = 'phi'",
    MINIMAL + "[boundary]\nx_lo = 'outflow'\n[inflow]\nh = 0.002",  # unused inflow
    MINIMAL + "[effects]\nfriction = 'none'",  # inflow needs u
    MINIMAL + "[effects]\nfriction = 'none'\n[initial]\nkind = 'uniform'\n"
    "[boundary]\nx_lo = 'periodic'\nx_hi = 'periodic'",  # uniform needs u0
    MINIMAL + "[output]\ntimes = 'all'",
    MINIMAL + "[material.small]\nzeta1_deg = 'twenty'",
    MINIMAL + "[material]\nsmall = [1, 2]",
    MINIMAL + "[flow]\nphi0 = 1979-05-27",
    "[time]\nt_end = 1.0\n[domain]\nLx = 1.0\nLy = 0.01\nresolution = 100",  # ny = 1 derived
    "[time]\nt_end = 1.0\n[domain]\nLx = 1.0\nnx = 3\nny = 1\n[boundary]\nx_lo = 'wall'\n"
    "x_hi = 'wall'",
    "\x00",
]


@pytest.mark.parametrize("text", FUZZ_TEXTS)
def test_fuzz_texts_raise_input_error(text, tmp_path):
    p = tmp_path / "fuzz.toml"
    p.write_text(text)
    with pytest.raises(InputError):
        load_scene(str(p))


def test_minimal_text_is_valid():
    # guards the fuzz cases above: their base scene is itself fine
    s = scene_from_text(MINIMAL, name="minimal")
    assert (s.domain.nx, s.domain.ny) == (40, 10) and s.has_inflow and s.inflow.modes == 1


def test_scene_to_dict_derived():
    d = scene_to_dict(load_scene("fingers"), derived=True)
    assert d["derived"]["u0"] == pytest.approx(0.208, abs=1e-3)
    assert d["derived"]["fields"] == ["h", "u", "v", "phi"]
    assert "u0" not in d["flow"]  # derived, so not written as an input
