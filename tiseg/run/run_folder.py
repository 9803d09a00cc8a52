"""The files of one run folder, written by callbacks of the run loop.

``scene.toml`` (the resolved scene), ``fields.nc`` (snapshots at the output times, a snapshot
callback, and with them the peak fields of `tiseg.run.peaks`), ``diagnostics.csv`` with its units in ``diagnostics.csv-metadata.json`` (a row per
step), ``checkpoint.npz`` (step states, see `tiseg.run.checkpoint`) and ``failure/`` (the states
a guard failure saves). A resumed run appends to the files of its folder.

Safety (`tiseg.output.paths`): the folder is locked for as long as the run writes there (a
second writer is refused, naming the holder); no file is written through a symbolic link; a
fresh run refuses a folder that holds any file tiseg did not write there (whatever its name:
the manifest ``.tiseg-files.json`` lists what tiseg wrote, `tiseg.output.manifest`), and
a finished or unfinished run, unless ``overwrite`` (the command line's ``--overwrite``); a
resume checks, once it holds the lock, that the checkpoint it read is still the folder's, and
removes the temporary files a killed writer left behind.

Checkpoints hold the state at the end of a step, never an interpolated snapshot, so a resumed
run continues with exactly the steps of an uninterrupted one. They are written after a step
that crossed an output time (after its snapshots) once ``checkpoint_spacing`` seconds of wall
time have passed since the last one, after each multiple of ``output.checkpoint_interval``
seconds of simulated time, after any step that ends ``checkpoint_wall`` seconds of wall time
after the last checkpoint, and at the end of a run that stops before the scene's end. The peak
fields in fields.nc are written with each checkpoint and at the end of the run: they are
those of the checkpoint a resume starts from.
"""

from __future__ import annotations

from ..output.names import (
    DIAGNOSTICS_FILE,
    DONE_FILE,
    FAILURE_DIR,
    FIELDS_FILE,
    FINGERS_FILE,
    GAUGES_FILE,
    SCENE_FILE,
    UNITS_SUFFIX,
)

import contextlib
import functools
import math
from dataclasses import dataclass
from typing import Callable
from pathlib import Path

from . import checkpoint as _ckpt
from .callbacks import Callback
from ..errors import InputError, TisegError
from .limits import disk_note
from ..output.paths import HOLDER_NAME, LOCK_NAME, RunLock, refuse_symlinks
from .schedules import (
    AnyOf,
    IterationInterval,
    SpecifiedTimes,
    TimeInterval,
    WallSpaced,
    WallTimeInterval,
)
from ..output.diagnostics import (
    DiagnosticsWriter,
    write_gauge_units,
    write_text_atomic,
    write_units,
)
from ..output.manifest import MANIFEST_NAME, Manifest, record
from ..output.fields import peak_variables, snapshot_fields, static_fields, with_computed
from ..output.netcdf import FieldsFileError, FieldsWriter
from ..log import logger

DIAGNOSTICS = DIAGNOSTICS_FILE
GAUGES = GAUGES_FILE
# what a run folder writes there itself (listed in the manifest before the first of them)
WRITES = (
    SCENE_FILE,
    FIELDS_FILE,
    DIAGNOSTICS,
    DIAGNOSTICS + UNITS_SUFFIX,
    GAUGES,
    GAUGES + UNITS_SUFFIX,
    _ckpt.CHECKPOINT_NAME,
    FAILURE_DIR,
)
# what a run (and a sweep member, and the demo) writes into its folder: those, the finger
# diagnostics and completion marker of a sweep member, and the lock
RUN_FILES = WRITES + (FINGERS_FILE, DONE_FILE, LOCK_NAME, HOLDER_NAME)


# tiseg's by name: the run lock is taken before anything in the folder can be checked, and the
# manifest is the record of what tiseg wrote (hidden names no one else uses)
OWN_NAMES = (LOCK_NAME, HOLDER_NAME, MANIFEST_NAME)


def foreign_files(folder: Path, also=()) -> list[str]:
    """Entries of ``folder`` that tiseg did not write there: not in its manifest (every entry
    when there is none), not a lock or temporary file of tiseg's (``also``: more names allowed
    by name, for a caller that writes files of its own there)."""
    manifest = Manifest.read(folder)
    known = set(OWN_NAMES) | set(also) | (manifest.files if manifest else set())
    out = []
    try:
        entries = sorted(Path(folder).iterdir())
    except OSError as exc:
        raise InputError(
            f"cannot read output folder {str(folder)!r}: {exc.strerror or exc}"
        ) from None
    for p in entries:
        n = p.name
        if n in known or (manifest and n.startswith(".") and n.endswith(".tmp")):
            continue  # an atomic write of tiseg's that a kill interrupted
        out.append(n + ("/" if p.is_dir() else ""))
    return out


def check_fresh_folder(folder, overwrite: bool = False, also=(), replace_run: bool = False) -> None:
    """Refuse a folder for a fresh run when it holds files tiseg did not write there, or a run
    (finished or not), unless ``overwrite``. ``replace_run``: the folder's own earlier run may
    be replaced (a sweep member's), files that are not tiseg's still may not.

    A run that saved nothing (no checkpoint, not finished: its first writes failed) left only
    tiseg's partial output, which a new run replaces without ``overwrite``."""
    folder = Path(folder)
    if overwrite or not folder.is_dir():
        return
    if not replace_run and (folder / _ckpt.CHECKPOINT_NAME).is_file():
        raise InputError(
            f"output folder {str(folder)!r} holds an unfinished run "
            f"({_ckpt.CHECKPOINT_NAME}); continue it with `tiseg run --resume "
            f"{folder}`, or pass --overwrite to start over there"
        )
    other = foreign_files(folder, also)
    if other:
        shown = ", ".join(other[:5]) + (f" and {len(other) - 5} more" if len(other) > 5 else "")
        raise InputError(
            f"output folder {str(folder)!r} holds files that are not a tiseg "
            f"run's ({shown}); choose another folder, or pass --overwrite "
            "(overwrite=True) to write there anyway"
        )
    manifest = Manifest.read(folder)
    started_only = manifest is not None and not manifest.saved
    if (
        not replace_run
        and (folder / FIELDS_FILE).exists()
        and not (started_only and not (folder / FAILURE_DIR).exists())
    ):
        raise InputError(
            f"output folder {str(folder)!r} holds an earlier run; choose another "
            "folder, or pass --overwrite (overwrite=True) to replace it"
        )


def clear_earlier_run(folder: Path) -> None:
    """A fresh run replaces an earlier one whole: its checkpoint, completion marker, finger
    diagnostics and failure states go (a later --resume must never find them)."""
    import shutil

    for name in (_ckpt.CHECKPOINT_NAME, DONE_FILE, FINGERS_FILE):
        (Path(folder) / name).unlink(missing_ok=True)
    shutil.rmtree(Path(folder) / FAILURE_DIR, ignore_errors=True)


def remove_stale_temporaries(folder: Path) -> None:
    """Temporary files of atomic writes (``.<name>.*.tmp``) that a killed writer left."""
    for name in RUN_FILES:
        for p in Path(folder).glob(f".{name}.*.tmp"):
            try:
                p.unlink()
            except OSError:
                pass


@contextlib.contextmanager
def _signals_deferred():
    """SIGINT and SIGTERM that arrive in the block are held back and sent again when it ends
    (their own handlers act then). Python handlers, not a signal mask: the signal may reach any
    thread of the process (Taichi's), its Python handler always runs in the main thread."""
    import signal
    import threading

    sigs = (signal.SIGINT, signal.SIGTERM)
    if threading.current_thread() is not threading.main_thread() or any(
        signal.getsignal(sig) is None
        for sig in sigs  # a handler Python cannot put back
    ):
        yield
        return
    caught: list[int] = []
    old = {sig: signal.signal(sig, lambda signum, frame: caught.append(signum)) for sig in sigs}
    try:
        yield
    finally:
        for sig, handler in old.items():
            signal.signal(sig, handler)
        for sig in dict.fromkeys(caught):
            # to this thread (raise(3)), so its handler acts here, before the block's caller
            # goes on: os.kill may hand a process-wide signal to another (Taichi's) thread,
            # which a loaded machine can schedule after the caller has moved past
            signal.raise_signal(sig)


class OutputError(TisegError):
    """A file of the run could not be written; the message names it and how to go on."""


class RunFolder:
    """Open (or, with ``resume``, continue) the files of ``sim`` 's run in ``path``."""

    def __init__(self, sim, path, resume: dict | None = None, overwrite: bool = False):
        self.sim = sim
        self.path = out = Path(path)
        self.fields = self.diag = self.gauges = self.lock = None
        sc = sim.scene
        try:
            out.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise InputError(
                f"cannot create output folder {str(out)!r}: {exc.strerror or exc}"
            ) from None
        refuse_symlinks(out, RUN_FILES)
        refuse_symlinks(out / FAILURE_DIR, ("last_good.npz", "offending.npz"))
        self.lock = RunLock(out).acquire()
        try:
            if resume is None:
                check_fresh_folder(out, overwrite)
                disk_note(out, sc, sim.backend.precision, len(sc.output_times))
                clear_earlier_run(out)
            else:
                self._check_still_current()
                remove_stale_temporaries(out)
            self._open(resume)
        except BaseException:
            self.close()
            raise
        self.checkpoint_path = out / _ckpt.CHECKPOINT_NAME
        self.saved_t = sim.t if resume is not None else None  # the last checkpoint's time
        # wall seconds at least between the checkpoints of output times (Simulation.run)
        self.checkpoint_spacing = _ckpt.DEFAULT_SPACING
        sim.failure_dir = out / FAILURE_DIR
        self.counts()

    def _check_still_current(self) -> None:
        """Refuse to resume from a state the folder's run has left behind: the checkpoint was
        read before the lock was taken, and a run that held the lock meanwhile may have
        continued or finished it; appending from the old state would truncate its files and
        compute its steps again. Checked under the lock, before anything is written."""
        sim = self.sim
        try:
            ck = _ckpt.load(self.path / _ckpt.CHECKPOINT_NAME)
        except _ckpt.CheckpointError:
            ck = {}
        if ck.get("t") != sim.t or ck.get("steps") != sim.stats.steps:
            now = (
                f"it is now at t={ck['t']:.6g} s"
                if isinstance(ck.get("t"), float)
                else "it has no checkpoint now (it finished)"
            )
            raise InputError(
                f"the run in {str(self.path)!r} went on since this resume read its checkpoint "
                f"at t={sim.t:.6g} s ({now}): another process continued it; nothing was "
                "written here"
            )

    def _open(self, resume) -> None:
        out, sim, sc = self.path, self.sim, self.sim.scene
        try:
            # listed before they are written: a kill in between leaves no unlisted file
            record(out, WRITES, saved=resume is not None)  # a resumed run has saved
            if resume is None:
                write_text_atomic(out / SCENE_FILE, sc.to_toml())
                self.fields = self._new_fields_writer(out / FIELDS_FILE)
                self.diag = DiagnosticsWriter(out / DIAGNOSTICS)
                write_units(out / DIAGNOSTICS, self.diag.columns, one_d=sim.layout.is_1d)
                if sim.gauges is not None:
                    self.gauges = DiagnosticsWriter(out / GAUGES, columns=sim.gauges.columns())
                    write_gauge_units(out / GAUGES, self.gauges.columns)
            else:
                self.diag = _ckpt.append_diagnostics(
                    out / DIAGNOSTICS, resume["diag_rows"], t=sim.t
                )
                if sim.gauges is not None:  # a row per diagnostics row: cut back alike
                    self.gauges = _ckpt.append_diagnostics(
                        out / GAUGES, resume["diag_rows"], t=sim.t, columns=sim.gauges.columns()
                    )
                try:
                    self.fields = FieldsWriter.append(
                        out / FIELDS_FILE,
                        resume["snapshots"],
                        sim.t,
                        h_min=sc.numerics.h_min,
                        shape=(sc.domain.ny, sc.domain.nx),
                    )
                except FieldsFileError as exc:
                    self.fields = self._salvage_fields(exc)
                self._write_peaks()  # the checkpoint's: what the killed run wrote may be later
        except OSError as exc:
            raise InputError(
                f"cannot write to output folder {str(out)!r}: {exc.strerror or exc}"
            ) from None

    # ------------------------------------------------------------------ callbacks
    def callbacks(self, times, checkpoint_wall: float | None) -> list[Callback]:
        """A callback per registered writer (`RUN_WRITERS`) that this run has, on its schedule:
        by default fields at ``times`` (snapshots), a diagnostics row per step, gauges, and
        the checkpoint."""
        out = []
        for w in RUN_WRITERS.values():
            schedule = w.schedule(self, times, checkpoint_wall)
            if schedule is not None:
                out.append(
                    Callback(
                        functools.partial(w.write, self),
                        schedule,
                        name=w.name,
                        snapshot=w.snapshot,
                        order=w.order,
                        checked=w.checked,
                    )
                )
        return out

    def write_fields(self, snap) -> None:
        """The snapshot's variables: the state's primitive fields and those computed from them
        (`tiseg.output.fields`)."""
        with self._writing(self.fields.path):
            self.fields.write(snap.t, **with_computed(snap.fields(), self.fields.fields))
        self.counts()

    def _write_peaks(self) -> None:
        """The peak fields of the step state (tiseg.run.peaks) into fields.nc, if kept."""
        sim = self.sim
        if sim.peaks is not None:
            self.fields.write_static(sim.t, **sim.peak_fields())

    def write_diagnostics(self, sim) -> None:
        info = sim.last_step
        self._row(info.dt, info.stages, sim.last_stability.max_speed)

    def write_gauges(self, sim) -> None:
        """gauges.csv's row of the step state (tiseg.run.gauges)."""
        with self._writing(self.gauges.path):
            self.gauges.write(**sim.gauges.row(sim.t))

    def start(self) -> None:
        """The rows of the initial state (a fresh run only)."""
        if self.sim.stats.steps == 0:
            self._row(0.0, 0, float("nan"))
            if self.gauges is not None:
                self.write_gauges(self.sim)

    def _row(self, dt: float, stages: int, max_speed: float) -> None:
        sim = self.sim
        tot = sim.totals()
        with self._writing(self.diag.path):
            self.diag.write(
                time=sim.t,
                dt=dt,
                stages=stages,
                mass=tot["mass"],
                small_mass=tot["small_mass"],
                max_speed=max_speed,
                wall_time_cumulative=sim.wall_time(),
            )
        self.counts()

    def save_checkpoint(self, sim) -> None:
        self.counts()
        sim.stats.wall = sim.wall_time()
        interval = sim.scene.output.checkpoint_interval
        nxt = (math.floor(sim.t / interval * (1 + 1e-12)) + 1) * interval if interval else math.nan
        with self._writing(self.fields.path):
            self._write_peaks()  # (the checkpoint's peaks: what a resume starts from)
        with self._writing(self.checkpoint_path):
            _ckpt.save(self.checkpoint_path, sim, next_sim=nxt)
            if self.saved_t is None:  # the first: the folder now holds a run
                record(self.path, saved=True)
        self.saved_t = sim.t

    def finish(self) -> None:
        """The end of a run: at the scene's end time nothing is left to resume, so the
        checkpoint goes (the peak fields are written); before it the run's last state is
        checkpointed unless it is already (a later run continues from there)."""
        t_end = self.sim.scene.t_end
        if self.sim.t >= t_end - 1e-12 * max(1.0, t_end):
            with self._writing(self.fields.path):
                self._write_peaks()
            record(self.path, saved=True)
            self.checkpoint_path.unlink(missing_ok=True)
        elif self.saved_t != self.sim.t or not self.checkpoint_path.is_file():
            self.save_checkpoint(self.sim)

    @contextlib.contextmanager
    def _writing(self, path: Path):
        """A failed write (disk full, I/O error, permission) becomes one line naming the file
        and how to go on; the previous checkpoint is intact (written atomically)."""
        try:
            yield
        except (OSError, RuntimeError) as exc:  # netCDF4 reports HDF5 failures as these
            reason = getattr(exc, "strerror", None) or str(exc) or type(exc).__name__
            saved = self.saved_t
            hint = (
                f"the checkpoint at t={saved:.6g} s is intact: make room and continue with "
                f"`tiseg run --resume {self.path}`"
                if saved is not None
                else "no checkpoint was written yet: make room and run again"
            )
            raise OutputError(
                f"cannot write {str(path)!r} at t={self.sim.t:.6g} s: {reason}; {hint}"
            ) from None

    def resume_info(self) -> dict:
        """What `Simulation.run` needs to append to these files later (the last
        checkpoint is the current state: a run ends on a step that wrote one)."""
        return {
            "dir": self.path.resolve(),
            "snapshots": self.fields.count,
            "diag_rows": self.diag.rows,
            "wall": self.sim.stats.wall,
        }

    def counts(self) -> None:
        """Tell the simulation how much is written (the checkpoint records it)."""
        self.sim._io_counts = (
            self.fields.count if self.fields else 0,
            self.diag.rows if self.diag else 0,
        )

    def close(self) -> None:
        """Close the files and release the folder; SIGINT and SIGTERM wait until this is done
        (a signal in the middle would leave the lock's holder file behind)."""
        with _signals_deferred():
            self.counts()
            for w in (self.fields, self.diag, self.gauges):
                if w is not None:
                    try:
                        w.close()
                    except (OSError, RuntimeError):  # after a failed write: keep its message
                        pass
            if self.lock is not None:
                self.lock.release()
                self.lock = None

    # ------------------------------------------------------------------ fields.nc
    def _new_fields_writer(self, path: Path) -> FieldsWriter:
        sim = self.sim
        x, y = sim.scene.domain.cell_centres()
        w = FieldsWriter(
            path,
            x,
            y,
            attrs={
                "scene": sim.scene.to_toml(),
                "tiseg_arch": sim.backend.arch,
                "tiseg_precision": sim.backend.precision,
            },
            fields=snapshot_fields(sim.scene.fields),
            dtype=sim.scene.output.dtype(sim.backend.precision),
            h_min=sim.scene.numerics.h_min,
            significant_digits=sim.scene.output.significant_digits,
            static=peak_variables(sim.layout.segregation) if sim.peaks is not None else (),
        )
        try:  # the terrain's b and solid, once (a flat run has none: its file is as before)
            w.write_fixed(**static_fields(sim.scene))
        except BaseException:
            w.close()
            raise
        return w

    def _salvage_fields(self, exc: Exception) -> FieldsWriter:
        """Resume with a fields.nc that cannot be continued: keep it under another name and
        start a new one from the checkpoint on (the state itself is safe in the checkpoint)."""
        old = self.path / FIELDS_FILE
        n = 1
        while (self.path / f"fields.damaged-{n}.nc").exists():
            n += 1
        kept = self.path / f"fields.damaged-{n}.nc"
        record(self.path, [kept.name])
        if old.exists():
            old.replace(kept)

        logger.warning(
            "warning: %s; it was moved to %s and a new fields.nc starts at t=%.9g s",
            exc,
            kept.name,
            self.sim.t,
        )
        return self._new_fields_writer(old)


# ---- the writers of a run folder, each named and on its schedule -------------------------------
@dataclass(frozen=True)
class RunWriter:
    """A named writer of every run folder. ``schedule(folder, times, checkpoint_wall)``: its
    `tiseg.run.schedules` schedule for this run, or None where the run has nothing for it;
    ``write(folder, arg)``: what it writes, with ``arg`` a `Snapshot` at each scheduled time
    (``snapshot``) or the simulation after a step that fell due. ``order`` and ``checked`` as
    for a `Callback` (the checkpoint runs last, on a checked state)."""

    name: str
    schedule: Callable
    write: Callable
    snapshot: bool = False
    order: int = 0
    checked: bool = False


RUN_WRITERS: dict[str, RunWriter] = {}


def register_writer(writer: RunWriter) -> RunWriter:
    """Add (or replace) a writer of every run folder opened from now on."""
    RUN_WRITERS[writer.name] = writer
    return writer


def _checkpoint_schedule(folder: RunFolder, times, checkpoint_wall):
    """After a step that crossed an output time, ``folder.checkpoint_spacing`` seconds of wall
    time after the last, each checkpoint_interval of simulated time and each
    ``checkpoint_wall`` seconds of wall time."""
    when = [WallSpaced(SpecifiedTimes(times), folder.checkpoint_spacing)]
    interval = folder.sim.scene.output.checkpoint_interval
    if interval:
        when.append(TimeInterval(interval))
    if checkpoint_wall is not None:
        when.append(WallTimeInterval(checkpoint_wall))
    return AnyOf(*when)


for _w in (
    RunWriter(
        "fields",
        lambda f, times, wall: SpecifiedTimes(times),
        RunFolder.write_fields,
        snapshot=True,
    ),
    RunWriter(
        "diagnostics", lambda f, times, wall: IterationInterval(1), RunFolder.write_diagnostics
    ),
    RunWriter(
        "gauges",
        lambda f, times, wall: IterationInterval(1) if f.gauges is not None else None,
        RunFolder.write_gauges,
    ),
    RunWriter(
        "checkpoint", _checkpoint_schedule, RunFolder.save_checkpoint, order=100, checked=True
    ),
):
    register_writer(_w)
del _w


__all__ = [
    "RunFolder",
    "RunWriter",
    "RUN_WRITERS",
    "register_writer",
    "OutputError",
    "DIAGNOSTICS",
    "RUN_FILES",
    "check_fresh_folder",
]
