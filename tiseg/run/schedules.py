"""When a callback runs: schedules in the style of Oceananigans.jl.

A schedule answers one question after every time step from t0 to t1: is the callback due? Time
schedules also name the scheduled times inside the step, so that a *snapshot* callback
(`tiseg.run.callbacks.Callback` with ``snapshot=True``) can be handed the state at each of
those times, interpolated between the two step states around it. Schedules never shorten a
step: the sequence of steps of a run does not depend on them.

* `TimeInterval` ``(dt)``: every multiple k dt of simulated time (k >= 1);
* `SpecifiedTimes` ``(times)``: the given simulated times;
* `IterationInterval` ``(n)``: after every step whose number is a multiple of n;
* `WallTimeInterval` ``(seconds)``: after the first step that ends at least that much
  wall time after the last firing (or after the start of the run);
* `AnyOf` ``(*schedules)``: due when one of them is;
* `WallSpaced` ``(schedule, seconds)``: when ``schedule`` is, but at least that much wall time
  after its last firing (or after the start of the run).

Every schedule depends on the simulation's (t, steps) alone, except the wall-time one; so a
resumed run fires the same callbacks at the same steps as an uninterrupted one.
"""

from __future__ import annotations

import bisect
import math
import time as _time
from typing import Iterable

from ..errors import InputError


class Schedule:
    """Base class: ``due(t0, t1, steps)`` after a step from t0 to t1 (steps: the count after it)."""

    #: whether `times_in` names the scheduled times (time schedules only)
    timed = False

    def start(self) -> None:
        """Called when a run starts (a wall-time schedule starts its clock)."""

    def due(self, t0: float, t1: float, steps: int) -> bool:
        raise NotImplementedError

    def times_in(self, t0: float, t1: float) -> list[float]:
        """Scheduled times t with t0 < t <= t1, increasing (time schedules)."""
        raise TypeError(f"{type(self).__name__} has no scheduled times")

    def contains(self, t: float) -> bool:
        """Whether t itself is a scheduled time (time schedules; the state at the start of a run)."""
        return False


class TimeInterval(Schedule):
    """Every ``interval`` seconds of simulated time: at t = k interval, k = 1, 2, ...

    The times are k * interval rounded to 12 significant digits (so 19 * 0.1 is 1.9, the time
    a user wrote, not 1.9000000000000001), as the scene's output times are.

    Asking whether a step is due costs the same however many multiples the step crosses (the
    first multiple past t0 is computed, not searched for). The schedule holds at most
    `MAX_MULTIPLES` multiples: beyond that the 12-digit times of successive multiples
    would no longer differ (the interval is lost in the time's rounding), so a time past
    ``MAX_MULTIPLES * interval`` is an `InputError`."""

    timed = True

    #: the largest k; 12-digit times resolve successive multiples with 1000-fold room
    MAX_MULTIPLES = 10**9

    def __init__(self, interval: float):
        if not (isinstance(interval, (int, float)) and math.isfinite(interval) and interval > 0):
            raise InputError(
                f"TimeInterval({interval!r}): the interval must be a positive number of seconds"
            )
        self.interval = float(interval)

    def _time(self, k: int) -> float:
        return float(f"{k * self.interval:.12g}")

    def _first_after(self, t: float) -> int:
        """The first k >= 1 whose time is past t (a step or two from t / interval)."""
        q = t / self.interval
        if not q < self.MAX_MULTIPLES:
            raise InputError(
                f"{self!r}: t={t:g} s is {q:.3g} intervals; at most {self.MAX_MULTIPLES:.0e} "
                "multiples are scheduled (the interval is too short for this time)"
            )
        k = max(1, math.floor(q))
        while self._time(k) <= t:
            k += 1
        return k

    def times_in(self, t0, t1):
        out = []
        k = self._first_after(t0)
        while self._time(k) <= t1:
            out.append(self._time(k))
            k += 1
        return out

    def due(self, t0, t1, steps):
        return self._time(self._first_after(t0)) <= t1

    def contains(self, t):
        q = t / self.interval
        if not q < self.MAX_MULTIPLES:
            return False
        k = round(q)
        return k >= 1 and self._time(k) == t

    def __repr__(self):
        return f"TimeInterval({self.interval!r})"


class SpecifiedTimes(Schedule):
    """At the given simulated times (sorted; duplicates merged)."""

    timed = True

    def __init__(self, times: Iterable[float]):
        ts = sorted({float(t) for t in times})
        if any(not math.isfinite(t) or t < 0 for t in ts):
            raise InputError(f"SpecifiedTimes: times must be finite and >= 0, got {ts!r}")
        self.times = tuple(ts)

    def times_in(self, t0, t1):
        return list(
            self.times[bisect.bisect_right(self.times, t0) : bisect.bisect_right(self.times, t1)]
        )

    def due(self, t0, t1, steps):
        return bisect.bisect_right(self.times, t0) < bisect.bisect_right(self.times, t1)

    def contains(self, t):
        return t in self.times

    def __repr__(self):
        return f"SpecifiedTimes({list(self.times)!r})"


class IterationInterval(Schedule):
    """After every step whose number (1, 2, ... counted from the start of the simulation) is a
    multiple of ``n``."""

    def __init__(self, n: int):
        if not (isinstance(n, int) and not isinstance(n, bool) and n >= 1):
            raise InputError(f"IterationInterval({n!r}): n must be an integer >= 1")
        self.n = n

    def due(self, t0, t1, steps):
        return steps % self.n == 0

    def __repr__(self):
        return f"IterationInterval({self.n})"


class WallTimeInterval(Schedule):
    """After the first step that ends at least ``seconds`` of wall time after the last firing
    (or after the start of the run)."""

    def __init__(self, seconds: float, clock=_time.perf_counter):
        if not (isinstance(seconds, (int, float)) and math.isfinite(seconds) and seconds >= 0):
            raise InputError(f"WallTimeInterval({seconds!r}): seconds must be a number >= 0")
        self.seconds = float(seconds)
        self.clock = clock
        self.last = clock()

    def start(self):
        self.last = self.clock()

    def due(self, t0, t1, steps):
        now = self.clock()
        if now - self.last >= self.seconds:
            self.last = now
            return True
        return False

    def __repr__(self):
        return f"WallTimeInterval({self.seconds!r})"


class AnyOf(Schedule):
    """Due when any of ``schedules`` is (each is asked, so every wall clock advances)."""

    def __init__(self, *schedules: Schedule):
        if not schedules or not all(isinstance(s, Schedule) for s in schedules):
            raise InputError("AnyOf needs one or more schedules")
        self.schedules = schedules

    def start(self):
        for s in self.schedules:
            s.start()

    def due(self, t0, t1, steps):
        return any([s.due(t0, t1, steps) for s in self.schedules])  # a list: ask them all

    def __repr__(self):
        return f"AnyOf({', '.join(map(repr, self.schedules))})"


class WallSpaced(Schedule):
    """Due when ``schedule`` is and at least ``seconds`` of wall time have passed since this
    schedule last fired (or since the start of the run): a writer that costs the same however
    short the run (a checkpoint) keeps a fixed share of a slow run's wall time and none of a
    fast one's. Not timed: it fires after the step, not at the inner schedule's times."""

    def __init__(self, schedule: Schedule, seconds: float, clock=_time.perf_counter):
        if not isinstance(schedule, Schedule):
            raise InputError(f"WallSpaced({schedule!r}): not a schedule")
        self.schedule = schedule
        # its clock, asked only when the inner schedule is due
        self.wall = WallTimeInterval(seconds, clock)

    def start(self):
        self.schedule.start()
        self.wall.start()

    def due(self, t0, t1, steps):
        return self.schedule.due(t0, t1, steps) and self.wall.due(t0, t1, steps)

    def __repr__(self):
        return f"WallSpaced({self.schedule!r}, {self.wall.seconds!r})"


__all__ = [
    "Schedule",
    "TimeInterval",
    "SpecifiedTimes",
    "IterationInterval",
    "WallTimeInterval",
    "AnyOf",
    "WallSpaced",
]
