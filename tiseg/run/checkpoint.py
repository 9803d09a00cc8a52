"""Checkpoints: everything a run needs to continue bit for bit after it was killed.

File
----
``DIR/checkpoint.npz``, a NumPy ``.npz`` archive (read with ``numpy.load(path,
allow_pickle=False)``; no pickles, so loading a checkpoint runs no code). It holds:

============== =================================================================================
``q``          slot 0 of the operator, ghost cells included, shape (nc, NX, NY), in the run's
               precision (float64 or float32: the exact bits, nothing is rounded)
``budget``     the boundary budget of slot 0 (mass and small-particle mass that entered through
               the x and y faces, see ``TaichiOperator.budget``), same precision
``t``          simulated time [s] (float64)
``steps``      steps taken; ``stages``: operator evaluations; ``last_stages``: the stage count of
               the last step (it sets the margin of the active x range of the next step)
``wall``       wall time of the run so far [s] (the diagnostics column continues from it)
``initial``    [mass, small-particle mass] at t = 0 (for the mass balance)
``snapshots``  records of ``fields.nc`` written so far; ``diag_rows``: rows of
               ``diagnostics.csv`` (the t = 0 row included)
``next_sim``   simulated time of the next interval checkpoint (NaN when there is no interval)
``scene``      the resolved scene TOML (``Scene.to_toml()``), ``precision``, ``arch``,
               ``layout`` (nc, NX, NY), ``format`` = "tiseg-checkpoint", ``version`` = 1,
               ``tiseg_version``
``rest_mask``  only where resting regions are skipped (projected friction with a law with
               hysteresis): the rest mask of the last step, int8 (NX, NY), and ``ranges``, the
               active and the wet x range and whether an inflow ran when the mask was taken
               [a, b, wa, wb, on] (on: 1, 0, or -1 for no mask); a checkpoint without them
               resumes with the whole wet range (correct, but not bit for bit)
``peak_*``     only with ``output.peak_fields`` (`tiseg.run.peaks`): ``peak_h_max``,
               ``peak_speed_max`` and ``peak_arrival``, the running peaks of the interior cells
               (nx, ny) in the run's precision (arrival -1 where the flow has not come); a
               checkpoint without them resumes with peaks that start at its time (a warning)
============== =================================================================================

Nothing else is needed: the RKC stepper keeps no state between steps (every slot but 0 is
overwritten before it is read), the stage coefficients are a pure function of the stage count,
the inflow parameters are a function of t, and the active x range is recomputed from slot 0,
``last_stages`` and the rest mask at the start of each step. Restoring these numbers therefore
continues the run exactly as if it had not been interrupted (``tests/test_checkpoint.py`` checks bitwise
equality of fields and diagnostics in f64).

When
----
With an output folder, `tiseg.run.simulation.Simulation.run` writes a checkpoint
(`tiseg.run.run_folder`, a callback of the run loop)

* after a step that crossed an output time, right after the snapshots it made, once
  ``checkpoint_spacing`` seconds of wall time (default `DEFAULT_SPACING` = 10 s) have passed
  since the last checkpoint: a checkpoint costs the same however short the run, so a slow run
  spends a fixed small share of its time on them and a member of a few seconds none;
* if ``output.checkpoint_interval`` is set, also after the first step that ends at or past each
  multiple of that many seconds of *simulated* time;
* and after any step that ends more than ``checkpoint_wall`` seconds of *wall* time after the
  previous wall-clock checkpoint (default `DEFAULT_WALL_INTERVAL` = 300 s), so that a
  slow run with sparse output times loses at most a few minutes of work;
* and at the end of a run that stops before the scene's end time (`Simulation.run` with an
  earlier ``t_end``), so that a later run continues from there.

A checkpoint always holds a step state (the state at the end of a step), never a snapshot
interpolated to an output time; checkpoints never shorten a step, so a run's results do not
depend on when (or whether) it was checkpointed, and a resumed run takes exactly the steps of
an uninterrupted one. The checkpoint is removed when the run reaches the scene's end time: a
finished run has nothing to resume. (``next_sim`` is kept for the file format; the schedules
are recomputed from ``t`` on resume.)

Writing is atomic: the archive goes to a temporary file in the same folder, is flushed and
fsync'ed, then renamed over the previous checkpoint with ``os.replace``; a kill at any moment
leaves either the old or the new checkpoint, never a half-written one.

Resume
------
``tiseg run --resume DIR`` (or `Simulation.resume`) reads ``DIR/checkpoint.npz`` (whose
scene must agree with ``DIR/scene.toml``), restores the state, trims ``fields.nc`` and
``diagnostics.csv`` to what the checkpoint knows of (dropping anything written after it by the
killed run), and appends from there.
"""

from __future__ import annotations

from ..output.names import CHECKPOINT_FILE, DIAGNOSTICS_FILE, FIELDS_FILE, SCENE_FILE

import math
import zipfile
from pathlib import Path

import numpy as np

from ..errors import InputError, TisegError
from ..output.atomic import replacing
from .._version import __version__
from ..output import DiagnosticsWriter, write_text_atomic
from ..log import logger

CHECKPOINT_NAME = CHECKPOINT_FILE
FORMAT = "tiseg-checkpoint"
VERSION = 1
DEFAULT_WALL_INTERVAL = 300.0  # [s] of wall time between checkpoints at most (see above)
DEFAULT_SPACING = 10.0  # [s] of wall time at least between the checkpoints of output times


class CheckpointError(TisegError):
    """A checkpoint or run folder that cannot be resumed; the message says why."""


# =================================================================================================
# The file
# =================================================================================================
def write_npz_atomic(path, arrays: dict) -> Path:
    """Write ``arrays`` as an uncompressed .npz via a temporary file and ``os.replace``."""
    path = Path(path)
    with replacing(path) as tmp:
        with open(tmp, "wb") as fh:  # a file object: np.savez(name) would add ".npz"
            np.savez(fh, **arrays)
    return path


def state_arrays(
    sim,
    q: np.ndarray | None = None,
    budget: np.ndarray | None = None,
    meta: dict | None = None,
    **extra,
) -> dict:
    """The checkpoint dict of ``sim`` (its current state unless q/budget/meta are given)."""

    op = sim.op
    meta = dict(meta) if meta is not None else sim.checkpoint_meta()
    # the rest mask belongs to the current state only
    own = q is None
    rest = op.rest_state() if own else None
    q = op.get(0) if q is None else q
    budget = op.budget(0) if budget is None else budget
    d = {
        "format": np.array(FORMAT),
        "version": np.array(VERSION),
        "tiseg_version": np.array(__version__),
        "q": np.asarray(q).astype(op.np_fp),
        "budget": np.asarray(budget).astype(op.np_fp),
        "t": np.array(float(meta["t"])),
        "steps": np.array(int(meta["steps"])),
        "stages": np.array(int(meta["stages"])),
        "last_stages": np.array(int(meta["last_stages"])),
        "wall": np.array(float(meta.get("wall", 0.0))),
        "initial": np.array([meta["initial_mass"], meta["initial_small_mass"]], dtype=float),
        "snapshots": np.array(int(meta.get("snapshots", 0))),
        "diag_rows": np.array(int(meta.get("diag_rows", 0))),
        "next_sim": np.array(float(meta.get("next_sim", math.nan))),
        "scene": np.array(sim.scene.to_toml()),
        "precision": np.array(sim.backend.precision),
        "arch": np.array(sim.backend.arch),
        "layout": np.array([op.nc, op.NX, op.NY]),
    }
    if rest is not None:
        d.update(rest)
    if own and sim.peaks is not None:  # (they too belong to the current state only)
        d.update(sim.peaks.state())
    for k, v in extra.items():
        d[k] = np.asarray(v)
    return d


def save(path, sim, **meta_updates) -> Path:
    """Write the current state of ``sim`` as a checkpoint (atomically)."""
    meta = sim.checkpoint_meta()
    meta.update(meta_updates)
    return write_npz_atomic(path, state_arrays(sim, meta=meta))


def load(path) -> dict:
    """Read and check a checkpoint; plain Python values for the scalars."""
    path = Path(path)
    try:
        with np.load(path, allow_pickle=False) as z:
            data = {k: z[k] for k in z.files}
    except FileNotFoundError:
        raise CheckpointError(f"no checkpoint {str(path)!r}") from None
    except (OSError, ValueError, EOFError, KeyError, zipfile.BadZipFile) as exc:
        raise CheckpointError(f"{str(path)!r} is not a readable checkpoint ({exc})") from None
    except MemoryError:  # a damaged header claiming an enormous array
        raise CheckpointError(
            f"{str(path)!r} is not a readable checkpoint (an array header asks for more "
            "memory than there is: the file is damaged)"
        ) from None
    if str(data.get("format", "")) != FORMAT:
        raise CheckpointError(f"{str(path)!r} is not a tiseg checkpoint")
    try:
        version = int(data["version"])
    except (KeyError, TypeError, ValueError):
        raise CheckpointError(f"{str(path)!r} has no readable checkpoint version") from None
    if version != VERSION:
        raise CheckpointError(
            f"{str(path)!r} has checkpoint version {version}; this tiseg reads version {VERSION}"
        )
    out = {}
    for k, v in data.items():
        if v.ndim > 0:  # q, budget, initial, layout, saved fields
            out[k] = v
        elif v.dtype.kind == "U":
            out[k] = str(v)
        elif v.dtype.kind in "iu":
            out[k] = int(v)
        elif v.dtype.kind in "fb":
            out[k] = float(v)
        else:  # complex, bytes, ...: nothing tiseg writes
            raise CheckpointError(
                f"{str(path)!r}: {k} holds a {v.dtype} value, not a number: the file is damaged"
            )
    return out


REQUIRED = (
    "q",
    "budget",
    "t",
    "steps",
    "stages",
    "last_stages",
    "initial",
    "scene",
    "precision",
    "layout",
    "snapshots",
    "diag_rows",
    "wall",
)


def validate(ck: dict, scene, path="checkpoint") -> None:
    """CheckpointError unless ``ck`` is a whole, sane checkpoint of ``scene``: every key, a
    time within [0, t_end], finite state and counts, and the scene's layout."""
    missing = [k for k in REQUIRED if k not in ck]
    if missing:
        raise CheckpointError(f"{path} lacks {', '.join(missing)}: it is not a whole checkpoint")
    t = ck["t"]
    if not (isinstance(t, float) and math.isfinite(t) and 0.0 <= t <= scene.t_end * (1 + 1e-12)):
        raise CheckpointError(
            f"{path} is at t={t!r} s, outside [0, time.t_end={scene.t_end!r}]: "
            "it does not belong to this run"
        )
    for k in ("steps", "stages", "last_stages", "snapshots", "diag_rows"):
        if not (isinstance(ck[k], int) and ck[k] >= 0):
            raise CheckpointError(f"{path}: {k}={ck[k]!r} must be a count >= 0")
    if not (isinstance(ck["wall"], float) and math.isfinite(ck["wall"]) and ck["wall"] >= 0):
        raise CheckpointError(f"{path}: wall={ck['wall']!r} must be a time >= 0")
    if np.asarray(ck["initial"]).shape != (2,):
        raise CheckpointError(f"{path}: initial must hold the two initial masses")
    for k in ("q", "budget", "initial"):
        a = np.asarray(ck[k])
        if k == "initial" and not scene.segregation:
            a = a[:1]  # no small particles: their initial mass is NaN (StateArrays.totals)
        if a.dtype.kind not in "fiu" or not np.all(np.isfinite(a)):
            raise CheckpointError(
                f"{path}: {k} holds NaN, Inf or non-numbers: the state is "
                "damaged; start the run again"
            )
    if np.asarray(ck["q"]).ndim != 3 or np.asarray(ck["layout"]).shape != (3,):
        raise CheckpointError(f"{path}: the state has the wrong shape")


def restore(sim, ck: dict) -> None:
    """Put a loaded checkpoint into ``sim`` (same scene, layout and precision)."""
    op = sim.op
    shape = (op.nc, op.NX, op.NY)
    if tuple(int(n) for n in ck["layout"]) != shape or ck["q"].shape != shape:
        raise CheckpointError(
            f"checkpoint layout {tuple(ck['layout'])} does not match this scene's {shape}"
        )
    if ck["precision"] != sim.backend.precision:
        raise CheckpointError(
            f"checkpoint precision {ck['precision']} differs from the run's "
            f"{sim.backend.precision}: resume in {ck['precision']}"
        )
    op.set(0, ck["q"])
    op.reset_budget(ck["budget"])
    sim.restore_meta(ck)
    if "rest_mask" in ck and "ranges" in ck:  # resting regions skipped as the run did
        if np.asarray(ck["rest_mask"]).shape != (op.NX, op.NY) or np.shape(ck["ranges"]) != (5,):
            raise CheckpointError("the checkpoint's rest mask or ranges have the wrong shape")
        op.restore_rest_state(ck["rest_mask"], ck["ranges"])
    if sim.peaks is not None:
        _restore_peaks(sim, ck)
    # The state must pass the run's checks as it stands: a checkpoint damaged in a way that
    # leaves its numbers finite would otherwise fail the first check of the resumed run and be
    # reported as the run's own broken mass balance.
    steps = sim.stats.steps
    v = sim.guard.scan(sim.t, steps) or sim.guard.check_mass(
        sim.totals(), sim.initial_totals, sim.budget(), sim.t, steps
    )
    if v is not None:
        raise CheckpointError(
            f"{CHECKPOINT_NAME} is damaged: its state fails the checks of a run "
            f"({v.message()}); start the run again with --overwrite"
        )


def _restore_peaks(sim, ck: dict) -> None:
    """The peak fields of the checkpoint; without them (a checkpoint of a run that kept none)
    they start again from the checkpoint's state, and a warning says so."""
    try:
        if sim.peaks.restore(ck):
            return
    except ValueError as exc:
        raise CheckpointError(f"the checkpoint's peak fields are damaged ({exc})") from None
    logger.warning(
        "warning: the checkpoint holds no peak fields; h_max, speed_max and arrival_time "
        "start again at t=%.9g s",
        sim.t,
    )
    sim.peaks.start(sim.t)


# =================================================================================================
# Run folders
# =================================================================================================
def open_run_dir(run_dir) -> tuple[object, dict]:
    """(scene, checkpoint) of a run folder to resume; a clear error if it is not one."""
    from ..setup.scene import load_scene, scene_from_text

    d = Path(run_dir)
    if not d.is_dir():
        raise InputError(f"--resume {str(run_dir)!r}: no such folder")
    missing = [n for n in (SCENE_FILE, FIELDS_FILE, DIAGNOSTICS_FILE) if not (d / n).is_file()]
    if missing:
        raise InputError(
            f"--resume {str(run_dir)!r} is not a tiseg run folder (missing {', '.join(missing)})"
        )
    if not (d / CHECKPOINT_NAME).is_file():
        raise InputError(
            f"--resume {str(run_dir)!r}: the run has no {CHECKPOINT_NAME} (it "
            "finished, or was stopped before its first checkpoint); nothing to resume"
        )
    try:
        ck = load(d / CHECKPOINT_NAME)
    except CheckpointError as exc:
        raise InputError(f"--resume {str(run_dir)!r}: {exc}") from None
    if "scene" not in ck:
        raise InputError(
            f"--resume {str(run_dir)!r}: {CHECKPOINT_NAME} lacks scene: it is not "
            "a whole checkpoint"
        )
    try:
        saved = load_scene(str(d / SCENE_FILE))
        scene = scene_from_text(ck["scene"], name=saved.name, source=str(d / SCENE_FILE))
    except InputError as exc:
        raise InputError(f"--resume {str(run_dir)!r}: {exc}") from None
    if saved.to_dict() != scene.to_dict():
        raise InputError(
            f"--resume {str(run_dir)!r}: scene.toml was changed after the run "
            "started (it differs from the scene in the checkpoint); restore it"
        )
    try:
        validate(ck, scene, CHECKPOINT_NAME)
    except CheckpointError as exc:
        raise InputError(f"--resume {str(run_dir)!r}: {exc}") from None
    _check_fields_grid(d / FIELDS_FILE, scene, run_dir)
    return scene, ck


def _check_fields_grid(path: Path, scene, run_dir) -> None:
    """InputError when ``path`` holds fields on another grid than ``scene`` 's: it is not the
    run's file (found before anything runs; an unreadable file is left to the resume, which
    keeps it aside as damaged)."""
    import netCDF4

    try:
        with netCDF4.Dataset(path, "r") as ds:
            grid = (ds.dimensions["x"].size, ds.dimensions["y"].size)
    except (OSError, RuntimeError, KeyError):
        return
    if grid != (scene.domain.nx, scene.domain.ny):
        raise InputError(
            f"--resume {str(run_dir)!r}: fields.nc holds fields on a {grid[0]} x {grid[1]} "
            f"grid, the run's scene has {scene.domain.nx} x {scene.domain.ny} cells: it is "
            "not this run's fields file; put the run's own fields.nc back"
        )


def append_diagnostics(path, keep_rows: int, t: float | None = None, columns=None):
    """A diagnostics writer that continues ``path`` after its first ``keep_rows`` rows.

    Rows written after the checkpoint by the killed run (and a half-written last line) are
    dropped by rewriting the file atomically; new rows are appended to it. The rows the
    checkpoint knows of must be whole, and (with ``t``, the checkpoint's time) the last of
    them at time ``t``: a damaged, lost or repeated row among them is refused, naming the line,
    rather than repaired. Why refuse: dropping the bad row would shift every later row (the
    checkpoint counts rows), and cutting the file there would silently lose the rows after it;
    refused, the file stays as it is and can be mended by hand. ``columns``: those the run
    goes on writing (the diagnostics' by default; gauges.csv's for the gauges)."""
    import csv
    import io

    path = Path(path)
    try:
        with open(path, newline="", encoding="utf-8") as fh:
            rows = list(csv.reader(fh))
    except OSError as exc:
        raise CheckpointError(f"cannot read {str(path)!r}: {exc.strerror or exc}") from None
    except (UnicodeDecodeError, csv.Error) as exc:
        raise CheckpointError(
            f"{str(path)!r} is damaged ({exc}): it is not the UTF-8 CSV tiseg writes; "
            "restore it, or start the run again with --overwrite"
        ) from None
    if not rows:
        raise CheckpointError(f"{str(path)!r} has no header row")
    header = rows[0]
    # the columns the run goes on writing (or their old names, which the writer maps): a
    # renamed or lost one would fail the first row written, mid-run
    from ..output.diagnostics import ALIASES, DEFAULT_COLUMNS

    want = DEFAULT_COLUMNS if columns is None else tuple(columns)
    lost = [c for c in want if c not in header and ALIASES.get(c) not in header]
    if lost:
        raise CheckpointError(
            f"{str(path)!r}: its header has no column {', '.join(map(repr, lost))} (it reads "
            f"{','.join(header)[:80]!r}); restore the header, or start the run again with "
            "--overwrite"
        )
    body = rows[1 : keep_rows + 1]  # what follows was written after the checkpoint: it goes
    if len(body) < keep_rows or (body and not _whole_row(body[-1], header)):
        whole = sum(_whole_row(r, header) for r in body)
        raise CheckpointError(
            f"{str(path)!r} has {whole} complete rows, the checkpoint expects {keep_rows}"
        )
    bad = next((i for i, r in enumerate(body) if not _whole_row(r, header)), None)
    if bad is not None:
        raise CheckpointError(
            f"{str(path)!r} line {bad + 2} is damaged ({','.join(body[bad])[:40]!r} is not a "
            f"row of {len(header)} numbers); the checkpoint needs its first {keep_rows} rows: "
            "mend that line, or start the run again with --overwrite"
        )
    if body and "time" in header:
        times = [float(r[header.index("time")]) for r in body]
        back = next((i for i in range(1, len(times)) if not times[i] > times[i - 1]), None)
        if back is not None or (t is not None and times[-1] != t):
            where = (
                f"row {back + 1} repeats or goes back in time"
                if back is not None
                else f"row {keep_rows} is at t={times[-1]!r} s, the checkpoint at t={t!r} s"
            )
            raise CheckpointError(
                f"{str(path)!r}: {where}: rows were lost or repeated; restore the file, or "
                "start the run again with --overwrite"
            )
    buf = io.StringIO(newline="")
    csv.writer(buf).writerows([header] + body)
    write_text_atomic(path, buf.getvalue())  # keeps the file's permissions

    class _Appending(DiagnosticsWriter):
        """DiagnosticsWriter that opens for appending instead of writing a new header."""

        def __init__(self):
            self.path = path
            self.columns = tuple(header)
            self._fh = open(path, "a", newline="", encoding="utf-8")
            self._writer = csv.writer(self._fh)
            self.rows = keep_rows

    return _Appending()


def _whole_row(row: list, header: list) -> bool:
    """A row as tiseg writes it: one cell per column, each a number or empty."""
    if len(row) != len(header):
        return False
    try:
        for cell in row:
            if cell != "":
                float(cell)
    except ValueError:
        return False
    return True


__all__ = [
    "CHECKPOINT_NAME",
    "DEFAULT_WALL_INTERVAL",
    "CheckpointError",
    "save",
    "load",
    "restore",
    "validate",
    "state_arrays",
    "write_npz_atomic",
    "open_run_dir",
    "append_diagnostics",
]
