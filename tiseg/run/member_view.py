"""One member of a batched operator, seen by its `Simulation` as an operator of its own.

A batch (`tiseg.run.batch`) advances the ensemble members of one `TaichiOperator` built with
``members=M`` together: one launch a stage for all of them. Each member keeps a `Simulation`
of its own (its scene, time, step plan, callbacks, output, guards and peaks), whose ``op`` is
a `MemberOperator`: the same interface as the operator, bound to the member. Reads and writes
of the state, the budget, the parameters and the checkpoint's rest mask go to the member's
rows; the shared launches (the wet scan, the stability pass, the steps) are the batch's, which
hands each member its own results (``extent``, ``numbers``) before the member plans its step,
and collects the x range each member asks for (``wanted``) to set their union.
"""

from __future__ import annotations

import numpy as np

from ..errors import TisegError
from ..solver.numerics.ranges import clamp_range


class MemberOperator:
    def __init__(self, op, member: int):
        """``op``: a `TaichiOperator` with several members; ``member``: this one's index."""
        self._op = op
        self.member = op.state._member(member)
        self.extent = None  # this step's wet and live extents (set by the batch)
        self.numbers = None  # this step's stability numbers (set by the batch)
        self.wanted = None  # the active and wet x ranges this member asks for, clamped
        self.shared_sums = None  # the batch's totals of slot 0 (SharedSums), where it keeps them

    def __getattr__(self, name):
        # the layout's constants, the fields, the state and the collaborators are the batch's
        return getattr(self._op, name)

    @property
    def batch(self):
        """The batched operator."""
        return self._op

    @property
    def cfg(self):
        """This member's run-time configuration."""
        return self._op.state.cfgs[self.member]

    # ------------------------------------------------------------------ the member's rows
    def get(self, slot: int = 0):
        return self._op.get(slot, self.member)

    def set(self, slot: int, arr) -> None:
        self._op.set(slot, arr, self.member)

    def budget(self, slot: int = 0):
        """The member's boundary budget; that of slot 0 after a batch's step is every
        member's, read at once by the first member that asks (`SharedSums`)."""
        if slot == 0 and self.shared_sums is not None:
            return self.shared_sums.budget_of(self.member)
        return self._op.budget(slot, self.member)

    def reset_budget(self, values=None) -> None:
        self._op.reset_budget(values, self.member)

    def sums(self, slot: int = 0):
        """The member's totals; those of slot 0 after a batch's step are every member's,
        taken in one launch by the first member that asks (`SharedSums`)."""
        if slot == 0 and self.shared_sums is not None:
            return self.shared_sums.of(self.member)
        return self._op.sums(slot, self.member)

    def set_params(self, cfg) -> None:
        """New run-time numbers: the whole interior active again, as the operator makes it."""
        self._op.set_params(cfg, self.member)
        self.wanted = None

    def blend(self, dst: int, a: int, b: int, theta: float) -> None:
        """A snapshot's blend of this member's slots alone."""
        self._op.blend(dst, a, b, theta, self.member)

    def rest_state(self):
        """The member's rest mask and the ranges its own step asked for (not the batch's
        union): the ranges a run of it alone holds, so that its checkpoint resumes alone or
        in a batch."""
        rest = self._op.rest_state(self.member)
        if rest is not None and self.wanted is not None:
            (a, b), (wa, wb) = self.wanted
            rest["ranges"] = np.array([a, b, wa, wb, rest["ranges"][4]], dtype=np.int64)
        return rest

    def restore_rest_state(self, rest_mask, ranges) -> None:
        self._op.restore_rest_state(rest_mask, ranges, self.member)

    def inflow_on(self, t: float) -> bool:
        """Whether this member's inflow runs at time t."""
        return self._op.bc[0] == "inflow" and not t > self.cfg.inflow_stop

    # ------------------------------------------------------------------ the batch's launches
    def wet_extent(self, slot: int, t: float):
        """This member's extents from the batch's wet scan of the step."""
        return self._given(self.extent, "wet scan")

    def stability(self, slot: int, t: float):
        """This member's numbers from the batch's stability pass of the step."""
        return self._given(self.numbers, "stability pass")

    def _given(self, value, what: str):
        if value is None:
            raise TisegError(
                f"member {self.member} of a batch has no {what} of its own: it steps with its "
                "batch (tiseg.run.batch)"
            )
        return value

    def set_active(self, a: int, b: int, wet=None) -> None:
        """Record the x ranges this member's next step needs; the batch sets their union."""
        self.wanted = clamp_range(self._op.lay, a, b, wet)

    @property
    def active(self) -> tuple[int, int]:
        """The active x range this member asked for (the batch works on a union that holds
        it), the whole interior until it asks."""
        if self.wanted is None:
            return self._op.active
        return self.wanted[0]

    @property
    def skip_rest(self) -> bool:
        return self._op.skip_rest

    @skip_rest.setter
    def skip_rest(self, on: bool) -> None:
        self._op.skip_rest = on


class SharedSums:
    """The totals and the boundary budgets of slot 0 of every member of a batch's operator
    after a step, each taken in one launch (`TaichiOperator.member_sums`, the budget field
    read whole) when the first member asks for its own (its diagnostics row, its mass check)
    and handed to the others, until the state changes (`OperatorState.changed`: the batch's
    next step, or a slot or budget set from the host: a member's new state, a reset, a
    checkpoint)."""

    def __init__(self, op):
        self._op = op
        self._sums = self._budget = None
        self._changes = self._budget_changes = None  # the state's change count when taken

    def of(self, member: int) -> tuple[float, float]:
        changes = self._op.state.changes
        if self._changes != changes:
            self._sums, self._changes = self._op.member_sums(0), changes
        return float(self._sums[member, 0]), float(self._sums[member, 1])

    def budget_of(self, member: int) -> np.ndarray:
        """Member ``member``'s budget of slot 0, as `OperatorState.budget` gives it."""
        state = self._op.state
        if self._budget_changes != state.changes:
            self._budget, self._budget_changes = state.bud.to_numpy(), state.changes
        return self._budget[member, 0].astype(float)
