"""NumPy twin of the solid cells' walls (`tiseg.solver.numerics.walls`), written independently
of the kernels, for the reference operator and the split sweeps' twin."""

from __future__ import annotations

import numpy as np

FLUID, WALL_HI, WALL_LO, SOLID = 0, 1, 2, 3


def face_kinds(solid: np.ndarray, axis: int) -> np.ndarray:
    """The kind of each face m + 1/2 along ``axis`` (1: x, 2: y) of the (NX, NY) mask, at
    index m of an array one shorter along that axis: solid(m + 1) + 2 solid(m)."""
    ax = axis - 1
    n = solid.shape[ax]
    lo = np.take(solid, range(0, n - 1), axis=ax).astype(int)
    hi = np.take(solid, range(1, n), axis=ax).astype(int)
    return hi + 2 * lo


def faced(lay, kinds: np.ndarray, wl: np.ndarray, wr: np.ndarray, direction: int):
    """The edge states a face takes: at a wall the fluid side and its mirror image (normal
    velocity reversed), as they are elsewhere."""
    comp = lay.HU if direction == 0 else lay.HV

    def mirror(w):
        m = w.copy()
        m[comp] = -w[comp]
        return m

    out_l = np.where((kinds == WALL_LO)[None], mirror(wr), wl)
    out_r = np.where((kinds == WALL_HI)[None], mirror(wl), wr)
    return out_l, out_r
