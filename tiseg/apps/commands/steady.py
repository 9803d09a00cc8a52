"""`tiseg steady`: the steady uniform state of section 4."""

from __future__ import annotations

from ...model.steady import steady_state
from .common import add_material_options, material_from_args, print_json


# `tiseg steady --help` ends with these (`tiseg.apps.examples`); a test parses each.
EXAMPLES = [
    (
        "tiseg steady --h0 0.002 --phi0 0.5",
        "Froude number, u0, phi0* and the critical Fc of Table 1's flow",
    ),
    (
        "tiseg steady --h0 0.003 --phi0 0.3 --zeta 28 --json",
        "another flow on a steeper slope, as JSON",
    ),
]


def register(sub) -> None:
    p = sub.add_parser(
        "steady",
        help="steady uniform flow (section 4): F, u0, phi0*, Fc",
        description="Steady uniform Froude number (4.9), velocity u0, phi0* (4.8), "
        "critical Froude number Fc (5.27) and the h0 where F = Fc.",
    )
    p.add_argument("--h0", type=float, required=True, help="flow thickness [m], e.g. 0.002")
    p.add_argument(
        "--phi0", type=float, required=True, help="small-particle concentration in [0, 1]"
    )
    p.add_argument("--json", action="store_true", help="print machine-readable JSON")
    add_material_options(p)
    p.set_defaults(func=run)


def run(args) -> int:
    m = material_from_args(args)
    s = steady_state(args.h0, args.phi0, m)
    out = {
        "F": s.F,
        "u0": s.u0,
        "phi0_star": s.phi0_star,
        "Fc": s.Fc,
        "h0_at_Fc": s.h0_at_Fc,
        "h0": s.h0,
        "phi0": s.phi0,
        "zeta_deg": m.zeta_deg,
    }
    if args.json:
        print_json(out)
    else:
        print(f"h0 = {s.h0 * 1e3:.4g} mm, phi0 = {s.phi0:.4g}, zeta = {m.zeta_deg:g} deg")
        print(f"F  = {s.F:.4f}   (4.9)")
        print(f"u0 = {s.u0:.4f} m/s")
        print(f"phi0* = {s.phi0_star:.4f}   (4.8)")
        print(f"Fc = {s.Fc:.4f}   (5.27), reached at h0 = {s.h0_at_Fc * 1e3:.4f} mm")
    return 0
