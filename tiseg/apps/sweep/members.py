"""One run of a sweep: executed under its folder's lock, its done marker and its metrics."""

from __future__ import annotations

from ...output.names import FIELDS_FILE, SCENE_FILE

import hashlib
import logging
import json
import os
import socket
import time as _time
from datetime import datetime, timezone
from pathlib import Path
from typing import Callable

import tomli_w

from ...errors import InputError, TisegError
from ...backend import available_cores
from ...setup.scene import Scene
from .spec import DONE_MARKER, FINGERS_FILE, MARKER_VERSION, PROGRESS_TOPIC
from ...setup.scene import scene_from_text
from ...output.paths import RunLock
from ... import backend
from ...post.analysis.fingers import analyse_run
from ...output import write_json_atomic
from ...output.numbers import measured_all
from ...output.manifest import record
from ...run.run_folder import check_fresh_folder
from ...post.analysis.fingers import ANALYSIS_VERSION, RUN_KEYS
from ...post.analysis.deposit import DEPOSIT_KEYS

log = logging.getLogger(__name__)


def scene_fingerprint(scene: Scene) -> str:
    """sha256 of the resolved scene (without its source path): what a run folder computed."""
    return hashlib.sha256(tomli_w.dumps(scene.to_dict()).encode()).hexdigest()


# =================================================================================================
# One run (a Dask task)
# =================================================================================================
def fields_readable(path: Path, size: int | None = None) -> bool:
    """Whether a finished member's fields.nc is there and opens as NetCDF (its header), with
    ``size`` bytes when the completion record gives its size (truncated or replaced files
    differ). Why not a checksum: a resume would read every member's fields in full."""
    try:
        if not path.is_file() or (size is not None and path.stat().st_size != size):
            return False
        import netCDF4

        with netCDF4.Dataset(path, "r"):
            return True
    except (OSError, RuntimeError, ValueError):
        return False


def read_marker(run_dir, scene: Scene | None = None) -> dict | None:
    """The completion record of a finished run folder, or None when it is absent or unreadable,
    when the run's fields.nc is gone or does not open (or differs in size from the record's
    ``fields_bytes``), or (with ``scene``) when the folder's stored ``scene.toml`` is not that
    scene: such a member is run again, never reused.

    Why compare scenes rather than a hash of their text: the stored scene is re-read with the
    current code, so a new scene key with a default (which does not change what was computed)
    does not invalidate finished runs, while any changed value does."""

    run_dir = Path(run_dir)
    try:
        rec = json.loads((run_dir / DONE_MARKER).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if not isinstance(rec, dict) or rec.get("marker_version") != MARKER_VERSION:
        return None
    if not fields_readable(run_dir / FIELDS_FILE, rec.get("fields_bytes")):
        return None  # the results are gone or damaged: not a finished run, run it again
    if scene is not None:
        try:
            stored = scene_from_text((run_dir / SCENE_FILE).read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, InputError):
            return None
        if stored != scene:
            return None
    return rec


def check_member_folder(run_dir, scene: Scene, overwrite: bool, hint: str) -> None:
    """Refuse (`InputError`) a member folder that holds a finished run of another scene unless
    ``overwrite``: a sweep and a calibration (or two of either with other scenes) name their
    members after the values alone, so the same name in one --out may be another command's
    finished work. ``hint``: what to do instead, said after the reason."""
    if overwrite or read_marker(run_dir) is None or read_marker(run_dir, scene) is not None:
        return
    raise InputError(
        f"{str(run_dir)!r} holds a finished run of another scene (another sweep's or "
        f"calibration's member of the same name); {hint}"
    )


def compiled_fingerprint(scene: Scene) -> str:
    """sha256 of what a scene's kernels are compiled for: the values of the schema's compiled
    keys (grid, effects, boundaries, numerics, terrain, ...; `tiseg.setup.schema
    .compiled_keys`) and the precision. Members with the same one can run on one
    simulation, its parameters set anew for each (`execute_batch`)."""
    from ...setup.schema import compiled_keys
    from ...setup.sections import SECTIONS

    data = scene.to_dict()
    picked = {}
    for full in (*compiled_keys(SECTIONS), "numerics.precision", "domain.nx", "domain.ny"):
        section, key = full.split(".")
        picked[full] = (data.get(section) or {}).get(key)
    return hashlib.sha256(json.dumps(picked, sort_keys=True, default=str).encode()).hexdigest()


# The simulation of the last member this process ran with ``reuse`` (a Dask worker's, or the
# calling process's): the next such member compiled for the same kernels runs on it
# (`execute_run`); anything else frees it with a fresh Taichi runtime.
_LAST: dict = {}


def execute_batch(specs: list[dict], run: Callable[[dict], dict] | None = None) -> list[dict]:
    """Run sweep members (a Dask task of `tiseg sweep --batch`) in this process, each into
    its own folder as `execute_run` would. Members that share their compiled fingerprint
    advance together on one operator with a member axis (`tiseg.run.batch.Batch`: one
    launch a stage for all of them, each member bitwise as run alone; tests/test_batch.py);
    the Taichi start-up and the compilation are paid once. A member that fails is reported
    and the others go on. Returns the records, in the order of ``specs``. ``run``: the
    function that runs a member alone (`execute_run`), for the members that cannot join
    the others (a batch of one)."""
    run = execute_run if run is None else run
    if run is not execute_run or len(specs) < 2:
        return [run({**spec, "reuse": True}) for spec in specs]
    records: list = [None] * len(specs)
    held = []  # (index, spec, run dir, scene, lock, checkpoint) of the members to run
    try:
        for k, spec in enumerate(specs):
            rec, entry = _claim(spec)
            if rec is not None:
                records[k] = rec
            else:
                held.append((k, *entry))
        groups: dict = {}
        for item in held:
            groups.setdefault(compiled_fingerprint(item[3]), []).append(item)
        for group in groups.values():
            if len(group) == 1:
                k, spec, run_dir, scene, _, ck = group[0]
                records[k] = _guarded(spec, _execute_locked, spec, run_dir, scene, _LAST, ck)
                continue
            for k, rec in _run_together(group):
                records[k] = rec
    finally:
        for item in held:
            item[4].release()
    return records


def _claim(spec: dict):
    """A member's folder made ready and locked: (record, None) where it needs no run (reused,
    busy, or a folder it may not write), else (None, (spec, run dir, scene, lock, the
    member's own checkpoint or None))."""
    run_dir = Path(spec["dir"])
    scene = scene_from_text(spec["scene_toml"], name=spec.get("scene_name", "scene"))
    rec = read_marker(run_dir, scene)
    if rec is not None:  # checked again here: the worker's view counts
        return {**rec, "status": "reused"}, None
    run_dir.mkdir(parents=True, exist_ok=True)
    lock = RunLock(run_dir)
    try:  # held from here to the marker: one writer only
        lock.acquire()
    except InputError:  # another worker (or an orphaned task) runs it now
        return {"name": spec["name"], "status": "busy", "holder": lock.holder()}, None
    try:
        rec = read_marker(run_dir, scene)
        if rec is not None:  # finished meanwhile by the holder we waited on
            lock.release()
            return {**rec, "status": "reused"}, None
        # a finished run of another scene is replaced only with overwrite (the submitter
        # checked too; this is the worker's view, which counts); the member's own earlier
        # output may be replaced, files that tiseg did not write may not
        check_member_folder(
            run_dir, scene, bool(spec.get("overwrite")), "pass --overwrite to replace it"
        )
        check_fresh_folder(run_dir, bool(spec.get("overwrite")), replace_run=True)
        (run_dir / DONE_MARKER).unlink(missing_ok=True)  # a stale marker of another scene
    except Exception as exc:  # (a user's folder, or a full disk: the member fails, once)
        lock.release()
        return _failure(spec, exc), None
    return None, (spec, run_dir, scene, lock, own_checkpoint(run_dir, scene))


def own_checkpoint(run_dir: Path, scene: Scene) -> dict | None:
    """The checkpoint a killed sweep left in this member's folder, when it is this member's
    (the same scene, in the scene's precision) and whole; else None (the member starts
    afresh, replacing the folder's files)."""
    from ...run.checkpoint import CHECKPOINT_NAME, open_run_dir

    if not (run_dir / CHECKPOINT_NAME).is_file():
        return None
    try:
        saved, ck = open_run_dir(run_dir)
    except InputError as exc:
        log.warning("%s: not resumed (%s)", run_dir, exc)
        return None
    if saved != scene or ck["precision"] != scene.numerics.precision:
        return None
    return ck


def _resume_member(sim, run_dir: Path, ck: dict | None) -> float | None:
    """Put a member's own checkpoint into its simulation (`own_checkpoint`): the time it
    resumes from, or None where it starts afresh (no checkpoint, or one that fails the
    checks of a resume, which the simulation's reset then undoes)."""
    from ...run.checkpoint import CheckpointError

    if ck is None:
        return None
    try:
        sim._continue(run_dir, ck)
    except (CheckpointError, InputError) as exc:
        log.warning("%s: not resumed, run again from the start (%s)", run_dir, exc)
        sim.reset()
        return None
    log.info("%s: resumed from its checkpoint at t=%.6g s", run_dir, sim.t)
    return sim.t


def _run_together(group: list) -> list:
    """Run the locked members of ``group`` (sharing compiled kernels) as one batch; their
    (index, record)s."""
    specs = [item[1] for item in group]
    spec0 = specs[0]
    t0 = _time.perf_counter()
    try:
        batch = _batch_for([item[3] for item in group], spec0.get("arch", "cpu"), _threads(spec0))
        resumed = [_resume_member(sim, item[2], item[5]) for sim, item in zip(batch.sims, group)]
        reports = [
            _reporter(s["name"], item[3].t_end) if s.get("report", True) else None
            for s, item in zip(specs, group)
        ]
        results = batch.run(out_dirs=[item[2] for item in group], on_output=reports, overwrite=True)
    except Exception as exc:  # the batch as a whole failed: every member reports it
        _LAST.clear()  # (its state is not known: the next task starts afresh)
        failed = _failure(spec0, exc)
        return [(item[0], {**failed, "name": item[1]["name"]}) for item in group]
    out = []
    for (k, spec, run_dir, scene, *_), sim, res, t in zip(group, batch.sims, results, resumed):
        if isinstance(res, Exception):
            out.append((k, _failure(spec, res)))
            continue
        spec = {**spec, "batch_members": len(group), "resumed_at": t}
        out.append((k, _guarded(spec, _member_record, spec, run_dir, scene, sim, res, t0)))
    return out


def _batch_for(scenes: list, arch: str, threads: int):
    """A batch of ``scenes``: the process's last one (`_LAST`) where it was built for the
    same kernels, number of members and threads, else a new one (`_kept`)."""
    from ...run.batch import Batch

    key = ("batch", arch, threads, compiled_fingerprint(scenes[0]), len(scenes))
    return _kept(_LAST, key, scenes, arch, threads, lambda: Batch(scenes))


def _kept(cache: dict | None, key: tuple, scenes: list, arch: str, threads: int, build):
    """What ``cache`` holds for ``key`` (a member's `Simulation` or a `Batch`), each of its
    simulations given its scene of ``scenes`` and reset to its initial state (the state, the
    time, the budget, the peaks and the statistics), where it was built on the Taichi
    runtime alive now: a worker's next task of the same kernels, with no start-up and no
    kernels traced or loaded again. Else ``build()`` on a fresh Taichi runtime, which frees
    the fields of the worker's last run, kept in ``cache`` for the next (None: nowhere)."""
    alive = cache is not None and cache.get("generation") == backend.generation()
    if alive and cache.get("key") == key:
        held = cache["held"]
        for sim, scene in zip(getattr(held, "sims", [held]), scenes):
            sim.set_parameters(scene=scene)
            sim.reset()
        return held
    if cache is not None:
        cache.clear()
    precision = scenes[0].numerics.precision
    try:
        backend.init(arch, precision, threads, force=True)
    except (RuntimeError, OSError):  # a transient failure (resources briefly short): once more
        _time.sleep(1.0)
        backend.init(arch, precision, threads, force=True)
    held = build()
    if cache is not None:
        # (a Taichi runtime started since, by anyone, has freed its fields)
        cache.update(key=key, held=held, generation=backend.generation())
    return held


def _guarded(spec: dict, fn, *args) -> dict:
    """``fn(*args)``, a member's record, or its failure record."""
    try:
        return fn(*args)
    except Exception as exc:
        _LAST.clear()
        return _failure(spec, exc)


def _failure(spec: dict, exc: Exception) -> dict:
    """The record of a member that failed: one line for a user mistake or a guard, the
    traceback kept for anything else (a full disk, a bug)."""
    if isinstance(exc, TisegError):
        return {"name": spec["name"], "status": "failed", "error": f"{type(exc).__name__}: {exc}"}
    import traceback

    first = next((ln for ln in str(exc).splitlines() if ln.strip()), "").strip()
    return {
        "name": spec["name"],
        "status": "failed",
        "error": f"{type(exc).__name__}: {first}" if first else type(exc).__name__,
        "traceback": "".join(traceback.format_exception(exc)),
    }


def execute_run(spec: dict, cache: dict | None = None) -> dict:
    """Run one sweep member into ``spec["dir"]`` unless a valid completion marker is there.

    ``spec``: ``name``, ``dir``, ``scene_toml`` (the resolved scene), ``fingerprint`` (for the
    record), ``arch``, ``threads`` (Taichi CPU threads; 0 = all cores), ``report`` (send progress events).
    Returns the completion record (also stored as ``done.json``) with ``status`` "done", or the
    stored one with ``status`` "reused", or ``status`` "busy" when another process holds the
    member's folder (its lock is held from the check of the marker to the writing of a new
    one). Runs in a Dask worker or in the calling process. With ``spec["reuse"]`` the
    simulation of the process's previous such member is reused when it was compiled for this
    one (`execute_batch`; a calibration's points); ``cache``: another holder of it.
    """
    if cache is None and spec.get("reuse"):
        cache = _LAST
    rec, entry = _claim(spec)
    if rec is not None:  # reused, busy or refused
        return rec
    _, run_dir, scene, lock, ck = entry
    try:
        return _execute_locked(spec, run_dir, scene, cache, ck)
    except Exception as exc:
        # a user mistake or a run that failed its guard: no retry, one line; anything else
        # (a full disk, a bug) fails the member the same way, its traceback kept in the
        # record (sweep.json): raised, Dask would run it again to the same end
        if cache is not None:
            cache.clear()  # the next member starts on a fresh simulation
        return _failure(spec, exc)
    finally:
        lock.release()


def _execute_locked(
    spec: dict, run_dir: Path, scene, cache: dict | None = None, ck: dict | None = None
) -> dict:
    """`execute_run` once the member's folder is locked and ready (`_claim`); ``ck``: the
    member's own checkpoint to resume from (`own_checkpoint`)."""
    from ...run.simulation import Simulation

    t0 = _time.perf_counter()
    arch, threads = spec.get("arch", "cpu"), _threads(spec)
    key = (arch, threads, compiled_fingerprint(scene))
    sim = _kept(cache, key, [scene], arch, threads, lambda: Simulation(scene))
    spec = {**spec, "resumed_at": _resume_member(sim, run_dir, ck)}
    report = _reporter(spec["name"], scene.t_end) if spec.get("report", True) else None
    stats = sim.run(
        out_dir=run_dir, progress=False, on_output=report, overwrite=True
    )  # its own folder, without a completion marker
    return _member_record(spec, run_dir, scene, sim, stats, t0)


def _member_record(spec: dict, run_dir: Path, scene, sim, stats, t0: float) -> dict:
    """The finished member's metrics, fingers.json and completion record (done.json, written
    last): the same whether it ran alone or in a batch."""
    metrics = measured_all(analyse_run(run_dir))  # the digits that matter (output.numbers)
    record(run_dir, [FINGERS_FILE, DONE_MARKER])
    write_json_atomic(run_dir / FINGERS_FILE, metrics)
    nx, ny = scene.domain.nx, scene.domain.ny
    rec = {
        "marker_version": MARKER_VERSION,
        "name": spec["name"],
        "scene_sha256": spec["fingerprint"],
        "finished": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "host": socket.gethostname(),
        "pid": os.getpid(),
        "arch": sim.backend.arch,
        "precision": sim.backend.precision,
        "threads": sim.backend.threads,
        "nx": nx,
        "ny": ny,
        "cells": nx * ny,
        "dx": scene.dx,
        "fields_bytes": (run_dir / FIELDS_FILE).stat().st_size,  # checked when reused
        "t_end": sim.t,
        "wall_s": stats.wall,
        "task_s": _time.perf_counter() - t0,
        "steps": stats.steps,
        "rhs_evaluations": stats.stages,
        "cell_updates_per_s": nx * ny * stats.stages / max(stats.wall, 1e-12),
        "metrics": _record_metrics(metrics),
    }
    if spec.get("batch_members"):
        rec["batch_members"] = int(spec["batch_members"])  # advanced together with others
    if spec.get("resumed_at") is not None:
        rec["resumed_at"] = float(spec["resumed_at"])  # continued a killed sweep's checkpoint
    rec = measured_all(rec)
    write_json_atomic(run_dir / DONE_MARKER, rec)  # last: its presence means "complete"
    return {**rec, "status": "done"}


def _record_metrics(metrics: dict) -> dict:
    """What a completion record keeps of analyse_run's result: every per-time series and the
    deposit's numbers (run-out, thickness, ...; None where the flow did not come to rest)."""

    deposit = metrics.get("deposit") or {}
    return {
        "analysis_version": ANALYSIS_VERSION,
        **{k: metrics[k] for k in RUN_KEYS},
        "deposit": {k: deposit.get(k) for k in DEPOSIT_KEYS},
    }


def refresh_metrics(run_dir, rec: dict) -> dict:
    """The completion record with finger diagnostics of the current definitions: a record of
    older ones is analysed again from the run's fields.nc, and fingers.json and done.json are
    rewritten (atomically). A run whose fields cannot be read keeps its old record."""

    run_dir = Path(run_dir)
    if (rec.get("metrics") or {}).get("analysis_version") == ANALYSIS_VERSION:
        if "deposit" in rec["metrics"]:
            return rec
        # a record of before the deposit was kept: its numbers are in fingers.json
        try:
            stored = json.loads((run_dir / FINGERS_FILE).read_text(encoding="utf-8"))
        except (OSError, ValueError):
            return rec
        if stored.get("analysis_version") != ANALYSIS_VERSION or "deposit" not in stored:
            return rec
        rec = {
            **{k: v for k, v in rec.items() if k != "status"},
            "metrics": _record_metrics(stored),
        }
        write_json_atomic(run_dir / DONE_MARKER, rec)
        return rec
    try:
        metrics = measured_all(analyse_run(run_dir))
    except InputError as exc:
        log.warning("cannot analyse %s again: %s", run_dir, exc)
        return rec
    write_json_atomic(run_dir / FINGERS_FILE, metrics)
    rec = {**{k: v for k, v in rec.items() if k != "status"}, "metrics": _record_metrics(metrics)}
    write_json_atomic(run_dir / DONE_MARKER, rec)
    return rec


def _threads(spec: dict) -> int:
    """The Taichi threads of a member's task: ``spec["threads"]`` (0: all cores), None for
    its Dask worker's own count."""
    threads = spec.get("threads", 0)
    return int(_worker_threads() if threads is None else threads)


def _worker_threads() -> int:
    """The thread count of the Dask worker running this task (0 outside a worker)."""
    try:
        from distributed import get_worker

        w = get_worker()
        n = getattr(getattr(w, "state", None), "nthreads", None) or getattr(w, "nthreads", 0)
        return max(0, min(int(n), available_cores()))
    except (ImportError, ValueError):
        return 0


def _reporter(name: str, t_end: float) -> Callable | None:
    """A callback sending (run, t, steps, wall) to the client as a Dask worker event."""
    try:
        from distributed import get_worker

        worker = get_worker()
    except (ImportError, ValueError):
        return None  # not inside a Dask worker
    t0 = _time.perf_counter()

    def report(snap) -> None:
        try:
            worker.log_event(
                PROGRESS_TOPIC,
                {
                    "run": name,
                    "t": snap.t,
                    "t_end": t_end,
                    "steps": snap.step,
                    "wall": _time.perf_counter() - t0,
                },
            )
        except Exception:  # progress is best effort, never fails a run
            pass

    return report


# =================================================================================================
# The whole sweep
# =================================================================================================
