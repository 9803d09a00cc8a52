"""Parameter sweeps: many runs of one scene, on Dask, collected into one table.

A sweep file (TOML) names a base scene, overrides applied to every run and a grid of overrides
whose Cartesian product gives the runs::

    name = "grid-study"                    # optional; default: the file name without .toml
    description = "Figure 16: wavelength and elongation against the grid resolution"
    scene = "fingers"                      # built-in scene name, or a path (relative to this file)
    times = [2.5, 5.0, 7.5]                # optional: also tabulate the metrics at these times

    [set]                                  # overrides applied to every run (any scene key)
    "time.t_end" = 7.5
    output.interval = 0.25                 # dotted keys may be written bare or quoted

    [grid]                                 # each key takes a non-empty list; runs = product
    "domain.resolution" = [250, 375, 500]
    "flow.nu" = [0.005, 0.01]

Every run writes its own folder ``OUT/<run name>/`` (``scene.toml``, ``fields.nc``,
``diagnostics.csv`` as ``tiseg run`` does, ``fingers.json`` with the finger diagnostics of every
output time, and last the completion marker ``done.json``). The run name is built from the grid
values only (``resolution-250_nu-0.01``), so it is stable across re-runs and safe as a file name.

Why a completion marker: a sweep can take hours. ``done.json`` is written atomically after
everything else, so a folder with a marker is complete and is reused on the next invocation,
while a folder without one (an interrupted run) is simply run again. A folder is reused only if
the resolved scene stored in it (``scene.toml``, re-read with the current code) equals the scene
the sweep asks for now; if the sweep file changed so that the same folder name means a different
scene, the run is repeated.

Why validate everything first: a typo in the fifth of eight long runs must not surface after the
first four have run for an hour. :func:`load_sweep` builds and validates the scene of every
combination (and checks the tabulation times against each scene's output times) before anything
is submitted.

Why Dask: runs are independent, and the same code scales from a laptop (a
``LocalCluster(processes=True, threads_per_worker=1)``: one process per concurrent run, because
Taichi's runtime is per process) to an existing cluster (``scheduler=ADDRESS``). Each task
(:func:`execute_run`) re-initialises Taichi (:func:`tiseg.backend.init`, the only place ti.init is
called) with the thread count asked for, so that consecutive runs in one worker do not keep the
previous run's fields alive. Runs report progress as Dask worker events (topic
:data:`PROGRESS_TOPIC`), which reach the client without a shared file system; the run folders
themselves must however be on a file system the workers share with the client for re-runs to be
skipped and for the figures to be drawn.

The table ``OUT/sweep.csv`` has one row per run (grid order): the run name, the grid values,
status (done / reused / failed), grid size, the finger metrics at the final time and at the
extra ``times`` (``wavelength@7.5``), and the run costs (simulation wall time, task time, steps,
operator evaluations, cells). ``OUT/sweep.json`` holds the same plus every run's full time
series of the finger diagnostics and the sweep definition.

Ensembles: runs that differ only in ``inflow.seed`` (a grid key; see the scene's
``inflow.noise``) are realisations of one experiment. ``OUT/summary.csv`` has one row per
combination of the other grid keys, with ``n`` (finished runs) and, for each metric of
:data:`SUMMARY_METRICS` at the final time and at each extra time (``wavelength@7.5``),
``<metric>_mean``, ``<metric>_std`` (sample standard deviation, ddof = 1; empty for n < 2) and
``<metric>_n`` (runs where the metric is defined: a wavelength is undefined without fingers),
plus the mean wall time per run.

Finished runs keep their diagnostics in ``fingers.json`` with the version of the definitions
(:data:`tiseg.analysis.fingers.ANALYSIS_VERSION`); a reused run whose diagnostics are older is
analysed again from its ``fields.nc`` (seconds, not a re-run).
"""

from __future__ import annotations

import csv
import difflib
import hashlib
import io
import itertools
import json
import logging
import math
import os
import socket
import time as _time
import tomllib
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path
from typing import Any, Callable, Mapping

import tomli_w

from .errors import InputError, TisegError
from .backend import available_cores
from .log import stderr_line
from .paths import UNSAFE_CHARS, check_name, safe_name
from .scene import Scene, list_builtin_scenes, load_scene

SWEEP_KEYS = ("name", "description", "scene", "times", "set", "grid")
DONE_MARKER = "done.json"
FINGERS_FILE = "fingers.json"
PROGRESS_TOPIC = "tiseg-sweep-progress"
MAX_RUNS = 10_000  # a guard against a grid that multiplies out by mistake
MAX_NAME = 120  # longest run-folder name before it is shortened with a hash
MARKER_VERSION = 1

# Metrics tabulated at the final time and at each extra time (a subset of analyse_run's keys).
FINAL_METRICS = (
    "finger_count",
    "wavelength",
    "wavelength_spectral",
    "elongation",
    "x_front_max",
    "x_front_min",
    "front_speed",
    "max_channel_speed_over_u0",
    "channel_speed_over_u0",
    "channel_phi",
    "levee_speed_over_u0",
)
TIME_METRICS = (
    "finger_count",
    "wavelength",
    "wavelength_spectral",
    "elongation",
    "x_front_max",
    "x_front_min",
    "channel_speed_over_u0",
)
COST_COLUMNS = ("wall_s", "task_s", "steps", "rhs_evaluations", "cell_updates_per_s")
# Ensemble statistics (summary.csv): over the runs that differ only in these grid keys.
ENSEMBLE_KEYS = ("inflow.seed",)
SUMMARY_METRICS = (
    "finger_count",
    "wavelength",
    "wavelength_spectral",
    "elongation",
    "channel_speed_over_u0",
    "channel_phi",
    "levee_speed_over_u0",
)

log = logging.getLogger(__name__)


# =================================================================================================
# The sweep definition
# =================================================================================================
@dataclass(frozen=True)
class SweepRun:
    """One member of a sweep: its folder name, its grid values and its validated scene."""

    name: str
    values: dict  # grid key -> value for this run (grid order)
    overrides: dict  # fixed overrides and grid values, as applied to the base scene
    scene: Scene

    @property
    def cells(self) -> int:
        return self.scene.domain.nx * self.scene.domain.ny

    @property
    def cost(self) -> float:
        """Rough relative cost (cells x steps ~ cells x nx x t_end): longest runs start first."""
        return float(self.cells) * self.scene.domain.nx * self.scene.t_end


@dataclass(frozen=True)
class Sweep:
    """A validated sweep file (see the module docstring)."""

    name: str
    description: str
    source: str | None  # the sweep file
    scene: str  # base scene as resolved (built-in name or absolute path)
    fixed: dict  # dotted key -> value
    grid: dict  # dotted key -> list of values
    times: tuple[float, ...]
    runs: tuple[SweepRun, ...]

    def to_dict(self) -> dict:
        """The definition as plain data (for sweep.json)."""
        return {
            "name": self.name,
            "description": self.description,
            "source": self.source,
            "scene": self.scene,
            "set": self.fixed,
            "grid": self.grid,
            "times": list(self.times),
            "runs": [r.name for r in self.runs],
        }


def list_builtin_sweeps() -> list[str]:
    """Names of the sweeps shipped in the package (``tiseg/data/sweeps``)."""
    from .data import SWEEP_DIR, builtin_names

    return builtin_names(SWEEP_DIR)


def resolve_sweep_path(path) -> Path:
    """A sweep file's path: ``path`` itself, or the built-in sweep of that name (no '/' and no
    '.toml'), or the built-in an old ``assets/sweeps/<name>.toml`` path meant."""
    from .data import SWEEP_DIR, builtin_file

    return builtin_file(path, SWEEP_DIR, "sweep") or Path(str(path)).expanduser()


def load_sweep(
    path, extra_overrides: Mapping | None = None, grid_overrides: Mapping | None = None
) -> Sweep:
    """Read and strictly validate a sweep file, building the scene of every combination.

    ``extra_overrides`` (``{"section.key": value}``) are added to the file's ``[set]`` table
    (a key of the grid may not be given again); ``grid_overrides`` (``{"section.key": [values]}``)
    replace a grid axis of the file or add one (e.g. fewer resolutions for a quick look).
    Raises :class:`InputError` with one line naming the file, the key and what is allowed.
    """
    p = resolve_sweep_path(path)
    where = f"sweep file {str(p)!r}"
    try:
        data = tomllib.loads(p.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise InputError(f"{where} not found") from None
    except UnicodeDecodeError as exc:
        raise InputError(f"{where} is not UTF-8 text: {exc}") from None
    except OSError as exc:
        raise InputError(f"cannot read {where}: {exc.strerror or exc}") from None
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{where} is not valid TOML: {exc}") from None
    except RecursionError:
        raise InputError(f"{where} nests arrays or tables too deeply") from None
    return sweep_from_dict(
        data,
        default_name=p.stem,
        source=str(p),
        base_dir=p.parent,
        extra_overrides=extra_overrides,
        grid_overrides=grid_overrides,
    )


def sweep_from_dict(
    data: Mapping,
    default_name: str = "sweep",
    source: str | None = None,
    base_dir=None,
    extra_overrides: Mapping | None = None,
    grid_overrides: Mapping | None = None,
) -> Sweep:
    """Validate a sweep given as the dict a sweep file parses to (see :func:`load_sweep`)."""
    where = f"sweep file {source!r}" if source else "sweep"

    def fail(msg: str):
        raise InputError(f"{where}: {msg}")

    if not isinstance(data, Mapping):
        fail(f"expected a table of keys, got {type(data).__name__}")
    for key in data:
        if key not in SWEEP_KEYS:
            close = difflib.get_close_matches(str(key), SWEEP_KEYS, n=1)
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            fail(f"unknown key {key!r}{hint}; allowed keys: {', '.join(SWEEP_KEYS)}")

    if "name" in data:
        try:
            name = check_name(data["name"])
        except InputError as exc:
            fail(str(exc))
    else:
        name = safe_name(default_name, "sweep")
    description = data.get("description", "")
    if not isinstance(description, str):
        fail(f"description={description!r} must be a string")

    if "scene" not in data:
        fail(
            "the key 'scene' is required: a built-in scene name "
            f"({', '.join(list_builtin_scenes())}) or a path to a scene .toml file"
        )
    scene_ref = data["scene"]
    if not isinstance(scene_ref, str) or not scene_ref.strip():
        fail(f"scene={scene_ref!r} must be a built-in scene name or a path")
    scene_ref = _resolve_scene_ref(scene_ref, base_dir)

    fixed = _flatten(data.get("set", {}), "set", fail)
    grid = _flatten(data.get("grid", {}), "grid", fail)
    for key, values in (grid_overrides or {}).items():
        grid[key] = values  # replaces the file's axis, or makes a fixed value an axis
        fixed.pop(key, None)
    for key, value in (extra_overrides or {}).items():
        fixed[key] = value
    for key, values in grid.items():
        if not isinstance(values, list) or not values:
            fail(
                f"grid key {key!r} = {_show(values)}: give a non-empty list of values, "
                f"e.g. {key} = [a, b, c]"
            )
        canon = [_canonical(v) for v in values]
        dup = next((v for v, c in zip(values, canon) if canon.count(c) > 1), None)
        if dup is not None:
            fail(f"grid key {key!r} lists the value {_show(dup)} more than once")
        if key in fixed:
            fail(f"{key!r} is both in [set] and in [grid]; give it in one of them")
    n_runs = math.prod(len(v) for v in grid.values())
    if n_runs > MAX_RUNS:
        fail(f"the grid multiplies out to {n_runs} runs; at most {MAX_RUNS} are allowed")

    times = data.get("times", [])
    if not isinstance(times, list) or not all(
        isinstance(t, (int, float)) and not isinstance(t, bool) and math.isfinite(t) and t >= 0
        for t in times
    ):
        fail(f"times={_show(times)} must be a list of times >= 0 [s], e.g. times = [2.5, 5.0]")
    times = tuple(sorted({float(t) for t in times}))

    # Build and validate every combination before anything runs (see the module docstring).
    keys = list(grid)
    combos = [dict(zip(keys, vals)) for vals in itertools.product(*(grid[k] for k in keys))]
    names = _run_names(combos)
    runs = []
    for run_name, values in zip(names, combos):
        overrides = {**fixed, **values}
        label = f"run {run_name!r}" if values else "the base run"
        try:
            scene = load_scene(scene_ref, overrides)
        except InputError as exc:
            problem = str(exc)
        else:
            problem = None
        if problem is not None:  # raised here, not inside except: one clean error
            fail(f"{label}: {problem}")
        for t in times:
            if t > scene.t_end * (1 + 1e-12):
                fail(f"{label}: times lists {t:g} s, after time.t_end = {scene.t_end:g} s")
            if time_index(scene.output_times, t) is None:
                fail(
                    f"{label}: times lists {t:g} s, which is not an output time of the scene; "
                    f"add it to output.times in [set]"
                )
        runs.append(SweepRun(run_name, values, overrides, scene))
    return Sweep(
        name=name,
        description=description,
        source=source,
        scene=scene_ref,
        fixed=fixed,
        grid=grid,
        times=times,
        runs=tuple(runs),
    )


def _resolve_scene_ref(ref: str, base_dir) -> str:
    """A built-in name stays a name; a path is taken relative to the sweep file's folder."""
    is_name = "/" not in ref and "\\" not in ref and not ref.endswith(".toml")
    if is_name or base_dir is None:
        return ref
    p = Path(ref).expanduser()
    if not p.is_absolute():
        p = Path(base_dir) / p
    return str(p.resolve())


def _flatten(table, section: str, fail) -> dict:
    """``{"domain": {"resolution": [..]}}`` -> ``{"domain.resolution": [..]}`` (leaf values)."""
    if not isinstance(table, Mapping):
        fail(f"[{section}] must be a table of 'section.key = value' entries, got {_show(table)}")
    out: dict[str, Any] = {}

    def walk(node, prefix):
        for k, v in node.items():
            key = f"{prefix}.{k}" if prefix else str(k)
            if isinstance(v, Mapping):
                if not v:
                    fail(f"[{section}] {key!r} is an empty table")
                walk(v, key)
            else:
                if "." not in key:
                    fail(
                        f"[{section}] key {key!r} must be a dotted scene key such as "
                        f"'domain.resolution' or 'flow.nu'"
                    )
                out[key] = v

    walk(table, "")
    return out


def _canonical(v) -> str:
    return json.dumps(v, sort_keys=True, default=str)


def _show(v) -> str:
    text = _canonical(v) if not isinstance(v, str) else repr(v)
    return text if len(text) <= 60 else text[:57] + "..."


def _format_value(v) -> str:
    """A grid value as part of a folder name: short, stable, file-system safe."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return format(v, ".12g")
    if isinstance(v, str):
        return UNSAFE_CHARS.sub("_", v).strip("_") or "_"
    if isinstance(v, list):
        return "+".join(_format_value(x) for x in v) or "empty"
    return hashlib.sha256(_canonical(v).encode()).hexdigest()[:8]


def _run_names(combos: list[dict]) -> list[str]:
    """Folder names from the grid values: ``resolution-250_nu-0.01``.

    A key is shown by its last part (``flow.nu`` -> ``nu``) unless two grid keys share it, then
    in full. Names that still collide (values equal after formatting) or are too long get a
    hash of the exact values appended, so every combination has its own stable folder.
    """
    if not combos or not combos[0]:
        return ["base"] * len(combos)
    keys = list(combos[0])
    last = [k.rsplit(".", 1)[-1] for k in keys]
    labels = {k: (s if last.count(s) == 1 else k) for k, s in zip(keys, last)}
    names = [
        "_".join(f"{UNSAFE_CHARS.sub('_', labels[k])}-{_format_value(v)}" for k, v in c.items())
        for c in combos
    ]
    out = []
    for name, c in zip(names, combos):
        if names.count(name) > 1 or len(name) > MAX_NAME:
            digest = hashlib.sha256(_canonical(c).encode()).hexdigest()[:8]
            name = f"{name[: MAX_NAME - 9]}-{digest}"
        out.append(name)
    return out


def scene_fingerprint(scene: Scene) -> str:
    """sha256 of the resolved scene (without its source path): what a run folder computed."""
    return hashlib.sha256(tomli_w.dumps(scene.to_dict()).encode()).hexdigest()


# =================================================================================================
# One run (a Dask task)
# =================================================================================================
def read_marker(run_dir, scene: Scene | None = None) -> dict | None:
    """The completion record of a finished run folder, or None when it is absent or unreadable,
    when the run's fields.nc is gone, or (with ``scene``) when the folder's stored
    ``scene.toml`` is not that scene.

    Why compare scenes rather than a hash of their text: the stored scene is re-read with the
    current code, so a new scene key with a default (which does not change what was computed)
    does not invalidate finished runs, while any changed value does."""
    from .scene import scene_from_text

    run_dir = Path(run_dir)
    try:
        rec = json.loads((run_dir / DONE_MARKER).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if not isinstance(rec, dict) or rec.get("marker_version") != MARKER_VERSION:
        return None
    if not (run_dir / "fields.nc").is_file():  # the results are gone: not a finished run
        return None
    if scene is not None:
        try:
            stored = scene_from_text((run_dir / "scene.toml").read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, InputError):
            return None
        if stored != scene:
            return None
    return rec


def execute_run(spec: dict) -> dict:
    """Run one sweep member into ``spec["dir"]`` unless a valid completion marker is there.

    ``spec``: ``name``, ``dir``, ``scene_toml`` (the resolved scene), ``fingerprint`` (for the
    record), ``arch``, ``threads`` (Taichi CPU threads; 0 = all cores), ``report`` (send progress events).
    Returns the completion record (also stored as ``done.json``) with ``status`` "done", or the
    stored one with ``status`` "reused", or ``status`` "busy" when another process holds the
    member's folder (its lock is held from the check of the marker to the writing of a new
    one). Runs in a Dask worker or in the calling process.
    """
    from .scene import scene_from_text

    run_dir = Path(spec["dir"])
    scene = scene_from_text(spec["scene_toml"], name=spec.get("scene_name", "scene"))
    rec = read_marker(run_dir, scene)
    if rec is not None:  # checked again here: the worker's view counts
        return {**rec, "status": "reused"}
    from .paths import RunLock

    run_dir.mkdir(parents=True, exist_ok=True)
    lock = RunLock(run_dir)
    try:  # held from here to the marker: one writer only
        lock.acquire()
    except InputError:  # another worker (or an orphaned task) runs it now
        return {"name": spec["name"], "status": "busy", "holder": lock.holder()}
    try:
        return _execute_locked(spec, run_dir, scene)
    except TisegError as exc:  # a user mistake or a run that failed its guard: no retry, one line
        return {"name": spec["name"], "status": "failed", "error": f"{type(exc).__name__}: {exc}"}
    finally:
        lock.release()


def _execute_locked(spec: dict, run_dir: Path, scene) -> dict:
    """:func:`execute_run` once the member's folder is locked."""
    from . import backend
    from .analysis.fingers import analyse_run
    from .output import write_json_atomic
    from .output.manifest import record
    from .output.numbers import measured_all
    from .output.run_folder import check_fresh_folder
    from .simulation import Simulation

    rec = read_marker(run_dir, scene)
    if rec is not None:  # finished meanwhile by the holder we waited on
        return {**rec, "status": "reused"}
    # the member's own earlier output may be replaced, files that tiseg did not write may not
    check_fresh_folder(run_dir, bool(spec.get("overwrite")), replace_run=True)
    (run_dir / DONE_MARKER).unlink(missing_ok=True)  # a stale marker of another scene
    t0 = _time.perf_counter()
    # A fresh Taichi runtime per task: frees the fields of the worker's previous run.
    threads = spec.get("threads", 0)
    if threads is None:
        threads = _worker_threads()
    backend.init(spec.get("arch", "cpu"), scene.numerics.precision, int(threads), force=True)
    sim = Simulation(scene)
    report = _reporter(spec["name"], scene.t_end) if spec.get("report", True) else None
    stats = sim.run(
        out_dir=run_dir, progress=False, on_output=report, overwrite=True
    )  # its own folder, without a completion marker
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
        "t_end": sim.t,
        "wall_s": stats.wall,
        "task_s": _time.perf_counter() - t0,
        "steps": stats.steps,
        "rhs_evaluations": stats.stages,
        "cell_updates_per_s": nx * ny * stats.stages / max(stats.wall, 1e-12),
        "metrics": _record_metrics(metrics),
    }
    rec = measured_all(rec)
    write_json_atomic(run_dir / DONE_MARKER, rec)  # last: its presence means "complete"
    return {**rec, "status": "done"}


def _record_metrics(metrics: dict) -> dict:
    """What a completion record keeps of analyse_run's result: every per-time series."""
    from .analysis.fingers import ANALYSIS_VERSION, RUN_KEYS

    return {"analysis_version": ANALYSIS_VERSION, **{k: metrics[k] for k in RUN_KEYS}}


def refresh_metrics(run_dir, rec: dict) -> dict:
    """The completion record with finger diagnostics of the current definitions: a record of
    older ones is analysed again from the run's fields.nc, and fingers.json and done.json are
    rewritten (atomically). A run whose fields cannot be read keeps its old record."""
    from .analysis.fingers import ANALYSIS_VERSION, analyse_run
    from .output import write_json_atomic
    from .output.numbers import measured_all

    if (rec.get("metrics") or {}).get("analysis_version") == ANALYSIS_VERSION:
        return rec
    run_dir = Path(run_dir)
    try:
        metrics = measured_all(analyse_run(run_dir))
    except InputError as exc:
        log.warning("cannot analyse %s again: %s", run_dir, exc)
        return rec
    write_json_atomic(run_dir / FINGERS_FILE, metrics)
    rec = {**{k: v for k, v in rec.items() if k != "status"}, "metrics": _record_metrics(metrics)}
    write_json_atomic(run_dir / DONE_MARKER, rec)
    return rec


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
@dataclass
class SweepResult:
    out: Path
    table: Path
    records: list[dict]  # one per run, grid order; status done / reused / failed / busy

    def count(self, status: str) -> int:
        return sum(1 for r in self.records if r.get("status") == status)

    def as_dict(self) -> dict:
        """The summary ``tiseg sweep --json`` prints: folders, counts and one entry per run."""
        keep = (
            "name",
            "status",
            "error",
            "holder",
            "wall_s",
            "steps",
            "rhs_evaluations",
            "nx",
            "ny",
            "t_end",
        )
        runs = [{k: r[k] for k in keep if k in r} for r in self.records]
        counts = {}
        for r in self.records:
            counts[r.get("status", "?")] = counts.get(r.get("status", "?"), 0) + 1
        return {"out": str(self.out), "table": str(self.table), "counts": counts, "runs": runs}


SWEEP_OUTPUTS = ("sweep.json", "sweep.csv", "summary.csv")
# what makes two sweeps the same: the runs and what is tabulated (not the file's place or text)
SAME_SWEEP_KEYS = ("name", "scene", "set", "grid", "times")


def check_sweep_folder(sweep: Sweep, out) -> None:
    """Refuse an ``out`` that holds another sweep (its ``sweep.json`` defines other runs) or a
    table that no sweep.json of tiseg's accounts for: running there would replace the other
    sweep's table and, under shared folder names, its finished runs."""
    out = Path(out)
    if not out.is_dir():
        return
    present = [n for n in SWEEP_OUTPUTS if (out / n).exists()]
    if not present:
        return
    hint = "choose a new --out, or pass --overwrite to replace it"
    try:
        stored = json.loads((out / "sweep.json").read_text(encoding="utf-8"))["sweep"]
        theirs = {k: stored[k] for k in SAME_SWEEP_KEYS}
    except (OSError, UnicodeDecodeError, ValueError, KeyError, TypeError):
        raise InputError(
            f"--out {str(out)!r} holds {', '.join(present)} that no sweep of tiseg's wrote "
            f"there (no readable sweep.json); {hint}"
        ) from None
    from .output.diagnostics import json_clean

    # as sweep.json stores it (tuples as lists, non-finite numbers as null)
    ours = json.loads(json.dumps(json_clean({k: sweep.to_dict()[k] for k in SAME_SWEEP_KEYS})))
    if _canonical(theirs) != _canonical(ours):
        differ = [k for k in SAME_SWEEP_KEYS if _canonical(theirs[k]) != _canonical(ours[k])]
        raise InputError(
            f"--out {str(out)!r} holds another sweep ({theirs['name']!r}, its "
            f"{', '.join(differ)} differ from this one's); {hint}"
        )


def run_sweep(
    sweep: Sweep,
    out,
    *,
    scheduler: str | None = None,
    workers: int | None = None,
    threads_per_task: int | None = None,
    arch: str = "cpu",
    echo: Callable[[str], None] | None = stderr_line,
    progress_interval: float = 30.0,
    overwrite: bool = False,
) -> SweepResult:
    """Run every unfinished member of ``sweep`` on Dask and write ``OUT/sweep.csv``.

    ``scheduler``: address of an existing Dask scheduler (``tcp://host:8786``); default: a
    ``LocalCluster(processes=True, threads_per_worker=1, n_workers=workers)`` started and
    stopped here. ``workers``: local worker processes (default: as many as CPU cores, at most
    the number of runs). ``threads_per_task``: Taichi CPU threads per run (default: cores /
    workers locally, the worker's own thread count on a remote cluster). ``echo``: where
    progress lines go (default stderr; the command line: the ``tiseg`` logger; None: silent). ``progress_interval``: seconds between progress lines
    of one running run. ``overwrite``: write into an ``out`` that holds
    another sweep, and replace files that tiseg did not write in member folders (by default
    both are refused, see :func:`check_sweep_folder`).

    The local cluster starts its workers with multiprocessing's "spawn", which re-imports the
    calling script: call this from under ``if __name__ == "__main__":`` in a script.
    """
    out = Path(out)
    say = echo or (lambda _s: None)
    if workers is not None and workers < 1:
        raise InputError(f"--workers={workers}: must be at least 1")
    if threads_per_task is not None and threads_per_task < 0:
        raise InputError(f"--threads-per-task={threads_per_task}: must be >= 0 (0 = all cores)")
    if threads_per_task and scheduler is None:
        from .backend import threads_problem

        problem = threads_problem(threads_per_task, "--threads-per-task")
        if problem:
            raise InputError(problem)
    if not overwrite:
        check_sweep_folder(sweep, out)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"cannot create output folder {str(out)!r}: {exc.strerror}") from None

    records: dict[str, dict] = {}
    pending: list[SweepRun] = []
    for run in sweep.runs:
        rec = read_marker(out / run.name, run.scene)
        if rec is not None:
            rec = refresh_metrics(out / run.name, rec)
            records[run.name] = {**rec, "status": "reused"}
        else:
            pending.append(run)
    say(
        f"sweep {sweep.name!r}: {len(sweep.runs)} runs, {len(records)} already finished, "
        f"{len(pending)} to run; output in {out}/"
    )
    # written now and after every finished run (a partial table survives an interruption)
    table = _write_outputs(sweep, out, records)
    if pending:
        _run_on_dask(
            sweep,
            out,
            pending,
            records,
            scheduler,
            workers,
            threads_per_task,
            arch,
            say,
            progress_interval,
            overwrite=overwrite,
        )
    result = SweepResult(
        out, table, [records.get(r.name, {"name": r.name, "status": "missing"}) for r in sweep.runs]
    )
    say(
        f"sweep {sweep.name!r}: {result.count('done')} ran, {result.count('reused')} reused, "
        f"{result.count('failed')} failed; table {table}, ensembles "
        f"{table.parent / 'summary.csv'}"
    )
    return result


def _run_on_dask(
    sweep,
    out,
    pending,
    records,
    scheduler,
    workers,
    threads_per_task,
    arch,
    say,
    progress_interval,
    overwrite=False,
) -> None:
    try:
        from distributed import Client, LocalCluster, as_completed
    except ImportError:
        raise TisegError(
            "sweeps need Dask: pip install 'tiseg[sweep]' (dask[distributed])"
        ) from None
    cores = available_cores()
    cluster = None
    if scheduler:
        try:
            client = Client(scheduler, timeout="10s")
        except Exception as exc:  # OSError, TimeoutError, ValueError for a bad address...
            first = next((ln for ln in str(exc).splitlines() if ln.strip()), type(exc).__name__)
            raise InputError(
                f"cannot connect to the Dask scheduler at {scheduler!r}: "
                f"{first.strip()} (give an address like tcp://host:8786)"
            ) from None
        # None: each task takes as many threads as its worker runs (its --nthreads)
        threads = threads_per_task
        where = f"Dask scheduler {scheduler}"
    else:
        n = workers or max(1, min(cores, len(pending)))
        threads = max(1, cores // n) if threads_per_task is None else threads_per_task
        # processes=True: Taichi's runtime is per process, one run per worker at a time.
        # The scheduler always serves HTTP; ":0" picks a free port so that several sweeps
        # (or other Dask users) on one machine never collide on 8787.
        cluster = LocalCluster(
            n_workers=n,
            threads_per_worker=1,
            processes=True,
            dashboard_address=":0",
            silence_logs=logging.ERROR,
        )
        client = Client(cluster)
        where = f"local Dask cluster ({n} worker{'s' if n > 1 else ''} x 1 task)"
        say(f"Dask dashboard: {client.dashboard_link}")
    per = "the worker's" if threads is None else (threads or "all")
    say(
        f"running {len(pending)} runs on the {where}, {per} Taichi thread"
        f"{'' if threads == 1 else 's'} per run"
    )

    last_report: dict[str, float] = {}

    def on_progress(event) -> None:
        # event = (timestamp, msg); throttled per run so long sweeps stay readable
        msg = event[1] if isinstance(event, tuple) else event
        try:
            name, now = msg["run"], _time.monotonic()
            if now - last_report.get(name, -math.inf) < progress_interval:
                return
            last_report[name] = now
            say(
                f"  running {name}: t = {msg['t']:.2f} / {msg['t_end']:.2f} s "
                f"({100 * msg['t'] / msg['t_end']:.0f} %), {msg['steps']} steps, "
                f"{msg['wall']:.0f} s"
            )
        except Exception:
            pass

    futures = {}
    try:
        try:
            client.subscribe_topic(PROGRESS_TOPIC, on_progress)
        except Exception:  # older distributed: no events, only completion lines
            pass
        for run in sorted(pending, key=lambda r: -r.cost):  # longest first: better packing
            spec = {
                "name": run.name,
                "dir": str((out / run.name).resolve()),
                "scene_toml": run.scene.to_toml(),
                "scene_name": run.scene.name,
                "fingerprint": scene_fingerprint(run.scene),
                "arch": arch,
                "threads": threads,
                "report": True,
                "overwrite": overwrite,
            }
            # retries=1: a transient failure (a worker lost, ti.init briefly out of resources)
            # is tried once more; a run's own error fails again and is reported
            fut = client.submit(
                execute_run,
                spec,
                key=f"tiseg-{run.name}-{os.urandom(4).hex()}",
                pure=False,
                priority=int(run.cost // 1e6),
                retries=1,
            )
            futures[fut] = run
        done = 0
        for fut in as_completed(list(futures)):
            run = futures[fut]
            done += 1
            try:
                rec = fut.result()
            except Exception as exc:  # a failed run is reported, the others go on
                first = next((ln for ln in str(exc).splitlines() if ln.strip()), "")
                rec = {
                    "name": run.name,
                    "status": "failed",
                    "error": f"{type(exc).__name__}: {first.strip()}",
                }
            if rec.get("status") == "failed":
                say(f"[{done}/{len(futures)}] {run.name}: FAILED ({rec['error']})")
            else:
                say(f"[{done}/{len(futures)}] {run.name}: {_summary(rec)}")
            records[run.name] = rec
            _write_outputs(sweep, out, records)  # a partial table survives an interruption
    except BaseException:
        for fut in futures:
            fut.cancel()
        raise
    finally:
        try:
            client.unsubscribe_topic(PROGRESS_TOPIC)
        except Exception:
            pass
        client.close()
        if cluster is not None:
            cluster.close()


def _summary(rec: dict) -> str:
    if rec.get("status") == "busy":
        return (
            f"skipped: another process is running it now ({rec.get('holder')}); "
            "run the sweep again when it has finished"
        )
    m = rec.get("metrics") or {}
    last = {
        k: (m.get(k) or [None])[-1] for k in ("time", "finger_count", "wavelength", "elongation")
    }
    wl = last["wavelength"]
    xl = last["elongation"]
    verb = "reused" if rec.get("status") == "reused" else "done"
    return (
        f"{verb} in {rec.get('wall_s', 0):.1f} s ({rec.get('steps')} steps, "
        f"{rec.get('rhs_evaluations')} operator evaluations); at t = {last['time']:g} s: "
        f"{last['finger_count']} fingers, wavelength "
        f"{'-' if wl is None else f'{100 * wl:.1f} cm'}, elongation "
        f"{'-' if xl is None else f'{xl:.3f} m'}"
    )


# =================================================================================================
# The table
# =================================================================================================
def table_columns(sweep: Sweep) -> list[str]:
    cols = ["run", *sweep.grid, "status", "nx", "ny", "cells", "dx", "t_final", *FINAL_METRICS]
    for t in sweep.times:
        cols += [f"{m}@{t:g}" for m in TIME_METRICS]
    return cols + [*COST_COLUMNS, "dir", "error"]


def table_rows(sweep: Sweep, records: Mapping[str, dict]) -> list[dict]:
    """One row per run (grid order) with the columns of :func:`table_columns`."""
    rows = []
    for run in sweep.runs:
        rec = records.get(run.name)
        row: dict[str, Any] = {
            "run": run.name,
            **{k: _cell(v) for k, v in run.values.items()},
            "status": "pending" if rec is None else rec.get("status"),
            "nx": run.scene.domain.nx,
            "ny": run.scene.domain.ny,
            "cells": run.cells,
            "dx": run.scene.dx,
            "dir": run.name,
        }
        if rec is not None:
            m = rec.get("metrics") or {}
            times = m.get("time") or []
            if times:
                row["t_final"] = times[-1]
                for k in FINAL_METRICS:
                    row[k] = (m.get(k) or [None])[-1]
            for t in sweep.times:
                i = time_index(times, t)
                for k in TIME_METRICS:
                    series = m.get(k) or []
                    row[f"{k}@{t:g}"] = series[i] if i is not None and i < len(series) else None
            for k in COST_COLUMNS:
                row[k] = rec.get(k)
            row["error"] = rec.get("error")
        rows.append(row)
    return rows


def summary_groups(sweep: Sweep) -> tuple[list[str], list[tuple[dict, list[SweepRun]]]]:
    """(the grid keys that tell ensembles apart, [(their values, the member runs), ...]) in grid
    order: runs that differ only in the keys of :data:`ENSEMBLE_KEYS` form one group."""
    keys = [k for k in sweep.grid if k not in ENSEMBLE_KEYS]
    groups: dict[str, tuple[dict, list]] = {}
    for run in sweep.runs:
        values = {k: run.values[k] for k in keys}
        groups.setdefault(_canonical(values), (values, []))[1].append(run)
    return keys, list(groups.values())


def summary_columns(sweep: Sweep) -> list[str]:
    keys, _ = summary_groups(sweep)
    names = list(SUMMARY_METRICS) + [
        f"{m}@{t:g}" for t in sweep.times for m in SUMMARY_METRICS if m in TIME_METRICS
    ]
    stats = [f"{m}_{s}" for m in names for s in ("mean", "std", "n")]
    return [*keys, "n", "runs", *stats, "wall_s_mean", "wall_s_std"]


def summary_rows(sweep: Sweep, records: Mapping[str, dict]) -> list[dict]:
    """One row per ensemble (see the module docstring): n, mean, sd and count of each metric."""
    import numpy as np

    keys, groups = summary_groups(sweep)
    by_run = {r["run"]: r for r in table_rows(sweep, records)}
    rows = []
    for values, runs in groups:
        done = [by_run[r.name] for r in runs if by_run[r.name]["status"] in ("done", "reused")]
        row: dict[str, Any] = {k: _cell(v) for k, v in values.items()}
        row["n"] = len(done)
        row["runs"] = " ".join(r["run"] for r in done)
        for col in [c[:-5] for c in summary_columns(sweep) if c.endswith("_mean")]:
            vals = np.array(
                [r[col] for r in done if isinstance(r.get(col), (int, float))], dtype=float
            )
            row[f"{col}_mean"] = float(vals.mean()) if vals.size else None
            row[f"{col}_std"] = float(vals.std(ddof=1)) if vals.size > 1 else None
            if col != "wall_s":
                row[f"{col}_n"] = int(vals.size)
        rows.append(row)
    return rows


def time_index(times, t) -> int | None:
    """Index of the output time equal to t (to 1e-9 relative), or None."""
    for i, s in enumerate(times):
        if abs(s - t) <= 1e-9 * max(1.0, t):
            return i
    return None


def _cell(v):
    return v if isinstance(v, (int, float, str)) else _canonical(v)


def _write_outputs(sweep: Sweep, out: Path, records: Mapping[str, dict]) -> Path:
    """Write sweep.csv (the table) and sweep.json (definition and full records) atomically."""
    from .output import write_json_atomic, write_text_atomic

    table = out / "sweep.csv"
    write_text_atomic(table, _csv_text(table_columns(sweep), table_rows(sweep, records)))
    write_text_atomic(
        out / "summary.csv", _csv_text(summary_columns(sweep), summary_rows(sweep, records))
    )
    write_json_atomic(
        out / "sweep.json",
        {
            "sweep": sweep.to_dict(),
            "runs": [
                {"run": r.name, "values": r.values, **records.get(r.name, {"status": "pending"})}
                for r in sweep.runs
            ],
        },
    )
    return table


def _csv_text(cols: list[str], rows: list[dict]) -> str:
    """CSV of rows under the header cols (missing and undefined values as empty cells)."""
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=cols, extrasaction="ignore", lineterminator="\n")
    w.writeheader()
    for row in rows:
        w.writerow({k: _csv_value(row.get(k)) for k in cols})
    return buf.getvalue()


def _csv_value(v) -> str:
    from .output.numbers import measured_text

    if v is None:
        return ""
    if isinstance(v, float):
        return "" if not math.isfinite(v) else measured_text(v)  # 12 significant digits
    return str(v)


def read_table(path) -> list[dict]:
    """Rows of a sweep.csv with numbers parsed (empty cells -> None)."""
    with open(path, newline="", encoding="utf-8") as fh:
        return [{k: _parse(v) for k, v in row.items()} for row in csv.DictReader(fh)]


def _parse(v: str):
    if v == "":
        return None
    for conv in (int, float):
        try:
            return conv(v)
        except ValueError:
            pass
    return v


__all__ = [
    "Sweep",
    "SweepRun",
    "SweepResult",
    "load_sweep",
    "sweep_from_dict",
    "run_sweep",
    "check_sweep_folder",
    "execute_run",
    "read_marker",
    "read_table",
    "refresh_metrics",
    "scene_fingerprint",
    "summary_columns",
    "summary_rows",
    "table_columns",
    "DONE_MARKER",
    "FINGERS_FILE",
]
