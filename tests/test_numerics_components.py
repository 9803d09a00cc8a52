"""The numerics components (tiseg.solver.numerics.reconstruction, .fluxes, .boundaries) one by one:
each component's Taichi function against its NumPy twin, on its own, in a kernel that calls
only that function; the registries behind the scene's choices; and the Rusanov flux, added as
one class, as a solver: conservative, positive on a dry bed, first order on Stoker's dam break.
"""

import numpy as np
import pytest

from solver_helpers import make_config, random_state
from tiseg.model.exact_dambreak import cell_averages, stoker
from tiseg.solver.numerics import config
from tiseg.solver.numerics.boundaries import BOUNDARIES
from tiseg.solver.numerics.fluxes import FLUXES, PHI_FLUXES
from tiseg.solver.numerics.reconstruction import RECONSTRUCTIONS
from tiseg.setup.scene import load_scene
from tiseg.run.simulation import Simulation


def _operator(cfg):
    from tiseg.solver.numerics.operator import TaichiOperator
    from tiseg.solver.reference import ReferenceOperator

    return TaichiOperator(cfg, nslots=3), ReferenceOperator(cfg)


def _run_pairwise(op, fn, a, b, d=None):
    """fn(a[k], b[k]) (or fn(a[k], b[k], d)) for every k in a Taichi kernel that calls only fn;
    a, b shaped (nc, n). Returns the results shaped (nc, n)."""
    import taichi as ti

    from tiseg.solver.field_tree import FieldTree

    nc, n = a.shape
    ft = FieldTree()
    fa, fb, out = (ft.vector(nc, op.fp, n) for _ in range(3))
    ft.finalize()
    fa.from_numpy(a.T.copy())
    fb.from_numpy(b.T.copy())

    if d is None:

        @ti.kernel
        def run():
            for k in range(n):
                out[k] = fn(fa[k], fb[k])

    else:

        @ti.kernel
        def run():
            for k in range(n):
                out[k] = fn(fa[k], fb[k], d)

    run()
    res = out.to_numpy().T.copy()
    ft.destroy()
    return res


def _edge_states(lay, rng, n=400):
    """Random primitive edge states (h, u[, v][, phi]) with dry (h = 0) and thin ones."""
    w = np.zeros((lay.nc, n))
    h = 0.002 * (1 + rng.random(n))
    h[rng.random(n) < 0.15] = 0.0
    w[0] = h
    w[1] = 0.3 * rng.standard_normal(n)
    if not lay.is_1d:
        w[lay.HV] = 0.2 * rng.standard_normal(n)
    if lay.segregation:
        w[lay.HPHI] = rng.random(n)
    return w


def _close(a, b, rel=1e-13):
    """a == b to ``rel`` of each component's largest magnitude (the twins use the same
    operations; the pointwise physics may round differently in its last bit)."""
    scale = np.maximum(np.abs(b).max(axis=-1, keepdims=True), 1e-300)
    return np.all(np.abs(a - b) <= rel * scale)


# ---------------------------------------------------------------- registries
def test_scene_choices_come_from_the_registries():
    """numerics.reconstruction / flux / phi_flux and the boundaries: the registry keys, in
    order; each entry is registered under its own name with a Taichi function and a twin."""
    assert config.RECONSTRUCTIONS == tuple(RECONSTRUCTIONS) == ("first-order", "minmod", "weno")
    assert config.FLUXES == tuple(FLUXES) == ("kt", "central-upwind", "rusanov")
    assert config.PHI_FLUXES == tuple(PHI_FLUXES) == ("central", "upwind")
    assert config.BOUNDARIES == tuple(BOUNDARIES) == ("inflow", "outflow", "periodic", "wall")
    for reg, twin in (
        (RECONSTRUCTIONS, "slope_np"),
        (FLUXES, "flux_np"),
        (PHI_FLUXES, "modify_np"),
        (BOUNDARIES, "fill_np"),
    ):
        for name, comp in reg.items():
            assert comp.name == name and callable(comp.taichi) and callable(getattr(comp, twin))


# ---------------------------------------------------------------- twins, per component
@pytest.mark.parametrize("name", [n for n, r in RECONSTRUCTIONS.items() if r.slopes])
@pytest.mark.parametrize("seg", [True, False])
def test_reconstruction_slope_equals_its_twin(ti_cpu, name, seg):
    """The slope of each reconstruction from random differences (of both signs, and zeros)."""
    cfg = make_config(6, 5, segregation=seg, reconstruction=name, theta=1.3)
    op, _ = _operator(cfg)
    lay = cfg.layout
    rng = np.random.default_rng(3)
    dm = rng.standard_normal((lay.nc, 300)) * 1e-3
    dp = rng.standard_normal((lay.nc, 300)) * 1e-3
    dp[:, :20] = 0.0  # flat on one side: minmod gives 0
    dc = 0.5 * (dm + dp)
    rec = RECONSTRUCTIONS[name]
    slope = rec.taichi(__import__("taichi"), op.par, lay, op.fp)

    def fn(a, b):  # (dc is the mean of the two: the stencil's central difference; member 0)
        return slope(0, a, b, 0.5 * (a + b))

    got = _run_pairwise(op, __import__("taichi").func(fn), dm, dp)
    want = rec.slope_np(cfg, lay, dm, dp, dc)
    if name == "minmod":
        assert np.array_equal(got, want)  # selections of the same products: exact
    else:
        assert _close(got, want, 1e-12)  # the twin divides by each weight: round-off


@pytest.mark.parametrize("name", list(FLUXES))
@pytest.mark.parametrize("phi_flux", list(PHI_FLUXES))
@pytest.mark.parametrize("d", [0, 1])
def test_numerical_flux_equals_its_twin(ti_cpu, name, phi_flux, d):
    """Each numerical flux, followed by each h phi modifier, on random edge states in x and y
    (dry and thin states included), against the twins."""
    import taichi as ti

    cfg = make_config(6, 5, flux=name, phi_flux=phi_flux)
    op, ref = _operator(cfg)
    rng = np.random.default_rng(7)
    wl, wr = _edge_states(cfg.layout, rng), _edge_states(cfg.layout, rng)
    flux = FLUXES[name].taichi(ti, op.phys)
    mod = PHI_FLUXES[phi_flux].taichi(ti, op.phys, cfg.layout)
    modifies = mod is not None  # (Taichi scope has no `is not`)

    @ti.func
    def fn(a, b, dd: ti.template()):
        F = flux(0, a, b, dd, op.phys.g0(0))  # (member 0's numbers)
        if ti.static(modifies):
            F = mod(0, F, a, b)
        return F

    got = _run_pairwise(op, fn, wl, wr, d)
    H = FLUXES[name].flux_np(ref, wl, wr, d)
    want = PHI_FLUXES[phi_flux].modify_np(ref, H, wl, wr)
    assert _close(got, want)


@pytest.mark.parametrize(
    "bc",
    [
        ("inflow", "outflow", "periodic", "periodic"),
        ("wall", "wall", "wall", "wall"),
        ("periodic", "periodic", "outflow", "wall"),
        ("outflow", "wall", "wall", "outflow"),
    ],
)
@pytest.mark.parametrize("t", [0.5, 3.0])
def test_boundary_ghosts_equal_their_twins(ti_cpu, bc, t):
    """The ghost cells each condition fills (copies and mirrors: bit for bit), an inflow
    before and after it stops (then a wall)."""
    cfg = make_config(7, 6, bc=bc, inflow_stop=2.0)
    op, ref = _operator(cfg)
    q = random_state(cfg.layout, np.random.default_rng(11))
    op.set(0, q)
    op.stability(0, t)  # prepares slot 0: its ghost cells first
    want = q.copy()
    ref.fill_ghosts(want, t)
    assert np.array_equal(op.get(0), want)
    assert not np.array_equal(want, q)  # the ghosts were written


# ---------------------------------------------------------------- the Rusanov flux
def _dam_break(nx, h_right, flux="rusanov", reconstruction="first-order", **extra):
    """1D dam break, 2 m long, dam at 1 m, h_l = 1 m, walls at both ends, SSPRK3 at the
    positivity bound of its Euler steps."""
    over = {
        "domain.Lx": 2.0,
        "domain.nx": nx,
        "boundary.x_lo": "wall",
        "boundary.x_hi": "wall",
        "flow.h0": 1.0,
        "initial.x0": 1.0,
        "initial.h_left": 1.0,
        "initial.h_right": h_right,
        "numerics.h_min": 1e-6,
        "numerics.h_eps": 1e-9,
        "numerics.reconstruction": reconstruction,
        "numerics.flux": flux,
        "numerics.stepper": "ssprk3",
        "numerics.step_rule": "max",
        "numerics.cfl": 0.25,
        "time.t_end": 0.1,
        "output.interval": 0.1,
        **extra,
    }
    return Simulation(load_scene("dam-break", over))


def test_rusanov_is_a_scene_choice_and_the_kt_flux_at_a_face(ti_cpu):
    """``numerics.flux = "rusanov"`` reads and runs. Face by face it is the flux of
    Kurganov-Tadmor (2000), whose scheme is Rusanov's flux on reconstructed edge states: the
    same run with either gives the same bits."""
    assert load_scene("dam-break", {"numerics.flux": "rusanov"}).numerics.flux == "rusanov"
    a, b = _dam_break(64, 0.1), _dam_break(64, 0.1, flux="kt")
    a.advance(0.05)
    b.advance(0.05)
    assert np.array_equal(a.fields()["h"], b.fields()["h"])


@pytest.mark.parametrize("reconstruction", ["first-order", "minmod"])
def test_rusanov_dry_bed_dam_break_stays_positive_and_conservative(ti_cpu, reconstruction):
    """Ritter's dam break onto a dry bed between walls: mass to round-off (the stage
    limiter clips h < 0 to 0, which would add mass: none had anything to clip), h >= 0."""
    sim = _dam_break(128, 0.0, reconstruction=reconstruction)
    m0 = sim.totals()["mass"]
    sim.advance(0.1)
    assert abs(sim.totals()["mass"] - m0) / m0 < 1e-13
    assert sim.fields()["h"].min() >= 0.0


@pytest.mark.slow  # a long run: the slow set (README), which CI runs after the suite
def test_rusanov_first_order_converges_to_stoker(ti_cpu):
    """Stoker's dam break (a bore and a transonic fan) with first-order cells: the L1 error
    falls at a first-order scheme's rate on a discontinuous solution, which approaches 1 from
    below as the fan's corners are resolved (measured 0.64 from 64 to 128 cells, 0.70 from
    128 to 256; L1 error 0.0088 m at 256 cells)."""
    errs = []
    for nx in (64, 128, 256):
        sim = _dam_break(nx, 0.1)
        sim.advance(0.1)
        x, _ = sim.scene.domain.cell_centres()
        exact = cell_averages(lambda p: stoker(p, 0.1, 1.0, 0.1, 1.0)[0], x, sim.scene.dx)
        errs.append(np.mean(np.abs(sim.fields()["h"][0] - exact)))
    rates = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.all(rates > 0.55) and rates[1] > rates[0], errs
    assert errs[-1] < 0.01, errs
