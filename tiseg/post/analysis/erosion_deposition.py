"""Erosion-deposition wave diagnostics of 1D profiles h(x), u(x) (the `erosion-deposition`
scene; Edwards & Gray 2015).

A wave travelling down a static layer of thickness h_l has three parts, each found from one
snapshot by `wave_profile`:

* the erosion front x_e: the downslope end of the moving material (u > 0); ahead of it the
  layer is still exactly at rest;
* the crest: the largest thickness h_c, its position x_c and the amplitude h_c - h_l;
* the deposition point x_d: the upslope end of the moving material; behind it the grains the
  wave left are at rest again, with the deposit thickness h_d (their mean).

`front_speeds` fits straight lines x(t) to each over a stretch of snapshots (least squares),
and says how far the speed in each half of the stretch strays from the whole (a steady wave
moves at one speed).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class WaveProfile:
    x_e: float  # erosion front [m]
    x_c: float  # crest position [m]
    h_c: float  # crest thickness [m]
    x_d: float  # deposition point [m] (upslope end of the moving material)
    h_d: float  # mean thickness of the deposit at rest behind x_d [m] (nan if none)
    length: float  # x_e - x_d, the length of the moving wave [m]


def wave_profile(x: np.ndarray, h: np.ndarray, u: np.ndarray, skip: float = 0.0) -> WaveProfile:
    """The parts of one profile (see the module). ``skip`` [m]: the stretch next to the inlet
    left out of the deposit's mean (where the inflow's own tail comes to rest)."""
    x, h, u = (np.asarray(a, dtype=float).ravel() for a in (x, h, u))
    moving = np.nonzero(u != 0.0)[0]
    if moving.size == 0:
        raise ValueError("no moving material: there is no wave")
    i_d, i_e = int(moving[0]), int(moving[-1])
    i_c = i_d + int(np.argmax(h[i_d : i_e + 1]))
    behind = (x >= skip) & (np.arange(x.size) < i_d)
    h_d = float(h[behind].mean()) if behind.any() else float("nan")
    return WaveProfile(
        x_e=float(x[i_e]),
        x_c=float(x[i_c]),
        h_c=float(h[i_c]),
        x_d=float(x[i_d]),
        h_d=h_d,
        length=float(x[i_e] - x[i_d]),
    )


def line_speed(t: np.ndarray, pos: np.ndarray) -> tuple[float, float]:
    """(speed, relative spread): the least-squares slope of pos(t), and the largest relative
    difference between it and the slopes of the two halves of the stretch."""
    t, pos = np.asarray(t, dtype=float), np.asarray(pos, dtype=float)
    c = float(np.polyfit(t, pos, 1)[0])
    m = t.size // 2
    halves = [np.polyfit(t[: m + 1], pos[: m + 1], 1)[0], np.polyfit(t[m:], pos[m:], 1)[0]]
    return c, float(max(abs(s / c - 1.0) for s in halves)) if c else float("inf")


def front_speeds(t: np.ndarray, profiles: list[WaveProfile]) -> dict[str, tuple[float, float]]:
    """{part: (speed [m/s], relative spread)} of the erosion front, crest and deposition
    point over the snapshots at times ``t``."""
    return {
        name: line_speed(t, [getattr(p, attr) for p in profiles])
        for name, attr in (("erosion", "x_e"), ("crest", "x_c"), ("deposition", "x_d"))
    }
