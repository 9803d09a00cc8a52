"""What accuracy costs in time: error against wall time on problems with known answers.

``tiseg bench accuracy --out DIR [--quick]`` runs every combination of

* resolution (per problem, below),
* reconstruction: first-order, minmod (theta: ``--thetas``), weno,
* flux: kt, central-upwind (``--fluxes``) and the h phi flux: central, upwind
  (``--phi-fluxes``); by default only the scenes' kt + central,
* stepper: rkc, ssprk3, euler (a run that blows up is recorded as ``unstable``),
* precision: f32, f64 (each in its own process: Taichi's precision is process-wide),
* backend: cpu, and gpu where one is present,

on these problems:

``transport``  T6b of NUMERICS: smooth large-particle transport with h, u held uniform by a
               Coulomb friction equal to tan(zeta), periodic, to half the breaking time; exact
               solution by characteristics. Error: mean |phi - phi_exact| of the cell averages.
``ritter``     T2: frictionless dam break onto a dry bed at t = 0.1 s; exact Ritter solution.
               Error: relative L1 error of h against exact cell averages.
``growth``     T7: the most unstable linear mode of the uniform flow (h0 = 2 mm, phi0 = 0.8,
               nu = 0.01, k = 0.2399); growth rate fitted over 12 h0/u0 against the eigenvalue of
               the linearised equations. Error: relative error of the growth rate. The amplitude
               is 1e-4 (the scene's 1e-6 is below f32 resolution of h0 + perturbation).
``fingers``    the fingers scene (on a 0.8 m long chute, which the front does not reach) at
               t = 2 s: front position x_f^+ against the finest run (1.5 x the finest study
               resolution, weno + rkc + f64). Error: |x_f^+ - x_f^+,ref| / x_f^+,ref. x_f^+ is
               ``tiseg.analysis.fingers.front_max`` refined to the h = h_min crossing between
               the last wet cell and the next (:func:`front_position`): the cell centre alone
               moves in steps of dx and made the errors 0 or multiples of dx by accident.
``fingers-late``  the same front after it has broken into fingers: the fingers scene on its own
               1.5 m chute, 0.25 m wide (two to three fingers), at t = 7.5 s, the scene's end
               time, against a 300 cells/m weno + rkc + f64 run. Late in the run the viscous
               and friction stiffness of the thin levees set dt rho ~ 2-4, where the single-stage
               steppers must shorten their steps and RKC does not: this problem decides which
               stepper the scene should use, the early front above cannot.
``channel``    the built-in ``channel`` scene at t = 3 s: a straight fine channel between coarse
               levees, periodic both ways, whose exact phi never changes (no mass crosses the
               contacts). Error: mean |phi - phi_exact|; value: phi at the channel centre.
               What numerical diffusion across contacts costs.
``channel-speed``  the same runs scored on u(y) against the steady cross-slope profile of
               :mod:`tiseg.steady_channel` (scipy's solve_bvp): relative L1 error.

Wall time is the time of the simulation alone (Taichi kernels compiled beforehand by one
warm-up step, error evaluation excluded), the minimum over 3 repeats for runs under 1 s and 2
for runs under 5 s (see :data:`REPEATS`). Output: ``accuracy.csv`` (one row per point), one ``<problem>.png`` per problem with the
Pareto front (the points no other point beats in both error and wall time), and
``summary.json`` / ``summary.md`` saying whether the scenes' defaults (weno + rkc + f64,
cfl 0.25) sit on the front.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Sequence

import numpy as np

from . import available_backends, log_stderr, machine_info, machine_line, run_child
from ..exact_dambreak import cell_averages, ritter

RECONSTRUCTIONS = ("first-order", "minmod", "weno")
STEPPERS = ("rkc", "ssprk3", "euler")
PRECISIONS = ("f32", "f64")
DEFAULT_COMBO = {
    "reconstruction": "weno",
    "flux": "kt",
    "phi_flux": "upwind",
    "stepper": "rkc",
    "precision": "f64",
    "backend": "cpu",
    "cfl": 0.25,
}
# numerics a point leaves unset take these (theta only matters for minmod)
DEFAULT_SCHEME = {
    "reconstruction": "weno",
    "theta": 1.5,
    "flux": "kt",
    "phi_flux": "upwind",
    "cfl": 0.25,
}
# what rows from before the flux options (no theta / flux / phi_flux columns) were run with
LEGACY_SCHEME = {"theta": 1.5, "flux": "kt", "phi_flux": "central"}
COLUMNS = (
    "problem",
    "resolution",
    "reconstruction",
    "stepper",
    "precision",
    "backend",
    "error",
    "wall_s",
    "steps",
    "rhs_evals",
    "cells",
    "cfl",
    "value",
    "status",
    "pareto",
    "theta",
    "flux",
    "phi_flux",
)  # (the scheme's last three came later: appended)

# On a shared machine other jobs steal cores at random moments and a parallel kernel waits for
# its slowest thread, so single timings scatter by 2-3x; the minimum over a few repeats is what
# the code costs without interference. Short runs are repeated more often (they are cheap).
REPEATS = ((1.0, 3), (5.0, 2))  # (runs shorter than this many seconds, are timed this often)


def repeats_for(wall: float) -> int:
    """How many timed repeats a run of this (best so far) wall time gets."""
    for limit, n in REPEATS:
        if wall < limit:
            return n
    return 1


SPEED_LIMIT = 10.0  # [m/s] nothing in these problems moves faster: beyond it a run blew up
STEP_LIMIT = 200_000


# =================================================================================================
# Problems
# =================================================================================================
@dataclass(frozen=True)
class Problem:
    """A reference problem: how to build its scene, run it, and score the result.

    ``run(sim)`` advances the simulation (timed) and returns raw data; ``score(raw, scene)``
    turns it into (value, error) outside the timing. ``resolution`` means what
    ``resolution_label`` says (cells per period, cells on the domain, cells per metre)."""

    name: str
    title: str
    error_label: str
    resolution_label: str
    resolutions: tuple[int, ...]
    quick_resolutions: tuple[int, ...]
    build: Callable
    run: Callable
    score: Callable
    reference_resolution: dict | None = None  # {"full": r, "quick": r} for relative problems


PERIODIC = {"x_lo": "periodic", "x_hi": "periodic", "y_lo": "periodic", "y_hi": "periodic"}


NUMERICS_KEYS = ("reconstruction", "theta", "flux", "phi_flux", "stepper", "cfl")


def _numerics(point: dict, stepper: str | None = None) -> dict:
    """The scene's numerics section of a point (its stepper replaced by ``stepper`` if given)."""
    num = {k: point.get(k, DEFAULT_SCHEME[k]) for k in NUMERICS_KEYS if k != "stepper"}
    num["stepper"] = stepper or point["stepper"]
    return num


def _overrides(num: dict) -> dict:
    return {f"numerics.{k}": v for k, v in num.items()}


# ---- (a) T6b smooth transport ------------------------------------------------------------------
T6B_L, T6B_U0, T6B_H0, T6B_AMP, T6B_MEAN = 0.1, 0.2, 0.002, 0.25, 0.5
T6B_T_END = 0.5 * 7 * T6B_L / (12 * T6B_U0 * T6B_AMP * 2 * math.pi)  # half the breaking time


def _transport_build(res, num, quick):
    from ..scene import scene_from_dict

    d = {
        "flow": {"h0": T6B_H0, "phi0": T6B_MEAN, "nu": 0.0, "u0": T6B_U0},
        # friction equal to the slope keeps h and u exactly uniform: phi alone evolves
        "effects": {
            "friction": "coulomb",
            "coulomb_mu": math.tan(math.radians(27.0)),
            "viscosity": False,
            "mobility_feedback": False,
        },
        "domain": {"nx": res, "ny": 1},
        "boundary": dict(PERIODIC),
        "initial": {
            "kind": "uniform",
            "amplitude": T6B_AMP,
            "mode": "phi",
            "k": 2 * math.pi * T6B_H0 / T6B_L,
            "wavelengths": 1,
        },
        "numerics": dict(num),
        "time": {"t_end": T6B_T_END},
    }
    return scene_from_dict(d, name="bench-transport")


def _transport_run(sim, on_step):
    sim.advance(sim.scene.t_end, on_step)
    return sim.fields()["phi"][0]


def transport_exact(x, t, L=T6B_L, u0=T6B_U0, mean=T6B_MEAN, amp=T6B_AMP):
    """phi of phi_t + (u0 (phi - G(phi)))_x = 0, phi(x, 0) = mean + amp cos(2 pi x / L), by
    characteristics phi = phi(x - u0 (1 - G'(phi)) t, 0); vectorised bisection (the root is
    unique before the breaking time)."""
    x = np.asarray(x, dtype=float)
    lo = np.full_like(x, mean - amp - 1e-12)
    hi = np.full_like(x, mean + amp + 1e-12)
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        speed = u0 * (1.0 / 7.0 + 12.0 * mid / 7.0)  # u0 (1 - G'(phi)), alpha = 1/7
        f = mid - (mean + amp * np.cos(2 * np.pi * (x - speed * t) / L))
        lo = np.where(f < 0, mid, lo)
        hi = np.where(f < 0, hi, mid)
    return 0.5 * (lo + hi)


def _transport_score(phi, scene):
    x, _ = scene.domain.cell_centres()
    # exact cell averages by 3-point Gauss quadrature (error << the scheme's)
    g = np.array([-math.sqrt(0.6), 0.0, math.sqrt(0.6)]) * 0.5 * scene.dx
    w = np.array([5.0, 8.0, 5.0]) / 18.0
    exact = sum(wk * transport_exact(x + gk, scene.t_end) for gk, wk in zip(g, w))
    return float("nan"), float(np.mean(np.abs(phi - exact)))


# ---- (b) T2 Ritter dam break -------------------------------------------------------------------
RITTER_T, RITTER_HL, RITTER_X0 = 0.1, 0.002, 0.1


def _ritter_build(res, num, quick):
    from ..scene import load_scene

    # tiny h_min / h_eps so that the thin tip is not cut off (NUMERICS T2)
    return load_scene(
        "dam-break",
        {
            "domain.nx": res,
            "time.t_end": RITTER_T,
            "numerics.h_min": 1e-7,
            "numerics.h_eps": 1e-9,
            **_overrides(num),
        },
    )


def _ritter_run(sim, on_step):
    sim.advance(RITTER_T, on_step)
    return sim.fields()["h"][0]


def _ritter_score(h, scene):
    x, _ = scene.domain.cell_centres()
    exact = cell_averages(lambda p: ritter(p, RITTER_T, RITTER_HL, RITTER_X0)[0], x, scene.dx)
    return float("nan"), float(np.sum(np.abs(h - exact)) / np.sum(exact))


# ---- (c) T7 linear growth rate -----------------------------------------------------------------
GROWTH_AMPLITUDE = 1e-4
GROWTH_SAMPLES = 49  # amplitude samples over 12 h0/u0 for the exponential fit


def _growth_build(res, num, quick):
    from ..scene import load_scene

    return load_scene(
        "uniform-flow",
        {
            "domain.nx": res,
            "domain.Lx": None,
            "initial.amplitude": GROWTH_AMPLITUDE,
            **_overrides(num),
        },
    )


def _growth_run(sim, on_step):
    sc = sim.scene
    t_end = 12 * sc.flow.h0 / sc.flow.u0
    ts, amp = [], []
    for j in range(GROWTH_SAMPLES):
        sim.advance(t_end * j / (GROWTH_SAMPLES - 1), on_step)
        c = np.fft.rfft(sim.conserved()[0, :, 0])[1]
        ts.append(sim.t)
        amp.append(abs(c))
    return np.array(ts), np.array(amp)


def _growth_score(raw, scene):
    from ..initial import eigenmode

    ts, amp = raw
    lam, _ = eigenmode(scene)
    sigma = lam.real * scene.flow.u0 / scene.flow.h0
    late = slice(GROWTH_SAMPLES // 4, None)  # the other (damped) modes have died out by then
    with np.errstate(divide="ignore", invalid="ignore"):
        rate = np.polyfit(ts[late], np.log(amp[late]), 1)[0]
    return float(rate), float(abs(rate - sigma) / abs(sigma))


# ---- (d) fingers front position ----------------------------------------------------------------
FINGERS_T = {"full": 2.0, "quick": 1.0}
FINGERS_LX, FINGERS_LY = 0.8, 0.5


def _fingers_build(res, num, quick):
    from ..scene import load_scene

    t = FINGERS_T["quick" if quick else "full"]
    return load_scene(
        "fingers",
        {
            "domain.resolution": res,
            "domain.Lx": FINGERS_LX,
            "domain.Ly": FINGERS_LY,
            "time.t_end": t,
            "output.times": [],
            "output.interval": t,
            **_overrides(num),
        },
    )


FINGERS_LATE_T = {"full": 7.5, "quick": 5.5}
FINGERS_LATE_LY = 0.25


def _fingers_late_build(res, num, quick):
    from ..scene import load_scene

    t = FINGERS_LATE_T["quick" if quick else "full"]
    return load_scene(
        "fingers",
        {
            "domain.resolution": res,
            "domain.Ly": FINGERS_LATE_LY,
            "time.t_end": t,
            "output.times": [],
            "output.interval": t,
            **_overrides(num),
        },
    )


def _fingers_run(sim, on_step):
    sim.advance(sim.scene.t_end, on_step)
    return sim.fields()["h"]


def front_position(h, x, h_min: float) -> float:
    """x_f^+ with sub-cell resolution: where the cross-slope maximum of h falls through h_min,
    linearly interpolated between the last wet cell centre and the next one.

    ``tiseg.analysis.fingers.front_max`` (the last wet cell centre) moves in steps of dx, so
    its error against a finer run is 0 or a multiple of dx by the accident of where the cell
    centres fall; the interpolated crossing converges smoothly. NaN without flow."""
    from ..analysis.fingers import front_max

    h = np.asarray(h, dtype=float)
    x = np.asarray(x, dtype=float)
    xf = front_max(h, x, h_min)
    if not math.isfinite(xf):
        return xf
    top = h.max(axis=0)
    i = int(np.nonzero(x == xf)[0][0])
    if i + 1 >= len(x):
        return xf
    frac = (top[i] - h_min) / max(top[i] - top[i + 1], 1e-300)
    return float(x[i] + min(max(frac, 0.0), 1.0) * (x[i + 1] - x[i]))


def _fingers_score(h, scene):
    x, _ = scene.domain.cell_centres()
    # the error needs the reference run: the parent fills it in (see _fill_relative_errors)
    return front_position(h, x, scene.numerics.h_min), float("nan")


# ---- (e) the straight channel: sharp contacts and the cross-slope speed profile ---------------
CHANNEL_T = {"full": 3.0, "quick": 1.0}


def _channel_build(res, num, quick):
    from ..scene import load_scene

    t = CHANNEL_T["quick" if quick else "full"]
    return load_scene(
        "channel",
        {"domain.resolution": res, "time.t_end": t, "output.interval": t, **_overrides(num)},
    )


def _channel_run(sim, on_step):
    sim.advance(sim.scene.t_end, on_step)
    f = sim.fields()
    return {"phi": f["phi"][:, 0], "u": f["u"][:, 0]}


def _channel_cells(scene):
    from ..initial import channel_fraction

    y = (np.arange(scene.domain.ny) + 0.5) * scene.dy
    return y, channel_fraction(y, scene.dy, scene.domain.Ly, scene.initial.width)


def _channel_score(raw, scene):
    """phi at the channel centre, and the mean |phi - phi_exact| (phi_exact: the initial cell
    averages, which the exact solution keeps for ever)."""
    ini = scene.initial
    y, frac = _channel_cells(scene)
    exact = ini.phi_levee + (ini.phi_channel - ini.phi_levee) * frac
    centre = float(np.mean(raw["phi"][np.abs(y - 0.5 * scene.domain.Ly) < scene.dy]))
    return centre, float(np.mean(np.abs(raw["phi"] - exact)))


def _channel_speed_score(raw, scene):
    """u at the channel centre, and the relative L1 error of u(y) against the cell averages of
    the steady cross-slope profile (tiseg.steady_channel; steady to 1e-3 by t = 3 s)."""
    from ..steady_channel import channel_profile

    y, _ = _channel_cells(scene)
    exact = channel_profile(scene).cell_averages(y, scene.dy)
    centre = float(np.mean(raw["u"][np.abs(y - 0.5 * scene.domain.Ly) < scene.dy]))
    return centre, float(np.sum(np.abs(raw["u"] - exact)) / np.sum(np.abs(exact)))


PROBLEMS: dict[str, Problem] = {
    p.name: p
    for p in (
        Problem(
            "transport",
            "T6b smooth transport (exact by characteristics)",
            "mean |phi - phi_exact|",
            "cells per period",
            (25, 50, 100, 200, 400),
            (50, 100),
            _transport_build,
            _transport_run,
            _transport_score,
        ),
        Problem(
            "ritter",
            "T2 Ritter dam break (exact)",
            "relative L1 error of h",
            "cells on 0.3 m",
            (100, 200, 400, 800, 1600),
            (100, 200),
            _ritter_build,
            _ritter_run,
            _ritter_score,
        ),
        Problem(
            "growth",
            "T7 linear growth rate of the uniform-flow mode",
            "relative error of sigma",
            "cells per wavelength",
            (16, 32, 64, 128),
            (16, 32),
            _growth_build,
            _growth_run,
            _growth_score,
        ),
        Problem(
            "fingers",
            "fingers: front position x_f+ (sub-cell) at t = 2 s vs the finest run",
            "|x_f+ - x_f+,ref| / x_f+,ref",
            "cells per metre",
            (50, 100, 150, 200),
            (40, 60),
            _fingers_build,
            _fingers_run,
            _fingers_score,
            reference_resolution={"full": 300, "quick": 80},
        ),
        Problem(
            "fingers-late",
            "fingers: front position x_f+ (sub-cell) at t = 7.5 s, after "
            "fingering, vs the finest run",
            "|x_f+ - x_f+,ref| / x_f+,ref",
            "cells per metre",
            (100, 150, 200),
            (40, 60),
            _fingers_late_build,
            _fingers_run,
            _fingers_score,
            reference_resolution={"full": 300, "quick": 80},
        ),
        Problem(
            "channel",
            "channel: phi kept across contacts no mass crosses, t = 3 s (exact: unchanged)",
            "mean |phi - phi_exact|",
            "cells per metre",
            (250, 375, 500, 750, 1000),
            (250, 500),
            _channel_build,
            _channel_run,
            _channel_score,
        ),
        Problem(
            "channel-speed",
            "channel: speed profile u(y) at t = 3 s vs the steady cross-slope solution",
            "relative L1 error of u",
            "cells per metre",
            (250, 375, 500, 750, 1000),
            (250, 500),
            _channel_build,
            _channel_run,
            _channel_speed_score,
        ),
    )
}


# =================================================================================================
# The plan and one point
# =================================================================================================
QUICK_RECONSTRUCTIONS = ("minmod", "weno")
QUICK_STEPPERS = ("rkc", "ssprk3")


def plan_points(
    quick: bool,
    problems: Sequence[str] | None = None,
    reconstructions: Sequence[str] | None = None,
    steppers: Sequence[str] | None = None,
    cfls: Sequence[float] = (0.25,),
    fluxes: Sequence[str] = ("kt",),
    phi_fluxes: Sequence[str] = ("upwind",),
    thetas: Sequence[float] = (1.5,),
) -> list[dict]:
    """Every (problem, resolution, reconstruction [x theta for minmod], flux, phi_flux, stepper,
    cfl) of the study, plus the reference run of each problem measured against a finer run
    (flag ``reference``).

    ``quick``: two resolutions per problem and, unless given, minmod/weno x rkc/ssprk3."""
    from ..errors import InputError

    reconstructions = reconstructions or (QUICK_RECONSTRUCTIONS if quick else RECONSTRUCTIONS)
    steppers = steppers or (QUICK_STEPPERS if quick else STEPPERS)
    names = list(problems) if problems else list(PROBLEMS)
    for n in names:
        if n not in PROBLEMS:
            raise InputError(f"problem {n!r} is not known; choose from {', '.join(PROBLEMS)}")
    schemes = []
    for rec in reconstructions:
        for th in thetas if rec == "minmod" else (DEFAULT_SCHEME["theta"],):
            for fl in fluxes:
                for pf in phi_fluxes:
                    schemes.append(
                        {"reconstruction": rec, "theta": float(th), "flux": fl, "phi_flux": pf}
                    )
    pts = []
    for n in names:
        p = PROBLEMS[n]
        for res in p.quick_resolutions if quick else p.resolutions:
            for sch in schemes:
                for st in steppers:
                    for cfl in cfls:
                        pts.append(
                            {
                                "problem": n,
                                "resolution": res,
                                **sch,
                                "stepper": st,
                                "cfl": float(cfl),
                                "reference": False,
                            }
                        )
        if p.reference_resolution:
            pts.append(
                {
                    "problem": n,
                    "resolution": p.reference_resolution["quick" if quick else "full"],
                    **{
                        k: DEFAULT_SCHEME[k]
                        for k in ("reconstruction", "theta", "flux", "phi_flux")
                    },
                    "stepper": DEFAULT_COMBO["stepper"],
                    "cfl": DEFAULT_COMBO["cfl"],
                    "reference": True,
                }
            )
    return pts


def scheme_label(row: dict) -> str:
    """Short name of a point's spatial scheme: the reconstruction (with theta for minmod), then
    '+cu' for the central-upwind flux and '+up' for the upwind h phi flux."""
    rec = row["reconstruction"]
    th = float(row.get("theta", LEGACY_SCHEME["theta"]))
    name = f"minmod{th:g}" if rec == "minmod" else rec
    if row.get("flux", "kt") == "central-upwind":
        name += "+cu"
    if row.get("phi_flux", LEGACY_SCHEME["phi_flux"]) == "upwind":
        name += "+up"
    return name


class _Unstable(Exception):
    pass


def _guard(sim):
    """on_step callback that stops a run that blew up (non-finite or absurd speeds, or a step
    count that means dt collapsed)."""

    def on_step(info):
        spd = sim.last_stability.max_speed
        if not math.isfinite(spd) or spd > SPEED_LIMIT or not math.isfinite(info.dt):
            raise _Unstable(f"speed {spd!r} at t = {sim.t:.4g}")
        if sim.stats.steps > STEP_LIMIT:
            raise _Unstable("too many steps")

    return on_step


def _blank_row(point: dict, scene, precision: str, backend_name: str) -> dict:
    row = {k: point[k] for k in ("problem", "resolution", "reconstruction", "stepper", "cfl")}
    row.update({k: point.get(k, DEFAULT_SCHEME[k]) for k in ("theta", "flux", "phi_flux")})
    row.update(
        precision=precision,
        backend=backend_name,
        cells=scene.domain.nx * scene.domain.ny,
        error=float("nan"),
        value=float("nan"),
        wall_s=float("nan"),
        steps=0,
        rhs_evals=0,
        status="reference" if point.get("reference") else "ok",
    )
    return row


def _group_key(point: dict) -> tuple:
    """Points differing only in the stepper share one simulation (and its compiled kernels)."""
    return (
        point["problem"],
        point["resolution"],
        *(point.get(k, DEFAULT_SCHEME[k]) for k in ("reconstruction", "theta", "flux", "phi_flux")),
        point["cfl"],
        point.get("reference", False),
    )


def run_group(points: Sequence[dict], quick: bool, precision: str, backend_name: str) -> list[dict]:
    """Time and score points that differ only in the stepper, in this process.

    The operator's kernels do not depend on the stepper, so one Simulation is built (with RKC,
    which needs the most state slots) and its stepper swapped per point: compiling costs
    seconds per simulation, more than most of these runs. Each point is warmed up (its
    combination kernels and the field export compile on first use), then reset and timed."""
    from ..errors import TisegError
    from ..simulation import Simulation
    from ..timestepping import stepper_for

    p0 = points[0]
    prob = PROBLEMS[p0["problem"]]
    scene = prob.build(p0["resolution"], _numerics(p0, "rkc"), quick)
    rows = [_blank_row(p, scene, precision, backend_name) for p in points]
    try:
        sim = Simulation(scene, precision=precision)
    except TisegError as exc:
        for r in rows:
            r.update(status="unstable", note=str(exc)[:200])
        return rows
    for point, row in zip(points, rows):
        sim.stepper = stepper_for(scene.numerics, point["stepper"])
        try:
            sim.reset()
            sim.step()
            sim.fields()
            best, raw, k = math.inf, None, 0
            while True:
                sim.reset()
                guard = _guard(sim)
                t0 = time.perf_counter()
                raw = prob.run(sim, guard)
                best = min(best, time.perf_counter() - t0)
                k += 1
                if k >= repeats_for(best):
                    break
            row.update(wall_s=best, steps=sim.stats.steps, rhs_evals=sim.stats.stages)
            value, err = prob.score(raw, scene)
            row.update(value=value, error=err)
            finite = math.isfinite(value) if prob.reference_resolution else math.isfinite(err)
            if not finite:
                row["status"] = "unstable"
        except (_Unstable, TisegError, FloatingPointError, np.linalg.LinAlgError) as exc:
            row.update(status="unstable", note=str(exc)[:200])
    return rows


def run_points(
    points: Sequence[dict],
    quick: bool,
    precision: str,
    backend_name: str = "cpu",
    threads: int = 0,
    reinit: bool = False,
    log=None,
) -> list[dict]:
    """All points for one (precision, backend) in this process, in the given order.

    ``reinit``: re-initialise Taichi before each simulation (children do, so that the fields
    of hundreds of simulations do not pile up in one runtime); in-process callers keep theirs."""
    from .. import backend

    groups: dict[tuple, list[int]] = {}
    for i, pt in enumerate(points):
        groups.setdefault(_group_key(pt), []).append(i)
    rows: list[dict | None] = [None] * len(points)
    backend.init(backend_name, precision, threads)
    done = 0
    for g, idx in enumerate(groups.values()):
        if reinit and g:
            backend.init(backend_name, precision, threads, force=True)
        for i, row in zip(idx, run_group([points[i] for i in idx], quick, precision, backend_name)):
            rows[i] = row
            done += 1
            if log is not None:
                log(
                    f"[{precision}/{backend_name} {done}/{len(points)}] {row['problem']} "
                    f"{row['resolution']} {scheme_label(row)} {row['stepper']}: "
                    f"error {row['error']:.3g} wall {row['wall_s']:.3g} s {row['status']}"
                )
    return rows


# =================================================================================================
# Pareto front and the verdict on the defaults
# =================================================================================================
def pareto_front(errors: Sequence[float], walls: Sequence[float]) -> list[int]:
    """Indices of the non-dominated points (minimise both error and wall time), by wall time.

    A point is dominated when another is no worse in both and better in one. Points with a
    non-finite error or time are never on the front."""
    idx = [i for i in range(len(errors)) if math.isfinite(errors[i]) and math.isfinite(walls[i])]
    # cheapest first; at equal time the more accurate first, so that it dominates the other
    idx.sort(key=lambda i: (walls[i], errors[i]))
    front, best = [], math.inf
    for i in idx:
        if errors[i] < best:
            front.append(i)
            best = errors[i]
    return front


def _is_default(row: dict) -> bool:
    # rows from before the flux options have no flux / phi_flux: they ran the legacy scheme
    return all(row.get(k, LEGACY_SCHEME.get(k)) == v for k, v in DEFAULT_COMBO.items())


def _work(row: dict) -> int:
    """Cell-updates of a run: operator evaluations x cells."""
    return int(row["rhs_evals"]) * int(row["cells"])


FRONT_KEYS = ("resolution", "reconstruction", "stepper", "precision", "backend", "error", "wall_s")
WORK_KEYS = ("resolution", "reconstruction", "stepper", "precision", "error", "rhs_evals")


def _described(row: dict, keys) -> dict:
    """A point as the assessment names it: its scheme label and the given columns."""
    return {"scheme": scheme_label(row), **{k: row[k] for k in keys}}


def assess_defaults(rows: Sequence[dict]) -> dict:
    """Per problem: for each default point (weno + rkc + f64 + cpu, cfl 0.25), is it on the
    Pareto front, and if not, how much faster the front reaches the same error.

    ``overhead`` = wall of the default / wall of the cheapest front point with an error no
    larger (1 on the front); ``instead`` names that point."""
    out = {}
    for prob in dict.fromkeys(r["problem"] for r in rows):
        pts = [r for r in rows if r["problem"] == prob and r["status"] == "ok"]
        front = [r for r in pts if r.get("pareto")]
        items = []
        for r in sorted((r for r in pts if _is_default(r)), key=lambda r: r["resolution"]):
            better = [f for f in front if f["error"] <= r["error"]]
            best = min(better, key=lambda f: f["wall_s"]) if better else r
            # the same question in cell-updates (operator evaluations x cells): a cost that
            # does not depend on the machine's load, nor on per-step overheads or precision
            cheaper = [q for q in pts if q["error"] <= r["error"]]
            least = min(cheaper, key=_work)
            items.append(
                {
                    "resolution": r["resolution"],
                    "error": r["error"],
                    "wall_s": r["wall_s"],
                    "on_front": bool(r.get("pareto")),
                    "overhead": r["wall_s"] / best["wall_s"] if best["wall_s"] > 0 else 1.0,
                    "instead": _described(best, FRONT_KEYS),
                    "work": _work(r),
                    "work_overhead": _work(r) / max(_work(least), 1),
                    "work_instead": _described(least, WORK_KEYS),
                }
            )
        ov = [i["overhead"] for i in items]
        wo = [i["work_overhead"] for i in items]
        out[prob] = {
            "defaults": items,
            "median_work_overhead": float(np.median(wo)) if wo else float("nan"),
            "on_front": sum(i["on_front"] for i in items),
            "count": len(items),
            "median_overhead": float(np.median(ov)) if ov else float("nan"),
            "max_overhead": float(max(ov)) if ov else float("nan"),
            "front": [_described(f, FRONT_KEYS) for f in sorted(front, key=lambda f: f["wall_s"])],
        }
    return out


def verdict(assessment: dict, clear: float = 1.5) -> str:
    """One paragraph: do the defaults sit on the front? 'Clearly not' = the front reaches the
    default's error at least ``clear`` times faster at the median default point."""
    lines = []
    for prob, a in assessment.items():
        if not a["count"]:
            continue
        worst = max(a["defaults"], key=lambda i: i["overhead"])
        ins = worst["instead"]
        tag = (
            "on the front"
            if a["on_front"] == a["count"]
            else "near the front"
            if a["median_overhead"] < clear
            else "clearly NOT on the front"
        )
        lines.append(
            f"- {prob}: {a['on_front']}/{a['count']} default points on the front, median "
            f"overhead {a['median_overhead']:.2f}x in wall time and "
            f"{a['median_work_overhead']:.2f}x in cell-updates ({tag}); worst at resolution "
            f"{worst['resolution']}: {worst['wall_s']:.3g} s for error {worst['error']:.3g}, "
            f"where {ins['scheme']} + {ins['stepper']} + {ins['precision']} at "
            f"resolution {ins['resolution']} gets {ins['error']:.3g} in {ins['wall_s']:.3g} s"
        )
    return "\n".join(lines)


# =================================================================================================
# The study
# =================================================================================================
def _fill_relative_errors(rows: list[dict]) -> None:
    """Errors of problems scored against their finest run (the row flagged reference)."""
    for name, prob in PROBLEMS.items():
        if not prob.reference_resolution:
            continue
        refs = [
            r
            for r in rows
            if r["problem"] == name and r["status"] == "reference" and math.isfinite(r["value"])
        ]
        if not refs:
            continue
        ref = refs[0]["value"]
        for r in rows:
            if r["problem"] == name and r["status"] == "ok":
                r["error"] = (
                    abs(r["value"] - ref) / abs(ref) if math.isfinite(r["value"]) else math.nan
                )
                if not math.isfinite(r["error"]):
                    r["status"] = "unstable"


def mark_pareto(rows: list[dict]) -> None:
    """Set ``pareto`` on every row (per problem, over the successful points)."""
    for r in rows:
        r["pareto"] = False
    for prob in dict.fromkeys(r["problem"] for r in rows):
        pts = [r for r in rows if r["problem"] == prob and r["status"] == "ok"]
        for i in pareto_front([r["error"] for r in pts], [r["wall_s"] for r in pts]):
            pts[i]["pareto"] = True


def write_csv(rows: Sequence[dict], path: Path) -> Path:
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=COLUMNS, extrasaction="ignore")
        w.writeheader()
        for r in rows:
            w.writerow({k: _fmt(r.get(k)) for k in COLUMNS})
    return path


def read_csv(path) -> list[dict]:
    """Rows of an accuracy.csv with numbers parsed back."""
    rows = []
    with open(path, newline="") as fh:
        for r in csv.DictReader(fh):
            for k in ("error", "wall_s", "cfl", "value"):
                r[k] = float(r[k]) if r[k] not in ("", None) else math.nan
            # files written before the flux options had none of these columns
            r["theta"] = float(r.get("theta") or LEGACY_SCHEME["theta"])
            r["flux"] = r.get("flux") or LEGACY_SCHEME["flux"]
            r["phi_flux"] = r.get("phi_flux") or LEGACY_SCHEME["phi_flux"]
            for k in ("resolution", "steps", "rhs_evals", "cells"):
                r[k] = int(r[k])
            r["pareto"] = r["pareto"] == "True"
            rows.append(r)
    return rows


def _fmt(v):
    if isinstance(v, float):
        return "" if not math.isfinite(v) else f"{v:.6g}"
    return v


def plot_problem(rows: Sequence[dict], problem: str, path: Path, machine: str = "") -> Path:
    """Error against wall time for one problem; the Pareto front as a black staircase."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    prob = PROBLEMS[problem]
    pts = [
        r
        for r in rows
        if r["problem"] == problem and r["status"] == "ok" and r["error"] > 0 and r["wall_s"] > 0
    ]
    colours = {"first-order": "tab:gray", "minmod1.5": "tab:blue", "weno": "tab:red"}
    extra = iter(
        (
            "tab:green",
            "tab:purple",
            "tab:orange",
            "tab:brown",
            "tab:pink",
            "tab:olive",
            "tab:cyan",
            "navy",
            "darkred",
            "teal",
            "gold",
            "k",
        )
    )
    for lab in dict.fromkeys(scheme_label(r) for r in pts):
        if lab not in colours:
            colours[lab] = next(extra, "k")
    markers = {"rkc": "o", "ssprk3": "s", "euler": "^", "ssprk2": "D"}
    fig, ax = plt.subplots(figsize=(8, 6))
    for r in pts:
        c = colours.get(scheme_label(r), "k")
        filled = r["precision"] == "f64"
        ax.scatter(
            r["wall_s"],
            r["error"],
            marker=markers.get(r["stepper"], "x"),
            s=60 if r["backend"] == "cpu" else 110,
            facecolors=c if filled else "none",
            edgecolors=c,
            linewidths=1.3,
            zorder=3,
        )
        ax.annotate(
            str(r["resolution"]),
            (r["wall_s"], r["error"]),
            fontsize=6,
            xytext=(3, 3),
            textcoords="offset points",
            color=c,
        )
    front = sorted((r for r in pts if r.get("pareto")), key=lambda r: r["wall_s"])
    if front:
        xs = [f["wall_s"] for f in front]
        ys = [f["error"] for f in front]
        ax.step(xs + [xs[-1] * 3], ys + [ys[-1]], where="post", color="k", lw=1.2, zorder=2)
        ax.scatter(xs, ys, s=200, facecolors="none", edgecolors="k", linewidths=1.0, zorder=4)
    defaults = sorted((r for r in pts if _is_default(r)), key=lambda r: r["wall_s"])
    if defaults:
        ax.plot(
            [d["wall_s"] for d in defaults],
            [d["error"] for d in defaults],
            "--",
            color="tab:red",
            lw=1,
            zorder=1,
        )
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("wall time of the run [s]")
    ax.set_ylabel(prob.error_label)
    ax.set_title(f"{prob.title}\n(labels: {prob.resolution_label}; {machine})", fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    used = {scheme_label(r) for r in pts}
    handles = (
        [
            Line2D([], [], ls="", marker="o", color=c, label=k)
            for k, c in colours.items()
            if k in used
        ]
        + [
            Line2D([], [], ls="", marker=m, color="0.55", label=k)
            for k, m in markers.items()
            if any(r["stepper"] == k for r in pts)
        ]
        + [
            Line2D([], [], ls="", marker="o", color="k", label="f64 (filled)"),
            Line2D([], [], ls="", marker="o", color="k", mfc="none", label="f32 (open)"),
            Line2D([], [], color="k", label="Pareto front (circled)"),
            Line2D([], [], color="tab:red", ls="--", label="scene default weno+rkc+f64"),
        ]
    )
    ax.legend(handles=handles, fontsize=7, loc="best")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def summary_markdown(rows: Sequence[dict], assessment: dict, machine: dict) -> str:
    """The study in short: per problem the Pareto front and where the defaults sit."""
    out = [f"# Accuracy against cost ({machine_line(machine)})", ""]
    ok = sum(r["status"] == "ok" for r in rows)
    bad = [r for r in rows if r["status"] == "unstable"]
    which = ", ".join(sorted({r["problem"] + "/" + r["stepper"] for r in bad})) or "none"
    out.append(f"{len(rows)} runs, {ok} scored, {len(bad)} unstable ({which}).")
    out += [
        "",
        "## Do the defaults (weno + rkc + f64, cfl 0.25) sit on the Pareto front?",
        "",
        verdict(assessment),
        "",
    ]
    for prob, a in assessment.items():
        p = PROBLEMS[prob]
        out += [
            f"## {prob}: {p.title}",
            "",
            f"error: {p.error_label}; resolution: {p.resolution_label}",
            "",
            "| front point | resolution | error | wall [s] |",
            "|---|---|---|---|",
        ]
        for f in a["front"]:
            out.append(
                f"| {f['scheme']} + {f['stepper']} + {f['precision']}/{f['backend']} "
                f"| {f['resolution']} | {f['error']:.3g} | {f['wall_s']:.3g} |"
            )
        out += [
            "",
            "| default at resolution | error | wall [s] | on front | overhead | "
            "cheapest front point with no larger error | cell-updates overhead | "
            "fewest cell-updates with no larger error |",
            "|---|---|---|---|---|---|---|---|",
        ]
        for d in a["defaults"]:
            i, w = d["instead"], d["work_instead"]
            out.append(
                f"| {d['resolution']} | {d['error']:.3g} | {d['wall_s']:.3g} | "
                f"{'yes' if d['on_front'] else 'no'} | {d['overhead']:.2f}x | "
                f"{i['scheme']} + {i['stepper']} + {i['precision']} at "
                f"{i['resolution']}: {i['error']:.3g} in {i['wall_s']:.3g} s | "
                f"{d['work_overhead']:.2f}x | {w['scheme']} + {w['stepper']} at "
                f"{w['resolution']}: {w['error']:.3g} with {w['rhs_evals']} evaluations |"
            )
        out.append("")
    return "\n".join(out)


def run_study(
    out_dir,
    quick: bool = False,
    problems=None,
    precisions=PRECISIONS,
    backends=None,
    reconstructions=None,
    steppers=None,
    cfls=(0.25,),
    threads: int = 0,
    in_process: bool | None = None,
    log=None,
    fluxes=("kt",),
    phi_fluxes=("upwind",),
    thetas=(1.5,),
) -> dict:
    """Run the study, write accuracy.csv, one PNG per problem and summary.json/.md.

    Each (precision, backend) runs in a child process unless there is only one combination
    and ``in_process`` is not False (then this process's Taichi is used: tests, quick runs)."""
    from .. import backend as _backend
    from ..errors import InputError

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    backends = list(backends) if backends else available_backends()
    for p in precisions:
        if p not in PRECISIONS:
            raise InputError(f"precision {p!r}: choose f32 or f64")
    combos = [(p, b) for b in backends for p in precisions]
    points = plan_points(
        quick, problems, reconstructions, steppers, cfls, fluxes, phi_fluxes, thetas
    )
    # the reference runs (finest fingers run) belong to the default combination if studied
    ref_combo = ("f64", "cpu") if ("f64", "cpu") in combos else combos[0]
    t0 = time.perf_counter()
    rows: list[dict] = []
    if in_process is None:
        in_process = len(combos) == 1
    for prec, be in combos:
        pts = [p for p in points if not p["reference"] or (prec, be) == ref_combo]
        if in_process:
            if len(combos) > 1:
                raise InputError("in-process runs take one precision and one backend")
            if _backend.is_initialised():
                st = _backend.state()
                threads = threads or st.threads
            rows += run_points(pts, quick, prec, be, threads, reinit=False, log=log)
        else:
            res = run_child(
                "tiseg.bench.accuracy",
                {
                    "points": pts,
                    "quick": quick,
                    "precision": prec,
                    "backend": be,
                    "threads": threads,
                },
                out / ".work",
                f"{prec}-{be}",
            )
            rows += res["rows"]
    return write_outputs(
        rows,
        out,
        machine_info(threads),
        quick=quick,
        study_wall_s=time.perf_counter() - t0,
        combinations=[list(c) for c in combos],
    )


def write_outputs(rows: list[dict], out_dir, machine: dict, **extra) -> dict:
    """Score relative errors, mark the Pareto fronts and write accuracy.csv, one PNG per
    problem, summary.json and summary.md into out_dir; return the summary."""
    from ..output import write_json_atomic, write_text_atomic

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    _fill_relative_errors(rows)
    mark_pareto(rows)
    write_csv(rows, out / "accuracy.csv")
    pngs = [
        plot_problem(rows, prob, out / f"{prob}.png", machine_line(machine))
        for prob in dict.fromkeys(r["problem"] for r in rows)
    ]
    assessment = assess_defaults(rows)
    summary = {
        "machine": machine,
        **extra,
        "points": len(rows),
        "assessment": assessment,
        "verdict": verdict(assessment),
        "files": ["accuracy.csv", *[p.name for p in pngs], "summary.json", "summary.md"],
    }
    write_json_atomic(out / "summary.json", summary, indent=2)
    write_text_atomic(out / "summary.md", summary_markdown(rows, assessment, machine))
    return summary


# =================================================================================================
# Child process entry
# =================================================================================================
def _child(task_path: str) -> int:
    task = json.loads(Path(task_path).read_text())

    rows = run_points(
        task["points"],
        task["quick"],
        task["precision"],
        task["backend"],
        task.get("threads", 0),
        reinit=True,
        log=log_stderr,
    )
    Path(task["result"]).write_text(json.dumps({"rows": rows}, default=_json_default))
    return 0


def _json_default(o):
    if isinstance(o, (np.floating, np.integer)):
        return o.item()
    raise TypeError(type(o))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m tiseg.bench.accuracy")
    ap.add_argument("--child", required=True, help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    return _child(a.child)


if __name__ == "__main__":  # pragma: no cover - entered in the child processes
    sys.exit(main())
