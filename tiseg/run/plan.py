"""The plan of a step: the step-size rules every step is planned with, and the records of
steps and runs.

Apart from `tiseg.run.simulation` so that what checks a plan (`tiseg.run.failures`) and what
estimates a run's cost (`tiseg.apps.estimate`) read these without importing the run loop (no
import circle: issue 49).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from ..model.physics.friction import FRICTION_LAWS
from ..solver.numerics.config import config_from_scene


# Cells beyond the wet region that the active x range keeps on top of one cell per RKC stage
# (the stencil's reach): the range stays exact (see SlotAlgebra._combine_cells).
ACTIVE_MARGIN = 3


def step_limits(
    ax: float,
    ay: float,
    rho_stiff: float,
    scene,
    rate_local: float | None = None,
    dt_gravity: float = math.inf,
) -> tuple[float, float]:
    """(dt_cfl, rho): the rules every step is planned with, shared with tiseg.apps.estimate.

    dt_cfl is the forward-Euler step of the KT positivity proof (Kurganov & Petrova 2007,
    section 3) at the Courant number C = numerics.cfl, infinite when nothing moves:

    * step_rule "max": dt = C min(dx / a_x, dy / a_y), positive for C <= 1/4 in 2D (1/2 in 1D);
    * step_rule "sum": dt = C / (a_x/dx + a_y/dy), positive for C <= 1/2. The proof writes the
      cell average as a convex mix of its four edge values; weighting the x and y pairs by
      their shares of a_x/dx + a_y/dy instead of 1/2 each gives this bound, which equals the
      1D one where a single direction carries the waves and is never below the max rule's.
    * step_rule "local": dt = C / max over cells of (A/dx + B/dy), positive for C <= 1/2,
      with A and B the largest speeds among the cell and its two neighbours along x and along
      y (``rate_local``, from the stability pass): the same proof with the weights chosen
      cell by cell, each cell needing only the speeds of its own four faces. The global
      maxima of a_x and a_y need not meet in one cell (a dam break's fastest x wave runs
      where the flow is shallow, its fastest y wave where it is deep), so this step is
      never below the sum rule's and is 1.17x it on the Stoker dam break. Without
      ``rate_local`` (tiseg.apps.estimate) it falls back to the sum rule, an upper bound on the
      steps. 1D: all three rules are dt = C dx / a_x.

    Where anything moves or could (rate > 0), dt_cfl is also at most ``dt_gravity``
    (`gravity_step`, C sqrt(dx / a) with a the largest acceleration gravity and the least
    friction give): the speed a cell gains in one step, a dt, may then carry it at most C^2
    of a cell in the next, whatever the speeds now. Material released from rest has none,
    and without this rule its first steps were as long as the pressure waves of a thin
    layer allow (at 89 degrees one step spanned 0.2 s, and a release fell 10 % short of
    g sin(zeta) t^2 / 2 in 1 s). It binds only where gravity outruns the waves (steep
    slopes, releases from rest); the fingers scene's steps are over 5x shorter than it.

    SSP steppers multiply it by their SSP coefficient. rho is the spectral radius the steppers
    plan with: the viscous + friction stiffness plus the KT dissipation 2 (a_x/dx + a_y/dy),
    a Gershgorin bound of the convective Jacobian, whose rows are cells: with the local rule
    2 rate_local bounds it. Without the dissipation term the SSP steppers' step is too long
    for their stability interval."""
    rx = ax / scene.dx
    ry = ay / scene.dy if not scene.is_1d else 0.0
    rule = scene.numerics.step_rule
    if rule == "local" and rate_local is not None:  # (the operator gives none in 1D)
        rate = conv = min(rate_local, rx + ry)  # (the bound can only be tighter)
    else:
        rate = rx + ry if rule in ("sum", "local") else max(rx, ry)
        conv = rx + ry
    dt_cfl = min(scene.numerics.cfl / rate, dt_gravity) if rate > 0 else math.inf
    return dt_cfl, rho_stiff + 2.0 * conv


def largest_acceleration(scene) -> float:
    """g (sin(zeta) - mu cos(zeta)) with mu the least coefficient the friction law can give:
    the largest downslope acceleration gravity and friction give a cell (6.4), 0 where the
    friction can always hold it."""
    m = scene.material
    mu = FRICTION_LAWS[scene.effects.friction].least_mu(config_from_scene(scene).fric)
    zeta = math.radians(m.zeta_deg)
    return max(0.0, m.g * (math.sin(zeta) - mu * math.cos(zeta)))


def gravity_step(scene) -> float:
    """C sqrt(dx / a), a = `largest_acceleration`: the step in which a cell at rest gains
    the speed that crosses C^2 of a cell in the next (C = numerics.cfl); infinite where
    nothing accelerates (flat ground, or a slope the friction holds)."""
    a = largest_acceleration(scene)
    return scene.numerics.cfl * math.sqrt(scene.dx / a) if a > 0 else math.inf


@dataclass
class StepInfo:
    t: float
    dt: float
    stages: int
    rhs_evals: int


@dataclass
class StepPlan:
    """The next step: ``dt``, ``stages``, the stability numbers it was planned from, and the
    time it ends at (``t_next``, exactly the stop time when it lands there)."""

    dt: float
    stages: int
    stability: object
    t_next: float
    dt_cfl: float = math.inf  # the convective limit it was planned from
    lands: bool = False  # it ends exactly on the stop time


@dataclass
class RunStats:
    steps: int = 0
    stages: int = 0  # operator evaluations
    wall: float = 0.0  # cumulative wall time of run() calls (resumed runs continue it)
    history: list = field(default_factory=list)
