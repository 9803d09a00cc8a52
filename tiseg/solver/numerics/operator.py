"""The semi-discrete operator dq/dt = L(q, t) of (6.1)-(6.6) in Taichi kernels: the facade
the time steppers talk to.

The operator is an explicit state object and collaborators that receive it (issue 49; before,
mixins over one ``self``), in the shape of Trixi.jl's and Basilisk's solvers:

* `state.OperatorState`: the fields, slots, active range, run-time parameters and caches, the
  one place that allocates fields;
* `ghosts.GhostCells` (state): the boundary conditions' ghost cells;
* `rest.RestRules` (state, ghosts): the projected friction's rest mask, face rules,
  projection and the wet scan;
* `finite_volume.FiniteVolume` (state, ghosts, rules): the evaluation of L, composed of the
  numerics components chosen by the scene (reconstruction, numerical flux, h phi modifier);
* `slots.SlotAlgebra` (state, fv, rules): combinations of slots, fused stages, the stage
  limiter, budgets;
* `split.SplitSweeps` (state, ghosts, fv, rules): the sweeps of the split scheme;
* `viscous_substep.ViscousSubstep` (state, ghosts, fv): its viscous sub-step;
* `reductions.StepReductions` (state): the stability pass and the totals.

Time steppers (`tiseg.solver.timestepping`) see only `rhs`, `combine` / `stage` (with the
stage limiter), `sweep` / `viscous_stage` and `stability`, which this class passes on. The
state's names (``q``, ``par``, ``cfg``, ``gx`` ...) stay reachable from the operator as
read-only attributes (`STATE_NAMES`) for the run's guards, gauges and renderers.
"""

import numpy as np

from ...taichi_classes import data_oriented

from .config import OperatorConfig
from .finite_volume import FiniteVolume
from .ghosts import GhostCells
from .ranges import SERIAL_CELLS, ActiveRange, row_pieces  # noqa: F401 (public name)
from .reductions import NSTAB, StabilityNumbers, StepReductions  # noqa: F401 (public names)
from .rest import HELD, REST, WET, X_NEG, X_POS, Y_NEG, Y_POS, RestRules  # noqa: F401
from .slots import MAX_TERMS, SlotAlgebra  # noqa: F401 (public names)
from .split import SplitSweeps
from .viscous_substep import ViscousSubstep
from .state import NBUDGET, OperatorState  # noqa: F401 (public names)

# the state's names that other code reads from the operator (read-only: the objects do not
# change; item assignment into a field, op.par[k] = v, still works)
STATE_NAMES = (
    "generation M lay nslots fp np_fp nc NX NY nx ny gx gy is_1d seg visc H HU HV HPHI "
    "rec_first local_rate split bc bcs field_tree q w fx sx fy sy ew ee drain par "
    "inflow_prof ranges strip_serial act wet wrng rows_per_block row_pieces bud phys rest "
    "spd0 hg spd red rowsum total cfg active wet_range force_serial"
).split()


@data_oriented
class TaichiOperator:
    def __init__(
        self,
        cfg: OperatorConfig,
        nslots: int = 6,
        serial: bool | None = None,
        members: int = 1,
    ):
        """``serial``: run every loop on the calling thread (True), never (False), or decide
        per launch (None, `serial_loops`); the results are the same bits either way.
        ``members``: the ensemble members the fields hold (`OperatorState`), each with its own
        state and run-time numbers (all ``cfg``'s until `set_params` gives a member others),
        advanced together by every launch."""
        self.state = st = OperatorState(cfg, nslots, serial, members)
        self.ghosts = GhostCells(st)
        self.rules = RestRules(st, self.ghosts)
        self.fv = FiniteVolume(st, self.ghosts, self.rules)
        self.slots = SlotAlgebra(st, self.fv, self.rules)
        self.sweeps = SplitSweeps(st, self.ghosts, self.fv, self.rules)
        self.viscous = ViscousSubstep(st, self.ghosts, self.fv)
        self.reduce = StepReductions(st, self.fv)
        st.finalize()  # the fields exist from here on
        self.ghosts.compose()
        self.fv.compose()
        st.set_active(st.gx, st.gx + st.nx)
        st.set_params(cfg)
        if st.batched:
            st.set_running(np.ones(st.M, dtype=bool))
        self.t = 0.0

    @property
    def skip_rest(self) -> bool:
        """Whether resting regions are left out of the active range (OperatorState); may be
        switched off before the first step."""
        return self.state.skip_rest

    @skip_rest.setter
    def skip_rest(self, on: bool) -> None:
        self.state.skip_rest = bool(on)

    @property
    def _prepared(self):
        """(slot, t, active range) whose primitives are in w (OperatorState.prepared)."""
        return self.state.prepared

    # ------------------------------------------------------------------ the state
    def set_params(self, cfg: OperatorConfig, member: int | None = None) -> None:
        """Copy run-time numbers into the parameter field (no recompilation): member
        ``member``'s, or every member's (None)."""
        self.state.set_params(cfg, member)

    def set_bed(self, b: np.ndarray | None = None, solid: np.ndarray | None = None) -> None:
        """The bed heights (nx, ny) [m] and the solid cells (nx, ny) of an operator built for
        them (OperatorState.set_bed)."""
        self.state.set_bed(b, solid)

    def check_alive(self) -> None:
        """Raise if Taichi was re-initialised since the fields were made."""
        self.state.check_alive()

    def get(self, slot: int = 0, member: int = 0) -> np.ndarray:
        """Slot of a member as a float64 array shaped (nc, NX, NY)."""
        return self.state.get(slot, member)

    def set(self, slot: int, arr: np.ndarray, member: int | None = None) -> None:
        """Replace a slot of a member (of every member: None) by an array shaped
        (nc, NX, NY)."""
        self.state.set(slot, arr, member)

    def budget(self, slot: int = 0, member: int = 0) -> np.ndarray:
        """Accumulated [mass, small mass] that entered through x faces and y faces [m^3]."""
        return self.state.budget(slot, member)

    def reset_budget(self, values=None, member: int | None = None) -> None:
        self.state.reset_budget(values, member)

    def set_active(self, a: int, b: int, wet: tuple[int, int] | None = None) -> None:
        """Restrict the operator to interior x indices [a, b) (OperatorState.set_active)."""
        self.state.set_active(a, b, wet)

    def serial_loops(self, whole: bool = False) -> bool:
        """Whether the next launch runs its loops on one thread (ActiveRange.serial_loops)."""
        return self.state.serial_loops(whole)

    def inflow_on(self, t: float) -> bool:
        """Whether an inflow runs at time t (until the scene's inflow stop time)."""
        return self.state.inflow_on(t)

    # ------------------------------------------------------------------ stepper interface
    def rhs(self, src: int, dst: int, t: float) -> None:
        """slot dst := L(slot src, t) on interior cells (FiniteVolume.rhs)."""
        self.fv.rhs(src, dst, t)

    def combine(self, dst, terms, limit: bool = False, tau=0.0, rates=(), live=None) -> None:
        """slot dst := sum(c * slot) over terms [(c, slot), ...] (SlotAlgebra.combine)."""
        self.slots.combine(dst, terms, limit, tau, rates, live)

    def stage(
        self, dst, terms, src: int, t, limit: bool = True, tau=None, rates=(), live=None
    ) -> None:
        """A combination with one term L(slot src, t), in one launch (SlotAlgebra.stage)."""
        self.slots.stage(dst, terms, src, t, limit, tau, rates, live)

    def blend(self, dst: int, a: int, b: int, theta: float, member: int | None = None) -> None:
        """slot dst := (1 - theta) slot a + theta slot b, whole (SlotAlgebra.blend)."""
        self.slots.blend(dst, a, b, theta, member)

    def sweep(self, d: int, t, dt, first: bool = True, last: bool = True) -> None:
        """One sweep of the split scheme along d (SplitSweeps.sweep)."""
        self.sweeps.sweep(d, t, dt, first, last)

    def viscous_stage(self, src, prev2, dst, coeffs, t, first: bool = False, live=None) -> None:
        """One stage of a split step's viscous sub-step (ViscousSubstep.viscous_stage)."""
        self.viscous.viscous_stage(src, prev2, dst, coeffs, t, first, live)

    def set_running(self, running) -> None:
        """Which members of a batch still advance (OperatorState.set_running)."""
        self.state.set_running(running)

    def stability(self, slot: int, t: float) -> StabilityNumbers:
        """Wave speeds and stiffness bounds of ``slot`` at time t (StepReductions.stability),
        member 0's; every member's then by `member_stability`."""
        return self.reduce.stability(slot, t)

    def member_stability(self) -> list[StabilityNumbers]:
        """Each member's numbers of the last stability pass (StepReductions.members)."""
        return self.reduce.members()

    def sums(self, slot: int = 0, member: int = 0) -> tuple[float, float]:
        """(sum of h, sum of h phi) over interior cells of a member, deterministic, in f64."""
        return self.reduce.totals(slot, self.state.serial_loops(whole=True), member)

    def member_sums(self, slot: int = 0) -> np.ndarray:
        """`sums` of every member at once, (M, 2), in one launch (a batch's step)."""
        return self.reduce.member_totals(slot, self.state.serial_loops(whole=True))

    # ------------------------------------------------------------------ the run's ranges
    def wet_extent(self, slot: int, t: float) -> tuple[int, int, int, int]:
        """The wet and live x extents of ``slot`` (RestRules.wet_extent)."""
        return self.rules.wet_extent(slot, t)

    def member_extents(self) -> list[tuple[int, int, int, int]]:
        """Each member's wet and live extents of the last wet scan (RestRules.member_extents)."""
        return self.rules.member_extents()

    def rest_state(self, member: int = 0) -> dict[str, np.ndarray] | None:
        """A member's rest mask and the ranges for a checkpoint (RestRules.rest_state)."""
        return self.rules.rest_state(member)

    def restore_rest_state(self, rest_mask: np.ndarray, ranges: np.ndarray, member: int = 0):
        """Inverse of `rest_state` (RestRules.restore_rest_state)."""
        self.rules.restore_rest_state(rest_mask, ranges, member)


def _state_name(name: str) -> property:
    return property(lambda self: getattr(self.state, name), doc=f"OperatorState.{name}")


for _name in STATE_NAMES:
    setattr(TaichiOperator, _name, _state_name(_name))
del _name
