"""The only place Taichi is initialised: :func:`init` (arch, precision).

Taichi reads its floating-point type (``default_fp``) at initialisation, so precision is a
process-wide choice; calling :func:`init` again with other settings resets the Taichi runtime and
invalidates every field made before (simulations check :func:`generation` to refuse stale fields).
"""
from __future__ import annotations

import contextlib
import os
import sys
from dataclasses import dataclass

from .errors import InputError

# Keep Taichi quiet and offline (no version check over the network, no banner).
os.environ.setdefault("TI_SKIP_VERSION_CHECK", "ON")
os.environ.setdefault("ENABLE_TAICHI_HEADER_PRINT", "0")

ARCHS = ("cpu", "gpu", "auto")
PRECISIONS = ("f32", "f64")


@dataclass(frozen=True)
class BackendState:
    arch: str          # resolved: "cpu", "cuda" or "metal"
    precision: str     # "f32" or "f64"
    threads: int       # CPU threads Taichi may use (0 = Taichi's default)
    generation: int    # increases with every (re)initialisation


_state: BackendState | None = None


def init(arch: str = "cpu", precision: str = "f64", threads: int = 0, debug: bool = False,
         force: bool = False) -> BackendState:
    """Initialise Taichi once for this process.

    arch: "cpu", "gpu" (CUDA or Metal; an error when there is none) or "auto" (GPU if present).
    precision: "f64" (default, needed for round-off-level tests) or "f32".
    threads: CPU thread count (0 = all cores).
    Calling again with the same settings is a no-op; other settings re-initialise Taichi.
    """
    global _state
    if arch not in ARCHS:
        raise InputError(f"arch={arch!r} is not allowed; choose one of {', '.join(ARCHS)}")
    if precision not in PRECISIONS:
        raise InputError(f"precision={precision!r} is not allowed; choose f32 or f64")
    if not isinstance(threads, int) or threads < 0:
        raise InputError(f"threads={threads!r} must be a non-negative integer")
    if (_state is not None and not force and _state.precision == precision
            and _state.threads == threads
            and (arch == "auto" or _requested_matches(arch, _state.arch))):
        return _state

    import taichi as ti

    if arch == "cpu":
        ti_arch = ti.cpu
    else:
        ti_arch = _probe_gpu(ti)
        if ti_arch is None:
            if arch == "gpu":
                raise InputError("arch='gpu' was asked for but no CUDA or Metal GPU is available "
                                 "here; use --arch cpu (or auto)")
            ti_arch = ti.cpu
    kwargs = dict(arch=ti_arch, default_fp=ti.f64 if precision == "f64" else ti.f32,
                  fast_math=False, debug=debug, offline_cache=True, log_level=ti.WARN)
    if threads and ti_arch == ti.cpu:
        kwargs["cpu_max_num_threads"] = threads
    # Taichi prints "[Taichi] Starting on arch=..." on stdout; keep stdout for results (JSON)
    with contextlib.redirect_stdout(sys.stderr):
        ti.init(**kwargs)
    resolved = {ti.cpu: "cpu", ti.cuda: "cuda", ti.metal: "metal"}.get(ti_arch, str(ti_arch))
    generation = 1 if _state is None else _state.generation + 1
    _state = BackendState(resolved, precision, threads, generation)
    return _state


def _requested_matches(requested: str, resolved: str) -> bool:
    return (requested == "cpu" and resolved == "cpu") or (requested == "gpu" and resolved != "cpu")


def _probe_gpu(ti):
    """Return ti.cuda / ti.metal when a device of that kind really works, else None."""
    from taichi._lib import core as _ti_core

    candidates = []
    if _ti_core.with_cuda():
        candidates.append(ti.cuda)
    if _ti_core.with_metal():
        candidates.append(ti.metal)
    for cand in candidates:
        try:
            if cand == ti.cuda:
                import ctypes
                for name in ("libcuda.so.1", "libcuda.so"):
                    try:
                        lib = ctypes.CDLL(name)
                        break
                    except OSError:
                        lib = None
                if lib is None or lib.cuInit(0) != 0:
                    continue
                count = ctypes.c_int(0)
                if lib.cuDeviceGetCount(ctypes.byref(count)) != 0 or count.value < 1:
                    continue
            return cand
        except Exception:
            continue
    return None


def state() -> BackendState:
    """The current backend; initialises the default (cpu, f64) when nothing has been asked yet."""
    if _state is None:
        return init()
    return _state


def is_initialised() -> bool:
    return _state is not None
