"""Deposits of a run that comes to rest: when the flow stopped, its run-out and thickness.

Read from the output snapshots (``fields.nc``), so the stop time is bracketed by two output
times. Definitions, with "wet" meaning h >= h_min as in (6.10):

* ``max_speed`` (per output time): the largest |u| (with v in 2D) over the wet cells.
* The flow is **at rest** at an output time when ``max_speed <= rest_speed`` (default
  `DEFAULT_REST_SPEED`; with ``numerics.friction_scheme = "projected"`` cells at rest
  have u = 0 exactly, while the regularised friction creeps at ~u_eps and never stops).
* ``stop_time``: the first output time from which the flow is at rest at every later output
  time; ``moving_until`` the output time before it (the flow stopped in between). None if the
  flow still moves at the last output time.
* ``momentum`` (per output time): the momentum of the wet cells, the sum of h |u| dx dy
  [m^4/s]. The flow has **settled** at an output time when the momentum is at most
  ``settle_fraction`` (default `DEFAULT_SETTLE_FRACTION`) of its largest value over the
  output times, a criterion on the moving mass as a whole, as avalanche codes use to end a
  run. ``settle_time`` / ``settling_until``: as ``stop_time`` / ``moving_until`` for it. A
  flow at rest has settled; one that has settled may still hold slow cells, such as the creep
  at ~u_eps of the regularised friction, which never stops.
  ``moving_cells`` / ``moving_volume`` / ``moving_max_speed``: the wet cells faster than
  ``rest_speed`` at the last output time, their volume [m^3] and largest speed [m/s].
* ``thickness_change``: the largest change of h in any cell between two consecutive output
  times from ``stop_time`` (else ``settle_time``) on [m]: exactly 0 for a deposit at rest
  (cells at rest keep their h bitwise), and how fixed a settled one is.
* ``basis``: ``"rest"`` when the flow stopped, ``"settled"`` when it settled without stopping,
  else None; the deposit numbers below are given in both cases, at that time.
* ``run_out``: x_f^+ (6.10) at ``stop_time`` (else ``settle_time``), the furthest downslope
  wet cell of the deposit [m]; ``run_out_at_domain_end`` says that the deposit reaches the last
  column, when material has left through the outflow and the run-out is only a lower bound.
* ``thickness_mean`` / ``thickness_max``: mean and largest h over the deposit (its wet cells)
  at the last output time [m]; ``channel_thickness`` / ``levee_thickness`` the mean h of its
  fine-rich (phi > phi_threshold) and coarse-rich cells, the locked-in channels and levees of
  figures 3(b) and 4(b); ``area`` [m^2] and ``volume`` [m^3] of the deposit.
* ``travel_angle_deg``: the Fahrboeschung (Heim 1932), the angle below the horizontal of the
  line from the release's top to the deposit's tip, with ``drop`` [m] and ``reach`` [m] its
  vertical and horizontal spans (`travel_angle`). The run-out x is measured along the bed
  line (the reference plane), as every x of the run.
"""

from __future__ import annotations

import math

import numpy as np

from ...model.material import REST_SPEED

DEFAULT_REST_SPEED = REST_SPEED  # [m/s] the flow is at rest where no wet cell is faster
# the flow has settled where its momentum is at most this fraction of its largest value
DEFAULT_SETTLE_FRACTION = 1e-5
DEPOSIT_KEYS = (
    "rest_speed",
    "stopped",
    "stop_time",
    "moving_until",
    "settle_fraction",
    "settled",
    "settle_time",
    "settling_until",
    "basis",
    "moving_cells",
    "moving_volume",
    "moving_max_speed",
    "run_out",
    "run_out_at_domain_end",
    "thickness_mean",
    "thickness_max",
    "channel_thickness",
    "levee_thickness",
    "area",
    "volume",
    "travel_angle_deg",
    "drop",
    "reach",
)


def cell_area(x, y) -> float:
    """dx dy of the grid of cell centres x, y [m^2] (a single cell's length counts as 1)."""
    dx = float(x[1] - x[0]) if len(x) > 1 else 1.0
    dy = float(y[1] - y[0]) if len(y) > 1 else 1.0
    return dx * dy


def _wet_speed(h, u, v, h_min: float):
    """(wet mask, |u| or |(u, v)|) of one snapshot."""
    h = np.asarray(h, dtype=float)
    s = np.abs(np.asarray(u, dtype=float))
    if v is not None:
        s = np.hypot(s, np.asarray(v, dtype=float))
    return h >= h_min, s


def max_speed(h, u, v, h_min: float) -> float | None:
    """Largest |u| over the wet cells of one snapshot (None without wet cells)."""
    wet, s = _wet_speed(h, u, v, h_min)
    if not wet.any():
        return None
    return float(s[wet].max())


def momentum(h, u, v, h_min: float, cell_area: float) -> float:
    """The momentum of the wet cells of one snapshot, sum of h |u| dx dy [m^4/s]."""
    wet, s = _wet_speed(h, u, v, h_min)
    return float((np.asarray(h, dtype=float)[wet] * s[wet]).sum() * cell_area)


def _first_of_last_run(flags) -> int | None:
    """Index of the first entry from which every later one is true; None if the last is
    not."""
    k = None
    for i in range(len(flags) - 1, -1, -1):
        if not flags[i]:
            break
        k = i
    return k


def stop_index(speeds, rest_speed: float = DEFAULT_REST_SPEED) -> int | None:
    """Index of the first output time from which every later one is at rest (a time without
    wet cells counts as at rest); None if the last one is not."""
    return _first_of_last_run([s is None or s <= rest_speed for s in speeds])


def settle_index(momenta, settle_fraction: float = DEFAULT_SETTLE_FRACTION) -> int | None:
    """Index of the first output time from which the momentum stays at most
    ``settle_fraction`` of its largest value over all the times; None if the last one is
    above it (or there are no times)."""
    if not len(momenta):
        return None
    limit = settle_fraction * max(momenta)
    return _first_of_last_run([m <= limit for m in momenta])


def thickness_change(frames) -> float:
    """The largest |h_{k+1} - h_k| over the cells and consecutive snapshots ``frames`` [m]
    (0 for fewer than two)."""
    out = 0.0
    for a, b in zip(frames[:-1], frames[1:]):
        out = max(out, float(np.abs(np.asarray(b, float) - np.asarray(a, float)).max()))
    return out


def travel_angle(h_start, h_deposit, x, y, b, zeta: float, h_min: float, line=None):
    """(angle [degrees], drop [m], reach [m]) of the line from the release's top to the
    deposit's tip, or None where either is empty.

    A point (x, y) of the bed, b normal to the plane inclined at zeta, lies at the horizontal
    distance X = x cos(zeta) + b sin(zeta) downslope and the height Z = -x sin(zeta) +
    b cos(zeta). On a run-out's bend (``line``, a `tiseg.model.bed_line.BedLine`; x the arc
    length) the reference point is the bed line's (X(x), Z(x)) and zeta its local
    inclination zeta(x). The top is the highest wet cell of ``h_start`` (the first snapshot; where it
    is empty, as under an inflow, the inlet's row x = 0 on its highest bed); the tip the
    furthest downslope wet cell of ``h_deposit`` (the lowest where several share that x). On a
    plane the angle is zeta; on a bed tilted by b = -s x it is zeta + atan(s). Arrays (ny, nx),
    x and y the cell centres."""
    X2, _ = np.meshgrid(np.asarray(x, dtype=float), np.asarray(y, dtype=float))
    bed = np.zeros_like(X2) if b is None else np.asarray(b, dtype=float)
    c, s = math.cos(zeta), math.sin(zeta)  # (on a bend: of the inlet x = 0, above it)
    if line is None:
        Z = -X2 * s + bed * c
        H = X2 * c + bed * s
    else:
        z = line.inclination(X2)
        X0, Z0 = line.coordinates(X2)
        Z = Z0 + bed * np.cos(z)
        H = X0 + bed * np.sin(z)
    dep = np.asarray(h_deposit, dtype=float) >= h_min
    if not dep.any():
        return None
    start = np.asarray(h_start, dtype=float) >= h_min
    if start.any():
        top = np.unravel_index(np.argmax(np.where(start, Z, -np.inf)), Z.shape)
        z_top, x_top = Z[top], H[top]
    else:  # an inflow: the inlet's edge x = 0
        j = int(np.argmax(bed[:, 0]))
        z_top, x_top = bed[j, 0] * c, bed[j, 0] * s
    far = np.where(dep, X2, -np.inf).max()
    tip = np.unravel_index(np.argmin(np.where(dep & (X2 == far), Z, np.inf)), Z.shape)
    drop, reach = float(z_top - Z[tip]), float(H[tip] - x_top)
    return math.degrees(math.atan2(drop, reach)), drop, reach


def deposit_index(
    speeds,
    momenta=None,
    rest_speed: float = DEFAULT_REST_SPEED,
    settle_fraction: float = DEFAULT_SETTLE_FRACTION,
) -> int | None:
    """The output time the deposit is reported at: the stop index if the flow stopped, else
    the settle index (None if neither; ``momenta`` None: the settling is not judged)."""
    k = stop_index(speeds, rest_speed)
    if k is None and momenta is not None:
        k = settle_index(momenta, settle_fraction)
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
    momenta=None,
    settle_fraction: float = DEFAULT_SETTLE_FRACTION,
    u_last=None,
    v_last=None,
) -> dict:
    """The deposit dict of `DEPOSIT_KEYS` (see the module docstring). ``speeds`` are
    the per-time `max_speed`, ``momenta`` the per-time `momentum` (None: the
    settling is not judged); ``h_last``, ``phi_last``, ``u_last``, ``v_last`` the last
    snapshot (ny, nx) (phi None without segregation, v None in 1D, u None: no moving cells
    counted); ``run_out``: x_f^+ at the stop time, else at the settle time, from the
    caller (at `deposit_index`)."""
    k = stop_index(speeds, rest_speed)
    ks = None if momenta is None else settle_index(momenta, settle_fraction)
    if k is not None and (ks is None or ks > k):
        ks = k  # at rest is settled
    out = dict.fromkeys(DEPOSIT_KEYS)
    out["rest_speed"] = float(rest_speed)
    out["settle_fraction"] = float(settle_fraction)
    out["stopped"] = k is not None
    out["settled"] = ks is not None
    h = np.asarray(h_last, dtype=float)
    da = cell_area(x, y)
    if u_last is not None:
        wet, s = _wet_speed(h, u_last, v_last, h_min)
        moving = wet & (s > rest_speed)
        out["moving_cells"] = int(moving.sum())
        out["moving_volume"] = float(h[moving].sum() * da)
        out["moving_max_speed"] = float(s[moving].max()) if moving.any() else 0.0
    if k is not None:
        out["stop_time"] = float(times[k])
        out["moving_until"] = float(times[k - 1]) if k > 0 else None
    if ks is not None:
        out["settle_time"] = float(times[ks])
        out["settling_until"] = float(times[ks - 1]) if ks > 0 else None
    if ks is None:
        return out
    out["basis"] = "rest" if k is not None else "settled"
    wet = h >= h_min
    out["run_out"] = None if run_out is None or not math.isfinite(run_out) else float(run_out)
    out["run_out_at_domain_end"] = bool(wet[:, -1].any())
    if wet.any():
        out["thickness_mean"] = float(h[wet].mean())
        out["thickness_max"] = float(h[wet].max())
        out["area"] = float(wet.sum() * da)
        out["volume"] = float(h[wet].sum() * da)
        if phi_last is not None:
            phi = np.asarray(phi_last, dtype=float)
            fine = wet & (phi > phi_threshold)
            coarse = wet & ~(phi > phi_threshold)
            out["channel_thickness"] = float(h[fine].mean()) if fine.any() else None
            out["levee_thickness"] = float(h[coarse].mean()) if coarse.any() else None
    return out


def deposit_when(d: dict) -> str:
    """'between t = a and b s' / 'by t = b s': when the flow stopped, else settled."""
    t, before = (
        (d["stop_time"], d["moving_until"])
        if d["stopped"]
        else (d["settle_time"], d["settling_until"])
    )
    return f"between t = {before:g} and {t:g} s" if before is not None else f"by t = {t:g} s"


def still_moving(d: dict) -> str:
    """What still moves in a flow that settled without coming to rest."""
    n = d["moving_cells"]
    if n is None:
        return f"momentum below {d['settle_fraction']:g} of its peak"
    return (
        f"momentum below {d['settle_fraction']:g} of its peak, but {n} cell"
        f"{'' if n == 1 else 's'} ({d['moving_volume']:.3g} m^3) still move at up to "
        f"{d['moving_max_speed']:.3g} m/s"
    )
