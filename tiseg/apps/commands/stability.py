"""`tiseg stability`: linear stability of the steady uniform flow (section 5, appendices A, B)."""

from __future__ import annotations

import math

import numpy as np

from ...errors import require
from .common import add_material_options, material_from_args, print_json
from .common import check_figure_path

DEFAULT_K = [0.01, 0.1, 0.5, 1.0, 2.0, 5.0, 10.0, 100.0]


# `tiseg stability --help` ends with these (`tiseg.apps.examples`); a test parses each.
EXAMPLES = [
    (
        "tiseg stability --h0 0.002 --phi0 0.5",
        "growth rates of the paper's flow at the default wavenumbers",
    ),
    (
        "tiseg stability --F 1.2 --phi0 0.5 --nu 0 --json",
        "the inviscid rates at Froude number 1.2, as JSON",
    ),
    (
        "tiseg stability --h0 0.002 --phi0 0.5 --plot growth.png",
        "also draw sigma_M(k) into growth.png",
    ),
]


# Older JSON keys for the growth rate per k, which differed from sigma_Max (the maximum over
# k) only in the case of one letter; written as aliases of the new ones (same values).
OLD_NAMES = {
    "sigma_max": "sigma_M",
    "sigma_max_imag": "sigma_M_imag",
    "sigma_max_per_s": "sigma_M_per_s",
    "sigma_max_2d": "sigma_M_2d",
    "sigma_max_2d_imag": "sigma_M_2d_imag",
}


def register(sub) -> None:
    p = sub.add_parser(
        "stability",
        help="linear stability (section 5): sigma_M(k), k_M, sigma_Max, cutoff k_c",
        description="Growth rates of normal modes about the steady uniform flow, eq. (5.21)-(5.23) "
        "(and the 2D problem of appendix B with --ky). Wavenumbers k and rates sigma "
        "are dimensionless in the scalings (5.1): k = k_SI h0, sigma = sigma_SI h0/u0.",
    )
    src = p.add_mutually_exclusive_group(required=True)
    src.add_argument("--h0", type=float, help="flow thickness [m], e.g. 0.002")
    src.add_argument(
        "--F",
        type=float,
        dest="froude",
        help="steady Froude number instead of h0 (h0 = F/(F/h0), F is linear in h0)",
    )
    p.add_argument(
        "--phi0", type=float, required=True, help="small-particle concentration in [0, 1]"
    )
    p.add_argument(
        "--nu",
        type=float,
        default=1e-3,
        help="viscosity coefficient [m^(3/2)/s] (default 1e-3, as in figures 9-10; 0 = inviscid)",
    )
    p.add_argument(
        "--k",
        type=float,
        nargs="+",
        default=None,
        metavar="K",
        help=f"dimensionless (downslope) wavenumbers (default {DEFAULT_K})",
    )
    p.add_argument(
        "--ky",
        type=float,
        nargs="+",
        default=None,
        metavar="KY",
        help="cross-slope wavenumbers: adds the 2D analysis of appendix B for every (k, ky) pair",
    )
    p.add_argument(
        "--precision",
        choices=("auto", "double", "extended"),
        default="auto",
        help="double: numpy eigenvalues; extended: mpmath (40 digits); auto (default): "
        "mpmath only where double round-off ~eps k^2/R matters (large k)",
    )
    p.add_argument(
        "--plot",
        metavar="FILE.png",
        default=None,
        help="also draw sigma_M(k), inviscid and viscous, into this PNG",
    )
    p.add_argument(
        "--json",
        action="store_true",
        help="print machine-readable JSON: sigma_M (per k, the paper's sigma_M(k)) and "
        "sigma_Max (its maximum over k); sigma_max* are older names of sigma_M*",
    )
    add_material_options(p)
    p.set_defaults(func=run)


MAX_K = 1e6  # dimensionless k h0: far beyond any cut-off, and the matrices stay finite


def _check_wavenumbers(name: str, values) -> np.ndarray:
    arr = np.asarray(values, dtype=float)
    require(
        arr.size > 0
        and bool(np.all(np.isfinite(arr)))
        and bool(np.all(arr >= 0))
        and bool(np.all(arr <= MAX_K)),
        f"--{name}={list(values)!r}: wavenumbers must be numbers in [0, {MAX_K:g}] "
        f"(dimensionless, k h0; the instability lives below k ~ 10)",
    )
    return arr


def analyse(bs, k, ky=None, precision="auto") -> dict:
    """All numbers printed by the command, as a plain dict (inf/nan are left for print_json)."""
    from ...model.stability import asymptotics as asy
    from ...model.stability import dispersion1d as d1

    ext = {"auto": "auto", "double": False, "extended": True}[precision]
    r = d1.roots(bs, k, extended=ext)
    kM, sM = d1.most_unstable(bs)
    kc = d1.cutoff(bs, kM) if math.isfinite(kM) else d1.cutoff(bs)
    a41, a42 = d1.cutoff_analytic(bs)
    ts = bs.time_scale
    out = {
        "h0": bs.h0,
        "phi0": bs.phi0,
        "nu": bs.nu,
        "zeta_deg": bs.material.zeta_deg,
        "F": bs.F,
        "u0": bs.u0,
        "R": bs.R,
        "Fc": bs.Fc,
        "regime": (
            "F < Fc"
            if bs.criticality() < -asy.CRITICAL_TOL
            else "F > Fc"
            if bs.criticality() > asy.CRITICAL_TOL
            else "F = Fc"
        ),
        "k": k.tolist(),
        "sigma_M": r[..., 0].real.tolist(),
        "sigma_M_imag": r[..., 0].imag.tolist(),
        "sigma_M_per_s": (r[..., 0].real / ts).tolist(),
        "k_max": kM,
        "sigma_Max": sM,
        "sigma_Max_is_limit": not math.isfinite(kM),
        "sigma_Max_per_s": sM / ts,
        "wavelength_at_k_max_m": 2 * math.pi * bs.h0 / kM if 0 < kM < math.inf else None,
        "k_cutoff": kc,
        "wavelength_at_cutoff_m": None if kc is None else 2 * math.pi * bs.h0 / kc,
        "k_cutoff_analytic": {"A41": a41, "A42": a42},
        "inviscid_limits": list(asy.inviscid_limits(bs)),
        "base_state": {
            n: getattr(bs, n)
            for n in (
                "gamma_S",
                "gamma_L",
                "mub_S",
                "mub_L",
                "Gamma_S",
                "Gamma_L",
                "mu_h",
                "mu_u",
                "mu_phi",
                "G0",
                "dG0",
                "tan_zeta",
            )
        },
        "time_scale_s": ts,
    }
    if ky is not None:
        from ...model.stability import dispersion2d as d2

        KX, KY = np.meshgrid(k, ky)  # rows: ky, columns: k
        r2 = d2.roots(bs, KX, KY, extended=ext)
        out["ky"] = ky.tolist()
        out["sigma_M_2d"] = r2[..., 0].real.tolist()
        out["sigma_M_2d_imag"] = r2[..., 0].imag.tolist()
    for old, new in OLD_NAMES.items():  # scripts written against the older names keep working
        if new in out:
            out[old] = out[new]
    return out


def _fmt(x, spec=".6g") -> str:
    if x is None:
        return "none"
    if isinstance(x, float) and not math.isfinite(x):
        return "inf" if x > 0 else ("-inf" if x < 0 else "nan")
    return format(x, spec)


def _print_text(o: dict) -> None:
    print(
        f"h0 = {o['h0'] * 1e3:.4g} mm, phi0 = {o['phi0']:.4g}, nu = {o['nu']:g} m^(3/2)/s, "
        f"zeta = {o['zeta_deg']:g} deg"
    )
    print(
        f"F = {o['F']:.5g} ({o['regime']}, Fc = {_fmt(o['Fc'], '.5g')}), u0 = {o['u0']:.4g} m/s, "
        f"R = {_fmt(o['R'], '.5g')}, h0/u0 = {o['time_scale_s']:.4g} s"
    )
    print("       k     sigma_M    Im(sigma)   sigma_M [1/s]")
    for k, s, si, sd in zip(o["k"], o["sigma_M"], o["sigma_M_imag"], o["sigma_M_per_s"]):
        print(f"{k:10.4g} {s:11.4e} {si:11.4e} {sd:13.4e}")
    if o["sigma_Max_is_limit"]:
        print(
            f"sup sigma_M = {_fmt(o['sigma_Max'])} approached as k -> inf (inviscid; "
            f"{_fmt(o['sigma_Max_per_s'], '.4g')} 1/s)"
        )
    else:
        print(
            f"most unstable: k_M = {_fmt(o['k_max'])}, sigma_Max = {_fmt(o['sigma_Max'])} "
            f"({o['sigma_Max_per_s']:.4g} 1/s, wavelength {o['wavelength_at_k_max_m'] * 1e3:.4g} mm)"
        )
    print(
        f"cutoff k_c = {_fmt(o['k_cutoff'])} (analytic (A41): "
        f"{_fmt(o['k_cutoff_analytic']['A41'])}, (A42): {_fmt(o['k_cutoff_analytic']['A42'])})"
    )
    if "ky" in o:
        print("2D sigma_M (rows ky, columns k):")
        print("      ky \\ k " + " ".join(f"{k:11.4g}" for k in o["k"]))
        for ky, row in zip(o["ky"], o["sigma_M_2d"]):
            print(f"{ky:12.4g} " + " ".join(f"{s:11.4e}" for s in row))


def run(args) -> int:
    from ...model.stability.base import base_state, base_state_from_froude

    m = material_from_args(args)
    if args.froude is not None:
        bs = base_state_from_froude(args.froude, args.phi0, args.nu, m)
    else:
        bs = base_state(args.h0, args.phi0, args.nu, m)
    k = _check_wavenumbers("k", DEFAULT_K if args.k is None else args.k)
    ky = None if args.ky is None else _check_wavenumbers("ky", args.ky)
    if args.plot:
        check_figure_path(args.plot)
    out = analyse(bs, k, ky, args.precision)
    if args.plot:
        from ..figures.stability import plot_growth_rate

        out["plot"] = str(plot_growth_rate(bs, args.plot, k_points=k))
    if args.json:
        print_json(out)
    else:
        _print_text(out)
        if args.plot:
            print(f"plot written to {out['plot']}")
    return 0
