"""The only place Taichi is initialised: `init` (arch, precision).

Taichi reads its floating-point type (``default_fp``) at initialisation, so precision is a
process-wide choice; calling `init` again with other settings resets the Taichi runtime and
invalidates every field made before (simulations check `generation` to refuse stale fields).
"""

from __future__ import annotations

import contextlib
import io
import os
import stat
import sys
import tempfile
from dataclasses import dataclass

from .errors import InputError, TisegError

# Keep Taichi quiet and offline (no version check over the network, no banner).
os.environ.setdefault("TI_SKIP_VERSION_CHECK", "ON")
os.environ.setdefault("ENABLE_TAICHI_HEADER_PRINT", "0")


def _private_temp_dir() -> str:
    """A folder of this user's under the system temp dir (the cache of last resort)."""
    uid = os.getuid() if hasattr(os, "getuid") else os.getpid()
    return os.path.join(tempfile.gettempdir(), f"tiseg-{uid}")


# Taichi's core library works out its cache folder ($XDG_CACHE_HOME/taichi, else
# $HOME/.cache/taichi) while it loads, and aborts the process (SIGABRT) when neither variable is
# set; this module is imported before anything imports Taichi (tiseg/__init__.py), so name one.
if "XDG_CACHE_HOME" not in os.environ and "HOME" not in os.environ:
    os.environ["XDG_CACHE_HOME"] = _private_temp_dir()

ARCHS = ("cpu", "gpu", "auto", "vulkan")
PRECISIONS = ("f32", "f64")


@dataclass(frozen=True)
class BackendState:
    arch: str  # resolved: "cpu", "cuda", "metal" or "vulkan"
    precision: str  # "f32" or "f64"
    threads: int  # CPU threads Taichi may use (0 = Taichi's default)
    generation: int  # increases with every (re)initialisation


_state: BackendState | None = None


def init(
    arch: str = "cpu",
    precision: str = "f64",
    threads: int = 0,
    debug: bool = False,
    force: bool = False,
) -> BackendState:
    """Initialise Taichi once for this process.

    Calling again with the same settings is a no-op; other settings re-initialise Taichi.

    Parameters
    ----------
    arch
        "cpu", "gpu" (CUDA or Metal; an error when there is none), "auto" (GPU if present)
        or "vulkan". Vulkan must be asked for by name: "gpu" and "auto" never pick it,
        because the Vulkan device of a machine without a GPU is software Vulkan (Mesa's
        lavapipe), a CPU in disguise that runs several times slower than the CPU backend; it
        serves to run the GPU code generator (SPIR-V) where there is no GPU.
    precision
        "f64" (default, needed for round-off-level tests) or "f32". A device without 64-bit
        floats (Metal; a Vulkan device without shaderFloat64) refuses f64 with one line.
    threads
        CPU thread count (0 = all cores).
    debug
        Taichi's debug mode (bounds checks in kernels).
    force
        Re-initialise even when the settings are the same.

    Returns
    -------
    BackendState
        The settings in force.
    """
    global _state
    if arch not in ARCHS:
        raise InputError(f"arch={arch!r} is not allowed; choose one of {', '.join(ARCHS)}")
    if precision not in PRECISIONS:
        raise InputError(f"precision={precision!r} is not allowed; choose f32 or f64")
    if not isinstance(threads, int) or threads < 0:
        raise InputError(f"threads={threads!r} must be a non-negative integer")
    problem = threads_problem(threads)
    if problem:
        raise InputError(problem)
    if (
        _state is not None
        and not force
        and _state.precision == precision
        and _state.threads == threads
        and (arch == "auto" or _requested_matches(arch, _state.arch))
    ):
        return _state

    import taichi as ti

    _memoise_source_positions()
    if arch == "cpu":
        ti_arch = ti.cpu
    elif arch == "vulkan":
        from taichi._lib import core as _ti_core

        if not _ti_core.with_vulkan():  # no loader, no driver, or a build without it
            raise InputError(NO_VULKAN)
        ti_arch = ti.vulkan
    else:
        ti_arch = _probe_gpu(ti)
        if ti_arch is None:
            if arch == "gpu":
                raise InputError(
                    "arch='gpu' was asked for but no CUDA or Metal GPU is available "
                    "here; use --arch cpu (or auto)"
                )
            ti_arch = ti.cpu
    if ti_arch == ti.metal and precision == "f64":
        raise InputError(NO_F64.format(device="Metal"))
    kwargs = dict(
        arch=ti_arch,
        default_fp=ti.f64 if precision == "f64" else ti.f32,
        fast_math=False,
        debug=debug,
        offline_cache=True,
        # Taichi's own warnings (a busy kernel cache, ...) only with -v: without it, a user
        # mistake stays one line on stderr
        log_level=ti.WARN if _verbose() else ti.ERROR,
    )
    cache = cache_folder()
    clear_stale_lock(cache)
    if cache != os.environ.get("TI_OFFLINE_CACHE_FILE_PATH"):
        kwargs["offline_cache_file_path"] = cache
    if ti_arch == ti.cpu:
        # LLVM's lighter code generation: on this package's kernels it compiles about 10x
        # faster (most of a small run's set-up), runs as fast (memory-bound stencils) and
        # gives the same bits (16 pinned cases, benchmarks/timings.md); GPUs keep Taichi's
        # default
        kwargs["opt_level"] = 0
    if threads and ti_arch == ti.cpu:
        kwargs["cpu_max_num_threads"] = threads
    # Taichi prints "[Taichi] Starting on arch=..." on stdout: on stderr with -v, else nowhere
    # (stdout is for results and JSON)
    with contextlib.redirect_stdout(sys.stderr if _verbose() else io.StringIO()):
        ti.init(**kwargs)
    if ti_arch == ti.vulkan:
        _check_vulkan(ti, precision)
    resolved = {ti.cpu: "cpu", ti.cuda: "cuda", ti.metal: "metal", ti.vulkan: "vulkan"}.get(
        ti_arch, str(ti_arch)
    )
    generation = 1 if _state is None else _state.generation + 1
    _state = BackendState(resolved, precision, threads, generation)
    return _state


def _memoise_source_positions() -> None:
    """Make Taichi's compile step remember what it reads and formats from the source.

    Each time a kernel is instantiated (once per simulation object) Taichi reads the kernel's
    source lines again (inspect, which tokenises the file) and, for every node of its syntax
    tree, formats the node's lines into the text of a possible error message
    (``ASTTransformerContext.get_pos_info``, with textwrap): together about a quarter of the
    time to set up a small simulation. Both depend only on the source and the node's position,
    so dictionaries return them, and what Taichi builds (and its kernel cache keys) stays the
    same. Taichi is pinned (pyproject.toml); if its internals move, nothing is patched."""
    try:
        from taichi.lang import kernel_impl
        from taichi.lang.ast.ast_transformer_utils import ASTTransformerContext
    except ImportError:
        return
    formatter = getattr(ASTTransformerContext, "get_pos_info", None)
    if formatter is not None and not getattr(formatter, "tiseg_memo", False):
        texts: dict = {}

        def get_pos_info(ctx, node):
            try:
                key = (
                    ctx.file,
                    ctx.lineno_offset,
                    ctx.indent,
                    ctx.func.func.__name__,
                    len(ctx.src),
                    type(node).__name__,
                    node.lineno,
                    node.col_offset,
                    node.end_lineno,
                    node.end_col_offset,
                )
            except AttributeError:
                return formatter(ctx, node)
            text = texts.get(key)
            if text is None:
                text = texts[key] = formatter(ctx, node)
            return text

        get_pos_info.tiseg_memo = True
        ASTTransformerContext.get_pos_info = get_pos_info
    reader = getattr(kernel_impl, "getsourcelines", None)
    if callable(reader) and not getattr(reader, "tiseg_memo", False):
        sources: dict = {}

        def getsourcelines(obj):
            code = getattr(obj, "__code__", None)
            if code is None:
                return reader(obj)
            if code not in sources:
                sources[code] = reader(obj)
            lines, start = sources[code]
            return list(lines), start

        getsourcelines.tiseg_memo = True
        kernel_impl.getsourcelines = getsourcelines


def _verbose() -> bool:
    """Whether the user asked for details (``-v``: the ``tiseg`` logger shows debug lines)."""
    import logging

    return logging.getLogger("tiseg").isEnabledFor(logging.DEBUG)


def cache_folder() -> str:
    """The folder for Taichi's offline kernel cache: TI_OFFLINE_CACHE_FILE_PATH when set, else
    Taichi's default ($XDG_CACHE_HOME/taichi/ticache or ~/.cache/taichi/ticache), else a folder
    under the system temp dir; the first one that can be written.

    Always checked and passed to Taichi, because Taichi writes to it at exit even with the offline
    cache off, and crashes (SIGSEGV, after a finished run) when it cannot be created."""
    xdg = os.environ.get("XDG_CACHE_HOME")
    home = os.environ.get("HOME")
    taichi_default = os.path.join(
        xdg if xdg is not None else os.path.join(home or "", ".cache"), "taichi", "ticache"
    )
    candidates = [os.environ.get("TI_OFFLINE_CACHE_FILE_PATH"), taichi_default]
    try:
        private = _private_temp_dir()  # also Taichi's default when HOME is unset (see above)
        candidates.append(os.path.join(private, "taichi", "ticache"))
    except OSError:  # gettempdir: no writable temp folder at all
        private = None
    tried = []
    for folder in candidates:
        if not folder or folder in tried:
            continue
        shared = private is not None and folder.startswith(private + os.sep)
        if (not shared or _owned_folder(private)) and _writable_folder(folder):
            if tried:
                from .log import debug

                debug(f"Taichi's kernel cache: {folder} ({', '.join(tried)} cannot be written)")
            return folder
        tried.append(folder)
    raise TisegError(
        f"no folder for Taichi's kernel cache can be written (tried {', '.join(tried)}): "
        "set TI_OFFLINE_CACHE_FILE_PATH to a writable folder"
    )


# Taichi holds its cache's lock file for the moment it reads or writes the cache's index; a
# process killed meanwhile (SIGKILL, a batch system's time limit) leaves it behind, and from then
# on every process finds the cache locked: it warns, and compiles every kernel anew (a tiny
# fingers run then takes 12 s instead of 2.5 s). A lock this old has no living holder.
STALE_LOCK_S = 600.0


def clear_stale_lock(folder: str, now: float | None = None) -> bool:
    """Remove the kernel cache's lock file when it is older than STALE_LOCK_S; True if removed."""
    import time

    lock = os.path.join(folder, "ticache.lock")
    try:
        age = (time.time() if now is None else now) - os.stat(lock).st_mtime
        if age <= STALE_LOCK_S:
            return False
        os.unlink(lock)
    except OSError:  # no lock (the usual case), or it went meanwhile, or it is not ours to remove
        return False
    from .log import debug

    debug(f"removed the stale lock of Taichi's kernel cache ({age:.0f} s old): {lock}")
    return True


def _owned_folder(folder: str) -> bool:
    """Whether ``folder`` (made here, mode 700, if missing) is a folder of this user's that no one
    else may write to: a fixed name in a shared temp folder may have been made by someone else,
    and Taichi loads compiled code from its kernel cache."""
    try:
        os.makedirs(folder, mode=0o700, exist_ok=True)
        st = os.lstat(folder)
    except OSError:
        return False
    mine = not hasattr(os, "getuid") or st.st_uid == os.getuid()
    return stat.S_ISDIR(st.st_mode) and mine and not st.st_mode & 0o022


def _writable_folder(folder: str) -> bool:
    """Whether ``folder`` exists or can be made, and a file can be created in it (tried, not
    judged from permission bits: root writes into a read-only folder)."""
    try:
        os.makedirs(folder, exist_ok=True)
        with tempfile.TemporaryFile(dir=folder):
            pass
    except OSError:
        return False
    return True


NO_VULKAN = (
    "arch='vulkan': no Vulkan device works here (install a driver, e.g. Debian's "
    "mesa-vulkan-drivers and libvulkan1 for software Vulkan), or use --arch cpu"
)
NO_F64 = (
    "the {device} device has no 64-bit floats, which precision 'f64' needs; use "
    "--precision f32 (or precision='f32')"
)


def _check_vulkan(ti, precision: str) -> None:
    """Taichi falls back to the CPU when no Vulkan device works, and a device may lack f64:
    refuse both with one line (after resetting Taichi, so nothing half-made stays)."""
    from taichi.lang import impl

    if impl.current_cfg().arch != ti.vulkan:
        ti.reset()
        raise InputError(NO_VULKAN)
    if precision == "f64" and not _f64_works(ti):
        ti.reset()
        raise InputError(NO_F64.format(device="Vulkan"))


def _f64_works(ti) -> bool:
    """Whether the device computes in 64-bit floats: a product and an atomic max that only f64
    resolves (1 + 2^-40 is 1 in f32), as the solver's kernels use them."""
    import numpy as np

    a = ti.field(ti.f64, shape=2)
    try:

        @ti.kernel
        def probe():
            x = a[0]
            a[1] = x * x
            ti.atomic_max(a[1], x * x - 1.0)

        a[0] = 1.0 + 2.0**-40
        probe()
        got = a.to_numpy()
    except Exception:  # a device without shaderFloat64 fails to compile the kernel
        return False
    return bool(got[1] == np.float64(1.0 + 2.0**-40) ** 2)


def requested_arch(resolved: str) -> str:
    """The ``arch`` to ask `init` for to get the resolved backend again."""
    return resolved if resolved in ("cpu", "vulkan") else "gpu"


def _requested_matches(requested: str, resolved: str) -> bool:
    if requested == "vulkan" or resolved == "vulkan":
        return requested == resolved
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


def generation() -> int:
    """How many times this process initialised Taichi (0 before the first)."""
    return 0 if _state is None else _state.generation


def conflict(arch: str | None, precision: str, threads: int = 0) -> str | None:
    """None when the initialised backend serves ``arch`` (None: any), ``precision`` and
    ``threads`` (0: any), else one line saying what differs and what to do. A simulation
    never re-initialises Taichi by itself: that would destroy every other simulation's fields."""
    if _state is None:
        return None
    diff = []
    if precision != _state.precision:
        diff.append(f"precision {precision}")
    if arch is not None and arch != "auto" and not _requested_matches(arch, _state.arch):
        diff.append(f"arch {arch}")
    if threads and threads != _state.threads:
        diff.append(f"{threads} threads")
    if not diff:
        return None
    have = f"{_state.arch}/{_state.precision}" + (
        f" with {_state.threads} threads" if _state.threads else ""
    )
    return (
        f"Taichi is already initialised for {have} in this process, and this simulation "
        f"asks for {' and '.join(diff)}; call tiseg.init(...) with the new settings first "
        "(that invalidates every existing simulation), or use a new process"
    )


def available_cores() -> int:
    """CPU cores this process may run on (its affinity mask where the OS has one)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        return max(1, os.cpu_count() or 1)


def threads_problem(threads: int, what: str = "threads") -> str | None:
    """None when ``threads`` CPU threads are sensible here, else why not (more threads than
    cores only slows a run down, and a huge number can exhaust the machine)."""
    cores = available_cores()
    if threads > cores:
        return (
            f"{what}={threads}: this machine offers {cores} core(s) to this process; use "
            f"at most {cores} (0 = all of them)"
        )
    return None


# Taichi's LLVM backends hold at most 512 field trees per runtime (one or a few per simulation,
# never freed until ti.init): past that, a kernel launch crashes the process
MAX_FIELD_TREES = 512
SPARE_FIELD_TREES = 24  # what one more simulation with a renderer may need


def field_trees() -> int:
    """Field trees (SNode trees) the current Taichi runtime holds (0 before init)."""
    if _state is None:
        return 0
    try:
        from taichi.lang import impl

        return int(impl.get_runtime().prog.get_snode_tree_size())
    except Exception:  # an odd Taichi without the count: nothing to check
        return 0


def check_field_room() -> None:
    """A TisegError instead of Taichi's crash when the runtime is nearly out of field trees."""
    n = field_trees()
    if n > MAX_FIELD_TREES - SPARE_FIELD_TREES:
        raise TisegError(
            f"this process holds {n} Taichi field trees (Taichi allows "
            f"{MAX_FIELD_TREES}; each simulation takes a few and keeps them): "
            "call tiseg.init(..., force=True) to free every simulation's fields, "
            "or use a new process"
        )
