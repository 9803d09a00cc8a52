"""Benchmarks: what accuracy costs in time, and how fast the operator runs.

* `tiseg.bench.accuracy`: error against wall time on reference problems with known answers,
  over resolution x reconstruction x stepper x precision x backend, with the Pareto front
  (``tiseg bench accuracy``).
* `tiseg.bench.throughput`: cell-updates per second of the operator and steps per second,
  with each effect switched off in turn, against the NumPy reference and a memory-bandwidth bound
  measured in the same run; the cost of each effect (``tiseg bench throughput``).
* `tiseg.bench.steppers`: time-stepping error and cost of each stepper restarted from a
  run's own saved states, on its own grid (``tiseg bench steppers RUN_DIR``).

Taichi's precision is fixed when it is initialised, so every (precision, backend) combination is
measured in a child process of its own (`run_child`); this module holds the small pieces
both benchmarks share (machine description, backends, children).
"""

from __future__ import annotations

import datetime as _dt
import json
import os
import platform
import subprocess
import sys
from pathlib import Path

from ..errors import TisegError


def cpu_model() -> str:
    """The CPU's model name (``/proc/cpuinfo``, else ``platform.processor()``)."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.lower().startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def machine_info(threads: int = 0) -> dict:
    """Where a measurement was taken: CPU model, core count, thread count, versions, date.

    ``threads`` is what the run asked Taichi for (0 = Taichi's default, all cores)."""
    import numpy as np

    info = {
        "date": _dt.date.today().isoformat(),
        "cpu_model": cpu_model(),
        "cpu_count": os.cpu_count(),
        "threads": threads or os.cpu_count(),
        "machine": platform.machine(),
        "system": platform.platform(terse=True),
        "python": platform.python_version(),
        "numpy": np.__version__,
    }
    try:
        import importlib.metadata as md

        info["taichi"] = md.version("taichi")
        info["tiseg"] = md.version("tiseg")
    except Exception:  # pragma: no cover - metadata missing in odd installs
        pass
    # L3 size matters for reading bandwidth numbers (arrays that fit in it are not DRAM-bound)
    try:
        out = subprocess.run(["lscpu"], capture_output=True, text=True, timeout=5).stdout
        for line in out.splitlines():
            if line.strip().lower().startswith("l3 cache"):
                info["l3_cache"] = line.split(":", 1)[1].strip()
    except (OSError, subprocess.SubprocessError):
        pass
    return info


def machine_line(info: dict) -> str:
    """One line naming the machine, for tables and plot titles."""
    return (
        f"{info.get('cpu_model', '?')}, {info.get('cpu_count', '?')} cores, "
        f"{info.get('threads', '?')} threads, {info.get('date', '')}"
    )


def available_backends() -> list[str]:
    """["cpu"] plus "gpu" where a CUDA or Metal device really works (without initialising)."""
    from .. import backend
    import taichi as ti

    return ["cpu"] + (["gpu"] if backend._probe_gpu(ti) is not None else [])


def log_stderr(message: str) -> None:
    """Progress lines of the benchmarks: the ``tiseg`` logger (stderr, not with -q); stdout
    carries results and JSON. Without logging configured (a benchmark child) plain stderr."""
    from ..log import info, logger, stderr_line

    if logger.handlers:
        info(message)
    else:
        stderr_line(message)


def child_env(**extra) -> dict:
    """The environment of a benchmark's child process: Taichi offline and quiet, no display."""
    return dict(
        os.environ,
        TI_SKIP_VERSION_CHECK="ON",
        ENABLE_TAICHI_HEADER_PRINT="0",
        MPLBACKEND="Agg",
        **extra,
    )


def run_child(module: str, task: dict, work_dir: Path, tag: str) -> dict:
    """Run ``python -m module --child TASK.json`` and return the JSON it wrote.

    The child's stderr (progress lines) passes straight through; its result goes to a file so
    that Taichi's own output on stdout cannot corrupt it."""
    work_dir.mkdir(parents=True, exist_ok=True)
    task_path = work_dir / f"task-{tag}.json"
    result_path = work_dir / f"result-{tag}.json"
    task = dict(task, result=str(result_path))
    task_path.write_text(json.dumps(task))
    if result_path.exists():
        result_path.unlink()
    env = child_env()
    proc = subprocess.run(
        [sys.executable, "-m", module, "--child", str(task_path)],
        stdout=subprocess.DEVNULL,
        env=env,
    )
    if proc.returncode != 0 or not result_path.exists():
        raise TisegError(
            f"benchmark child {tag} ({module}) failed with exit status "
            f"{proc.returncode}; see the messages above"
        )
    return json.loads(result_path.read_text())
