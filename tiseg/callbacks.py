"""Callbacks: what runs between time steps, each on its own schedule (`tiseg.schedules`).

A `Callback` is a function and a schedule. After every step the simulation asks each
schedule whether it is due:

* a plain callback is called as ``func(sim)`` once after a step on which it fell due, with the
  simulation at the step's end (diagnostics, checkpoints, progress, the viewer's recording);
* a *snapshot* callback (``snapshot=True``, a time schedule) is called as ``func(snap)`` for
  every scheduled time t the step crossed, with a `Snapshot` of the state at exactly t
  (field output, movie frames, the sweep's progress reports).

Snapshots are observers: the steps never land on their times (only ``time.t_end`` is landed on),
so a run's results do not depend on its output schedule. The state at a time t inside a step
from t0 to t1 is the linear interpolation of the two step states,

    q(t) = (1 - theta) q(t0) + theta q(t1),   theta = (t - t0) / (t1 - t0),

made on the device in a spare slot of the operator. Accuracy: where the solution is smooth in
time the error is at most theta (1 - theta) dt^2 / 2 max|q_tt| <= dt^2 / 8 max|q_tt|, second
order in dt like the steppers themselves; a front moving at speed a is drawn as the average of
two fronts a dt apart: a quarter of a cell with RKC at cfl = 1/4, below the scheme's own
resolution, half a cell at the sum rule's 1/2, but up to 4.5 cells with SSPRK(10,2), whose steps
are 9 Euler steps long (a fine movie wants a short-stepping stepper). Being a convex combination
it keeps h >= 0 and 0 <= phi <= 1, and the boundary budget is interpolated the same way, so the
mass balance of a snapshot holds to round-off. A time that coincides with the step's end (t_end,
always) is the step state itself, bit for bit.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from .errors import InputError
from .schedules import Schedule


@dataclass
class Snapshot:
    """The state of ``sim`` at time ``t``, held in operator slot ``slot`` until the next step.

    ``fields()``, ``conserved()`` and ``totals()`` read it like the simulation's own methods;
    `tiseg.render.FrameRenderer` draws it with ``to_numpy(state=snap)``. ``step``: steps
    taken when it was made (the step that crossed t included); ``theta``: where t lies in that
    step (1: the step state itself)."""

    sim: object
    t: float
    slot: int
    step: int
    theta: float

    def fields(self):
        return self.sim.fields(slot=self.slot)

    def conserved(self):
        return self.sim.conserved(slot=self.slot)

    def totals(self):
        return self.sim.totals(slot=self.slot)

    def budget(self):
        return self.sim.budget(slot=self.slot)


class Callback:
    """``func`` on ``schedule``; ``snapshot=True`` hands it a `Snapshot` at each scheduled
    time instead of the simulation after the step (needs a time schedule). ``order``: plain
    callbacks due after the same step run in increasing order (the checkpoint runs last, after
    everything it must agree with has been written). ``checked``: the guard checks the state
    first (checkpoints and snapshots: no broken state is ever saved)."""

    def __init__(
        self,
        func: Callable,
        schedule: Schedule,
        name: str | None = None,
        snapshot: bool = False,
        order: int = 0,
        checked: bool = False,
    ):
        if not callable(func):
            raise InputError(f"Callback: {func!r} is not callable")
        if not isinstance(schedule, Schedule):
            raise InputError(f"Callback: schedule {schedule!r} is not a tiseg.schedules schedule")
        if snapshot and not schedule.timed:
            raise InputError(
                f"Callback {name or func!r}: a snapshot callback needs a time "
                f"schedule (TimeInterval or SpecifiedTimes), not {schedule!r}"
            )
        self.func = func
        self.schedule = schedule
        self.name = name or getattr(func, "__name__", type(func).__name__)
        self.snapshot = bool(snapshot)
        self.order = int(order)
        # the state must pass the guard before this callback sees it (it saves the state)
        self.checked = bool(checked) or self.snapshot

    def __call__(self, arg):
        return self.func(arg)

    def __repr__(self):
        kind = "snapshot " if self.snapshot else ""
        return f"<{kind}callback {self.name!r} on {self.schedule!r}>"


class ProgressBar:
    """A tqdm bar over simulated time; as a plain callback it advances after every step."""

    def __init__(self, total: float, name: str, start: float = 0.0):
        from tqdm import tqdm

        from .log import bar_disable

        self.bar = tqdm(
            total=total,
            initial=start,
            unit="s",
            desc=name,
            disable=bar_disable(),
            bar_format=(
                "{desc}: {percentage:3.0f}%|{bar}| t={n:.3f}/{total:.3f} s "
                "[{elapsed}<{remaining}{postfix}]"
            ),
        )

    def __call__(self, sim) -> None:
        info = sim.last_step
        self.bar.update(info.t - self.bar.n)
        self.bar.set_postfix(
            steps=sim.stats.steps, stages=info.stages, dt=f"{info.dt:.2e}", refresh=False
        )

    def close(self) -> None:
        self.bar.close()


__all__ = ["Callback", "Snapshot", "ProgressBar"]
