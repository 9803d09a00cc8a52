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


def periodic_runs(mask, min_width: int = 1, min_gap: int = 1) -> list[tuple[int, int]]:
    """Connected runs of True in a periodic 1D boolean array, after the noise filters.

    Returns ``(start, length)`` pairs in cells, start in [0, n) (a run may wrap past n - 1 to
    0). Runs shorter than ``min_width`` cells are dropped first; then runs separated by a gap
    shorter than ``min_gap`` cells are merged (the merged run includes the gap). A line that is
    True everywhere, or becomes one run closing on itself through gaps shorter than ``min_gap``,
    has no boundary and yields ``[]`` -- as does a line without any True cell.
    """
    m = np.asarray(mask, dtype=bool).reshape(-1)
    n = m.size
    if n == 0 or m.all() or not m.any():
        return []
    # Rotate so that index 0 is a gap cell: then no run wraps and plain linear runs suffice.
    k = int(np.argmin(m))  # first False
    r = np.roll(m, -k)
    edges = np.diff(np.concatenate(([0], r.astype(np.int8), [0])))
    starts = np.flatnonzero(edges == 1)
    ends = np.flatnonzero(edges == -1)  # exclusive
    runs = [[int(s), int(e)] for s, e in zip(starts, ends) if e - s >= min_width]
    if not runs:
        return []
    merged = [runs[0]]
    for s, e in runs[1:]:
        if s - merged[-1][1] < min_gap:
            merged[-1][1] = e
        else:
            merged.append([s, e])
    # the gap through the seam of the rotated line (from the last run back to the first)
    wrap_gap = n - merged[-1][1] + merged[0][0]
    if wrap_gap < min_gap:
        if len(merged) == 1:
            return []  # closes on itself: no levee on this line
        last = merged.pop()
        merged[0] = [last[0], merged[0][1] + n]
    return [((s + k) % n, e - s) for s, e in merged]


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


def count_channels(line_runs, cols, x, ny: int, min_span_m: float) -> tuple[int, list]:
    """The finger count max_s N(s) and, per line, the flags of runs in counted fingers.

    ``line_runs``: per column of ``cols`` (ascending x) the list of (start, length) runs;
    ``x``: cell-centre x of every column; ``min_span_m``: the extent [m] an object must have.
    """
    dx = float(np.median(np.diff(x))) if len(x) > 1 else 1.0
    obj = _Objects(min_span_m, dx)
    nodes: list[list[int]] = [[] for _ in cols]
    best = 0
    prev = np.full(ny, -1, dtype=np.int64)
    for k in range(len(cols) - 1, -1, -1):  # from the front x_f^+ backwards
        xk = float(x[cols[k]])
        lab = np.full(ny, -1, dtype=np.int64)
        for start, length in line_runs[k]:
            rows = (start + np.arange(length)) % ny
            node = obj.add(xk)
            for p in np.unique(prev[rows]):
                if p >= 0:
                    obj.union(int(p), node)
            lab[rows] = node
            nodes[k].append(node)
        prev = lab
        best = max(best, obj.qualifying)
    in_finger = [[obj._q(obj.find(n)) for n in line] for line in nodes]
    return best, in_finger


def channel_numbers(
    line_runs, in_finger, cols, h, phi, speed, h_min: float, thr: float, u0: float | None
) -> dict:
    """Channel-centre speed, channel phi and levee speed over the counted fingers."""
    ny = h.shape[0]
    centre_speed, chan_phi, levee_speed = [], [], []
    for k, j in enumerate(cols):
        runs = [r for r, ok in zip(line_runs[k], in_finger[k]) if ok]
        if not runs:
            continue
        in_channel = np.zeros(ny, dtype=bool)
        for start, length in runs:
            rows = (start + np.arange(length)) % ny
            in_channel[rows] = True
            centre_speed.append(speed[(start + length // 2) % ny, j])
            chan_phi.extend(phi[rows, j])
        coarse = (h[:, j] >= h_min) & (phi[:, j] <= thr) & ~in_channel
        for start, length in periodic_runs(coarse):
            if in_channel[(start - 1) % ny] or in_channel[(start + length) % ny]:
                levee_speed.extend(speed[(start + np.arange(length)) % ny, j])

    def ratio(values):
        if not values or not u0:
            return math.nan
        return float(np.median(values)) / u0

    return {
        "channel_speed_over_u0": ratio(centre_speed),
        "channel_phi": float(np.mean(chan_phi)) if chan_phi else math.nan,
        "levee_speed_over_u0": ratio(levee_speed),
    }


__all__ = ["periodic_runs", "count_channels", "channel_numbers", "DEFAULT_MIN_SPAN"]
