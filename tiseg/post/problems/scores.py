"""What a problem's timed run keeps (records) and how it is scored against its solution
(scores), found by the names a problem file gives in its ``[record]`` and ``[score]`` tables.

A record runs the simulation (this part is timed) and returns raw data; a score turns raw data
and the solution into ``(value, error)`` outside the timing. ``value`` is what the run measured
(NaN when nothing but the error is of interest); a problem scored against a finer run leaves
the error NaN for the study to fill in from the reference run's value.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..analysis.fingers import front_max
from .solutions import FIELD, FINER_RUN, RATE

# the cuts of a 2D field a "final" record keeps: the first row (1D problems), the first column
# (problems uniform downslope), or all of it
CUTS = {
    "row": lambda f: f[0],
    "column": lambda f: f[:, 0],
    "all": lambda f: f,
}


@dataclass(frozen=True)
class Record:
    """A registered way to run a problem: ``run(sim, on_step, **params)`` -> raw data."""

    name: str
    doc: str
    params: dict  # name -> meaning; the [record] table must give each
    run: Callable


def _final(sim, on_step, fields, cut):
    """Advance to the scene's end time; the fields named, cut as ``cut`` says."""
    sim.advance(sim.scene.t_end, on_step)
    f = sim.fields()
    return {k: CUTS[cut](f[k]) for k in fields}


def _mode_amplitude(sim, on_step, flow_times, samples):
    """|first Fourier coefficient of h along x| at ``samples`` times evenly spread over
    ``flow_times`` h0/u0 (the time scale of (5.1)): (times, amplitudes)."""
    sc = sim.scene
    t_end = flow_times * sc.flow.h0 / sc.flow.u0
    ts, amp = [], []
    for j in range(samples):
        sim.advance(t_end * j / (samples - 1), on_step)
        c = np.fft.rfft(sim.conserved()[0, :, 0])[1]
        ts.append(sim.t)
        amp.append(abs(c))
    return np.array(ts), np.array(amp)


RECORDS: dict[str, Record] = {
    r.name: r
    for r in (
        Record(
            "final",
            "the fields at the scene's end time",
            {"fields": "names of the fields kept", "cut": "row, column or all"},
            _final,
        ),
        Record(
            "mode-amplitude",
            "the amplitude of the first downslope Fourier mode of h over time",
            {"flow_times": "span in units of h0/u0", "samples": "number of samples (>= 3)"},
            _mode_amplitude,
        ),
    )
}


@dataclass(frozen=True)
class Score:
    """A registered score: ``score(raw, exact, scene, **params)`` -> (value, error).

    ``takes``: what solution it compares with (solutions.FIELD, RATE or FINER_RUN);
    ``record``: the record it needs; ``params``: required parameters, ``optional`` ones with
    their defaults."""

    name: str
    doc: str
    takes: str
    record: str
    params: dict
    optional: dict
    score: Callable


def _centre(values, scene) -> float:
    """Mean over the cells within dy of the channel centre y = Ly/2 (NaN when not asked)."""
    y = (np.arange(scene.domain.ny) + 0.5) * scene.dy
    return float(np.mean(values[np.abs(y - 0.5 * scene.domain.Ly) < scene.dy]))


def _value(values, scene, value) -> float:
    return _centre(values, scene) if value == "centre" else float("nan")


def _mean_abs(raw, exact, scene, field, value="none"):
    f = raw[field]
    return _value(f, scene, value), float(np.mean(np.abs(f - exact)))


def _relative_l1(raw, exact, scene, field, value="none"):
    f = raw[field]
    return _value(f, scene, value), float(np.sum(np.abs(f - exact)) / np.sum(np.abs(exact)))


def _growth_rate(raw, sigma, scene, discard):
    """The rate of an exponential fitted to the amplitudes after the first ``discard`` samples
    (the other, damped, modes have died out by then), and its relative error."""
    ts, amp = raw
    late = slice(discard, None)
    with np.errstate(divide="ignore", invalid="ignore"):
        rate = np.polyfit(ts[late], np.log(amp[late]), 1)[0]
    return float(rate), float(abs(rate - sigma) / abs(sigma))


def front_position(h, x, h_min: float) -> float:
    """x_f^+ with sub-cell resolution: where the cross-slope maximum of h falls through h_min,
    linearly interpolated between the last wet cell centre and the next one.

    ``tiseg.post.analysis.fingers.front_max`` (the last wet cell centre) moves in steps of dx, so
    its error against a finer run is 0 or a multiple of dx by the accident of where the cell
    centres fall; the interpolated crossing converges smoothly. NaN without flow."""
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


def _front(raw, exact, scene, field):
    x, _ = scene.domain.cell_centres()
    # the error needs the reference run: the study fills it in from its value
    return front_position(raw[field], x, scene.numerics.h_min), float("nan")


VALUES = ("none", "centre")  # what a field score reports as the run's value

SCORES: dict[str, Score] = {
    s.name: s
    for s in (
        Score(
            "mean-abs",
            "mean |f - f_exact| over the cells",
            FIELD,
            "final",
            {"field": "the field scored"},
            {"value": "none"},
            _mean_abs,
        ),
        Score(
            "relative-l1",
            "sum |f - f_exact| / sum |f_exact|",
            FIELD,
            "final",
            {"field": "the field scored"},
            {"value": "none"},
            _relative_l1,
        ),
        Score(
            "growth-rate",
            "relative error of the fitted exponential growth rate",
            RATE,
            "mode-amplitude",
            {"discard": "samples left out of the fit at the start"},
            {},
            _growth_rate,
        ),
        Score(
            "front-position",
            "front position x_f+ (sub-cell); error |x_f+ - x_f+,ref| / x_f+,ref",
            FINER_RUN,
            "final",
            {"field": "the thickness field (h)"},
            {},
            _front,
        ),
    )
}
