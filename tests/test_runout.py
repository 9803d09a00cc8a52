"""A reference surface that bends (``[terrain.runout]``, tiseg.solver.numerics.gravity): the
kernels equal their NumPy twin on a bend in both schemes; a mass released on the chute runs
out like the point mass of Savage & Hutter (1991) on the same bed line (tiseg.model
.exact_runout), curvature term included; a layer the friction holds stays bitwise at rest
across the bend; bad bends are one-line errors."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from tests.solver_helpers import (
    assert_equals_twin,
    make_config,
    projected_stage_equals_reference,
    random_state,
    rates_equal_reference,
    stage_and_twin,
)
from tiseg.errors import InputError
from tiseg.model import exact_runout as er
from tiseg.setup.reading import scene_from_dict

# zeta = 0.5 rad above a bend to level ground over 3 cm .. 11 cm of a 14-cell grid
BEND = (0.0, 0.03, 0.08)


@pytest.mark.parametrize(
    "ny, scheme, rec, friction",
    [
        (1, "regularised", "weno", "pouliquen-mixture"),
        (1, "projected", "minmod", "pouliquen-extended"),
        (5, "regularised", "minmod", "coulomb"),
        (5, "projected", "weno", "pouliquen-mixture"),
    ],
)
def test_the_kernels_equal_the_twin_on_a_bend(ti_cpu, ny, scheme, rec, friction):
    """Rates of L (and, projected, a first stage with its friction and static hold) on a
    random wet-dry state against the twin, to 1e-12 of each component's scale; and the bend
    did act: the rates differ from the plane's."""
    from tiseg.solver.reference import ReferenceOperator

    rng = np.random.default_rng(7)
    cfg = make_config(
        14, ny, bend=BEND, zeta=0.5, friction_scheme=scheme, reconstruction=rec, friction=friction
    )
    q = random_state(cfg.layout, rng, wet_dry=True)
    op, ref, r_ti = rates_equal_reference(cfg, q)  # to 1e-12 of each component's scale
    r_np = ref.rhs(q.copy(), 0.0)
    ix, iy = cfg.layout.interior()
    scale = np.abs(r_np)[:, ix, iy].max(axis=(1, 2))
    if scheme == "projected":
        projected_stage_equals_reference(op, ref, q, r_ti, 2e-3, 2e-3)
    plane = ReferenceOperator(dataclasses.replace(cfg, bend=None)).rhs(q.copy(), 0.0)
    assert np.abs(plane - r_np)[1].max() > 0.05 * scale[1]


def _bump(cfg):
    """A bed with a bump and ripples, normal to the bent surface."""
    lay = cfg.layout
    x = (np.arange(lay.nx) + 0.5) * cfg.dx
    y = (np.arange(lay.ny) + 0.5) * cfg.dy
    X, Y = np.meshgrid(x, y, indexing="ij")
    return 0.004 * np.exp(-(((X - 0.07) / 0.03) ** 2)) + 5e-4 * np.cos(40 * X + 30 * Y)


@pytest.mark.parametrize("split", [False, True])
def test_a_bed_on_a_bend_equals_the_twin(ti_cpu, split):
    """A bump normal to the bent surface: the hydrostatic reconstruction with each face's and
    cell's own g cos zeta, unsplit rates and split sweeps against the twin."""
    from tiseg.solver.numerics.operator import TaichiOperator
    from tiseg.solver.reference import ReferenceOperator

    rng = np.random.default_rng(17)
    kw = dict(split=True, friction_scheme="projected", viscous=False) if split else {}
    cfg = make_config(14, 4, bend=BEND, zeta=0.5, bed=True, reconstruction="weno", **kw)
    b = _bump(cfg)
    q = random_state(cfg.layout, rng, wet_dry=True)
    op = TaichiOperator(cfg, nslots=2)
    op.set_bed(b)
    op.set(0, q)
    a, r = stage_and_twin(op, ReferenceOperator(cfg, bed=b), q, split)
    assert_equals_twin(a, r, cfg.layout)


@pytest.mark.parametrize("ny, rec", [(1, "minmod"), (6, "weno")])
def test_the_sweeps_equal_the_twin_on_a_bend(ti_cpu, ny, rec):
    from tiseg.solver.numerics.operator import TaichiOperator
    from tiseg.solver.reference import ReferenceOperator
    from tiseg.solver.reference.split import hancock_sweep

    rng = np.random.default_rng(13)
    cfg = make_config(
        14,
        ny,
        bend=BEND,
        zeta=0.5,
        split=True,
        friction_scheme="projected",
        viscous=False,
        reconstruction=rec,
        flux="central-upwind",
        bc=("inflow", "outflow", "periodic", "periodic"),
    )
    q = random_state(cfg.layout, rng, wet_dry=True)
    ref = ReferenceOperator(cfg)
    for dirs in ((0,),) if ny == 1 else ((0, 1), (1, 0)):
        op = TaichiOperator(cfg, nslots=2)
        op.set(0, q)
        qr = q.copy()
        for d in dirs:
            op.sweep(d, 0.05, 0.01)
            hancock_sweep(ref, qr, 0.05, 0.01, d)
        assert_equals_twin(op.get(0), qr, cfg.layout, dirs)


Z1, Z2, XB, LB = 35.0, 0.0, 0.5, 0.5  # a 35 degree chute levelling out over 0.5 m
MU = math.tan(math.radians(25.0))


def _slide_scene(numerics, nx=500, runout=True, **initial):
    return scene_from_dict(
        {
            "material": {"zeta_deg": Z1},
            "flow": {"h0": 0.002, "nu": 0.0, "u0": 0.1},
            "effects": {
                "segregation": False,
                "viscosity": False,
                "friction": "coulomb",
                "coulomb_mu": MU,
            },
            "domain": {"Lx": 2.0, "nx": nx, "ny": 1},
            "boundary": {"x_lo": "wall", "x_hi": "outflow", "y_lo": "periodic", "y_hi": "periodic"},
            "initial": {"kind": "cap", "x0": 0.2, "half_width": 0.05, "h": 0.004, **initial},
            **({"terrain": {"runout": {"x": XB, "length": LB, "zeta_deg": Z2}}} if runout else {}),
            "numerics": numerics,
            "time": {"t_end": 2.0},
            "output": {"interval": 2.0, "peak_fields": False},
        },
        name="slide",
    )


def _centre(sim, dx):
    h = sim.fields()["h"].ravel()
    x = (np.arange(h.size) + 0.5) * dx
    return float((h * x).sum() / h.sum()), float(h.sum() * dx)


SPLIT = {"stepper": "hancock", "friction_scheme": "projected", "cfl": 0.9}


def test_a_mass_runs_out_like_the_point_mass(ti_cpu):
    """A parabolic cap released on a 35 degree chute (Coulomb mu = tan 25 degrees) that levels
    out over 0.5 m: on the straight its centre of mass moves exactly as the point mass (the
    pressure integrates to nothing on a plane); it stops in the run-out where the point mass
    with the curvature term kappa u^2 does, to 1 cm of 0.72 m, far nearer than to where the
    classical block without that term stops (5.5 cm further). The spread of the deposit over
    the bend, which the point mass lacks, is what is left (the gap does not close with
    the grid: 6.1 mm at 500 and 5.5 mm at 2000 cells)."""
    from tiseg.run.simulation import Simulation

    line = er.BedLine(math.radians(Z1), math.radians(Z2), XB, LB)
    sc = _slide_scene(SPLIT)
    sim = Simulation(sc)
    sim.advance(0.4)
    on_straight = er.slide(line, MU, s0=0.2, t_max=0.4).s[-1]
    xc, mass0 = _centre(sim, sc.domain.dx)
    assert abs(xc - on_straight) < 1e-3
    sim.advance(2.0)
    xc, mass = _centre(sim, sc.domain.dx)
    assert abs(mass - mass0) < 1e-14
    with_term = er.slide(line, MU, s0=0.2)
    without = er.slide(line, MU, s0=0.2, curvature=False)
    assert with_term.stopped and without.stopped
    assert abs(xc - with_term.s_stop) < 0.01
    assert abs(xc - without.s_stop) > 4 * abs(xc - with_term.s_stop)
    f = sim.fields()
    deposit = f["h"] > 1e-6  # (films thinner than that keep sliding on the chute)
    assert float(np.abs(f["u"][deposit]).max()) == 0.0  # at rest


@pytest.mark.parametrize("numerics", [SPLIT, {"stepper": "rkc", "friction_scheme": "projected"}])
def test_a_layer_held_across_the_bend_stays_at_rest(ti_cpu, numerics):
    """A layer over the bend from 20 degrees to level ground, which Coulomb friction with
    mu = tan 25 degrees holds everywhere: its state does not change at all in 40 steps, in
    either scheme (the pressure of a layer whose g cos zeta varies along the bend is held
    with the gravity)."""
    from tiseg.run.simulation import Simulation

    sc = scene_from_dict(
        {
            "material": {"zeta_deg": 20.0},
            "flow": {"h0": 0.002, "nu": 0.0, "u0": 0.1},
            "effects": {
                "segregation": True,
                "viscosity": False,
                "friction": "coulomb",
                "coulomb_mu": MU,
            },
            "domain": {"Lx": 0.4, "nx": 80, "ny": 1},
            "boundary": {"x_lo": "wall", "x_hi": "wall", "y_lo": "periodic", "y_hi": "periodic"},
            "initial": {"kind": "release", "x0": 0.05, "x1": 0.35, "h": 0.003},
            "terrain": {"runout": {"x": 0.1, "length": 0.2, "zeta_deg": 0.0}},
            "numerics": numerics,
            "time": {"t_end": 1.0},
            "output": {"interval": 1.0, "peak_fields": False},
        },
        name="held",
    )
    sim = Simulation(sc)
    q0 = sim.conserved().copy()
    for _ in range(40):
        sim.step()
    assert np.array_equal(sim.conserved(), q0)


def _with_runout(**runout):
    return {
        "material": {"zeta_deg": 30.0},
        "domain": {"Lx": 1.0, "nx": 100, "ny": 1},
        "boundary": {"x_lo": "inflow", "x_hi": "outflow"},
        "terrain": {"runout": {"x": 0.5, "length": 0.3, "zeta_deg": 0.0, **runout}},
        "time": {"t_end": 0.5},
    }


@pytest.mark.parametrize(
    "runout, words",
    [
        ({"zeta_deg": 90.0}, "past vertical"),
        ({"zeta_deg": -95.0}, "zeta_deg"),
        ({"x": 1.0}, "beyond the domain"),
        ({"length": 0.0}, "length"),
        ({"length": 0.005}, "make the bend longer"),
        ({"height": 1.0}, "height"),
    ],
)
def test_bad_bends_are_one_line_errors(runout, words):
    with pytest.raises(InputError) as e:
        scene_from_dict(_with_runout(**runout), name="bad")
    assert words in str(e.value) and "\n" not in str(e.value)


def test_a_periodic_bend_is_refused():
    data = _with_runout()
    data["boundary"] = {"x_lo": "periodic", "x_hi": "periodic"}
    with pytest.raises(InputError) as e:
        scene_from_dict(data, name="wrap")
    assert "periodic" in str(e.value) and "\n" not in str(e.value)


def test_the_bend_is_written_and_read_back():
    from tiseg.setup.writing import scene_to_dict

    sc = scene_from_dict(_with_runout(), name="ok")
    assert sc.terrain.runout.length == 0.3
    again = scene_from_dict(scene_to_dict(sc), name="ok")
    assert again.terrain == sc.terrain
    assert not sc.has_terrain  # no bed field: the bend is the reference surface's


def _bed_line_points(line, s):
    """(X, Z) of the bed line at arc lengths s by quadrature of (cos zeta, -sin zeta): a
    computation apart from BedLine.coordinates' closed form."""
    fine = np.linspace(0.0, float(np.max(s)), 200001)
    z = line.inclination(fine)
    ds = np.diff(fine)
    X = np.concatenate([[0.0], np.cumsum(0.5 * (np.cos(z[1:]) + np.cos(z[:-1])) * ds)])
    Z = np.concatenate([[0.0], np.cumsum(-0.5 * (np.sin(z[1:]) + np.sin(z[:-1])) * ds)])
    return np.interp(s, fine, X), np.interp(s, fine, Z)


def test_the_travel_angle_follows_the_bed_line():
    """A release at the top of a 30 degree chute bending to level ground over 0.4 m and a
    deposit whose tip lies on the pad: the angle of the line between them, on the bed line's
    Cartesian coordinates (by quadrature), not on the plane's."""
    from tiseg.post.analysis.deposit import travel_angle

    line = er.BedLine(math.radians(30.0), 0.0, 0.5, 0.4)
    x = (np.arange(120) + 0.5) * 0.01
    y = np.array([0.005, 0.015])
    start = np.zeros((2, 120))
    start[:, 10:20] = 0.003  # the release: its top at x = 0.105 m
    dep = np.zeros((2, 120))
    dep[:, 95:101] = 0.002  # the deposit: its tip at x = 1.005 m, on the pad
    angle, drop, reach = travel_angle(start, dep, x, y, None, math.radians(30.0), 1e-4, line)
    (X0, X1), (Z0, Z1) = _bed_line_points(line, np.array([0.105, 1.005]))
    assert drop == pytest.approx(Z0 - Z1, abs=1e-8)
    assert reach == pytest.approx(X1 - X0, abs=1e-8)
    assert angle == pytest.approx(math.degrees(math.atan2(Z0 - Z1, X1 - X0)), abs=1e-6)
    plane = travel_angle(start, dep, x, y, None, math.radians(30.0), 1e-4)
    assert plane[0] == pytest.approx(30.0) and angle < 25.0  # the pad flattens the line


def test_the_runout_scene_leaves_a_deposit_in_the_bend(ti_cpu, tmp_path):
    """The built-in scene on a coarse grid: the fingering flow settles with its deposit in
    the bend (past 0.9 m, short of the pad's end), the whole released volume in it but the
    film left on the chute, and a travel angle below the chute's 27 degrees and above the
    extended law's least friction angle (tan 20.9 degrees for the small grains)."""
    from tests.solver_helpers import exit_code
    from tiseg.post.analysis.fingers import analyse_run

    out = tmp_path / "runout"
    args = ["run", "runout", "--out", str(out), "--no-progress"]
    for k in ("domain.resolution=50", "domain.Ly=0.2", "time.t_end=20", "output.interval=2"):
        args += ["--set", k]
    assert exit_code(args) == 0
    d = analyse_run(out, settle_fraction=1e-2)["deposit"]
    assert d["settled"] and d["basis"] == "settled"
    assert 0.9 < d["run_out"] < 1.2
    released = 0.2 * 0.002 * 0.208 * 3.0  # Ly h0 u0 t_stop, the inflow's volume (about)
    assert 0.7 * released < d["volume"] < 1.05 * released
    assert 21.0 < d["travel_angle_deg"] < 27.0


def test_a_release_too_thick_for_the_bend_is_refused():
    """The bend's h kappa is checked on the initial state as well: a 5 cm block on a bend of
    radius 0.3 m (h kappa = 0.17) is a one-line error when the simulation is built."""
    from tiseg.run.simulation import Simulation

    data = _with_runout(length=0.3 * math.radians(30.0))
    data["boundary"] = {"x_lo": "wall", "x_hi": "outflow"}
    data["initial"] = {"kind": "release", "x0": 0.1, "x1": 0.3, "h": 0.05}
    sc = scene_from_dict(data, name="thick")
    with pytest.raises(InputError) as e:
        Simulation(sc)
    assert "make the bend longer" in str(e.value) and "\n" not in str(e.value)
