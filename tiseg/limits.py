"""Limits checked before work starts: memory for the grid, disk for the output.

:func:`check_memory` compares what a simulation's fields will take (the operator's state slots
and work arrays, the guard's last-good copy) with the memory the machine has available, and
refuses with the numbers when it does not fit, before Taichi tries to allocate it.
:func:`disk_note` warns when the expected output of a run exceeds the free space where it goes.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

from .errors import InputError
from .log import note

GB = 1024**3
# arrays of one state's size besides the state slots: primitives, x fluxes, x slopes, y
# fluxes, y slopes (TaichiOperator) and the guard's last-good copy
WORK_ARRAYS = 6


def memory_needed(layout, nslots: int, precision: str) -> int:
    """Bytes of the simulation's cell fields (an upper estimate, within a few per cent)."""
    value = 8 if precision == "f64" else 4
    return (nslots + WORK_ARRAYS) * layout.nc * layout.NX * layout.NY * value


def memory_available() -> int | None:
    """Bytes of memory available to a new allocation (Linux: MemAvailable), or None."""
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (AttributeError, OSError, ValueError):
        return None


def check_memory(layout, nslots: int, precision: str) -> None:
    """InputError when the grid's fields cannot fit in the available memory."""
    need = memory_needed(layout, nslots, precision)
    have = memory_available()
    if have is not None and need > have:
        raise InputError(
            f"the grid of {layout.nx} x {layout.ny} cells needs about {need / GB:.3g} GB of "
            f"memory in {precision} and this machine has {have / GB:.3g} GB available; use a "
            "coarser domain.resolution (memory grows with its square in 2D)"
            + (" or --precision f32" if precision == "f64" else "")
        )


def output_volume(scene, precision: str, snapshots: int) -> int:
    """Bytes of fields.nc for ``snapshots`` records, uncompressed (an upper bound)."""
    value = 8 if precision == "f64" else 4
    return snapshots * len(scene.fields) * scene.domain.nx * scene.domain.ny * value


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
