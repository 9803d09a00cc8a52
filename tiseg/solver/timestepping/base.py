"""Stepper interface and registry."""

from __future__ import annotations

from ...errors import InputError

STEPPERS: dict[str, type] = {}

# The slot of the rate in a stage's terms: op.stage(dst, [(c, slot), ..., (c, RATE)], src, t)
# is op.rhs(src, F, t) then op.combine(dst, [..., (c, F)]) for a spare slot F, fused (the rate is
# used where it is computed and never stored). Steppers use it where a rate is needed once.
RATE = -1


def register(cls):
    STEPPERS[cls.name] = cls
    return cls


class Stepper:
    """Base class. ``slots`` is how many state slots (slot 0 = the solution) a step needs; a
    step sees the operator through the interface of the package docstring."""

    name = "base"
    slots = 1
    order = 1
    # whether a cell held at rest keeps its h bit for bit through a step (every stage a
    # limited combination of states and rates: RestRules.keep_rest); the skipping of
    # resting regions is exact only then
    keeps_rest = True
    # advances by dimensionally split sweeps (tiseg.solver.numerics.split) rather than stages of L
    split = False
    # its stage count follows the stiffness (dt rho), up to the scene's numerics.max_stages,
    # which its constructor takes as ``max_stages``; a fixed-stage stepper takes none
    stage_cap = False
    # how many convective limits a step may span: 2 for the split step with viscosity (two
    # half steps of sweeps, each at most the limit), else 1
    halves = 1
    # how many steps the run has taken before this one, set by the simulation before each
    # step: a stepper whose steps differ by their parity (the split step's sweep order) reads
    # it, so that a resumed run steps as the run it continues
    index = 0

    def plan(
        self, dt_cfl: float, rho: float, dt_max: float, stages: int | None = None
    ) -> tuple[float, int]:
        """(dt, stages) for the next step given the convective limit, the spectral radius and
        an upper bound (the time left to the end of the run). ``stages``: a fixed stage count
        instead of the one the stiffness asks for (benchmarks and the estimate's calibration;
        stability is then the caller's business)."""
        raise NotImplementedError

    def step(self, op, t: float, dt: float, stages: int) -> None:
        """Advance slot 0 of ``op`` from t to t + dt."""
        raise NotImplementedError

    def step_members(self, op, t, dt, stages) -> None:
        """Advance slot 0 of each member of a batch (``op`` with several members) by its own
        step: ``t``, ``dt`` and ``stages`` one per member. A stepper with a fixed stage count
        takes its `step` with arrays for t and dt (each member's numbers are the single run's,
        element by element); one whose stage count varies overrides this."""
        counts = set(int(k) for k in stages)
        if len(counts) != 1:
            raise InputError(
                f"{self.name} takes the same stage count in every member, got {counts}"
            )
        self.step(op, t, dt, counts.pop())


def stepper_for(
    numerics, name: str | None = None, is_1d: bool = False, viscous: bool = False
) -> Stepper:
    """The stepper of a scene's [numerics] (or the one named), with the scene's RKC stage cap
    (and, for the split sweeps, how many directions there are and whether they take the
    viscous sub-step, ``viscous``)."""
    name = name or numerics.stepper
    kw = {}
    if getattr(STEPPERS.get(name), "stage_cap", False):
        kw["max_stages"] = numerics.max_stages
    if getattr(STEPPERS.get(name), "split", False):
        kw["dims"] = 1 if is_1d else 2
        if viscous:
            kw["viscous"] = True
            kw["max_stages"] = numerics.max_stages
    return make_stepper(name, **kw)


def make_stepper(name: str, **kwargs) -> Stepper:
    if name not in STEPPERS:
        raise InputError(
            f"numerics.stepper={name!r} is not known; choose one of {', '.join(sorted(STEPPERS))}"
        )
    return STEPPERS[name](**kwargs)
