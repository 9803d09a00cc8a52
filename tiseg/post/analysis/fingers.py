"""Finger diagnostics of section 6.3: front positions (6.10)-(6.12), finger count, wavelength, speeds.

All functions work on one snapshot of the primitive fields on the cell-centre grid, arrays of
shape (ny, nx) with ``x`` (length nx, downslope) and ``y`` (length ny, cross-slope, periodic),
or on a saved run (``fields.nc`` written by `tiseg.output.FieldsWriter`).

Front positions
---------------
* ``x_front_max`` = x_f^+ of (6.10). Read literally, (6.10) ``max{x : h < h_min}`` is the end of
  the domain (the slope ahead of the flow is empty). The intended meaning, and the dotted line of
  figure 15, is the furthest downstream extent of the flow, so here
  ``x_f^+ = max{x : h(x, y) >= h_min}``: the largest cell-centre x of any wet cell.
* ``x_front_min`` = x_f^- of (6.11): ``min{x : |phi - phi0| > phi0/2}`` taken over *wet* cells
  (h >= h_min) only; dry cells carry no grains (phi is meaningless there, often 0) and would
  otherwise make x_f^- the first empty cell. x_f^- marks the rear of the coarse-rich region
  (the large-particle islands behind the levees).
* ``elongation`` = x_l = x_f^+ - x_f^- of (6.12).

Positions are cell centres (no sub-cell interpolation), accurate to one grid spacing like the
set definitions of the paper on its grid.

Counting fingers (mean wavelength Lambda = Ly / count, section 6.3, figure 16a)
------------------------------------------------------------------------------------------
A finger is a fine-rich, mobile channel bounded by coarse-rich levees (or by empty slope).
Channel cells are wet (h >= h_min) and fine-rich (phi > ``phi_threshold``, default phi0/2, the
same "coarse-rich" boundary as (6.11)), and, optionally, fast (|u| >= ``min_speed_over_u0``
u0). On each cross-slope line (grid column) through the fingered zone x_f^- <= x <= x_f^+ they
form runs:

1. Channel cells form connected runs along y with **periodic wrap-around** (the domain is
   periodic in y, section 6.2), so a finger straddling the seam y = 0 = Ly counts once.
2. Noise filters, in this order: runs narrower than ``min_width`` are dropped (isolated fine
   cells in a levee are not fingers); then neighbouring runs separated by a gap narrower than
   ``min_gap`` are merged (an isolated coarse cell inside a channel does not split it). Both
   default to two grid cells, i.e. a single cell is treated as noise.
3. A line whose channel covers the whole circumference (after merging) has no levees: the
   front is uniform (e.g. monodisperse, phi = 1 everywhere) and the line counts 0; a line with no
   channel cell (all coarse, e.g. across the coarse head before break-up, or dry) also counts 0.
4. **The headline count** (default): the runs of neighbouring lines that touch are joined into
   2D channels, and the count is the number of distinct channels, each reaching at least
   ``min_span`` (default 0.1) of x_l downslope, before they join into the mixed flow behind
   the fingers (`tiseg.post.analysis.channels`). Each finger counts once whatever its length,
   so the count holds still while the fingers grow at different speeds.
5. With ``line_fractions`` given, only the lines x = x_f^- + f x_l (nearest column) are used and
   the count is their median (the lower median for an even number of lines).
6. ``finger_count_lines`` (a detail, the headline of earlier versions): the non-zero line count
   that persists over the longest downslope distance (ties go to the larger count), on at
   least ``min_persistence`` (default 0.1) of the lines and on at least two lines, else 0.
   While the fingers differ much in length it follows the single longest finger's tip.
7. Without a coarse-rich region (x_f^- undefined) there are no levees and the count is 0.

``wavelength`` = Ly / count, or None when the count is 0 (undefined).
``wavelength_spectral``: the dominant cross-slope wavelength of phi over the fingered zone from
its power spectrum, refined between the spectral bins (`tiseg.post.analysis.spectrum`): an
independent check of the count that needs no channel detection.

Channels and levees (`tiseg.post.analysis.channels`)
---------------------------------------------------
``channel_speed_over_u0`` (median speed on the channel centrelines over u0), ``channel_phi``
(mean phi in the channels) and ``levee_speed_over_u0`` (median speed of the coarse cells beside
them over u0), over the counted fingers.

Speeds
------
* ``max_channel_speed``: the largest speed |u| = (u^2 + v^2)^(1/2) (as plotted in figure 13) over
  channel cells (wet and phi > phi_threshold) with x_f^- <= x <= x_f^+; reported only when
  fingers were counted. ``max_channel_speed_over_u0`` divides by u0: the paper finds about 2 in
  the channels once fingers form.
* ``front_speed`` (runs only): d x_f^+/dt by the chord ``(x_f^+[i+1] - x_f^+[i-1]) /
  (t[i+1] - t[i-1])`` through the neighbouring output times, one-sided at the first and last
  time or next to a time without flow.

Runs without segregation
------------------------
A run without phi (``effects.segregation = false``: a dam break, a monodisperse flow) has
fronts, a front speed and a deposit but no fingers: `analyse_run` reports ``x_front_max``,
``front_speed`` and the deposit as for any run, and every finger number (x_f^-, x_l, the
count, the wavelengths, the channel and levee numbers) as None; ``segregation`` says which
kind of run it was.

Undefined quantities are None (JSON null), never NaN.
"""

from __future__ import annotations

from ...output.names import FIELDS_FILE, SCENE_FILE

import math
from pathlib import Path
from typing import Sequence

import numpy as np

from ...errors import InputError
from .channels import (
    DEFAULT_MIN_SPAN,
    channel_numbers,
    column_runs,
    count_channels,
    periodic_runs,
)
from .deposit import (
    DEFAULT_REST_SPEED,
    DEFAULT_SETTLE_FRACTION,
    cell_area,
    deposit_index,
    deposit_metrics,
    max_speed,
    momentum,
    thickness_change,
    travel_angle,
)
from .spectrum import spectral_wavelength

DEFAULT_MIN_PERSISTENCE = 0.1  # fraction of the lines in [x_f^-, x_f^+] the count must hold on
DEFAULT_NOISE_CELLS = 2  # default min_width and min_gap, in grid cells

# Per-time keys of `analyse_run` (in table order).
RUN_KEYS = (
    "time",
    "x_front_max",
    "x_front_min",
    "elongation",
    "finger_count",
    "wavelength",
    "wavelength_spectral",
    "front_speed",
    "front_speed_over_u0",
    "max_channel_speed",
    "max_channel_speed_over_u0",
    "channel_speed_over_u0",
    "channel_phi",
    "levee_speed_over_u0",
    "finger_count_lines",
)
# Version of the definitions above: stored in fingers.json, so that results computed with
# older definitions are recognised and recomputed from fields.nc (tiseg sweep does).
ANALYSIS_VERSION = 4


# =================================================================================================
# Front positions (6.10)-(6.12)
# =================================================================================================
def count_text(count) -> str:
    """A finger count in words for a message: "1 finger", "8 fingers" ("-" where unknown)."""
    if count is None:
        return "- fingers"
    return f"{count} finger" if count == 1 else f"{count} fingers"


def front_max(h, x, h_min: float) -> float:
    """x_f^+ (6.10): largest cell-centre x of a wet cell (h >= h_min); NaN without flow."""
    h = np.asarray(h, dtype=float)
    wet_cols = np.any(h >= h_min, axis=0)
    if not wet_cols.any():
        return math.nan
    return float(np.asarray(x, dtype=float)[wet_cols].max())


def front_min(h, phi, x, h_min: float, phi0: float) -> float:
    """x_f^- (6.11): smallest x of a wet cell with |phi - phi0| > phi0/2; NaN if there is none."""
    h = np.asarray(h, dtype=float)
    phi = np.asarray(phi, dtype=float)
    coarse = (h >= h_min) & (np.abs(phi - phi0) > 0.5 * phi0)
    cols = np.any(coarse, axis=0)
    if not cols.any():
        return math.nan
    return float(np.asarray(x, dtype=float)[cols].min())


# =================================================================================================
# One snapshot
# =================================================================================================
def finger_metrics(
    h,
    u,
    v,
    phi,
    x,
    y,
    h_min: float,
    phi0: float,
    u0: float | None = None,
    *,
    phi_threshold: float | None = None,
    line_fractions: Sequence[float] | None = None,
    min_persistence: float = DEFAULT_MIN_PERSISTENCE,
    min_span: float = DEFAULT_MIN_SPAN,
    min_width: float | None = None,
    min_gap: float | None = None,
    min_speed_over_u0: float | None = None,
    Ly: float | None = None,
) -> dict:
    """Finger diagnostics of one snapshot (see the module docstring for the definitions).

    ``h``, ``u``, ``v``, ``phi``: (ny, nx) arrays [m, m/s, m/s, -]; ``u`` or ``v`` may be None
    (then taken as 0, e.g. a 1D run without v). ``x``, ``y``: cell centres [m]. ``h_min``: wet
    threshold [m] (section 6.2); ``phi0``: inflow concentration; ``u0``: steady uniform speed
    [m/s] (for the speed ratios; None leaves them undefined).

    Options: ``phi_threshold`` (channel cells have phi above it; default phi0/2),
    ``line_fractions`` (None: the 2D channel count; else the median count on the lines
    x_f^- + f x_l), ``min_span`` (fraction of x_l a counted channel must reach; default 0.1),
    ``min_persistence`` (fraction of the columns the persistent line count
    ``finger_count_lines`` must hold on; default 0.1), ``min_width`` / ``min_gap`` [m] (noise
    filters; default two cells, 2 dy), ``min_speed_over_u0`` (channel cells must also move at
    |u| >= this times u0; default off), ``Ly`` [m] (domain width; default ny dy).

    Returns a dict with ``x_front_max``, ``x_front_min``, ``elongation`` [m], ``finger_count``
    (int), ``wavelength`` [m], ``wavelength_spectral`` [m], ``max_channel_speed`` [m/s],
    ``max_channel_speed_over_u0``, ``channel_speed_over_u0``, ``channel_phi``,
    ``levee_speed_over_u0``, ``finger_count_lines``, and
    the details ``line_x`` (x of the lines [m]), ``line_counts`` (count per line),
    ``count_length`` [m] (downslope length of the lines that show the chosen count) and
    ``channel_widths`` (widths [m] of the channels on the middle one of those lines).
    Undefined values are None.
    """
    h = np.asarray(h, dtype=float)
    phi = np.asarray(phi, dtype=float)
    x = np.asarray(x, dtype=float).reshape(-1)
    y = np.asarray(y, dtype=float).reshape(-1)
    if h.ndim == 1:  # a 1D run: one cell row
        h, phi = h[None, :], phi.reshape(1, -1)
    ny, nx = h.shape
    if phi.shape != h.shape:
        raise InputError(f"phi has shape {phi.shape}, h has {h.shape}")
    if x.size != nx or y.size != ny:
        raise InputError(
            f"coordinates x ({x.size}) and y ({y.size}) do not match the fields "
            f"of shape (ny, nx) = {h.shape}"
        )
    u = np.zeros_like(h) if u is None else np.asarray(u, dtype=float).reshape(h.shape)
    v = np.zeros_like(h) if v is None else np.asarray(v, dtype=float).reshape(h.shape)
    if not (math.isfinite(h_min) and h_min > 0):
        raise InputError(f"h_min={h_min!r} must be a positive number")
    if not (math.isfinite(phi0) and 0 < phi0 <= 1):
        raise InputError(f"phi0={phi0!r} must lie in (0, 1]")
    if u0 is not None and not (math.isfinite(u0) and u0 > 0):
        raise InputError(f"u0={u0!r} must be a positive number or None")
    fractions = None if line_fractions is None else [float(f) for f in line_fractions]
    if fractions is not None and (not fractions or any(not 0.0 <= f <= 1.0 for f in fractions)):
        raise InputError(f"line_fractions={list(line_fractions)!r}: give fractions in [0, 1]")
    if not (0.0 <= min_persistence <= 1.0):
        raise InputError(f"min_persistence={min_persistence!r} must lie in [0, 1]")
    if not (0.0 <= min_span <= 1.0):
        raise InputError(f"min_span={min_span!r} must lie in [0, 1]")

    dy = _spacing(y) if ny > 1 else (float(Ly) if Ly else 1.0)
    Ly = float(Ly) if Ly is not None else ny * dy
    thr, w_cells, g_cells = _settings(dy, phi0, phi_threshold, min_width, min_gap)

    speed = np.hypot(u, v)
    channel = (h >= h_min) & (phi > thr)
    if min_speed_over_u0 is not None:
        if u0 is None:
            raise InputError("min_speed_over_u0 needs u0")
        channel &= speed >= min_speed_over_u0 * u0

    xf_max = front_max(h, x, h_min)
    xf_min = front_min(h, phi, x, h_min, phi0)
    x_l = xf_max - xf_min  # NaN if either is undefined

    band: list[int] = []  # every column of the fingered zone
    if math.isfinite(x_l):
        band = [int(j) for j in np.flatnonzero((x >= xf_min) & (x <= xf_max))]
    band_runs = column_runs(channel[:, band], w_cells, g_cells)
    band_counts = band_runs.counts()
    if fractions is None:
        cols, line_runs = band, band_runs
    else:
        cols = [int(np.argmin(np.abs(x - (xf_min + f * x_l)))) for f in fractions] if band else []
        line_runs = column_runs(channel[:, cols], w_cells, g_cells)
    line_counts = line_runs.counts().tolist()
    # the persistent line count: the non-zero count held over the longest downslope distance
    count_lines = 0
    values, hits = np.unique(band_counts[band_counts > 0], return_counts=True)
    if values.size:
        best = int(np.flatnonzero(hits == hits.max())[-1])  # ties: the larger count
        if hits[best] >= max(2, min_persistence * len(band)):
            count_lines = int(values[best])
    # no lines (x_f^- undefined: no coarse-rich region, no levees) -> no segregation fingers
    count, in_finger = 0, np.zeros(band_runs.col.size, dtype=bool)
    if band:
        count, in_finger = count_channels(band_runs, band, x, min_span * x_l)
    if fractions is not None:
        count = sorted(line_counts)[(len(line_counts) - 1) // 2] if line_counts else 0
    chosen = [k for k, c in enumerate(line_counts) if c == count] if count else []
    widths = line_runs.of(chosen[len(chosen) // 2]) if chosen else []
    count_length = len(chosen) * _spacing(x) if chosen else math.nan
    numbers = channel_numbers(band_runs, in_finger, band, h, phi, speed, h_min, thr, u0)

    max_speed = math.nan
    if count > 0:
        zone = (x >= xf_min) & (x <= xf_max)
        sel = channel & zone[None, :]
        if sel.any():
            max_speed = float(speed[sel].max())

    return _none_for_nan(
        {
            "x_front_max": xf_max,
            "x_front_min": xf_min,
            "elongation": x_l,
            "finger_count": int(count),
            "wavelength": Ly / count if count > 0 else math.nan,
            "wavelength_spectral": spectral_wavelength(h, phi, band, Ly, h_min),
            "max_channel_speed": max_speed,
            "max_channel_speed_over_u0": max_speed / u0 if u0 else math.nan,
            **numbers,
            "finger_count_lines": count_lines,
            "line_x": [float(x[j]) for j in cols],
            "line_counts": line_counts,
            "count_length": count_length,
            "channel_widths": [n * dy for _, n in widths],
        }
    )


# =================================================================================================
# Time series
# =================================================================================================
def front_speed(times, x_front) -> list[float | None]:
    """d x_f^+/dt at each time by finite differences over the output times.

    Interior times use the chord through both neighbours, (x[i+1] - x[i-1]) / (t[i+1] - t[i-1])
    (the centred difference for equal spacing; a chord rather than a weighted three-point formula
    because x_f^+ moves in steps of one cell); the first / last time, or a time next to one
    without flow (x_f^+ undefined), use the one-sided difference with the neighbour that exists.
    None where no difference can be formed.
    """
    t = np.asarray(times, dtype=float)
    xf = np.array([math.nan if a is None else a for a in x_front], dtype=float)
    out: list[float | None] = []
    for i in range(t.size):
        if not math.isfinite(xf[i]):
            out.append(None)
            continue
        lo = i - 1 if i > 0 and math.isfinite(xf[i - 1]) else i
        hi = i + 1 if i + 1 < t.size and math.isfinite(xf[i + 1]) else i
        out.append(None if hi == lo else float((xf[hi] - xf[lo]) / (t[hi] - t[lo])))
    return out


def analyse_run(
    run_dir,
    *,
    time: float | None = None,
    phi0: float | None = None,
    u0: float | None = None,
    h_min: float | None = None,
    Ly: float | None = None,
    rest_speed: float = DEFAULT_REST_SPEED,
    settle_fraction: float = DEFAULT_SETTLE_FRACTION,
    **opts,
) -> dict:
    """Finger diagnostics of every output time of a saved run.

    ``run_dir``: a run folder holding ``fields.nc`` (as written by ``tiseg run``) or the path of
    a fields file itself. ``phi0``, ``u0``, ``h_min``, ``Ly`` default to the scene stored in the
    file's global attribute "scene" (``flow.phi0``, ``flow.u0``, ``numerics.h_min``,
    ``domain.Ly``), else to ``scene.toml`` next to it. ``time``: analyse only the output time
    equal to it (within 1e-6 relative); the front speed still uses the neighbouring times.
    Further keyword options go to `finger_metrics`.

    Returns ``{"analysis_version", "file", "phi0", "u0", "h_min", "Ly", "options", "times": n}``
    plus per-time lists under the keys of `RUN_KEYS`: ``time``, ``x_front_max``,
    ``x_front_min``, ``elongation``, ``finger_count``, ``wavelength``, ``wavelength_spectral``,
    ``front_speed``, ``front_speed_over_u0``, ``max_channel_speed``,
    ``max_channel_speed_over_u0``, ``channel_speed_over_u0``, ``channel_phi``,
    ``levee_speed_over_u0``, ``finger_count_lines`` (None where undefined), and ``deposit``:
    whether and when the flow stopped (at most ``rest_speed`` [m/s] anywhere) or settled (its
    momentum at most ``settle_fraction`` of its peak), its run-out and thickness
    (`tiseg.post.analysis.deposit.deposit_metrics`, with the per-time ``max_speed`` and
    ``momentum``), over all output times whatever ``time`` says.
    ``segregation``: whether the file has phi; without it every finger number is None and
    ``phi0`` and ``options["phi_threshold"]`` are those of the stored scene (or None), the
    fronts, front speed and deposit are as for any run.
    Raises `tiseg.errors.InputError` for a missing or unreadable file, a file without h
    or u, or a time that is not an output time.
    """
    path = _fields_path(run_dir)
    from ...output import read_fields
    from ...output.netcdf import TimeFrames

    try:
        ds = read_fields(path)
    except Exception as exc:  # netCDF4 / HDF5 errors have no common base class
        raise InputError(f"cannot read {str(path)!r} as a NetCDF fields file: {exc}") from None
    with ds:
        missing = [name for name in ("h", "u") if name not in ds.variables]
        if missing:
            raise InputError(
                f"{str(path)!r} has no {' and no '.join(missing)} field "
                "(the front and deposit analysis needs h and u)"
            )
        has_phi = "phi" in ds.variables
        if "time" not in ds.variables or "x" not in ds.variables or "y" not in ds.variables:
            raise InputError(f"{str(path)!r} lacks the time, x or y coordinate of a fields file")
        scene = None
        if None in (phi0, h_min) or u0 is None or Ly is None:
            scene = _stored_scene(ds, path)
        if scene is not None:
            phi0 = scene.flow.phi0 if phi0 is None else phi0
            h_min = scene.numerics.h_min if h_min is None else h_min
            u0 = scene.flow.u0 if u0 is None else u0
            Ly = scene.domain.Ly if Ly is None else Ly
        if h_min is None or (has_phi and phi0 is None):
            raise InputError(
                f"{str(path)!r} stores no readable scene: give "
                + ("phi0 and h_min" if has_phi else "h_min")
            )

        times = np.asarray(ds["time"].values, dtype=float)
        if times.size == 0:
            raise InputError(f"{str(path)!r} holds no snapshot yet: nothing to analyse")
        x = np.asarray(ds["x"].values, dtype=float)
        y = np.asarray(ds["y"].values, dtype=float)
        idx = list(range(times.size))
        if time is not None:
            idx = [_time_index(times, float(time), path)]

        # each variable's snapshots, read a block of times at once (every pass below visits
        # them all)
        frames = {name: TimeFrames(ds, name) for name in ("h", "u", "v", "phi") if name in ds}
        h_all, u_all = frames["h"], frames["u"]
        v_all, phi_all = frames.get("v"), frames.get("phi")
        # x_f^+ at every time (needs h only) so that the front speed has its neighbours
        xf_all = [front_max(h_all[i], x, h_min) for i in range(times.size)]
        speeds = front_speed(times, xf_all)
        # the deposit: the largest speed and the momentum at every time, the last snapshot's
        # thickness
        area = cell_area(x, y)
        flow, moms = [], []
        for i in range(times.size):
            h_i, u_i = h_all[i], u_all[i]
            v_i = v_all[i] if v_all is not None else None
            flow.append(max_speed(h_i, u_i, v_i, h_min))
            moms.append(momentum(h_i, u_i, v_i, h_min, area))
        k = deposit_index(flow, moms, rest_speed, settle_fraction)
        thr = _threshold(phi0, opts.get("phi_threshold"))
        last = times.size - 1
        deposit = deposit_metrics(
            times,
            flow,
            h_all[last],
            phi_all[last] if has_phi else None,
            x,
            y,
            h_min,
            thr,
            None if k is None else xf_all[k],
            rest_speed,
            momenta=moms,
            settle_fraction=settle_fraction,
            u_last=u_all[last],
            v_last=v_all[last] if v_all is not None else None,
        )
        if deposit["basis"] is not None and scene is not None:
            bed = np.asarray(ds["b"].values) if "b" in ds.variables else None
            found = travel_angle(
                h_all[0],
                h_all[last],
                x,
                y,
                bed,
                scene.material.zeta,
                h_min,
                line=scene.bed_line(),
            )
            if found is not None:
                deposit["travel_angle_deg"], deposit["drop"], deposit["reach"] = found
        if k is not None:
            deposit["thickness_change"] = thickness_change([h_all[i] for i in range(k, times.size)])
        deposit["max_speed"] = flow
        deposit["momentum"] = moms

        result = {k: [] for k in RUN_KEYS}
        for i in idx:
            snap = {
                name: (frames[name][i] if name in frames else None)
                for name in ("h", "u", "v", "phi")
            }
            if has_phi:
                m = finger_metrics(
                    snap["h"],
                    snap["u"],
                    snap["v"],
                    snap["phi"],
                    x,
                    y,
                    h_min,
                    phi0,
                    u0,
                    Ly=Ly,
                    **opts,
                )
            else:  # fronts only: no fingers without phi
                m = dict.fromkeys(RUN_KEYS)
                m["x_front_max"] = xf_all[i] if math.isfinite(xf_all[i]) else None
            sp = speeds[i]
            row = dict(
                m,
                time=float(times[i]),
                front_speed=sp,
                front_speed_over_u0=(sp / u0 if sp is not None and u0 else None),
            )
            for k in RUN_KEYS:
                result[k].append(row[k])

    # the settings finger_metrics used, resolved (defaults filled in, widths in whole cells)
    dy = _spacing(y)
    _, w_cells, g_cells = _settings(dy, 1.0, None, opts.get("min_width"), opts.get("min_gap"))
    fr = opts.get("line_fractions")
    options = {
        "phi_threshold": _threshold(phi0, opts.get("phi_threshold")),
        "line_fractions": None if fr is None else [float(f) for f in fr],
        "min_persistence": opts.get("min_persistence", DEFAULT_MIN_PERSISTENCE),
        "min_span": opts.get("min_span", DEFAULT_MIN_SPAN),
        "min_width": w_cells * dy,
        "min_gap": g_cells * dy,
        "min_width_cells": w_cells,
        "min_gap_cells": g_cells,
        "min_speed_over_u0": opts.get("min_speed_over_u0"),
    }
    head = {
        "analysis_version": ANALYSIS_VERSION,
        "file": str(path),
        "segregation": has_phi,
        "phi0": None if phi0 is None else float(phi0),
        "u0": None if u0 is None else float(u0),
        "h_min": float(h_min),
        "Ly": float(Ly) if Ly is not None else len(y) * _spacing(y),
        "options": options,
        "times": len(idx),
    }
    return {**head, **result, "deposit": deposit}


# =================================================================================================
# Helpers
# =================================================================================================
def _none_for_nan(d: dict) -> dict:
    return {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in d.items()}


def _settings(dy: float, phi0: float, phi_threshold, min_width, min_gap) -> tuple[float, int, int]:
    """(phi threshold, min_width in cells, min_gap in cells) with the defaults filled in."""
    thr = 0.5 * phi0 if phi_threshold is None else float(phi_threshold)

    def cells(w):
        # "narrower than w" [m]: keep runs of at least ceil(w / dy) cells (w = n dy keeps n)
        if w is None or not math.isfinite(dy):
            return DEFAULT_NOISE_CELLS
        if not (math.isfinite(w) and w >= 0):
            raise InputError(f"min_width / min_gap = {w!r} must be a non-negative length [m]")
        return max(1, math.ceil(w / dy - 1e-9))

    return thr, cells(min_width), cells(min_gap)


def _threshold(phi0, phi_threshold) -> float | None:
    """The channel threshold on phi: the given one, else phi0/2 (None without either)."""
    if phi_threshold is not None:
        return float(phi_threshold)
    return None if phi0 is None else 0.5 * float(phi0)


def _spacing(y) -> float:
    y = np.asarray(y, dtype=float)
    return float(np.median(np.diff(y))) if y.size > 1 else math.nan


def _fields_path(run_dir) -> Path:
    p = Path(run_dir)
    if p.is_dir():
        f = p / FIELDS_FILE
        if not f.is_file():
            raise InputError(f"run folder {str(p)!r} has no fields.nc (written by `tiseg run`)")
        return f
    if p.is_file():
        return p
    raise InputError(f"{str(p)!r} does not exist (give a run folder or a fields.nc file)")


def _stored_scene(ds, path: Path):
    """The scene stored with the run (file attribute, else scene.toml beside it), or None."""
    from ...setup.scene import scene_from_text

    text = ds.attrs.get("scene")
    where = f"the scene attribute of {str(path)!r}"
    if not isinstance(text, str):
        side = path.parent / SCENE_FILE
        if not side.is_file():
            return None
        text, where = side.read_text(encoding="utf-8"), repr(str(side))
    try:
        return scene_from_text(text)
    except InputError as exc:
        raise InputError(f"{where} is not a valid scene: {exc}") from None


def _time_index(times: np.ndarray, t: float, path: Path) -> int:
    if times.size == 0:
        raise InputError(f"{str(path)!r} holds no snapshots")
    i = int(np.argmin(np.abs(times - t)))
    if abs(times[i] - t) > 1e-6 * max(1.0, abs(t)):
        raise InputError(
            f"--time {t:g} is not an output time of {str(path)!r}; the nearest is "
            f"{times[i]:g} (output times {times[0]:g} .. {times[-1]:g} s)"
        )
    return i


__all__ = [
    "finger_metrics",
    "analyse_run",
    "front_max",
    "front_min",
    "front_speed",
    "periodic_runs",
    "RUN_KEYS",
    "ANALYSIS_VERSION",
    "DEFAULT_MIN_PERSISTENCE",
    "DEFAULT_MIN_SPAN",
    "DEFAULT_NOISE_CELLS",
]
