"""Small helpers shared by the sub-commands."""

from __future__ import annotations

import contextlib
import errno
import json
import math
import os
import sys
import tempfile
from pathlib import Path

from ...backend import ARCHS
from ...errors import InputError, RunInterrupted, TisegError
from ...model.material import Material
from ...model.physics.segregation import TRANSPORTS
from ...output.diagnostics import json_clean
from ...backend import threads_problem


def add_material_options(p) -> None:
    """Options overriding Table 1 (the defaults)."""
    g = p.add_argument_group("material (Table 1 by default)")
    g.add_argument("--zeta", type=float, default=None, metavar="DEG", help="slope angle [deg] (27)")
    g.add_argument("--alpha", type=float, default=None, help="shear-profile slip alpha (1/7)")
    g.add_argument(
        "--transport",
        choices=TRANSPORTS,
        default=None,
        help="transport function G: linear (2.17), the paper's, or bagnold (2.18) (linear)",
    )


def material_from_args(args) -> Material:
    m = Material()
    changes = {}
    if getattr(args, "zeta", None) is not None:
        changes["zeta_deg"] = args.zeta
    if getattr(args, "alpha", None) is not None:
        changes["alpha"] = args.alpha
    if getattr(args, "transport", None) is not None:
        changes["transport"] = args.transport
    return m.with_(**changes) if changes else m


def print_json(obj) -> None:
    json.dump(json_clean(obj), sys.stdout, indent=2)
    sys.stdout.write("\n")


def positive(name: str, value: float) -> float:
    if not (math.isfinite(value) and value > 0):
        raise InputError(f"--{name}={value!r} must be a positive number")
    return value


def check_threads(threads: int) -> None:
    """The --threads option of every command that runs kernels."""

    if threads < 0:
        raise InputError(f"--threads={threads}: must be >= 0 (0 = all cores)")
    problem = threads_problem(threads, "--threads")
    if problem:
        raise InputError(problem)


def stdout_for_json(as_json: bool):
    """Context for the work before a command prints JSON: Taichi greets on stdout when it
    starts, so anything printed meanwhile goes to stderr and stdout carries the JSON alone."""
    return contextlib.redirect_stdout(sys.stderr) if as_json else contextlib.nullcontext()


# ---- the options several commands share, each declared once -------------------------------------
ARCH_HELP = (
    "Taichi backend: cpu, gpu (CUDA/Metal; error if none), auto, or vulkan "
    "(software Vulkan where there is no GPU; default cpu)"
)


def add_overrides(p, help: str) -> None:
    """--set SECTION.KEY=VALUE (repeatable) into ``args.overrides``."""
    p.add_argument(
        "--set",
        dest="overrides",
        action="append",
        default=[],
        metavar="SECTION.KEY=VALUE",
        help=help,
    )


def add_out(p, help: str, default=None, required: bool = False) -> None:
    """--out DIR, the folder a command writes."""
    p.add_argument("--out", default=default, required=required, metavar="DIR", help=help)


def add_json(p, help: str = "print the summary as JSON") -> None:
    p.add_argument("--json", action="store_true", help=help)


def add_overwrite(p, help: str) -> None:
    p.add_argument("--overwrite", action="store_true", help=help)


def add_arch(p, help: str = ARCH_HELP) -> None:
    p.add_argument("--arch", choices=ARCHS, default="cpu", help=help)


def add_threads(p) -> None:
    p.add_argument("--threads", type=int, default=0, help="CPU threads (0 = all cores)")


def add_dask_options(p, runs: str) -> None:
    """Where the members of a sweep or a calibration run: --scheduler, --workers,
    --threads-per-task, --arch, --batch (``runs``: what a member is called in the help)."""
    p.add_argument(
        "--scheduler",
        default=None,
        metavar="ADDRESS",
        help="address of an existing Dask scheduler (e.g. tcp://host:8786); default: "
        "start a local cluster of worker processes",
    )
    p.add_argument(
        "--workers",
        type=int,
        default=None,
        metavar="N",
        help=f"local worker processes, i.e. {runs} at the same time (default: CPU "
        f"cores, at most the number of {runs})",
    )
    p.add_argument(
        "--threads-per-task",
        type=int,
        default=None,
        metavar="N",
        help="Taichi CPU threads per run (default: cores / workers locally; all "
        "cores on a remote cluster; 0 = all cores)",
    )
    add_arch(p, help="Taichi backend of each run (default cpu)")
    p.add_argument(
        "--batch",
        type=int,
        default=None,
        metavar="N",
        help=f"run up to N {runs} that share their compiled kernels (grid, effects, "
        "numerics) in one task, advanced together (one kernel launch a stage for all of "
        "them), each member's results bitwise those of a run alone; 1 runs each of the "
        f"{runs} in its own task; either way a worker pays Taichi's start-up and the "
        "kernels' compilation once. Default: enough tasks for two per worker, at most 16 "
        "members each; on a local cluster no more than fit in a worker's share of the free "
        "memory; on the CPU 1 for runs of more than 20,000 cells, where batching does not "
        "pay",
    )


def dask_options(args) -> dict:
    """The keyword arguments of `tiseg.apps.sweep.run_sweep` and
    `tiseg.apps.calibration.run_calibration` that `add_dask_options` and --overwrite give,
    with the closing results on stdout (kept by -q), or on stderr when stdout holds JSON."""
    from ...log import info

    return dict(
        scheduler=args.scheduler,
        workers=args.workers,
        threads_per_task=args.threads_per_task,
        arch=args.arch,
        batch=args.batch,
        echo=info,
        overwrite=args.overwrite,
        report=info if args.json else print,
    )


def add_scene_arguments(p, scene_optional: bool = False) -> None:
    """SCENE, --set, --arch, --precision, --threads: how every command that runs a scene picks it."""
    p.add_argument(
        "scene",
        nargs="?" if scene_optional else None,
        default=None,
        help="built-in scene name (e.g. fingers) or path to a TOML file",
    )
    add_overrides(p, "override a scene value, e.g. --set domain.resolution=250 (repeatable)")
    add_arch(p)
    p.add_argument(
        "--precision",
        choices=("f32", "f64"),
        default=None,
        help="floating-point precision (default: the scene's numerics.precision)",
    )
    add_threads(p)


def load_scene_args(args):
    """The scene named by SCENE, --set and --precision."""
    from ...setup.scene import load_scene

    overrides = list(args.overrides)
    if args.precision:
        overrides.append(f"numerics.precision={args.precision}")
    return load_scene(args.scene, overrides)


def check_output_folder(out: Path, what: str = "--out") -> None:
    """Refuse an output folder that cannot be created or written, before any work is done."""
    if out.exists() and not out.is_dir():
        raise InputError(f"{what}={str(out)!r} is a file, not a folder")
    try:
        out.mkdir(parents=True, exist_ok=True)
        fd, probe = tempfile.mkstemp(dir=out, prefix=".tiseg-write-test.")
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        raise InputError(
            f"{what}={str(out)!r}: cannot write there ({exc.strerror or exc})"
        ) from None


def check_figure_path(path: str, what: str = "--plot") -> Path:
    """A figure file name whose suffix matplotlib can write, in a folder that can be made."""
    from matplotlib.figure import Figure

    p = Path(path)
    kinds = Figure().canvas.get_supported_filetypes()
    suffix = p.suffix.lower().lstrip(".")
    if suffix not in kinds:
        raise InputError(
            f"{what}={path!r}: give a file name ending in one of "
            f".{', .'.join(sorted(kinds))} (e.g. .png or .pdf)"
        )
    check_output_folder(p.parent if str(p.parent) else Path("."), what)
    return p


@contextlib.contextmanager
def sigterm_stops(what: str, resume: str):
    """SIGTERM in the block raises `RunInterrupted` in the main thread, as Ctrl-C raises
    KeyboardInterrupt: the Dask tasks are cancelled, the cluster closed, a file being written
    atomically is removed, and the command ends in one line (exit 143) saying ``resume``.
    Without it the process died at once, in silence, leaving its half-written temporaries.
    Further SIGTERMs during that clean-up are ignored (SIGKILL still stops it)."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def stop(signum, frame):
        signal.signal(signal.SIGTERM, signal.SIG_IGN)  # once: let the clean-up finish
        raise RunInterrupted(f"{what} stopped by SIGTERM; {resume}", signum)

    old = signal.signal(signal.SIGTERM, stop)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, old)


# what an environment does to a writer (a full disk, a read-only mount, no permission, a file
# over its size limit, a failing device); any other OSError is a bug and keeps its traceback
WRITE_ERRNOS = frozenset(
    {errno.ENOSPC, errno.EDQUOT, errno.EROFS, errno.EACCES, errno.EPERM, errno.EFBIG, errno.EIO}
)


@contextlib.contextmanager
def results_written(out, kept: str):
    """An OSError of `WRITE_ERRNOS` in the block (a sweep or calibration writing its tables,
    its members' records) ends in one line naming the folder and the cause, then ``kept`` (what
    survives and how to go on), as `tiseg run` does, instead of a traceback."""
    try:
        yield
    except OSError as exc:
        if isinstance(exc, BrokenPipeError) or exc.errno not in WRITE_ERRNOS:
            raise
        name = f" ({Path(exc.filename).name})" if exc.filename else ""
        raise TisegError(
            f"cannot write in {str(out)!r}{name}: {exc.strerror or exc}; {kept}"
        ) from None
