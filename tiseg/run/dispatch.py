"""Callbacks after each step: which are due, snapshots interpolated at their times, in order.

A collaborator of `tiseg.run.simulation.Simulation` (issue 49; a mixin before) that receives
the run: it reads the run's callbacks (``callbacks``, a dictionary the run owns and may swap),
step count, time and operator (whose slots PREV and SNAP hold the snapshots), and calls the
run's guard. Output observes the run: a snapshot at a scheduled time between two steps is
interpolated from the states around it, so what is written, and when, never changes the
steps."""

from __future__ import annotations

from ..errors import InputError
from .callbacks import Callback, Snapshot
from .schedules import IterationInterval, Schedule

GUARD_ORDER = -100  # the guard callback runs before everything else after a step


class CallbackDispatch:
    """Registering callbacks and calling them after a step of a
    `tiseg.run.simulation.Simulation`."""

    def __init__(self, run):
        self.run = run

    def add(
        self,
        func,
        schedule: Schedule | None = None,
        name: str | None = None,
        snapshot: bool = False,
        order: int = 0,
    ) -> Callback:
        """Register ``func`` to run on ``schedule`` after steps (see `tiseg.run.callbacks`),
        or a ready `Callback`; a callback of the same name is replaced. Returns it."""
        if isinstance(func, Callback):
            cb = func
        elif schedule is None:
            raise InputError(
                "add_callback: give a schedule (e.g. IterationInterval(10) or "
                "TimeInterval(0.1) from tiseg.run.schedules)"
            )
        else:
            cb = Callback(func, schedule, name, snapshot, order)
        self.run.callbacks[cb.name] = cb
        return cb

    def remove(self, name: str) -> None:
        self.run.callbacks.pop(name, None)

    def set_check_every(self, n: int) -> None:
        """Register the guard callback every ``n`` steps (0: only on steps that make a
        snapshot)."""
        if not (isinstance(n, int) and n >= 0):
            raise InputError(f"check_every={n!r} must be an integer >= 0")
        self.run.callbacks.pop("guard", None)
        if n:
            # before the step's snapshots (negative order): nothing is written unchecked
            self.run.callbacks["guard"] = Callback(
                lambda sim: sim._guard(), IterationInterval(n), name="guard", order=GUARD_ORDER
            )

    def guard_due(self, steps: int, pending) -> bool:
        """Whether `after_step` of step number ``steps`` with the snapshots ``pending`` will
        check the guard: a forecast for a batch, which scans those members in one launch (a
        check that a callback on a wall clock asks for is not foreseen: that member's scan
        is a launch of its own)."""
        guard = self.run.callbacks.get("guard")
        if guard is not None and isinstance(guard.schedule, IterationInterval):
            if guard.schedule.due(None, None, steps):
                return True
        return bool(pending)

    def pending_snapshots(self, t0: float, t1: float) -> list[tuple[float, list[Callback]]]:
        """(time, snapshot callbacks) for every scheduled snapshot time in (t0, t1], in order."""
        by_time: dict[float, list[Callback]] = {}
        for cb in self.run.callbacks.values():
            if cb.snapshot:
                for tk in cb.schedule.times_in(t0, t1):
                    by_time.setdefault(tk, []).append(cb)
        return sorted(by_time.items(), key=lambda item: item[0])

    def snapshot(self, tk: float, t0: float, t1: float) -> Snapshot:
        """The state at tk in (t0, t1]: slot 0 when tk is the step's end, else interpolated
        linearly from the state before the step (slot PREV) into slot SNAP."""
        run = self.run
        if t1 - tk <= 1e-12 * max(1.0, abs(t1)):
            return Snapshot(run, tk, 0, run.stats.steps, 1.0)
        theta = (tk - t0) / (t1 - t0)
        run.op.blend(run.SNAP, run.PREV, 0, theta)
        return Snapshot(run, tk, run.SNAP, run.stats.steps, theta)

    def after_step(self, t0: float, t1: float, pending) -> None:
        """The callbacks of the step: those due with a negative order (the guard), the
        snapshots at the scheduled times the step crossed, then the other callbacks due, in
        increasing order (the checkpoint last)."""
        run = self.run
        steps = run.stats.steps
        due = sorted(
            (
                cb
                for cb in run.callbacks.values()
                if not cb.snapshot and cb.schedule.due(t0, t1, steps)
            ),
            key=lambda c: c.order,
        )  # every schedule is asked (wall clocks)
        before = [cb for cb in due if cb.order < 0]
        if (pending or any(cb.checked for cb in due)) and "guard" not in (cb.name for cb in before):
            run._guard()  # nothing is saved from an unchecked state
        for cb in before:
            cb(run)
        for tk, cbs in pending:
            snap = self.snapshot(tk, t0, t1)
            for cb in cbs:
                cb(snap)
        for cb in due:
            if cb.order >= 0:
                cb(run)

    def initial_snapshots(self) -> None:
        """Snapshot callbacks whose schedule holds the current time get the current state."""
        run = self.run
        snap = Snapshot(run, run.t, 0, run.stats.steps, 1.0)
        for cb in list(run.callbacks.values()):
            if cb.snapshot and cb.schedule.contains(run.t):
                cb(snap)
