"""Limits checked before work starts: memory for the grid, disk for the output.

`check_memory` compares what a simulation will take at its peak (the operator's fields,
the guard's last-good copy, the host copies made when states are read and written) with the
memory available to this process: the machine's available memory or, when lower, what the
memory limit of its cgroup (a container's, a batch job's) still allows. It refuses with the
numbers when the grid does not fit, before Taichi tries to allocate it (past a cgroup's limit
the kernel kills the process with no message).
`disk_note` warns when the expected output of a run exceeds the free space where it goes.
"""

from __future__ import annotations

from ..output.fields import snapshot_fields

import os
import shutil
from pathlib import Path

from ..errors import InputError
from ..log import note

GB = 1024**3
# Peak memory of a run, in arrays of one state's size (every component of every cell, ghost
# cells included) in the run's precision. Fitted to the peak RSS of fingers runs of 0.3 to 1.1
# million cells, f64 and f32, with a snapshot (a run of 3000 x 1000 cells in f64 peaked at
# 2.4 GB, 2.2 times the Taichi fields alone, which is all the estimate used to count):
#  - Taichi's fields: the state slots, and WORK_ARRAYS besides them: primitives, x fluxes,
#    x slopes, y fluxes, y slopes (TaichiOperator) and the guard's last-good copy;
#  - the host copy of every slot that reading or writing one slot makes (q.to_numpy());
#  - HOST_ARRAYS more on the host: the initial state, a slot read back, a snapshot's fields
#    and the temporaries that compute and write them. Some of those are float64 whatever the
#    run's precision (the snapshot's derived fields, the peak fields), so an f32 run counts two
#    more of its own arrays.
# Measured with `tiseg run` (a snapshot and a checkpoint mid-run; issue 48), grown RSS over
# the estimate: f64 2000 cells/m 0.88; f32 1000, 2000, 3000 cells/m 0.84, 0.92, 0.89 (the
# former estimate: 1.09, 1.04, 0.98 in f32).
WORK_ARRAYS = 6
HOST_ARRAYS = {"f64": 10, "f32": 12}
# what the process grows by besides the cell fields after the check: compiling the kernels
# (LLVM: 120-210 MB measured when the kernel cache does not have them), the output libraries'
# buffers
OVERHEAD = 160 * 1024**2

MEMINFO = Path("/proc/meminfo")
CGROUP_ROOT = Path("/sys/fs/cgroup")
SELF_CGROUP = Path("/proc/self/cgroup")
# cgroup v1 writes "no limit" as 2**63 - 1 rounded down to a page
UNLIMITED = 2**60


def memory_needed(layout, nslots: int, precision: str, members: int = 1) -> int:
    """Bytes the run adds at its peak (an upper estimate, within 10 % on large grids: see
    HOST_ARRAYS); ``members``: a batch's (`tiseg.run.batch`), whose Taichi fields hold every
    member while its host arrays are one member's at a time."""
    value = 8 if precision == "f64" else 4
    state = layout.nc * layout.NX * layout.NY * value
    taichi = members * (nslots + WORK_ARRAYS) * state
    host = (nslots + HOST_ARRAYS.get(precision, HOST_ARRAYS["f32"])) * state
    return taichi + host + OVERHEAD


def members_that_fit(layout, nslots: int, precision: str, share: int = 1) -> int | None:
    """The most members of a batch on this grid that fit in 1/``share`` of the memory
    available now (`memory_needed`; at least 1), or None where the memory is unknown."""
    have = memory_available()
    if have is None:
        return None
    one = memory_needed(layout, nslots, precision)
    more = memory_needed(layout, nslots, precision, members=2) - one  # each further member
    return max(1, 1 + int((have / max(share, 1) - one) // more))


def memory_available(meminfo=None, cgroup_root=None, self_cgroup=None) -> int | None:
    """Bytes of memory available to a new allocation, or None when unknown: the machine's
    (Linux: MemAvailable) or what this process's cgroup limits still allow, the lower. The
    paths default to MEMINFO, CGROUP_ROOT and SELF_CGROUP (read when called: tests set them)."""
    found = (
        _machine_available(meminfo or MEMINFO),
        cgroup_available(cgroup_root or CGROUP_ROOT, self_cgroup or SELF_CGROUP),
    )
    return min((v for v in found if v is not None), default=None)


def _machine_available(meminfo: Path) -> int | None:
    try:
        with open(meminfo, encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (AttributeError, OSError, ValueError):
        return None


def cgroup_available(root: Path, self_cgroup: Path) -> int | None:
    """Bytes that the memory limits of this process's cgroup and of every cgroup above it still
    allow (limit minus usage, the least of them), or None when none is set. cgroup v2
    (memory.max, memory.current) and v1 (memory/memory.limit_in_bytes, memory.usage_in_bytes);
    ``root`` is where the hierarchy is mounted (/sys/fs/cgroup), ``self_cgroup`` the file
    naming this process's cgroups (/proc/self/cgroup)."""
    least = None
    for limit_file, usage_file in _cgroup_files(Path(root), Path(self_cgroup)):
        limit = _read_int(limit_file)
        if limit is None or limit >= UNLIMITED:
            continue
        left = max(0, limit - (_read_int(usage_file) or 0))
        least = left if least is None else min(least, left)
    return least


def _cgroup_files(root: Path, self_cgroup: Path):
    """(limit, usage) file pairs from this process's cgroup up to the hierarchy's root, for v2
    and for v1's memory controller; the process's path comes from /proc/self/cgroup (inside a
    container's namespace it is "/", the root itself)."""
    v2 = v1 = "/"
    try:
        lines = self_cgroup.read_text(encoding="utf-8").splitlines()
    except (OSError, UnicodeDecodeError):
        lines = []
    for line in lines:  # "0::/path" (v2), "4:memory:/path" (v1)
        parts = line.split(":", 2)
        if len(parts) == 3 and parts[1] == "":
            v2 = parts[2]
        elif len(parts) == 3 and "memory" in parts[1].split(","):
            v1 = parts[2]
    for base, rel, names in (
        (root, v2, ("memory.max", "memory.current")),
        (root / "memory", v1, ("memory.limit_in_bytes", "memory.usage_in_bytes")),
    ):
        d = base / rel.strip("/")
        while True:
            yield d / names[0], d / names[1]
            if d == base or base not in d.parents:
                break
            d = d.parent


def _read_int(path: Path) -> int | None:
    """The integer in a one-line file; None when it is missing, unreadable or "max"."""
    try:
        return int(path.read_text(encoding="ascii").strip())
    except (OSError, ValueError, UnicodeDecodeError):
        return None


def check_memory(layout, nslots: int, precision: str, members: int = 1) -> None:
    """InputError when the grid's fields (of ``members`` members) cannot fit in the
    available memory."""
    need = memory_needed(layout, nslots, precision, members)
    have = memory_available()
    if have is not None and need > have:
        what = f"{members} members on the grid" if members > 1 else "the grid"
        fewer = "fewer members in a batch (--batch), " if members > 1 else ""
        raise InputError(
            f"{what} of {layout.nx} x {layout.ny} cells needs about {need / GB:.3g} GB of "
            f"memory in {precision} and {have / GB:.3g} GB are available (free memory, within "
            f"any cgroup memory limit); use {fewer}a coarser domain.resolution (memory grows "
            "with its square in 2D)" + (" or --precision f32" if precision == "f64" else "")
        )


def output_volume(scene, precision: str, snapshots: int) -> int:
    """Bytes of fields.nc for ``snapshots`` records, uncompressed (an upper bound)."""
    value = 8 if precision == "f64" else 4
    return (
        snapshots * len(snapshot_fields(scene.fields)) * scene.domain.nx * scene.domain.ny * value
    )


def disk_note(folder, scene, precision: str, snapshots: int) -> None:
    """A note when the run's output may not fit in the free space of ``folder``."""
    try:
        free = shutil.disk_usage(Path(folder)).free
    except OSError:
        return
    need = output_volume(scene, precision, snapshots)
    if need > free:
        note(
            f"the output may need up to {need / GB:.3g} GB ({snapshots} snapshots, "
            f"uncompressed) and {str(folder)!r} has {free / GB:.3g} GB free; the run stops "
            "with a message if the disk fills (resume it after making room)"
        )
