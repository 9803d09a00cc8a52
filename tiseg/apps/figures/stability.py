"""Figures 8-11 of the paper (sections 4-5) and the growth-rate plot of ``tiseg stability --plot``.

Matplotlib is used through ``Figure`` + ``FigureCanvasAgg`` (the Agg backend) without pyplot, so
nothing depends on, or changes, a global backend. Wavenumbers and growth rates are the
dimensionless k^ = k h0 and sigma^ = sigma h0/u0 of the scalings (5.1); axis labels say so.

Speed: double-precision eigenvalues are used wherever they are accurate; mpmath only where the
growth rate is below the double round-off (the k^-2/k^-4 tails, ``extended="auto"``).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ...model.material import TABLE1, Material
from . import new_figure, save_figure
from ...model.stability import asymptotics as asy
from ...model.stability import dispersion1d as d1
from ...model.stability.base import BaseState, base_state, base_state_from_froude
from ...model.steady import froude_per_thickness, phi0_star

PHI0 = 0.8  # concentration of figures 9-11
NU_FIG = 1e-3  # viscosity of figures 9-10 [m^(3/2)/s]
NUS_FIG11 = (5e-4, 1e-3, 2e-3, 1e-2)  # viscous curves of figure 11
FILES = {
    "fig08": "fig08_froude.png",
    "fig09": "fig09_growth_rates.png",
    "fig10": "fig10_critical.png",
    "fig11": "fig11_sigma_max.png",
}
K_LABEL = r"wavenumber $\hat k = k\,h_0$"
S_LABEL = r"growth rate $\sigma_M$ [units of $u_0/h_0$]"


def _figure(nrows=1, ncols=1, size=(6.0, 4.2)):
    return new_figure(nrows, ncols, size)


def _save(fig, path, dpi) -> Path:
    return save_figure(fig, path, dpi, tight=True)


# ---- figure 8 ----------------------------------------------------------------------------------
def fig08_froude(path, m: Material = TABLE1, dpi=90) -> Path:
    """Contours of F(h0, phi0) (4.9); phi0 < phi0* (4.8) shaded; the curve F = Fc (5.27) dashed."""
    star = phi0_star(m)
    h_mm = np.linspace(0.0, 5.0, 101)
    phi = np.linspace(0.0, 1.0, 201)
    per = np.array([froude_per_thickness(p, m) if p > star else np.nan for p in phi])
    F = per[:, None] * (h_mm[None, :] * 1e-3)
    fig, ax = _figure()
    ax = ax[0, 0]
    cs = ax.contour(
        h_mm, phi, F, levels=[0.25, 0.5, 1, 1.5, 2, 3, 4, 5, 6, 7], colors="k", linewidths=0.8
    )
    ax.clabel(cs, fmt="%g", fontsize=7)
    ax.axhspan(0.0, star, color="0.8", zorder=0)
    ax.text(
        2.5,
        star / 2,
        rf"$\bar\phi_0 < \bar\phi_0^* = {star:.3f}$: no steady uniform flow",
        ha="center",
        va="center",
        fontsize=8,
    )
    # thickness at which F = Fc, i.e. where the inviscid model is ill posed
    pc = phi[(phi > star + 1e-9) & (np.abs(m.dG(phi)) > 1e-9)]
    hc = np.array([1e3 / (abs(float(m.dG(p))) * froude_per_thickness(p, m)) for p in pc])
    ok = hc <= 5.0
    ax.plot(hc[ok], pc[ok], "r--", lw=1, label=r"$F = F_c = 1/|G'(\bar\phi_0)|$ (5.27)")
    for h0, mk in ((2.0, "o"), (2.4728, "s"), (3.0, "^")):
        ax.plot(h0, PHI0, mk, color="C0", ms=5)
    ax.set_xlabel(r"flow thickness $h_0$ [mm]")
    ax.set_ylabel(r"small-particle concentration $\bar\phi_0$ [-]")
    ax.set_title(r"Fig. 8: steady uniform Froude number $F(h_0, \bar\phi_0)$ (4.9)", fontsize=10)
    ax.set_xlim(0, 5)
    ax.set_ylim(0, 1)
    ax.legend(loc="lower right", fontsize=7)
    return _save(fig, path, dpi)


# ---- figure 9 ----------------------------------------------------------------------------------
def _growth_panel(ax, bs: BaseState, k, title: str, limit=None, limit_label=None):
    inv = bs.with_nu(0.0)
    ax.semilogx(k, d1.sigma_M(inv, k), "k-", lw=1.2, label=r"inviscid ($\nu = 0$)")
    visc = d1.sigma_M(bs, k, extended="auto")
    ax.semilogx(k, visc, "C0-", lw=1.2, label=rf"viscous ($\nu = {bs.nu:g}$ m$^{{3/2}}$/s)")
    if limit is not None:
        ax.axhline(limit, color="k", ls="-.", lw=0.9, label=limit_label)
    kM, sM = d1.most_unstable(bs)
    ax.plot(
        [kM], [sM], "o", color="C0", ms=4, label=rf"$k_M = {kM:.3f}$, $\sigma_{{Max}} = {sM:.4f}$"
    )
    kc = d1.cutoff(bs, kM)
    if kc is not None:
        ax.axvline(kc, color="C3", ls=":", lw=1)
        ax.plot([kc], [0.0], "x", color="C3", ms=7, label=rf"cutoff $k_c = {kc:.4f}$ (A42)")
    ax.axhline(0.0, color="0.5", lw=0.5)
    ax.set_xlabel(K_LABEL)
    ax.set_ylabel(S_LABEL)
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=7, loc="lower left")


def fig09_growth_rates(path, m: Material = TABLE1, dpi=90) -> Path:
    """sigma_M(k) for nu = 0 and nu = 1e-3 at h0 = 2 mm (F < Fc) and 3 mm (F > Fc)."""
    k = np.logspace(-2, 2, 400)
    fig, axes = _figure(1, 2, size=(11.0, 4.3))
    b2 = base_state(0.002, PHI0, NU_FIG, m)
    b3 = base_state(0.003, PHI0, NU_FIG, m)
    _growth_panel(
        axes[0, 0],
        b2,
        k,
        rf"(a) $h_0$ = 2 mm: $F = {b2.F:.2f} < F_c = {b2.Fc:.2f}$, $R = {b2.R:.2f}$",
        asy.inviscid_limits(b2)[2],
        r"inviscid limit (5.30)",
    )
    _growth_panel(
        axes[0, 1],
        b3,
        k,
        rf"(b) $h_0$ = 3 mm: $F = {b3.F:.2f} > F_c = {b3.Fc:.2f}$, $R = {b3.R:.2f}$",
        asy.inviscid_limits(b3)[1],
        r"inviscid limit (5.29)",
    )
    fig.suptitle(rf"Fig. 9: growth rates, $\bar\phi_0 = {PHI0}$", fontsize=10)
    return _save(fig, path, dpi)


# ---- figure 10 ---------------------------------------------------------------------------------
def fig10_critical(path, m: Material = TABLE1, dpi=90) -> Path:
    """sigma_M(k) at F = Fc on log-log axes with the k^{1/2} (5.31) and k^-4 (5.35) laws."""
    Fc = base_state(0.002, PHI0, 0.0, m).Fc
    bs = base_state_from_froude(Fc, PHI0, NU_FIG, m)
    inv = bs.with_nu(0.0)
    k = np.logspace(-2, 4, 241)
    fig, ax = _figure()
    ax = ax[0, 0]
    si = d1.sigma_M(inv, k, extended="auto")
    sv = d1.sigma_M(bs, k, extended="auto")
    ax.loglog(k, np.where(si > 0, si, np.nan), "k-", lw=1.2, label=r"inviscid ($\nu = 0$)")
    ax.loglog(
        k,
        np.where(sv > 0, sv, np.nan),
        "C0-",
        lw=1.2,
        label=rf"viscous ($\nu = {NU_FIG:g}$ m$^{{3/2}}$/s)",
    )
    c = asy.critical_sqrt_coefficient(inv)
    kk = k[k >= 10]
    ax.loglog(kk, c * np.sqrt(kk), "--", color="C3", lw=1.2, label=rf"(5.31): ${c:.4f}\,k^{{1/2}}$")
    c4 = asy.viscous_k4_coefficient(bs)
    kk = k[k >= 5]
    ax.loglog(kk, c4 / kk**4, "-.", color="C3", lw=1.2, label=rf"(5.35): ${c4:.4f}\,k^{{-4}}$")
    kM, sM = d1.most_unstable(bs)
    ax.plot(
        [kM], [sM], "o", color="C0", ms=4, label=rf"$k_M = {kM:.3f}$, $\sigma_{{Max}} = {sM:.4f}$"
    )
    ax.set_ylim(1e-17, 1e2)
    ax.set_xlabel(K_LABEL)
    ax.set_ylabel(S_LABEL)
    ax.set_title(
        rf"Fig. 10: $F = F_c = {Fc:.3f}$ ($h_0$ = {bs.h0 * 1e3:.2f} mm, "
        rf"$\bar\phi_0 = {PHI0}$, $R = {bs.R:.2f}$)",
        fontsize=9,
    )
    ax.legend(fontsize=7, loc="lower left")
    return _save(fig, path, dpi)


# ---- figure 11 ---------------------------------------------------------------------------------
def sigma_max_curve(Fs, nu, m: Material = TABLE1):
    """sigma_Max(F) at phi0 = 0.8 (inviscid: the supremum, inf at Fc)."""
    return np.array(
        [d1.most_unstable(base_state_from_froude(float(F), PHI0, nu, m))[1] for F in Fs]
    )


def cutoff_curve(Fs, nu, m: Material = TABLE1):
    """Numerical k_c(F) (nan where there is none) and the analytic (A42) value."""
    num, ana = [], []
    for F in Fs:
        bs = base_state_from_froude(float(F), PHI0, nu, m)
        kc = d1.cutoff(bs)
        num.append(np.nan if kc is None else kc)
        a = [v for v in d1.cutoff_analytic(bs) if v is not None]
        ana.append(min(a) if a else np.nan)
    return np.array(num), np.array(ana)


def fig11_sigma_max(path, m: Material = TABLE1, dpi=90) -> Path:
    """(a) sigma_Max(F) for nu = 0, 5e-4, 1e-3, 2e-3, 1e-2; (b) the cutoff k_c(F) (F > Fc)."""
    Fc = base_state(0.002, PHI0, 0.0, m).Fc
    Fs = np.unique(
        np.concatenate(
            [
                np.linspace(0.25, 3.5, 53),
                Fc
                + np.array([-0.05, -0.02, -0.01, -0.004, -0.001, 0.001, 0.004, 0.01, 0.02, 0.05]),
            ]
        )
    )
    fig, axes = _figure(1, 2, size=(11.0, 4.3))
    ax = axes[0, 0]
    below, above = Fs[Fs < Fc], Fs[Fs > Fc]
    for part in (below, above):
        ax.semilogy(
            part,
            sigma_max_curve(part, 0.0, m),
            "k-",
            lw=1.2,
            label=r"$\nu = 0$ (sup, $k\to\infty$)" if part is below else None,
        )
    for i, nu in enumerate(NUS_FIG11):
        ax.semilogy(Fs, sigma_max_curve(Fs, nu, m), f"C{i}-", lw=1.1, label=rf"$\nu = {nu:g}$")
    ax.axvline(Fc, color="0.4", ls="--", lw=0.8)
    ax.text(Fc, 30, r" $F_c$", fontsize=8)
    ax.set_ylim(1e-2, 50)
    ax.set_xlabel(r"steady Froude number $F$ (varied through $h_0$)")
    ax.set_ylabel(r"$\sigma_{Max}$ [units of $u_0/h_0$]")
    ax.set_title(r"(a) maximum growth rate", fontsize=9)
    ax.legend(fontsize=7, title=r"$\nu$ in m$^{3/2}$/s", title_fontsize=7)

    ax = axes[0, 1]
    Fk = np.concatenate(
        [Fc + np.array([0.005, 0.01, 0.02, 0.035]), np.linspace(Fc + 0.05, 3.5, 24)]
    )
    for i, nu in enumerate(NUS_FIG11):
        num, ana = cutoff_curve(Fk, nu, m)
        ax.semilogy(Fk, num, f"C{i}-", lw=1.1, label=rf"$\nu = {nu:g}$ (numerical)")
        ax.semilogy(Fk[::3], ana[::3], f"C{i}o", ms=3, mfc="none")
    ax.plot([], [], "ko", ms=3, mfc="none", label="analytic (A41)/(A42)")
    ax.axvline(Fc, color="0.4", ls="--", lw=0.8)
    ax.set_xlim(0.25, 3.5)
    ax.set_ylim(0.3, 100)
    ax.set_xlabel(r"steady Froude number $F$")
    ax.set_ylabel(r"cutoff wavenumber $\hat k_c = k_c h_0$")
    ax.set_title(r"(b) cutoff wavenumber (only for $\nu > 0$, $F > F_c$)", fontsize=9)
    ax.legend(fontsize=7)
    fig.suptitle(rf"Fig. 11: $\bar\phi_0 = {PHI0}$, $F_c = {Fc:.4f}$", fontsize=10)
    return _save(fig, path, dpi)


# ---- all of them, and the CLI plot -----------------------------------------------------------------
def make_all(out_dir, m: Material = TABLE1, dpi=90) -> list[Path]:
    """Write figures 8-11 as PNGs into out_dir; returns the paths."""
    out = Path(out_dir)
    return [
        fig08_froude(out / FILES["fig08"], m, dpi),
        fig09_growth_rates(out / FILES["fig09"], m, dpi),
        fig10_critical(out / FILES["fig10"], m, dpi),
        fig11_sigma_max(out / FILES["fig11"], m, dpi),
    ]


def plot_growth_rate(bs: BaseState, path, k_points=None, dpi=90) -> Path:
    """sigma_M(k) of one base state, inviscid and (if nu > 0) viscous, for `tiseg stability --plot`."""
    k_points = np.asarray([] if k_points is None else k_points, dtype=float)
    kp = k_points[k_points > 0]
    lo = min(1e-2, kp.min() / 2) if kp.size else 1e-2
    hi = max(1e2, kp.max() * 2) if kp.size else 1e2
    k = np.logspace(math.log10(lo), math.log10(hi), 300)
    fig, ax = _figure()
    ax = ax[0, 0]
    inv = bs.with_nu(0.0)
    ax.semilogx(k, d1.sigma_M(inv, k, extended="auto"), "k-", lw=1.2, label=r"inviscid ($\nu = 0$)")
    sup = asy.inviscid_supremum(inv)
    if math.isfinite(sup):
        ax.axhline(sup, color="k", ls="-.", lw=0.8, label=rf"inviscid sup {sup:.4g} (5.28)-(5.30)")
    if not bs.inviscid:
        ax.semilogx(
            k,
            d1.sigma_M(bs, k, extended="auto"),
            "C0-",
            lw=1.2,
            label=rf"viscous ($\nu = {bs.nu:g}$ m$^{{3/2}}$/s, $R = {bs.R:.3g}$)",
        )
        kM, sM = d1.most_unstable(bs)
        ax.plot(
            [kM],
            [sM],
            "o",
            color="C0",
            ms=4,
            label=rf"$k_M = {kM:.4g}$, $\sigma_{{Max}} = {sM:.4g}$",
        )
        kc = d1.cutoff(bs, kM)
        if kc is not None:
            ax.axvline(kc, color="C3", ls=":", lw=1, label=rf"cutoff $k_c = {kc:.4g}$")
    if kp.size:
        ax.plot(kp, d1.sigma_M(bs, kp, extended="auto"), "s", color="C1", ms=4, label="requested k")
    ax.axhline(0.0, color="0.5", lw=0.5)
    ax.set_xlabel(K_LABEL)
    ax.set_ylabel(S_LABEL)
    ax.set_title(
        rf"$h_0$ = {bs.h0 * 1e3:.4g} mm, $\bar\phi_0$ = {bs.phi0:g}, $F$ = {bs.F:.4g}, "
        rf"$F_c$ = {bs.Fc:.4g}",
        fontsize=9,
    )
    ax.legend(fontsize=7)
    return _save(fig, path, dpi)


__all__ = [
    "make_all",
    "fig08_froude",
    "fig09_growth_rates",
    "fig10_critical",
    "fig11_sigma_max",
    "plot_growth_rate",
    "sigma_max_curve",
    "cutoff_curve",
    "FILES",
]
