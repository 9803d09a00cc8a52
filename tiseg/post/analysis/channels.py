"""Fingers as 2D channels: the headline finger count and the channel and levee numbers.

A finger is a fine-rich, mobile channel bounded by coarse-rich levees (or by empty slope) that
reaches from its tip a good way back into the fingered zone x_f^- <= x <= x_f^+ (section 6.3).
Counted on single cross-slope lines, the fingers of unequal length give a count that depends on
the line: near the tips only the longest fingers are crossed, near x_f^- the channels have
merged. Counted as 2D objects, each finger counts once whatever its length.

The count (`count_channels`)
----------------------------------
1. Channel cells are wet (h >= h_min) and fine-rich (phi > phi_threshold); on each grid column
   (cross-slope line) of the fingered zone they form periodic runs after the noise filters of
   `periodic_runs` (runs narrower than ``min_width`` cells dropped,
   gaps narrower than ``min_gap`` cells closed; a line that is channel all across has no
   levee and no run).
2. Runs on neighbouring columns that share a row are connected (4-connectivity, periodic in
   y: a finger across the seam y = 0 = Ly is one object).
3. Sweeping the columns from the front x_f^+ back to x_f^-, N(s) is the number of connected
   objects of the channel runs at x >= s whose downslope extent is at least ``min_span``
   (default 0.1) of x_l. Behind the tips the fingers appear one by one as s decreases; further
   back their channels join into the mixed flow. The finger count is max over s of N(s): the
   number of distinct channels before they join. Channels that split around a coarse island
   and join again are one finger; a Y of two channels that join behind their tips is two.

Why ``min_span`` relative to x_l: it removes fine-rich specks inside levees and incipient
intrusions without depending on the grid, and it scales with the fingered zone as it grows.

Channel and levee numbers (`channel_numbers`)
---------------------------------------------------
Over the runs that belong to counted fingers (objects of extent >= min_span after the sweep):

* ``channel_speed_over_u0``: the median speed |u| at the centre cell of each run (the channel
  centrelines, one sample per run and column), over u0;
* ``channel_phi``: the mean phi over the cells of those runs;
* ``levee_speed_over_u0``: the median speed of the levees, over u0: on each column, the runs
  of wet coarse-rich cells (phi <= threshold) that touch a counted channel run. The coarse caps
  of the finger tips and the coarse head ahead of them, which move with the front, border dry
  slope or other coarse cells, not a channel, and are left out.
"""

from __future__ import annotations

import math

import numpy as np

DEFAULT_MIN_SPAN = 0.1  # fraction of x_l a finger must reach along x


class ColumnRuns:
    """The runs of every column of a (ny, ncols) mask: flat arrays, one entry a run.

    ``col``: the run's column (0 .. ncols - 1), ``start``: its first row in [0, ny) (a run may
    wrap past ny - 1 to 0), ``length``: its cells. Ordered by column and, within a column, as
    `periodic_runs` lists them. Built by `column_runs`.
    """

    def __init__(self, col, start, length, ncols: int, ny: int):
        self.col = np.asarray(col, dtype=np.int64)
        self.start = np.asarray(start, dtype=np.int64)
        self.length = np.asarray(length, dtype=np.int64)
        self.ncols = int(ncols)
        self.ny = int(ny)

    def counts(self) -> np.ndarray:
        """The number of runs of each column."""
        return np.bincount(self.col, minlength=self.ncols)

    def of(self, k: int) -> list[tuple[int, int]]:
        """Column ``k``'s runs as (start, length) pairs."""
        sel = self.col == k
        return list(zip(self.start[sel].tolist(), self.length[sel].tolist()))

    def lists(self) -> list[list[tuple[int, int]]]:
        """Every column's runs as (start, length) pairs."""
        return self.by_column(zip(self.start.tolist(), self.length.tolist()))

    def by_column(self, values) -> list[list]:
        """One value a run (in the runs' order), as a list for each column."""
        out: list[list] = [[] for _ in range(self.ncols)]
        for k, value in zip(self.col.tolist(), values):
            out[k].append(value)
        return out

    def cells(self, sel=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(run index, row, column) of every cell of the runs (of those ``sel`` picks), run by
        run in order and each run's rows from its start."""
        idx = np.arange(self.col.size) if sel is None else np.flatnonzero(sel)
        n = self.length[idx]
        run = np.repeat(idx, n)
        first = np.cumsum(n) - n  # where each run's cells begin in the flat list
        offset = np.arange(int(n.sum())) - np.repeat(first, n)
        return run, (self.start[run] + offset) % self.ny, self.col[run]


def column_runs(mask, min_width: int = 1, min_gap: int = 1) -> ColumnRuns:
    """`periodic_runs` of every column of a (ny, ncols) boolean array, found together."""
    m = np.asarray(mask, dtype=bool)
    if m.ndim == 1:
        m = m.reshape(-1, 1)
    ny, ncols = m.shape
    none = ColumnRuns([], [], [], ncols, ny)
    if ny == 0 or ncols == 0:
        return none
    # Rotate each column so that its row 0 is a gap cell: then no run wraps and plain linear
    # runs suffice (a column without a gap cell is all channel: no boundary, no run).
    k = np.argmin(m, axis=0)
    r = np.take_along_axis(m, (np.arange(ny)[:, None] + k[None, :]) % ny, axis=0)
    pad = np.zeros((ncols, 1), dtype=np.int8)
    edges = np.diff(np.concatenate((pad, r.T.astype(np.int8), pad), axis=1), axis=1)
    col, s = np.nonzero(edges == 1)  # by column, then row
    e = np.nonzero(edges == -1)[1]  # exclusive ends, paired with the starts in order
    keep = (e - s >= min_width) & ~m.all(axis=0)[col]
    col, s, e = col[keep], s[keep], e[keep]
    if col.size == 0:
        return none
    # runs closer than min_gap to the previous one of their column join it (gap included)
    new = np.ones(col.size, dtype=bool)
    new[1:] = (col[1:] != col[:-1]) | (s[1:] - e[:-1] >= min_gap)
    first = np.flatnonzero(new)
    last = np.append(first[1:], col.size) - 1
    col, s, e = col[first], s[first], e[last]
    # the gap through the seam of the rotated column, from its last run back to its first:
    # narrower than min_gap, the last run joins the first (which keeps its place), or a
    # column of one run closes on itself (no levee on this line)
    lo = np.flatnonzero(np.append(True, col[1:] != col[:-1]))
    hi = np.append(lo[1:], col.size) - 1
    closes = ny - e[hi] + s[lo] < min_gap
    drop = np.zeros(col.size, dtype=bool)
    drop[lo[closes & (lo == hi)]] = True
    join = closes & (lo != hi)
    s[lo[join]] = s[hi[join]]
    e[lo[join]] += ny
    drop[hi[join]] = True
    col, s, e = col[~drop], s[~drop], e[~drop]
    return ColumnRuns(col, (s + k[col]) % ny, e - s, ncols, ny)


def periodic_runs(mask, min_width: int = 1, min_gap: int = 1) -> list[tuple[int, int]]:
    """Connected runs of True in a periodic 1D boolean array, after the noise filters.

    Returns ``(start, length)`` pairs in cells, start in [0, n) (a run may wrap past n - 1 to
    0). Runs shorter than ``min_width`` cells are dropped first; then runs separated by a gap
    shorter than ``min_gap`` cells are merged (the merged run includes the gap). A line that is
    True everywhere, or becomes one run closing on itself through gaps shorter than ``min_gap``,
    has no boundary and yields ``[]`` -- as does a line without any True cell. The runs are
    listed from the first gap cell on, a run through the seam of that order first.
    """
    return column_runs(np.asarray(mask, dtype=bool).reshape(-1, 1), min_width, min_gap).of(0)


class _Objects:
    """Union-find over runs, each root carrying the x range (tip, low) of its object."""

    def __init__(self, span: float, dx: float):
        self.parent: list[int] = []
        self.tip: list[float] = []
        self.low: list[float] = []
        self.span = span
        self.dx = dx
        self.qualifying = 0  # roots whose extent reaches span

    def _q(self, r: int) -> bool:
        return self.tip[r] - self.low[r] + self.dx >= self.span * (1.0 - 1e-12)

    def find(self, a: int) -> int:
        while self.parent[a] != a:
            self.parent[a] = self.parent[self.parent[a]]
            a = self.parent[a]
        return a

    def add(self, x: float) -> int:
        n = len(self.parent)
        self.parent.append(n)
        self.tip.append(x)
        self.low.append(x)
        self.qualifying += self._q(n)
        return n

    def union(self, a: int, b: int) -> None:
        ra, rb = self.find(a), self.find(b)
        if ra == rb:
            return
        self.qualifying -= self._q(ra) + self._q(rb)
        self.parent[ra] = rb
        self.tip[rb] = max(self.tip[rb], self.tip[ra])
        self.low[rb] = min(self.low[rb], self.low[ra])
        self.qualifying += self._q(rb)


def count_channels(runs: ColumnRuns, cols, x, min_span_m: float) -> tuple[int, np.ndarray]:
    """The finger count max_s N(s) and, per run, whether it belongs to a counted finger.

    ``runs``: the runs of the columns ``cols`` (ascending x; `column_runs`); ``x``: cell-centre
    x of every column; ``min_span_m``: the extent [m] an object must have.
    """
    dx = float(np.median(np.diff(x))) if len(x) > 1 else 1.0
    obj = _Objects(min_span_m, dx)
    ny = runs.ny
    # runs of neighbouring columns that share a row touch: the label of each run's cells on
    # a (ny, ncols) image, and the distinct label pairs across each column boundary
    label = np.full((ny, runs.ncols), -1, dtype=np.int64)
    run, row, col = runs.cells()
    label[row, col] = run
    left, right = label[:, :-1], label[:, 1:]
    both = (left >= 0) & (right >= 0)
    pairs = np.unique(np.stack((left[both], right[both]), axis=1), axis=0)
    touching: list[list[int]] = [[] for _ in range(runs.col.size)]
    for a, b in pairs.tolist():  # a in column k, b in column k + 1
        touching[a].append(b)
    column_x = np.asarray(x, dtype=float)[np.asarray(cols, dtype=np.int64)].tolist()
    node = [-1] * runs.col.size  # each run's union-find node
    order = runs.col.tolist()
    best = 0
    for i in range(runs.col.size - 1, -1, -1):  # from the front x_f^+ backwards
        node[i] = obj.add(column_x[order[i]])
        for b in touching[i]:
            obj.union(node[b], node[i])
        if i == 0 or order[i - 1] != order[i]:  # a column done: N(s) at its x
            best = max(best, obj.qualifying)
    in_finger = np.array([obj._q(obj.find(n)) for n in node], dtype=bool)
    return best, in_finger


def channel_numbers(
    runs: ColumnRuns, in_finger, cols, h, phi, speed, h_min: float, thr: float, u0: float | None
) -> dict:
    """Channel-centre speed, channel phi and levee speed over the counted fingers."""
    ny = h.shape[0]
    cols = np.asarray(cols, dtype=np.int64)
    in_finger = np.asarray(in_finger, dtype=bool)
    _, row, col = runs.cells(in_finger)
    j = cols[col]
    chan_phi = phi[row, j]
    centre = (runs.start[in_finger] + runs.length[in_finger] // 2) % ny
    centre_speed = speed[centre, cols[runs.col[in_finger]]]
    # levees: the wet coarse runs of the columns with a counted channel that touch it
    in_channel = np.zeros((ny, runs.ncols), dtype=bool)
    in_channel[row, col] = True
    active = np.flatnonzero(in_channel.any(axis=0))
    levee_speed = np.empty(0)
    if active.size:
        hj, pj = h[:, cols[active]], phi[:, cols[active]]
        coarse = column_runs((hj >= h_min) & (pj <= thr) & ~in_channel[:, active])
        at = active[coarse.col]
        before = in_channel[(coarse.start - 1) % ny, at]
        after = in_channel[(coarse.start + coarse.length) % ny, at]
        _, lrow, lcol = coarse.cells(before | after)
        levee_speed = speed[lrow, cols[active[lcol]]]

    def ratio(values):
        if not values.size or not u0:
            return math.nan
        return float(np.median(values)) / u0

    return {
        "channel_speed_over_u0": ratio(centre_speed),
        "channel_phi": float(np.mean(chan_phi)) if chan_phi.size else math.nan,
        "levee_speed_over_u0": ratio(levee_speed),
    }


__all__ = [
    "ColumnRuns",
    "column_runs",
    "periodic_runs",
    "count_channels",
    "channel_numbers",
    "DEFAULT_MIN_SPAN",
]
