"""Figures 12-18 of the paper (sections 6.2-6.3) from sweep results, and the runs beyond it.

* figures 12-14: phi, |u| and h of the fingers scene at t = 1.9, 3.3, 5.1, 6.2, 7.5 s, from the
  finest run of the grid study (`tiseg.post.render.panels.plot_panels`, experiment colours);
* figure 15: phi at t = 7.5 s of every grid- and width-study run, with x_f+ and x_f- dotted;
* figure 16: mean finger wavelength Lambda (t = 7.5 s) and elongation x_l (t = 2.5, 5, 7.5 s)
  against the grid resolution and against the domain width Ly;
* figure 17: Lambda and x_l at t = 7.5 s against the viscosity coefficient nu;
* figure 18: x_f+, x_f- and x_l against time for every nu, with the finger onset marked;
* the ill-posed limit: Lambda and the finger count against the grid resolution with nu = 0.01
  (the grid study) and nu = 0 (the inviscid study, Woodhouse et al. 2012), side by side;
* beyond the paper (``beyond=True``): the finite release (inflow stopped, figures 3b/4b) and the
  monodisperse front (figure 5).

The numbers come from sweeps (`tiseg.apps.sweep`) over the built-in sweep files in
``tiseg/data/sweeps`` (grid-study, width-study, nu-study, inviscid-study, finite-release,
monodisperse), kept
under one runs folder (``RUNS/<sweep name>/``). A study whose folder has a ``sweep.json`` is
taken as it is (and resumed if it was interrupted); a missing one is run first, with the
sweep file's settings or the cheaper ones asked for (``settings``, or ``quick``). The finger
diagnostics are those of `tiseg.post.analysis.fingers` (section 6.3 definitions).
"""

from __future__ import annotations

from ...output.names import FIELDS_FILE, SCENE_FILE

import csv
import io
import json
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Callable

import numpy as np

from ...data import SWEEP_DIR
from ...errors import InputError
from . import new_figure, save_figure
from ...post.analysis.fingers import count_text
from ...post.render.panels import plot_panels
from ...post.render.movie import _snapshot
from ...post.render.panels import nearest_indices

PAPER_TIMES = (1.9, 3.3, 5.1, 6.2, 7.5)  # panels of figures 12-14
FINAL_TIME = 7.5  # figures 15-17
ELONGATION_TIMES = (2.5, 5.0, 7.5)  # figure 16(b)
PAPER_WAVELENGTH = 0.05  # "around 5 cm" (section 6.2), nu = 0.01

# study key -> sweep file stem (and the sweep's default folder name)
STUDIES = {
    "grid": "grid-study",
    "width": "width-study",
    "nu": "nu-study",
    "inviscid": "inviscid-study",
    "finite": "finite-release",
    "mono": "monodisperse",
}
PAPER_STUDIES = ("grid", "width", "nu", "inviscid")
BEYOND_STUDIES = ("finite", "mono")

# --quick: the same studies at resolutions that fit in a few minutes on 2 cores (fingers need
# about 150 cells per metre, so these show the trends only roughly).
QUICK_SETTINGS = {
    "grid": {"grid": {"domain.resolution": [100, 150, 200]}},
    "width": {"set": {"domain.resolution": 150}, "grid": {"domain.Ly": [0.25, 0.5]}},
    "nu": {"set": {"domain.resolution": 150}},
    "inviscid": {"grid": {"domain.resolution": [100, 150, 200]}},
    "finite": {"set": {"domain.resolution": 150}},
    "mono": {"grid": {"domain.resolution": [150]}},
}

FILES = {
    "fig12": "fig12_phi.png",
    "fig13": "fig13_speed.png",
    "fig14": "fig14_h.png",
    "fig15": "fig15_phi_runs.png",
    "fig16": "fig16_grid_width.png",
    "fig17": "fig17_nu.png",
    "fig18": "fig18_fronts.png",
    "inviscid": "inviscid_limit.png",
    "finite_phi": "beyond_finite_release_phi.png",
    "finite_fronts": "beyond_finite_release_fronts.png",
    "mono_phi": "beyond_monodisperse_phi.png",
}


# =================================================================================================
# Studies: finished sweep runs
# =================================================================================================
@dataclass
class StudyRun:
    """One finished run of a study: its grid values, folder and completion record."""

    name: str
    values: dict
    dir: Path
    record: dict

    @property
    def metrics(self) -> dict:
        return self.record.get("metrics") or {}

    def at(self, key: str, t: float | None = None):
        """A metric at time t (default: the final time); None where undefined or not stored."""
        m = self.metrics
        times = m.get("time") or []
        if not times or key not in m:
            return None
        if t is None:
            return m[key][-1]
        from ..sweep import time_index

        i = time_index(times, t)
        return None if i is None else m[key][i]

    def onset(self) -> float | None:
        """First output time with fingers (finger_count > 0), or None."""
        m = self.metrics
        for t, c in zip(m.get("time") or [], m.get("finger_count") or []):
            if c:
                return t
        return None

    @cached_property
    def scene(self):
        """The run's resolved scene (read once from its scene.toml)."""
        from ...setup.scene import load_scene

        return load_scene(self.dir / SCENE_FILE)


@dataclass
class Study:
    key: str
    name: str
    out: Path
    runs: list[StudyRun] = field(default_factory=list)
    definition: dict = field(default_factory=dict)


def load_study(key: str, out: Path) -> Study | None:
    """The finished runs of the sweep in ``out`` (from its sweep.json), or None without one."""
    from ..sweep import read_marker, refresh_metrics

    path = out / "sweep.json"
    if not path.is_file():
        return None
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except ValueError as exc:
        raise InputError(f"{str(path)!r} is not valid JSON: {exc}") from None
    runs = []
    for r in data.get("runs", []):
        d = out / r["run"]
        rec = read_marker(d)
        if rec is not None:  # finished runs only: their marker is the record
            rec = refresh_metrics(d, rec)  # diagnostics of the current definitions
            runs.append(StudyRun(r["run"], r.get("values") or {}, d, rec))
    return Study(key, STUDIES[key], out, runs, data.get("sweep") or {})


def obtain_study(
    key: str,
    runs_root: Path,
    settings: dict | None = None,
    *,
    run: bool = True,
    echo: Callable[[str], None] | None = print,
    **run_kwargs,
) -> Study | None:
    """A study's finished runs, running (or resuming) its sweep first where needed.

    With ``settings`` (``{"set": {...}, "grid": {...}}`` overrides of the sweep file) the sweep
    is run with them (finished runs reused). Without, a study folder holding a ``sweep.json`` is
    resumed with its own stored definition, and a missing one is run with the sweep file as it
    is. ``run=False`` never starts a run: it returns what is there, or None.
    """
    from ..sweep import load_sweep, run_sweep, sweep_from_dict

    out = runs_root / STUDIES[key]
    existing = load_study(key, out)
    if not run:
        return existing
    if settings is not None:
        sweep = load_sweep(
            SWEEP_DIR / f"{STUDIES[key]}.toml",
            extra_overrides=settings.get("set"),
            grid_overrides=settings.get("grid"),
        )
    elif existing is not None and existing.definition:
        d = existing.definition
        sweep = sweep_from_dict(
            {
                "name": d["name"],
                "description": d.get("description", ""),
                "scene": d["scene"],
                "times": d.get("times", []),
                "set": d.get("set", {}),
                "grid": d.get("grid", {}),
            },
            source=str(out / "sweep.json"),
        )
    else:
        sweep = load_sweep(SWEEP_DIR / f"{STUDIES[key]}.toml")
    run_sweep(sweep, out, echo=echo, **run_kwargs)
    return load_study(key, out)


# =================================================================================================
# Figures
# =================================================================================================
def _figure(nrows=1, ncols=1, size=(6.0, 4.2), **kw):
    return new_figure(nrows, ncols, size, layout="constrained", **kw)


_save = save_figure


def _resolution(run: StudyRun) -> float:
    sc = run.scene
    return sc.domain.resolution or sc.domain.nx / sc.domain.Lx


def fig12_14(study: Study, out: Path, dpi: int) -> list[Path]:
    """Panels of phi, |u| and h at the paper's times from the finest grid-study run."""

    run = max(study.runs, key=_resolution)
    res = _resolution(run)
    paths = []
    for key, fld, what in (
        ("fig12", "phi", "concentration"),
        ("fig13", "speed", "speed"),
        ("fig14", "h", "thickness"),
    ):
        path = out / FILES[key]
        fig = plot_panels(
            run.dir,
            times=PAPER_TIMES,
            field=fld,
            width=6.5,
            title=f"Figure {key[3:]}: {what}, fingers scene at {res:g} cells/m",
        )
        paths.append(_save(fig, path, dpi))
    return paths


def _render_phi(run: StudyRun, t: float):
    """(RGB image in the experiment colours, imshow extent [m]) of phi at the output
    time nearest t of a run; the same frame kernel as the movies and plot_panels."""
    from ...output.netcdf import read_fields
    from ...post.render.frame import render_fields

    sc = run.scene
    with read_fields(run.dir / FIELDS_FILE) as ds:
        k = nearest_indices(ds["time"].values, [t])[0]
        snap = _snapshot(ds, k)
    img = render_fields(snap, sc.numerics.h_min, field="phi", colourbar=False, aspect=sc.dy / sc.dx)
    return img, (0.0, sc.domain.Lx, 0.0, sc.domain.Ly)


def _phi_stack(items, path: Path, dpi: int, title: str) -> Path:
    """One phi panel per (label, run, time), heights proportional to Ly / Lx, x_f+ and x_f-
    dotted as in figure 15."""
    width = 6.5
    heights = []
    for _, run, _ in items:
        sc = run.scene
        heights.append(sc.domain.Ly / sc.domain.Lx)
    fig, axes = _figure(
        len(items),
        1,
        size=(width, sum(h * width * 0.9 + 0.45 for h in heights) + 0.5),
        gridspec_kw={"height_ratios": heights},
    )
    for ax, (label, run, t) in zip(axes[:, 0], items):
        img, extent = _render_phi(run, t)
        ax.imshow(img, extent=extent, interpolation="nearest", aspect="equal")
        for key in ("x_front_max", "x_front_min"):
            x = run.at(key, t)
            if x is not None:
                ax.axvline(x, color="k", ls=":", lw=1.2)
        count, wl, xl = run.at("finger_count", t), run.at("wavelength", t), run.at("elongation", t)
        stats = (f"{count_text(count)}, Λ = {100 * wl:.1f} cm" if wl else "no fingers") + (
            f", x_l = {xl:.2f} m" if xl is not None else ""
        )
        ax.set_title(f"{label}: {stats}", fontsize=8)
        ax.tick_params(labelsize=7)
        ax.set_ylabel("y [m]", fontsize=7)
    axes[-1, 0].set_xlabel("x [m]", fontsize=8)
    fig.suptitle(title, fontsize=9)
    return _save(fig, path, dpi)


def _run_key(run: StudyRun):
    sc = run.scene
    return (sc.domain.nx, sc.domain.ny, sc.domain.Lx, sc.domain.Ly, _nu(run))


def fig15(grid: Study | None, width: Study | None, out: Path, dpi: int) -> Path | None:
    items, seen = [], set()
    for study in (grid, width):
        if study is None:
            continue
        for run in sorted(study.runs, key=lambda r: (_resolution(r), r.scene.domain.Ly)):
            if run.at("time", FINAL_TIME) is None or _run_key(run) in seen:
                continue  # not run to 7.5 s, or the same scene as one already shown
            seen.add(_run_key(run))
            sc = run.scene
            items.append(
                (f"{_resolution(run):g} cells/m, Ly = {sc.domain.Ly:g} m", run, FINAL_TIME)
            )
    if not items:
        return None
    return _phi_stack(
        items,
        out / FILES["fig15"],
        dpi,
        f"Figure 15: φ at t = {FINAL_TIME:g} s, x_f+ and x_f- dotted",
    )


@dataclass
class Series:
    """A metric against a study parameter, over the ensemble of runs at each value (the
    seeds): mean, sample sd (0 for a single run) and the runs where it is defined."""

    x: np.ndarray
    mean: np.ndarray
    std: np.ndarray
    n: np.ndarray  # runs where the metric is defined
    runs: np.ndarray  # runs at this value
    undefined: int  # runs where it is not (no fingers: no wavelength)


def _series(runs, xkey: Callable, ykey: str, t: float) -> Series:
    groups: dict[float, list] = {}
    for r in runs:
        groups.setdefault(float(xkey(r)), []).append(r.at(ykey, t))
    xs = sorted(groups)
    vals = [np.array([v for v in groups[x] if v is not None], dtype=float) for x in xs]
    return Series(
        x=np.array(xs, dtype=float),
        mean=np.array([v.mean() if v.size else np.nan for v in vals]),
        std=np.array([v.std(ddof=1) if v.size > 1 else 0.0 for v in vals]),
        n=np.array([v.size for v in vals]),
        runs=np.array([len(groups[x]) for x in xs]),
        undefined=sum(len(groups[x]) - v.size for x, v in zip(xs, vals)),
    )


def _plot_series(ax, s: Series, scale: float = 1.0, **kw) -> None:
    """Mean +- sd error bars (sd over the seeds at each value)."""
    ok = s.n > 0
    ax.errorbar(s.x[ok], scale * s.mean[ok], yerr=scale * s.std[ok], capsize=3, **kw)


def _ensemble_label(s: Series) -> str:
    sizes = sorted(set(int(k) for k in s.runs))
    return f"mean ± sd of {'/'.join(map(str, sizes))} run{'s' if max(sizes) > 1 else ''}"


def _note_no_fingers(ax, s: Series) -> None:
    """Say so where a run has no fingers (its wavelength is undefined and left out)."""
    if s.undefined:
        n = s.undefined
        ax.text(
            0.03,
            0.04,
            f"{n} run{'s' if n > 1 else ''} without fingers (left out)",
            transform=ax.transAxes,
            fontsize=7,
            color="0.3",
        )


def fig16(grid: Study | None, width: Study | None, out: Path, dpi: int) -> Path | None:
    """(a) Lambda and (b) x_l against resolution; (c) Lambda and (d) x_l against Ly."""
    panels = [
        (s, name, fn)
        for s, name, fn in (
            (grid, "grid resolution $N_x/L_x$ [1/m]", _resolution),
            (width, "domain width $L_y$ [m]", lambda r: r.scene.domain.Ly),
        )
        if s and s.runs
    ]
    if not panels:
        return None
    fig, axes = _figure(len(panels), 2, size=(8.0, 3.2 * len(panels)))
    for row, (study, xlabel, xfn) in enumerate(panels):
        ax = axes[row, 0]
        wl = _series(study.runs, xfn, "wavelength", FINAL_TIME)
        _plot_series(ax, wl, 100, fmt="ko-", label=f"Ly / count, {_ensemble_label(wl)}")
        _plot_series(
            ax,
            _series(study.runs, xfn, "wavelength_spectral", FINAL_TIME),
            100,
            fmt="s--",
            color="C0",
            mfc="none",
            label="spectral",
        )
        _note_no_fingers(ax, wl)
        ax.axhline(
            100 * PAPER_WAVELENGTH,
            color="0.5",
            ls="--",
            lw=1,
            label="paper: about 5 cm (ν = 0.01, 750/m)",
        )
        ax.set_xlabel(xlabel)
        ax.set_ylabel(f"wavelength Λ at t = {FINAL_TIME:g} s [cm]")
        ax.set_ylim(bottom=0)
        ax.legend(fontsize=7, loc="lower right")
        ax = axes[row, 1]
        for t, mk in zip(ELONGATION_TIMES, ("o", "s", "^")):
            _plot_series(
                ax,
                _series(study.runs, xfn, "elongation", t),
                marker=mk,
                ls="-",
                label=f"t = {t:g} s",
            )
        ax.set_xlabel(xlabel)
        ax.set_ylabel("elongation x_l [m]")
        ax.set_ylim(bottom=0)
        ax.legend(fontsize=7)
    fig.suptitle(
        "Figure 16: finger wavelength and elongation (ν = 0.01 m$^{3/2}$ s$^{-1}$)", fontsize=10
    )
    return _save(fig, out / FILES["fig16"], dpi)


def _nu(run: StudyRun) -> float:
    """The viscosity coefficient the run solved with: 0 where the viscous term is off."""
    return run.scene.acting_nu


def fig17(nu: Study | None, out: Path, dpi: int) -> Path | None:
    if nu is None or not nu.runs:
        return None
    res = sorted({_resolution(r) for r in nu.runs})
    fig, axes = _figure(1, 2, size=(8.0, 3.2))
    wl = _series(nu.runs, _nu, "wavelength", FINAL_TIME)
    _plot_series(axes[0, 0], wl, 100, fmt="ko-", label=f"Ly / count, {_ensemble_label(wl)}")
    _plot_series(
        axes[0, 0],
        _series(nu.runs, _nu, "wavelength_spectral", FINAL_TIME),
        100,
        fmt="s--",
        color="C0",
        mfc="none",
        label="spectral",
    )
    axes[0, 0].legend(fontsize=7, loc="lower right")
    _note_no_fingers(axes[0, 0], wl)
    axes[0, 0].set_ylabel(f"wavelength Λ at t = {FINAL_TIME:g} s [cm]")
    _plot_series(axes[0, 1], _series(nu.runs, _nu, "elongation", FINAL_TIME), fmt="ko-")
    axes[0, 1].set_ylabel(f"elongation x_l at t = {FINAL_TIME:g} s [m]")
    nus = sorted({_nu(r) for r in nu.runs})
    for ax in axes[0]:
        ax.set_xscale("log")
        ax.set_xticks(nus, [f"{v:g}" for v in nus])  # the study's values, not 10^k ticks
        ax.minorticks_off()
        ax.set_xlabel("ν [m$^{3/2}$ s$^{-1}$]")
        ax.set_ylim(bottom=0)
    fig.suptitle(
        f"Figure 17: effect of ν at {'/'.join(f'{r:g}' for r in res)} cells/m", fontsize=10
    )
    return _save(fig, out / FILES["fig17"], dpi)


def _fronts(
    study: Study,
    path: Path,
    dpi: int,
    label: Callable,
    title: str,
    marks: Callable | None = None,
    order: Callable | None = None,
) -> Path:
    """x_f+ (solid) and x_f- (dashed) against t, and x_l against t, one colour per label:
    the runs of one point of an ensemble (its seeds) share their colour and legend entry."""
    fig, axes = _figure(1, 2, size=(8.5, 3.4))
    runs = sorted(study.runs, key=order or (lambda r: r.name))
    colours: dict[str, str] = {}
    for run in runs:
        name = label(run)
        first = name not in colours
        c = colours.setdefault(name, f"C{len(colours) % 10}")
        name = name if first else None
        m = run.metrics
        t = np.array(m["time"], dtype=float)
        arr = {
            k: np.array([np.nan if v is None else v for v in m[k]], dtype=float)
            for k in ("x_front_max", "x_front_min", "elongation")
        }
        axes[0, 0].plot(t, arr["x_front_max"], "-", color=c, label=name)
        axes[0, 0].plot(t, arr["x_front_min"], "--", color=c)
        axes[0, 1].plot(t, arr["elongation"], "-", color=c, label=name)
        on = run.onset()
        if on is not None:
            i = int(np.argmin(np.abs(t - on)))
            axes[0, 1].plot([on], [arr["elongation"][i]], "o", color=c, ms=5)
        if marks is not None:
            for ax in axes[0]:
                for tm in marks(run):
                    ax.axvline(tm, color=c, ls=":", lw=0.8)
    axes[0, 0].set_ylabel("$x_f^+$ (solid), $x_f^-$ (dashed) [m]")
    axes[0, 1].set_ylabel("elongation $x_l$ [m]  (dot: first fingers)")
    for ax in axes[0]:
        ax.set_xlabel("t [s]")
        ax.legend(fontsize=7)
    fig.suptitle(title, fontsize=10)
    return _save(fig, path, dpi)


def fig_inviscid(grid: Study | None, inviscid: Study | None, out: Path, dpi: int) -> Path | None:
    """Lambda and the finger count against the resolution, nu = 0.01 beside nu = 0: the
    viscous wavelength converges, the inviscid one keeps shrinking (section 6.3)."""
    studies = [
        (s, lab, fmt)
        for s, lab, fmt in (
            (grid, "ν = 0.01", "ko-"),
            (inviscid, "ν = 0 (inviscid)", "rs--"),
        )
        if s is not None and s.runs
    ]
    if inviscid is None or not inviscid.runs:
        return None
    fig, axes = _figure(1, 2, size=(8.0, 3.2))
    for study, label, fmt in studies:
        wl = _series(study.runs, _resolution, "wavelength", FINAL_TIME)
        _plot_series(axes[0, 0], wl, 100, fmt=fmt, label=f"{label}, {_ensemble_label(wl)}")
        count = _series(study.runs, _resolution, "finger_count", FINAL_TIME)
        _plot_series(axes[0, 1], count, fmt=fmt, label=label)
    axes[0, 0].set_ylabel(f"wavelength Λ at t = {FINAL_TIME:g} s [cm]")
    axes[0, 1].set_ylabel(f"fingers at t = {FINAL_TIME:g} s")
    for ax in axes[0]:
        ax.set_xlabel("grid resolution $N_x/L_x$ [1/m]")
        ax.set_ylim(bottom=0)
        ax.legend(fontsize=7, loc="lower right")
    fig.suptitle("The ill-posed limit: the viscous terms set the finger scale", fontsize=10)
    return _save(fig, out / FILES["inviscid"], dpi)


def fig18(nu: Study | None, out: Path, dpi: int) -> Path | None:
    if nu is None or not nu.runs:
        return None
    return _fronts(
        nu,
        out / FILES["fig18"],
        dpi,
        lambda r: f"ν = {_nu(r):g}",
        "Figure 18: front positions and finger length against time",
        order=_nu,
    )


def beyond_figures(finite: Study | None, mono: Study | None, out: Path, dpi: int) -> list[Path]:
    """phi and front positions of the finite releases; phi panels of the monodisperse front."""
    paths = []
    if finite is not None and finite.runs:

        def stop(r):
            return r.scene.inflow.stop_time

        items = []
        for r in sorted(finite.runs, key=stop):  # each run at 7.5 s and at its last time
            t_last = r.metrics["time"][-1]
            items += [
                (f"inflow stops at {stop(r):g} s, t = {t:g} s", r, t)
                for t in sorted({FINAL_TIME, t_last})
                if r.at("time", t) is not None
            ]
        paths.append(
            _phi_stack(
                items,
                out / FILES["finite_phi"],
                dpi,
                "Finite release (figures 3b, 4b): φ after the inflow stops",
            )
        )
        paths.append(
            _fronts(
                finite,
                out / FILES["finite_fronts"],
                dpi,
                lambda r: f"stop at {stop(r):g} s",
                "Finite release: x_f and x_l after the inflow stops (dotted)",
                marks=lambda r: [stop(r)],
                order=stop,
            )
        )
    if mono is not None and mono.runs:
        run = max(mono.runs, key=_resolution)
        # the explicitly listed output times (the sweep's panels), else the last three
        times = list(run.scene.output.times)[-3:] or run.metrics["time"][-3:]
        fig = plot_panels(
            run.dir,
            times=times,
            field="phi",
            width=6.5,
            title=f"Monodisperse front (figure 5), {_resolution(run):g} cells/m: no fingers",
        )
        paths.append(_save(fig, out / FILES["mono_phi"], dpi))
    return paths


# =================================================================================================
# Summary table
# =================================================================================================
SUMMARY_COLUMNS = (
    "study",
    "run",
    "resolution",
    "Ly",
    "nu",
    "stop_time",
    "seed",
    "t_final",
    "finger_count",
    "wavelength",
    "wavelength_spectral",
    "elongation",
    "x_front_max",
    "x_front_min",
    "channel_speed_over_u0",
    "channel_phi",
    "levee_speed_over_u0",
    "onset",
    "front_speed_over_u0",
    "wall_s",
    "steps",
    "rhs_evaluations",
    "cells",
)


def summary_rows(studies: dict[str, Study | None]) -> list[dict]:
    """One row per finished run: the study values, the metrics at the last time, the onset
    time of fingers and the run costs."""
    rows = []
    for study in studies.values():
        if study is None:
            continue
        for run in study.runs:
            sc = run.scene
            m = run.metrics
            u0 = sc.flow.u0
            fs = run.at("front_speed")
            rows.append(
                {
                    "study": study.name,
                    "run": run.name,
                    "resolution": _resolution(run),
                    "Ly": sc.domain.Ly,
                    "nu": _nu(run),
                    "stop_time": sc.inflow.stop_time if sc.inflow else None,
                    "seed": sc.inflow.seed if sc.inflow else None,
                    "t_final": m["time"][-1] if m.get("time") else None,
                    **{
                        k: run.at(k)
                        for k in (
                            "finger_count",
                            "wavelength",
                            "wavelength_spectral",
                            "elongation",
                            "x_front_max",
                            "x_front_min",
                            "channel_speed_over_u0",
                            "channel_phi",
                            "levee_speed_over_u0",
                        )
                    },
                    "onset": run.onset(),
                    "front_speed_over_u0": fs / u0 if fs is not None and u0 else None,
                    **{
                        k: run.record.get(k)
                        for k in ("wall_s", "steps", "rhs_evaluations", "cells")
                    },
                }
            )
    return rows


def write_summary(rows: list[dict], out: Path) -> list[Path]:
    from ...output import write_json_atomic, write_text_atomic
    from ...output.numbers import measured_all

    rows = measured_all(rows)  # 12 significant digits: no round-off tails
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=SUMMARY_COLUMNS, lineterminator="\n")
    w.writeheader()
    for r in rows:
        w.writerow({k: ("" if r.get(k) is None else r[k]) for k in SUMMARY_COLUMNS})
    return [
        write_text_atomic(out / "fingers_studies.csv", buf.getvalue()),
        write_json_atomic(out / "fingers_studies.json", rows),
    ]


def format_summary(rows: list[dict]) -> str:
    """A plain-text table of the summary rows (what the command prints)."""
    head = ("study", "run", "Λ [cm]", "fingers", "x_l [m]", "onset [s]", "wall [s]")
    lines = []
    for r in rows:
        wl = r["wavelength"]
        lines.append(
            (
                r["study"],
                r["run"],
                "-" if wl is None else f"{100 * wl:.1f}",
                str(r["finger_count"]),
                "-" if r["elongation"] is None else f"{r['elongation']:.3f}",
                "-" if r["onset"] is None else f"{r['onset']:g}",
                "-" if r["wall_s"] is None else f"{r['wall_s']:.0f}",
            )
        )
    widths = [
        max(len(h), *(len(x[i]) for x in lines)) if lines else len(h) for i, h in enumerate(head)
    ]
    fmt = "  ".join(f"{{:>{w}}}" for w in widths)
    return "\n".join([fmt.format(*head)] + [fmt.format(*x) for x in lines])


# =================================================================================================
# Everything
# =================================================================================================
def make_all(
    out,
    runs_root,
    *,
    dpi: int = 90,
    quick: bool = False,
    settings: dict[str, dict] | None = None,
    beyond: bool = False,
    run: bool = True,
    echo: Callable[[str], None] | None = print,
    **run_kwargs,
) -> list[Path]:
    """Obtain the studies (running missing sweeps) and draw figures 12-18 and the inviscid
    limit (and, with
    ``beyond``, the finite-release and monodisperse figures) into ``out``. ``settings``:
    per-study sweep overrides (``{"grid": {"grid": {"domain.resolution": [...]}}}``);
    ``quick``: `QUICK_SETTINGS` for the studies without settings. Returns the files."""
    out, runs_root = Path(out), Path(runs_root)
    settings = dict(settings or {})
    keys = PAPER_STUDIES + (BEYOND_STUDIES if beyond else ())
    studies: dict[str, Study | None] = {}
    for key in keys:
        s = settings.get(key)
        if s is None and quick and not (runs_root / STUDIES[key] / "sweep.json").is_file():
            s = QUICK_SETTINGS[key]
        studies[key] = obtain_study(key, runs_root, s, run=run, echo=echo, **run_kwargs)
        if studies[key] is None or not studies[key].runs:
            if echo:
                echo(
                    f"no finished runs of the {STUDIES[key]} study in "
                    f"{runs_root / STUDIES[key]}: its figures are left out"
                )
    grid, width, nu = studies["grid"], studies["width"], studies["nu"]
    inviscid = studies["inviscid"]
    paths: list[Path | None] = []
    if grid is not None and grid.runs:
        paths += fig12_14(grid, out, dpi)
    paths += [
        fig15(grid, width, out, dpi),
        fig16(grid, width, out, dpi),
        fig17(nu, out, dpi),
        fig18(nu, out, dpi),
        fig_inviscid(grid, inviscid, out, dpi),
    ]
    if beyond:
        paths += beyond_figures(studies["finite"], studies["mono"], out, dpi)
    rows = summary_rows(studies)
    paths += write_summary(rows, out)
    if echo and rows:
        echo(format_summary(rows))
    return [p for p in paths if p is not None]


def shrink_copy(src: Path, dest: Path, max_bytes: int = 150_000) -> Path:
    """Copy a PNG, re-encoded with an adaptive palette (and then scaled down) until it is
    smaller than ``max_bytes``: small enough to commit, the figures' flat colours survive."""
    from PIL import Image

    dest.parent.mkdir(parents=True, exist_ok=True)
    img = Image.open(src).convert("RGB")
    for scale in (1.0, 0.85, 0.7, 0.55, 0.4):
        im = (
            img
            if scale == 1.0
            else img.resize(
                (max(1, int(img.width * scale)), max(1, int(img.height * scale))), Image.LANCZOS
            )
        )
        for colours in (256, 128, 64):
            im.quantize(colours, method=Image.Quantize.MEDIANCUT).save(dest, optimize=True)
            if dest.stat().st_size < max_bytes:
                return dest
    return dest


__all__ = [
    "make_all",
    "obtain_study",
    "load_study",
    "Study",
    "StudyRun",
    "summary_rows",
    "format_summary",
    "shrink_copy",
    "QUICK_SETTINGS",
    "STUDIES",
    "FILES",
]
