"""Helpers for the solver tests: build operators straight from an OperatorConfig."""

import numpy as np

from tiseg.model.material import TABLE1
from tiseg.solver.numerics.config import FrictionParams, Layout, OperatorConfig


def table1_friction(m=TABLE1, coulomb_mu=0.36):
    """Table 1's friction parameters, the laws' constants at their declared values (beta*,
    kappa from the Material) but ``coulomb_mu``."""
    return FrictionParams.of(m, coulomb_mu=coulomb_mu)


def rates_equal_reference(cfg, q):
    """The Taichi rates of q against the NumPy reference's, to 1e-12 of each component's
    largest rate; returns (op, ref, Taichi rates) for further stages (slots 0..2 in use)."""
    from tiseg.solver.numerics.operator import TaichiOperator
    from tiseg.solver.reference import ReferenceOperator

    op = TaichiOperator(cfg, nslots=3)
    ref = ReferenceOperator(cfg)
    op.set(0, q)
    op.rhs(0, 1, 0.0)
    r_ti, r_np = op.get(1), ref.rhs(q.copy(), 0.0)
    ix, iy = cfg.layout.interior()
    scale = np.abs(r_np)[:, ix, iy].max(axis=(1, 2))
    assert np.all(np.abs(r_ti - r_np)[:, ix, iy].max(axis=(1, 2)) <= 1e-12 * scale)
    return op, ref, r_ti


def stage_and_twin(op, ref, q, split: bool, t: float = 0.0, dt: float = 0.01):
    """(Taichi, twin) results from q, which is in op's slot 0: a sweep of dt along x then y
    (``split``), else one evaluation of L at time t."""
    from tiseg.solver.reference.split import hancock_sweep

    if split:
        qr = q.copy()
        for d in (0, 1):
            op.sweep(d, t, dt)
            hancock_sweep(ref, qr, t, dt, d)
        return op.get(0), qr
    op.rhs(0, 1, t)
    return op.get(1), ref.rhs(q.copy(), t)


def assert_equals_twin(a, r, lay, what=()) -> None:
    """Every component of the interior cells of a within 1e-12 of its largest value in r."""
    ix, iy = lay.interior()
    err = np.abs(a - r)[:, ix, iy].max(axis=(1, 2))
    scale = np.abs(r)[:, ix, iy].max(axis=(1, 2))
    assert np.all(err <= 1e-12 * scale), (*what, err, scale)


def projected_stage_equals_reference(op, ref, q, r_ti, dt, tau):
    """One limited Euler stage q + dt L(q) with the friction projected over tau, the first of a
    step (where a law with hysteresis decides which resting cells it holds), against the
    reference's limiter + holds + project_friction; returns the Taichi result (slot 2)."""
    lay = op.cfg.layout
    op.combine(2, [(1.0, 0), (dt, 1)], limit=True, tau=tau, rates=(1,))  # the step's first
    a = op.get(2)
    b = q + dt * r_ti
    ref.postprocess(b)
    ref.project_friction(b, tau, q, held=ref.holds(b, tau, ref.at_rest(q)))
    ix, iy = lay.interior()
    for c in range(lay.nc):
        assert np.allclose(a[c][ix, iy], b[c][ix, iy], rtol=1e-12, atol=1e-18), c
    return a


def local_rate_twin(a, b, dx, dy) -> float:
    """NumPy twin of the stability pass's rate of step_rule "local": the largest, over the
    cells, of max(a over i-1..i+1) / dx + max(b over j-1..j+1) / dy. a, b: the x and y wave
    speeds indexed (x, y), on the cells that count plus one layer of neighbours around them."""
    A = np.maximum(np.maximum(a[:-2, 1:-1], a[1:-1, 1:-1]), a[2:, 1:-1])
    B = np.maximum(np.maximum(b[1:-1, :-2], b[1:-1, 1:-1]), b[1:-1, 2:])
    return float((A / dx + B / dy).max())


def make_config(nx, ny, segregation=True, **kw):
    defaults = dict(
        dx=0.01,
        dy=0.012,
        Ly=ny * 0.012,
        viscous=True,
        feedback=segregation,
        fric=table1_friction(),
        nu=0.01,
        inflow_h=0.002,
        inflow_u=0.2,
        inflow_phi=0.8,
        inflow_delta=0.1,
        # the numerics these tests were written for (the scene's defaults differ in the first
        # two: weno, projected)
        reconstruction="minmod",
        friction_scheme="regularised",
        theta=1.5,
        flux="kt",
        phi_flux="upwind",
        h_min=1e-4,
        h_eps=1e-7,
        u_eps=1e-3,
    )
    defaults.update(kw)
    return OperatorConfig(layout=Layout(nx, ny, segregation), **defaults)


def random_state(lay, rng, wet_dry=False, smooth=False):
    """A random state: smooth waves, or noisy with dry cells and films below h_min."""
    q = np.zeros((lay.nc, lay.NX, lay.NY))
    X, Y = np.meshgrid(
        np.linspace(0, 2 * np.pi, lay.NX), np.linspace(0, 2 * np.pi, lay.NY), indexing="ij"
    )
    if smooth:
        h = 0.002 * (1 + 0.3 * np.sin(X + 0.5) * np.cos(Y))
        u = 0.2 + 0.05 * np.cos(X)
        v = 0.03 * np.sin(Y + X)
        phi = 0.5 + 0.4 * np.sin(X) * np.sin(Y + 1)
    else:
        h = 0.002 * (1 + 0.3 * rng.random(X.shape))
        u = 0.2 + 0.1 * rng.standard_normal(X.shape)
        v = 0.05 * rng.standard_normal(X.shape)
        phi = rng.random(X.shape)
    if wet_dry:
        mask = rng.random(X.shape)
        h = np.where(mask < 0.2, 0.0, h)
        h = np.where((mask >= 0.2) & (mask < 0.35), 5e-5 * rng.random(X.shape), h)
    q[lay.H] = h
    q[lay.HU] = h * u
    if not lay.is_1d:
        q[lay.HV] = h * v
    if lay.segregation:
        q[lay.HPHI] = h * phi
    return q


# A small valid 2D scene file (no name): the base of the malformed-text cases of the scene and
# bad-input tests.
MINIMAL_SCENE = """
[domain]
Lx = 0.2
Ly = 0.05
resolution = 200
[time]
t_end = 0.5
"""

PERIODIC = {"x_lo": "periodic", "x_hi": "periodic", "y_lo": "periodic", "y_hi": "periodic"}
OPEN = {"x_lo": "outflow", "x_hi": "outflow", "y_lo": "periodic", "y_hi": "periodic"}


def coulomb_scene(
    zeta, mu, initial, boundary, stepper, nx, Lx, t_end, friction_scheme="regularised"
):
    """A 1D monodisperse layer (h0 = 2 mm) with Coulomb friction mu on a slope zeta [deg]: no
    viscosity, no segregation, minmod slopes, and a tiny h_min (the O(h_min) stall of a front
    tip is not what these cases test)."""
    from tiseg.setup.scene import scene_from_dict

    return scene_from_dict(
        {
            "material": {"zeta_deg": zeta},
            "flow": {"h0": 0.002, "phi0": 0.8, "nu": 0.0},
            "effects": {
                "segregation": False,
                "viscosity": False,
                "mobility_feedback": False,
                "friction": "coulomb",
                "coulomb_mu": mu,
            },
            "domain": {"Lx": Lx, "nx": nx, "ny": 1},
            "boundary": dict(boundary),
            "initial": initial,
            "numerics": {
                "reconstruction": "minmod",
                "stepper": stepper,
                "h_min": 1e-7,
                "h_eps": 1e-9,
                "friction_scheme": friction_scheme,
            },
            "time": {"t_end": t_end},
        },
        name="coulomb",
    )


def exit_code(argv) -> int:
    """tiseg's main(argv), with argparse's SystemExit(2) turned into its exit code."""
    from tiseg.apps.cli import main

    try:
        return main(argv)
    except SystemExit as exc:
        return exc.code


def child_env(**extra) -> dict:
    """Environment for a test's child process: Taichi offline and quiet, no display backend."""
    import os

    env = dict(os.environ)
    env.update(TI_SKIP_VERSION_CHECK="ON", ENABLE_TAICHI_HEADER_PRINT="0", MPLBACKEND="Agg")
    env.update(extra)
    return env


def tiny_fingers(t_end: float, interval: float | None = None) -> list[str]:
    """The command line of a tiny fingers run (40 cells/m on 0.3 x 0.1 m, no progress bar) to
    t_end, with snapshots every ``interval`` s if given."""
    args = ["run", "fingers"]
    keys = ["domain.resolution=40", "domain.Lx=0.3", "domain.Ly=0.1", f"time.t_end={t_end}"]
    if interval is not None:
        keys.append(f"output.interval={interval}")
    for k in keys:
        args += ["--set", k]
    return [*args, "--no-progress"]
