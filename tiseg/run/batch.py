"""Ensemble members run together: one operator with a member axis, one launch a stage for all.

`Batch` holds M simulations of scenes that share their compiled options (grid, effects,
boundaries, numerics, precision) and differ in run-time numbers (an inflow seed, nu, a
friction constant, the slope, the inflow): one `TaichiOperator` with ``members=M`` and, for
each member, a `Simulation` whose operator is its view of it (`MemberOperator`). Each member
keeps everything a run has: its own time, step plan (dt and stage count from its own
stability numbers), callbacks, output folder, checkpoints, guards and peak fields. A step of
the batch is

1. the wet scan of every running member, one launch; each member then asks for the x range
   its step needs, and the batch sets their union;
2. the stability pass of every member, one launch; each member plans its step from its own
   numbers (`Simulation._plan_step`), which may widen its range;
3. the step of every running member with its own dt and stage count, one launch a stage
   (`Stepper.step_members`: a member with fewer RKC stages sits out the later ones);
4. the peak fields of every member in one launch (`PeakStore.update_members`), the guard
   scan of the members due a check in one (`GuardStore.scan_members`), then each member's
   time, statistics and callbacks (`Simulation._step_end`); the first member that asks for
   slot 0's totals (its diagnostics row, its mass check) takes every member's in one launch
   (`SharedSums`), and the last good states of the members that passed are copied in one
   launch after them (`GuardStore.flush`).

A member's steps, diagnostics and fields are bitwise those of the same member run alone
(tests/test_batch.py). A member that reaches its end time, or fails a guard, stops (its state
is no longer written) and the others go on; a failure is reported for that member only.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import InputError, TisegError
from ..solver.numerics.config import config_from_scene
from ..solver.numerics.operator import TaichiOperator
from ..solver.timestepping import stepper_for
from .guards import GuardStore
from .limits import check_memory
from .member_view import SharedSums
from .simulation import RunSession, Simulation, state_slots


def slots_of(scene) -> int:
    """The state slots a simulation of ``scene`` holds (`state_slots`)."""
    cfg = config_from_scene(scene)
    return state_slots(stepper_for(scene.numerics, is_1d=scene.is_1d, viscous=cfg.viscous))


def members_that_fit(scene, share: int = 1) -> int | None:
    """The most members of ``scene`` a batch can hold in 1/``share`` of the memory available
    now (None where unknown): what `tiseg sweep` gives a task at most by default."""
    from .limits import members_that_fit as fit

    layout = config_from_scene(scene).layout
    return fit(layout, slots_of(scene), scene.numerics.precision, share)


class Batch:
    def __init__(self, scenes, **kwargs):
        """The members of ``scenes`` (at least two, sharing their compiled options) on one
        operator; ``kwargs`` as `Simulation`'s (arch, precision, threads, ...)."""
        scenes = list(scenes)
        if len(scenes) < 2:
            raise InputError("a batch takes at least two scenes (run one alone as a Simulation)")
        # the first member's simulation fixes Taichi and the operator's options
        cfg = config_from_scene(scenes[0])
        nslots = slots_of(scenes[0])
        from .. import backend

        prec = kwargs.get("precision") or scenes[0].numerics.precision
        if not backend.is_initialised():
            backend.init(kwargs.get("arch") or "cpu", prec, kwargs.get("threads", 0))
        if backend.state().arch == "cpu":
            check_memory(cfg.layout, nslots, backend.state().precision, members=len(scenes))
        self.op = TaichiOperator(cfg, nslots=nslots, members=len(scenes))
        self.sims = [
            Simulation(sc, operator=self.op, member=e, **kwargs) for e, sc in enumerate(scenes)
        ]
        self.views = [sim.op for sim in self.sims]
        # slot 0's totals after a step: every member's in one launch (diagnostics rows, checks)
        self.sums = SharedSums(self.op)
        for view in self.views:
            view.shared_sums = self.sums
        # the guards of the members due a check after a step: one scan, one copy (GuardStore)
        self.guards = self.op.state.observer(GuardStore)
        self.guards.shared = True

    @classmethod
    def resume(cls, run_dirs, **kwargs) -> "Batch":
        """The batch of killed run folders, each member at its folder's last checkpoint (a
        batch member's or a single run's: they are the same); continue it with
        ``batch.run(out_dirs=run_dirs)``, which appends to each folder's files. The members
        must share their compiled options and precision; ``kwargs`` as `Simulation`'s."""
        from . import checkpoint as _ckpt

        run_dirs = [Path(d) for d in run_dirs]
        opened = [_ckpt.open_run_dir(d) for d in run_dirs]
        precisions = sorted({ck["precision"] for _, ck in opened})
        if len(precisions) > 1:
            raise InputError(
                f"Batch.resume: the checkpoints were written in {' and '.join(precisions)}; "
                "a batch runs in one precision"
            )
        batch = cls([scene for scene, _ in opened], precision=precisions[0], **kwargs)
        for sim, d, (_, ck) in zip(batch.sims, run_dirs, opened):
            sim._continue(d, ck)
        return batch

    def __len__(self) -> int:
        return len(self.sims)

    def run(self, out_dirs=None, on_output=None, **kwargs) -> list:
        """Run every member to its end time, each as `Simulation.run` would (``out_dirs``: a
        folder per member or None; ``on_output``: a snapshot callback per member or None;
        ``kwargs``: the other options of `Simulation.run`, for every member; no progress bar
        and no signal handlers by default). Returns, per member, its `RunStats`, or the
        `TisegError` that stopped it (a guard's `SimulationError`, ...): the others went on."""
        n = len(self.sims)
        out_dirs = list(out_dirs) if out_dirs is not None else [None] * n
        on_output = list(on_output) if on_output is not None else [None] * n
        if len(out_dirs) != n or len(on_output) != n:
            raise InputError(f"Batch.run: give one folder and one callback per member ({n})")
        folders = [Path(d).resolve() for d in out_dirs if d is not None]
        if len(set(folders)) < len(folders):
            same = next(str(d) for d in folders if folders.count(d) > 1)
            raise InputError(
                f"Batch.run: two members were given the folder {same!r}; each writes its own"
            )
        kwargs.setdefault("progress", False)
        sessions = [
            RunSession(sim, out_dirs[e], on_output=on_output[e], **kwargs)
            for e, sim in enumerate(self.sims)
        ]
        results: list = [None] * n
        live = [True] * n

        def stop(e: int, exc: Exception) -> None:
            results[e] = exc
            live[e] = False
            sessions[e].close()

        try:
            # the first check of each (RunSession.open) in one scan (a member whose state
            # its opening sets, a resumed one, scans alone)
            self.guards.scan_members(np.ones(n, dtype=np.int32))
            for e, session in enumerate(sessions):
                try:
                    session.open()
                except TisegError as exc:
                    stop(e, exc)
            while True:
                running = [live[e] and not sessions[e].done() for e in range(n)]
                if not any(running):
                    break
                for e, exc in self._step([s.t_end for s in sessions], running):
                    stop(e, exc)
            for e, session in enumerate(sessions):
                if live[e]:
                    try:
                        session.finish()
                        results[e] = self.sims[e].stats
                    except TisegError as exc:
                        results[e] = exc
        finally:
            for e, session in enumerate(sessions):
                if live[e]:
                    session.close()
        return results

    def _step(self, t_stops, running) -> list:
        """One step of every running member towards its stop time; returns (member, error)
        for the members that failed in it."""
        op, sims, views = self.op, self.sims, self.views
        idx = [e for e, r in enumerate(running) if r]
        failed = []
        self.guards.flush()  # the last good states kept since the last step, before it
        op.set_running(running)
        ts = np.array([sim.t for sim in sims])
        # 1. the wet scan of all, each member's range, their union
        if any(sims[e].active_region for e in idx):
            op.wet_extent(0, ts)
            extents = op.member_extents()
            for e in idx:
                views[e].extent = extents[e]
        ranges = {}
        for e in idx:
            ranges[e] = sims[e]._plan_range()
        self._set_union(idx)
        # 2. the stability pass of all, each member's plan
        op.stability(0, ts)
        numbers = op.member_stability()
        plans, pending = {}, {}
        for e in idx:
            views[e].numbers = numbers[e]
            try:
                plans[e] = sims[e]._plan_step(ranges[e], t_stops[e], None)
                pending[e] = sims[e]._step_begin(plans[e])
            except TisegError as exc:
                failed.append((e, exc))
            views[e].extent = views[e].numbers = None
        for e, _ in failed:
            running[e] = False
        idx = [e for e in idx if running[e]]
        if not idx:
            return failed
        self._set_union(idx)
        # 3. the step of all
        op.set_running(running)
        dt = np.zeros(len(sims))
        stages = [plans[idx[0]].stages] * len(sims)
        for e in idx:
            dt[e], stages[e] = plans[e].dt, plans[e].stages
        stepper = sims[idx[0]].stepper
        stepper.index = sims[idx[0]].stats.steps
        stepper.step_members(op, ts, dt, stages)
        op.state.changed()  # (the shared totals, budgets and guard scans taken before: stale)
        # 4. the peaks of all in one launch, the guard scan of those due a check in one, then
        # each member's time, statistics and callbacks
        observed = [e for e in idx if sims[e].peaks is not None]
        if observed:
            on = np.zeros(len(sims), dtype=np.int32)
            on[observed] = 1
            t_next = np.array([plans[e].t_next if on[e] else 0.0 for e in range(len(sims))])
            sims[observed[0]].peaks.store.update_members(t_next, on)
        due = [e for e in idx if sims[e].dispatch.guard_due(sims[e].stats.steps + 1, pending[e])]
        if len(due) > 1:
            on = np.zeros(len(sims), dtype=np.int32)
            on[due] = 1
            self.guards.scan_members(on)
        for e in idx:
            try:
                sims[e]._step_end(plans[e], pending[e], peaks_done=True)
            except TisegError as exc:
                failed.append((e, exc))
        self.guards.flush()
        return failed

    def _set_union(self, idx) -> None:
        """The batch's x ranges: the union of those the running members ``idx`` asked for
        (the whole interior where one of them has no active region)."""
        lay = self.op.lay
        whole = ((lay.gx, lay.gx + lay.nx), (lay.gx, lay.gx + lay.nx))
        wanted = [self.views[e].wanted if self.sims[e].active_region else whole for e in idx]
        wanted = [w for w in wanted if w is not None] or [whole]
        live = [w for w in wanted if w[0][1] > w[0][0]]
        if live:
            a, b = min(w[0][0] for w in live), max(w[0][1] for w in live)
        else:
            a = b = wanted[0][0][0]
        wa, wb = min(w[1][0] for w in wanted), max(w[1][1] for w in wanted)
        self.op.set_active(a, b, (min(wa, a), max(wb, b)))
