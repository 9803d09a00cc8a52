"""`tiseg fingers DIR`: finger diagnostics of a saved run (section 6.3, (6.10)-(6.12), figure 16)."""

from __future__ import annotations

import math

from ...post.analysis.deposit import deposit_when, still_moving
from .common import print_json
from ...post.analysis.fingers import analyse_run
from ...errors import require
from ...output.netcdf import reading
from ...output.numbers import measured_all


# `tiseg fingers --help` ends with these (`tiseg.apps.examples`); a test parses each.
EXAMPLES = [
    ("tiseg fingers runs/fingers", "fronts, finger counts and wavelengths at every output time"),
    ("tiseg fingers runs/fingers --time 7.5 --json", "the numbers at t = 7.5 s, as JSON"),
]


def register(sub) -> None:
    p = sub.add_parser(
        "fingers",
        help="front positions, finger count and wavelength of a saved run",
        description="Per output time: front positions x_f+ (6.10), x_f- (6.11), elongation x_l "
        "(6.12), number of fingers and mean wavelength Lambda = Ly / count, the "
        "spectral wavelength of phi, front speed dx_f+/dt, channel and levee "
        "speeds over u0 and the channel phi. Fingers are the fine-rich wet "
        "channels between coarse levees in x_f- <= x <= x_f+, joined into 2D "
        "objects (periodic in y) and counted once each if they reach --min-span "
        "of x_l; or the median count on the cross-slope lines of --lines. Once the flow "
        "has come to rest: when it stopped, the run-out x_f+ and the deposit thickness. "
        "A run without segregation (no phi: a dam break) gets the front, its speed and the "
        "deposit; its finger numbers are null.",
    )
    p.add_argument("dir", metavar="DIR", help="run folder with fields.nc, or a fields.nc file")
    p.add_argument(
        "--time", type=float, default=None, metavar="T", help="only the output time T [s]"
    )
    p.add_argument("--json", action="store_true", help="print machine-readable JSON")
    p.add_argument(
        "--rest-speed",
        type=float,
        default=None,
        metavar="U",
        help="the flow is at rest at an output time when no wet cell is faster than U [m/s] "
        "(default 1e-6): then the deposit's run-out, thickness and stop time are reported",
    )
    p.add_argument(
        "--settle-fraction",
        type=float,
        default=None,
        metavar="F",
        help="the flow has settled at an output time when its momentum (sum of h |u| over the "
        "wet cells) is at most F times its largest value (default 1e-5); a flow that settled "
        "without coming to rest gets its deposit reported at the settle time, with the cells "
        "still moving",
    )
    g = p.add_argument_group("counting (defaults from the stored scene and the grid)")
    g.add_argument(
        "--phi-threshold",
        type=float,
        default=None,
        metavar="PHI",
        help="channel cells have phi above PHI (default phi0/2)",
    )
    g.add_argument(
        "--lines",
        type=float,
        nargs="+",
        default=None,
        metavar="F",
        help="count on the lines x_f- + F x_l only and take the median (default: "
        "the fine-rich channels as 2D objects)",
    )
    g.add_argument(
        "--min-span",
        type=float,
        default=None,
        metavar="FRAC",
        help="a channel counts as a finger if it reaches this fraction of x_l "
        "downslope (default 0.1)",
    )
    g.add_argument(
        "--min-persistence",
        type=float,
        default=None,
        metavar="FRAC",
        help="the persistent line count (finger_count_lines) must hold on this "
        "fraction of the columns (default 0.1)",
    )
    g.add_argument(
        "--min-width",
        type=float,
        default=None,
        metavar="M",
        help="ignore channels narrower than M metres (default 2 cells)",
    )
    g.add_argument(
        "--min-gap",
        type=float,
        default=None,
        metavar="M",
        help="merge channels separated by less than M metres (default 2 cells)",
    )
    p.set_defaults(func=run)


def run(args) -> int:

    require(
        args.time is None or (math.isfinite(args.time) and args.time >= 0),
        f"--time={args.time!r}: give a time in seconds >= 0 (a snapshot of the run)",
    )

    opts = {}
    if args.phi_threshold is not None:
        require(
            0 <= args.phi_threshold <= 1,
            f"--phi-threshold={args.phi_threshold!r} must lie in [0, 1]",
        )
        opts["phi_threshold"] = args.phi_threshold
    if args.lines is not None:
        require(
            all(0 <= f <= 1 for f in args.lines),
            f"--lines {' '.join(f'{f:g}' for f in args.lines)}: fractions must lie in [0, 1]",
        )
        opts["line_fractions"] = args.lines
    if args.min_span is not None:
        require(0 <= args.min_span <= 1, f"--min-span={args.min_span!r} must lie in [0, 1]")
        opts["min_span"] = args.min_span
    if args.min_persistence is not None:
        require(
            0 <= args.min_persistence <= 1,
            f"--min-persistence={args.min_persistence!r} must lie in [0, 1]",
        )
        opts["min_persistence"] = args.min_persistence
    for name in ("min_width", "min_gap"):
        value = getattr(args, name)
        if value is not None:
            require(
                math.isfinite(value) and value >= 0,
                f"--{name.replace('_', '-')}={value!r} must be a length >= 0 [m]",
            )
            opts[name] = value
    if args.rest_speed is not None:
        require(
            math.isfinite(args.rest_speed) and args.rest_speed >= 0,
            f"--rest-speed={args.rest_speed!r} must be a speed >= 0 [m/s]",
        )
        opts["rest_speed"] = args.rest_speed
    if args.settle_fraction is not None:
        require(
            math.isfinite(args.settle_fraction) and 0 <= args.settle_fraction < 1,
            f"--settle-fraction={args.settle_fraction!r} must be a fraction in [0, 1)",
        )
        opts["settle_fraction"] = args.settle_fraction
    with reading(args.dir):  # a damaged data block: one line
        res = analyse_run(args.dir, time=args.time, **opts)
    if args.json:
        print_json(measured_all(res))  # 12 significant digits (tiseg.output.numbers)
        return 0

    o = res["options"]
    seg = res["segregation"]
    u0 = "-" if res["u0"] is None else f"{res['u0']:.4g} m/s"
    phi0 = f"phi0 = {res['phi0']:g}" if seg else "no segregation (no phi: fronts only)"
    print(f"{res['file']}: {phi0}, u0 = {u0}, h_min = {res['h_min']:g} m, Ly = {res['Ly']:g} m")
    if seg:
        if o["line_fractions"] is None:
            lines = f"2D channels reaching >= {o['min_span']:g} x_l in [x_f-, x_f+]"
        else:
            lines = f"median count on x_f- + {'/'.join(f'{f:g}' for f in o['line_fractions'])} x_l"
        print(
            f"channels: wet, phi > {o['phi_threshold']:g}, min width {o['min_width']:.3g} m, "
            f"min gap {o['min_gap']:.3g} m; {lines}"
        )
    if not res["time"]:
        print("no snapshots")
        return 0
    cols = [
        ("t [s]", "time", "{:.4g}"),
        ("x_f+ [m]", "x_front_max", "{:.4f}"),
        ("x_f- [m]", "x_front_min", "{:.4f}"),
        ("x_l [m]", "elongation", "{:.4f}"),
        ("fingers", "finger_count", "{:d}"),
        ("Lambda [m]", "wavelength", "{:.4f}"),
        ("Lambda_spec [m]", "wavelength_spectral", "{:.4f}"),
        ("dx_f+/dt [m/s]", "front_speed", "{:.4f}"),
        ("|u|_ch/u0", "channel_speed_over_u0", "{:.3f}"),
        ("phi_ch", "channel_phi", "{:.3f}"),
        ("|u|_lev/u0", "levee_speed_over_u0", "{:.3f}"),
        ("max|u|/u0", "max_channel_speed_over_u0", "{:.3f}"),
    ]
    if not seg:  # the columns that exist without phi
        cols = [c for c in cols if c[1] in ("time", "x_front_max", "front_speed")]
    rows = [
        [(fmt.format(res[key][i]) if res[key][i] is not None else "-") for _, key, fmt in cols]
        for i in range(len(res["time"]))
    ]
    widths = [max(len(title), *(len(r[c]) for r in rows)) for c, (title, _, _) in enumerate(cols)]
    print("  ".join(title.rjust(w) for (title, _, _), w in zip(cols, widths)))
    for r in rows:
        print("  ".join(cell.rjust(w) for cell, w in zip(r, widths)))
    print(_deposit_line(res["deposit"], res["time"][-1] if res["time"] else None, seg))
    return 0


def _deposit_line(d: dict, t_last, segregation: bool = True) -> str:
    """One line on the deposit: when the flow stopped (or settled), its run-out and
    thickness (of its channels and levees too with ``segregation``)."""
    last = d["max_speed"][-1] if d["max_speed"] else None
    if not d["settled"]:
        speed = "no wet cell" if last is None else f"max |u| = {last:.3g} m/s"
        return (
            f"deposit: the flow has not come to rest by the last output time ({speed} > "
            f"{d['rest_speed']:g} m/s; momentum above {d['settle_fraction']:g} of its peak)"
        )
    since = deposit_when(d)
    state = "at rest" if d["stopped"] else "settled"
    if d["run_out"] is None:
        return f"deposit: {state} {since}, nothing left on the chute"

    def mm(v):
        return "-" if v is None else f"{1e3 * v:.3g} mm"

    bound = " (reaches the domain end: a lower bound)" if d["run_out_at_domain_end"] else ""
    parts = (
        f", channels {mm(d['channel_thickness'])}, levees {mm(d['levee_thickness'])}"
        if segregation
        else ""
    )
    line = (
        f"deposit: {state} {since}; run-out x_f+ = {d['run_out']:.4f} m{bound}; thickness "
        f"mean {mm(d['thickness_mean'])}, max {mm(d['thickness_max'])}{parts}; area "
        f"{d['area']:.4g} m^2, volume {d['volume']:.4g} m^3; h changes by at most "
        f"{d['thickness_change']:.3g} m between outputs from then on"
    )
    if not d["stopped"]:
        line += f"; {still_moving(d)}"
    return line
