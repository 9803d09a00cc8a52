"""Deposits of a run that comes to rest: when the flow stopped, its run-out and thickness.

Read from the output snapshots (``fields.nc``), so the stop time is bracketed by two output
times. Definitions, with "wet" meaning h >= h_min as in (6.10):

* ``max_speed`` (per output time): the largest |u| (with v in 2D) over the wet cells.
* The flow is **at rest** at an output time when ``max_speed <= rest_speed`` (default
  :data:`DEFAULT_REST_SPEED`; with ``numerics.friction_scheme = "projected"`` cells at rest
  have u = 0 exactly, while the regularised friction creeps at ~u_eps and never stops).
* ``stop_time``: the first output time from which the flow is at rest at every later output
  time; ``moving_until`` the output time before it (the flow stopped in between). None if the
  flow still moves at the last output time.
* ``run_out``: x_f^+ (6.10) at ``stop_time``, the furthest downslope wet cell of the deposit
  [m]; ``run_out_at_domain_end`` says that the deposit reaches the last column, when material
  has left through the outflow and the run-out is only a lower bound.
* ``thickness_mean`` / ``thickness_max``: mean and largest h over the deposit (its wet cells)
  at the last output time [m]; ``channel_thickness`` / ``levee_thickness`` the mean h of its
  fine-rich (phi > phi_threshold) and coarse-rich cells, the locked-in channels and levees of
  figures 3(b) and 4(b); ``area`` [m^2] and ``volume`` [m^3] of the deposit.
"""

from __future__ import annotations

import math

import numpy as np

DEFAULT_REST_SPEED = 1e-6  # [m/s] the flow is at rest where no wet cell is faster
DEPOSIT_KEYS = (
    "rest_speed",
    "stopped",
    "stop_time",
    "moving_until",
    "run_out",
    "run_out_at_domain_end",
    "thickness_mean",
    "thickness_max",
    "channel_thickness",
    "levee_thickness",
    "area",
    "volume",
)


def max_speed(h, u, v, h_min: float) -> float | None:
    """Largest |u| over the wet cells of one snapshot (None without wet cells)."""
    h = np.asarray(h, dtype=float)
    wet = h >= h_min
    if not wet.any():
        return None
    s = np.abs(np.asarray(u, dtype=float))
    if v is not None:
        s = np.hypot(s, np.asarray(v, dtype=float))
    return float(s[wet].max())


def stop_index(speeds, rest_speed: float = DEFAULT_REST_SPEED) -> int | None:
    """Index of the first output time from which every later one is at rest (a time without
    wet cells counts as at rest); None if the last one is not."""
    k = None
    for i in range(len(speeds) - 1, -1, -1):
        s = speeds[i]
        if s is not None and not s <= rest_speed:
            break
        k = i
    return k


def deposit_metrics(
    times,
    speeds,
    h_last,
    phi_last,
    x,
    y,
    h_min: float,
    phi_threshold: float,
    run_out: float | None,
    rest_speed: float = DEFAULT_REST_SPEED,
) -> dict:
    """The deposit dict of :data:`DEPOSIT_KEYS` (see the module docstring). ``speeds`` are
    the per-time :func:`max_speed`; ``h_last``, ``phi_last`` the last snapshot (ny, nx) (phi
    None without segregation); ``run_out``: x_f^+ at the stop time, from the caller."""
    k = stop_index(speeds, rest_speed)
    out = dict.fromkeys(DEPOSIT_KEYS)
    out["rest_speed"] = float(rest_speed)
    out["stopped"] = k is not None
    if k is None:
        return out
    out["stop_time"] = float(times[k])
    out["moving_until"] = float(times[k - 1]) if k > 0 else None
    h = np.asarray(h_last, dtype=float)
    wet = h >= h_min
    dx = float(x[1] - x[0]) if len(x) > 1 else 1.0
    dy = float(y[1] - y[0]) if len(y) > 1 else 1.0
    out["run_out"] = None if run_out is None or not math.isfinite(run_out) else float(run_out)
    out["run_out_at_domain_end"] = bool(wet[:, -1].any())
    if wet.any():
        out["thickness_mean"] = float(h[wet].mean())
        out["thickness_max"] = float(h[wet].max())
        out["area"] = float(wet.sum() * dx * dy)
        out["volume"] = float(h[wet].sum() * dx * dy)
        if phi_last is not None:
            phi = np.asarray(phi_last, dtype=float)
            fine = wet & (phi > phi_threshold)
            coarse = wet & ~(phi > phi_threshold)
            out["channel_thickness"] = float(h[fine].mean()) if fine.any() else None
            out["levee_thickness"] = float(h[coarse].mean()) if coarse.any() else None
    return out
