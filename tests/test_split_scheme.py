"""The split MUSCL-Hancock scheme (numerics.stepper = "hancock", tiseg.solver.numerics.split) as a
solver: order of accuracy on smooth flows in 1D and 2D (the alternating sweep order is what
makes 2D second order), positivity and conservation on dry beds at Courant numbers up to 1,
the exact Stoker and Ritter solutions, phi at 0 and 1, a resumed run's bits, and the scene's
refusal of stiff terms (friction with the split sweeps: test_split_full_model.py). Its equality with the NumPy twin is in test_split_reference.py."""

import math

import numpy as np
import pytest

from test_step_rules import _column_collapse, dam_break_2d
from tiseg.errors import InputError
from tiseg.model.exact_dambreak import cell_averages, ritter, stoker
from tiseg.setup.scene import load_scene
from tiseg.run.simulation import Simulation
from tiseg.solver.timestepping.split import Hancock


def _smooth(n, ny, cfl, t_end=0.05):
    """A smooth periodic wave on flat ground: h = 1 + 0.2 sin(2 pi (x + y)), u, v cosines
    (1D: ny = 1, y = 0). No shock forms before t = 0.1."""
    over = {
        "domain.Lx": 1.0,
        "domain.Ly": 1.0,
        "domain.nx": n,
        "domain.ny": ny,
        "boundary.x_lo": "periodic",
        "boundary.x_hi": "periodic",
        "flow.h0": 1.0,
        "numerics.h_min": 1e-6,
        "numerics.h_eps": 1e-9,
        "numerics.stepper": "hancock",
        "numerics.step_rule": "max",
        "numerics.cfl": cfl,
        "time.t_end": t_end,
        "output.interval": t_end,
    }
    if ny == 1:
        over["domain.Ly"] = 0.01
    sim = Simulation(load_scene("dam-break", over))
    x, y = sim.scene.domain.cell_centres()
    X, Y = np.meshgrid(x, y if ny > 1 else [0.0])
    v = None if ny == 1 else 0.3 * np.sin(2 * np.pi * Y)
    sim.set_state(1 + 0.2 * np.sin(2 * np.pi * (X + Y)), u=0.5 * np.cos(2 * np.pi * X), v=v)
    sim.advance(t_end)
    return sim.fields()["h"]


def _rates(errs):
    return np.log2(np.array(errs[:-1]) / np.array(errs[1:]))


@pytest.mark.slow  # a long run: the slow set (README), which CI runs after the suite
def test_second_order_on_a_smooth_1d_wave(ti_cpu):
    """Self-convergence at cfl 0.9 against a 4096-cell run at cfl 0.2: order 2."""
    ref = _smooth(4096, 1, 0.2)[0]
    errs = []
    for n in (64, 128, 256):
        r = ref.reshape(n, -1).mean(axis=1)
        errs.append(np.abs(_smooth(n, 1, 0.9)[0] - r).mean())
    assert np.all(_rates(errs) > 1.85), errs


@pytest.mark.slow
def test_alternating_sweeps_make_2d_second_order(ti_cpu, monkeypatch):
    """A diagonal wave in a periodic square: with the sweep order alternating from step to
    step the error falls at second order; with x-then-y every step (Godunov splitting) the
    splitting error makes it first order, which this test tells apart (measured with a
    512-cell reference: 2.1 against 1.5 and 1.3 from 32 to 128 cells; here 16 to 64 cells
    against 192)."""
    n_ref = 192
    ref = _smooth(n_ref, n_ref, 0.5)

    def errors(grids):
        out = []
        for n in grids:
            k = n_ref // n
            r = ref.reshape(n, k, n, k).mean(axis=(1, 3))
            out.append(np.abs(_smooth(n, n, 0.9) - r).mean())
        return out

    alternating = _rates(errors((16, 32, 64)))
    assert np.all(alternating > 1.8), alternating
    step = Hancock.step

    def fixed_order(self, op, t, dt, stages):
        self.index = 0
        step(self, op, t, dt, stages)

    monkeypatch.setattr(Hancock, "step", fixed_order)
    fixed = _rates(errors((32, 64)))
    assert fixed[-1] < 1.6, fixed


@pytest.mark.parametrize("cfl", [0.9, 1.0])
def test_dry_bed_dam_break_stays_positive_and_conservative(ti_cpu, cfl):
    """Ritter's dam break in a closed 2D box at Courant numbers up to 1 per sweep: h >= 0
    after every step (the draining factors, not the limiter: mass is conserved to round-off,
    and a clip would add mass), y-independent data stay so, the front lands where Ritter's
    does. The SSP steppers' positivity bound is 1/2 of the sum rule."""
    sc = dam_break_2d(96, 0.0, "hancock", "max", **{"numerics.cfl": cfl})
    sim = Simulation(sc)
    m0 = sim.totals()["mass"]
    sim.advance(0.1)
    # (the limiter clips h < 0 to 0, so h >= 0 holds anyway: mass to round-off says no clip
    # had anything to do)
    assert abs(sim.totals()["mass"] - m0) / m0 < 1e-13
    h = sim.fields()["h"]
    assert np.abs(h - h[:1]).max() == 0.0  # the y sweeps change nothing, bit for bit
    x, _ = sc.domain.cell_centres()
    exact = cell_averages(lambda p: ritter(p, 0.1, 1.0, 1.0)[0], x, sc.dx)
    assert np.mean(np.abs(h[0] - exact)) < 0.012
    c10 = 1.0 + (2 * math.sqrt(9.81) - math.sqrt(0.9 * 9.81)) * 0.1
    assert abs(x[h[0] >= 0.1].max() - c10) <= 2 * sc.dx


@pytest.mark.slow  # a long run: the slow set (README), which CI runs after the suite
def test_dry_column_collapse_stays_positive_and_conservative(ti_cpu):
    """A column collapsing in x and y at once onto a dry bed, at cfl 1: h >= 0 after every
    step and mass to round-off, where the waves cross both sweeps."""
    sc, sim = _column_collapse(48, "max", "hancock", cfl=1.0)
    m0 = sim.totals()["mass"]
    sim.advance(0.1)
    assert abs(sim.totals()["mass"] - m0) / m0 < 1e-13  # (a clip of h < 0 would add mass)


def _stoker_errors(nx) -> dict:
    """Mean |h - Stoker| of the split scheme (cfl 0.6) and of SSPRK(4,2) at the sum rule's
    bound, with the same minmod slopes and fluxes on an nx-cell dam break."""
    out = {}
    for st, rule, cfl in (("hancock", "max", 0.6), ("ssprk4_2", "sum", 0.5)):
        sc = dam_break_2d(nx, 0.1, st, rule, **{"numerics.cfl": cfl})
        sim = Simulation(sc)
        sim.advance(0.1)
        x, _ = sc.domain.cell_centres()
        exact = cell_averages(lambda p: stoker(p, 0.1, 1.0, 0.1, 1.0)[0], x, sc.dx)
        out[st] = np.mean(np.abs(sim.fields()["h"][0] - exact))
    return out


@pytest.mark.slow  # a long run: the slow set (README), which CI runs after the suite
def test_wet_bed_dam_break_beats_ssprk4_2_on_a_coarse_grid(ti_cpu):
    """The fast set's share of the next test (its grid of 64 cells): Stoker's dam break with
    the split scheme below the error of SSPRK(4,2) on the same grid."""
    out = _stoker_errors(64)
    assert out["hancock"] < 0.95 * out["ssprk4_2"], out


@pytest.mark.slow
def test_wet_bed_dam_break_converges_to_stoker(ti_cpu):
    """Stoker's dam break (a bore and a transonic fan): first order or better (a shock), and
    below the error of SSPRK(4,2) with the same minmod slopes and fluxes on the same grid
    at the sum rule's bound (measured 0.79-0.86 of it at cfl 0.6 from 64 to 256 cells).
    (A convergence study: in the slow set; the fast set keeps the 64-cell comparison.)"""
    errs = []
    for nx in (64, 128):
        out = _stoker_errors(nx)
        errs.append(out["hancock"])
        assert out["hancock"] < 0.95 * out["ssprk4_2"], out
    assert np.all(_rates(errs) > 0.9), errs


def test_closed_box_on_a_slope_keeps_its_mass(ti_cpu):
    """Material sliding down a 20 degree slope into a wall, in a closed 2D box: no mass may
    cross the walls. The ghost cells of a wall mirror the cell next to it, so their gravity
    source is mirrored too; with the interior's sign the predictor pushed mass through the
    walls (about dt g sin(zeta) h / 2 per step, booked in the budget as inflow)."""
    over = {
        "material.zeta_deg": 20.0,
        "domain.Lx": 0.4,
        "domain.nx": 80,
        "domain.ny": 4,
        "domain.Ly": 0.02,
        "boundary.x_lo": "wall",
        "boundary.x_hi": "wall",
        "boundary.y_lo": "wall",
        "boundary.y_hi": "wall",
        "initial.x0": 0.3,
        "numerics.stepper": "hancock",
        "time.t_end": 0.3,
        "output.interval": 0.3,
    }
    sim = Simulation(load_scene("dam-break", over))
    m0 = sim.totals()["mass"]
    sim.advance(0.3)
    assert abs(sim.budget()["mass_in"]) <= 1e-15 * m0 / 0.02
    assert abs(sim.totals()["mass"] - m0) <= 1e-13 * m0
    h = sim.fields()["h"]
    assert h[:, -1].max() > 3 * h[:, 0].max()  # it did slide down to the x_hi wall


@pytest.mark.slow  # a long run: the slow set (README), which CI runs after the suite
def test_rows_of_a_quasi_1d_run_equal_the_1d_run(ti_cpu):
    """With walls across the slope and no v, the y sweeps must change nothing: every row of
    the 2D Stoker run is the 1D run, bit for bit (the x sweep is the same per row)."""
    base = {
        "domain.Lx": 2.0,
        "domain.nx": 128,
        "flow.h0": 1.0,
        "initial.x0": 1.0,
        "initial.h_left": 1.0,
        "initial.h_right": 0.1,
        "numerics.h_min": 1e-6,
        "numerics.h_eps": 1e-9,
        "numerics.stepper": "hancock",
        "numerics.step_rule": "max",
        "time.t_end": 0.1,
        "output.interval": 0.1,
    }
    one = Simulation(load_scene("dam-break", base))
    one.advance(0.1)
    two = Simulation(
        load_scene(
            "dam-break",
            {
                **base,
                "domain.ny": 4,
                "domain.Ly": 0.0625,
                "boundary.y_lo": "wall",
                "boundary.y_hi": "wall",
            },
        )
    )
    two.advance(0.1)
    assert one.stats.steps == two.stats.steps
    h1, h2 = one.fields()["h"], two.fields()["h"]
    assert np.array_equal(np.broadcast_to(h1, h2.shape), h2)


def test_concentrations_at_0_and_1_stay_bounded_and_conserved(ti_cpu):
    """Segregation with the split scheme: a flow down a slope (gravity source, periodic in x)
    carrying pure coarse next to pure fine material. phi stays in [0, 1] and both masses are
    conserved to round-off over 200 steps at cfl 0.9: the h phi flux F_h (phi - G(phi)) is
    upwinded by the mass flux, and the clip of the limiter, which would create or destroy
    small particles, never acts."""
    over = {
        "effects.segregation": True,
        "material.zeta_deg": 10.0,
        "domain.Lx": 0.5,
        "domain.nx": 100,
        "domain.ny": 6,
        "domain.Ly": 0.03,
        "boundary.x_lo": "periodic",
        "boundary.x_hi": "periodic",
        "numerics.stepper": "hancock",
        "numerics.step_rule": "max",
        "numerics.cfl": 0.9,
        "time.t_end": 10.0,
        "output.interval": 10.0,
    }
    sc = load_scene("dam-break", over)
    sim = Simulation(sc)
    x, y = sc.domain.cell_centres()
    X, Y = np.meshgrid(x, y)
    h = 0.002 * (1 + 0.3 * np.sin(2 * np.pi * X / 0.5))
    phi = np.where((X > 0.1) & (X < 0.3), 1.0, 0.0)
    sim.set_state(h, u=np.full_like(h, 0.2), v=0.02 * np.sin(2 * np.pi * Y / 0.03), phi=phi)
    tot0 = sim.totals()
    for _ in range(120):
        sim.step()
    # the limiter clips h phi into [0, h], so phi is bounded anyway: conservation of the small
    # particles to round-off is what says the clip never acted
    tot = sim.totals()
    assert abs(tot["mass"] - tot0["mass"]) <= 1e-13 * tot0["mass"]
    assert abs(tot["small_mass"] - tot0["small_mass"]) <= 1e-12 * tot0["mass"]
    assert 0.0 < tot["small_mass"] < tot["mass"]


def test_scene_refuses_the_regularised_friction_and_defaults_to_cfl_0_6(caplog):
    base = {"numerics.stepper": "hancock", "numerics.step_rule": "max"}
    assert load_scene("dam-break", base).numerics.cfl == 0.6
    assert load_scene("dam-break", {**base, "numerics.stepper": "ssprk4_2"}).numerics.cfl == 0.25
    assert load_scene("dam-break", {**base, "numerics.cfl": 1.0}).numerics.cfl == 1.0
    # the viscosity is a sub-step of the split step (tests/test_split_viscous.py)
    assert load_scene("dam-break", {**base, "effects.viscosity": True, "flow.nu": 1e-3}).viscous
    # friction only as the projection (tests/test_split_full_model.py)
    assert load_scene("dam-break", {**base, "effects.friction": "coulomb"}).effects
    with pytest.raises(InputError, match="numerics.friction_scheme.*'projected'.*ssprk4_2"):
        over = {"effects.friction": "coulomb", "numerics.friction_scheme": "regularised"}
        load_scene("dam-break", {**base, **over})
    assert load_scene("fingers", {**base, "effects.viscosity": False}).effects.segregation
    with pytest.raises(InputError, match="numerics.cfl"):
        load_scene("dam-break", {**base, "numerics.cfl": 1.2})
    # a rule that sums the directions halves its steps for nothing: said, not refused
    for rule, noted in (("local", True), ("sum", True), ("max", False)):
        caplog.clear()
        with caplog.at_level("WARNING"):
            over = {**base, "numerics.step_rule": rule, "domain.ny": 4, "domain.Ly": 0.01}
            over.update({"boundary.y_lo": "wall", "boundary.y_hi": "wall"})
            load_scene("dam-break", over)
        assert any("step_rule = 'max'" in r.getMessage() for r in caplog.records) == noted


@pytest.mark.slow  # a long run: the slow set (README), which CI runs after the suite
def test_a_resumed_run_sweeps_as_the_uninterrupted_one(ti_cpu, tmp_path):
    """The sweep order alternates with the step's index, which a checkpoint carries: a run
    saved after an odd number of steps and restored into a fresh simulation ends on the bits
    of the run that never stopped (and would not with the order restarted at x first)."""
    from tiseg.run import checkpoint

    _, sim = _column_collapse(32, "max", "hancock")  # waves along x and y: order matters
    start, ck = tmp_path / "start.npz", tmp_path / "ck.npz"
    checkpoint.save(start, sim)
    for _ in range(12):
        sim.step()
    whole = sim.conserved().copy()
    checkpoint.restore(sim, checkpoint.load(start))
    for _ in range(5):
        sim.step()
    checkpoint.save(ck, sim)
    sim.reset()  # (steps and state gone: all from the checkpoint now)
    checkpoint.restore(sim, checkpoint.load(ck))
    for _ in range(7):
        sim.step()
    assert np.array_equal(sim.conserved(), whole)
    # the same restore with the step count lost sweeps x first after an odd step: other bits
    checkpoint.restore(sim, checkpoint.load(ck))
    sim.stats.steps = 0
    for _ in range(7):
        sim.step()
    assert not np.array_equal(sim.conserved(), whole)
