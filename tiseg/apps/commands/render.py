"""`tiseg render RUN_DIR`: movies, PNG frames, GIFs and paper-style panels of a finished run;
`tiseg render SWEEP_DIR` (or its probability.nc): the figure of a sweep's probability maps."""

from __future__ import annotations

import math
from pathlib import Path

from .common import print_json
from ...errors import InputError
from ...output.netcdf import reading
from ...post.render.colours import canonical_field


# `tiseg render --help` ends with these (`tiseg.apps.examples`); a test parses each.
EXAMPLES = [
    ("tiseg render runs/fingers --movie fingers.mp4", "a movie of phi with a colour bar"),
    ("tiseg render runs/fingers --panels panels.png --times 2.5 5 7.5", "figure-12-like panels"),
    ("tiseg render runs/fingers --raster", "peak fields and the deposit as ESRI ASCII grids"),
    ("tiseg render runs/sweeps/gate-probability", "the probability maps of a sweep"),
]


def register(sub) -> None:
    p = sub.add_parser(
        "render",
        help="render a run's snapshots to mp4 / GIF / PNG frames / panels, or a sweep's "
        "probability maps",
        description="Render the snapshots in RUN_DIR/fields.nc (written by "
        "`tiseg run`) with the experiment-like colours of figure 12 "
        "(white fines, brown coarse grains, turquoise empty chute) or "
        "a viridis map of h, |u|, u or v. Given a sweep folder with probability.nc (a sweep "
        "with a [probability] table) or that file, draw its maps instead: a panel per "
        "threshold of P(h_max > threshold) and P(speed_max > threshold), the probability of "
        "arrival, and the mean and quantiles of h_max and of the arrival time, into "
        "SWEEP_DIR/probability.png (or --panels OUT.png). Needs no display or Vulkan.",
    )
    p.add_argument(
        "run_dir",
        metavar="RUN_DIR",
        help="run folder (or its fields.nc), or a sweep folder with probability.nc (or the file)",
    )
    p.add_argument("--field", default=None, help="phi (default), h, speed (or |u|), u or v")
    p.add_argument("--movie", default=None, metavar="OUT.mp4", help="write an mp4 movie")
    p.add_argument("--gif", default=None, metavar="OUT.gif", help="write an animated GIF")
    p.add_argument("--frames", default=None, metavar="DIR", help="write PNG frames into DIR")
    p.add_argument(
        "--panels",
        default=None,
        metavar="OUT.png",
        help="write a paper-style figure with one panel per time (see --times)",
    )
    p.add_argument(
        "--times",
        type=float,
        nargs="+",
        default=None,
        metavar="T",
        help="panel times [s] (default: five snapshots evenly spread)",
    )
    p.add_argument(
        "--raster",
        action="store_true",
        help="write the peak fields and the deposit (h_max, speed_max, arrival_time, "
        "deposit_h, deposit_phi) as ESRI ASCII grids RUN_DIR/NAME.asc, in metres, for GIS",
    )
    p.add_argument(
        "--peaks",
        action="store_true",
        help="draw the peak fields and the deposit (h_max, speed_max, arrival_time, "
        "deposit_h, deposit_phi) as maps, over the shaded relief of a run with terrain, into "
        "RUN_DIR/peaks.png",
    )
    p.add_argument(
        "--gauges",
        action="store_true",
        help="draw the run's gauges (gauges.csv of [[output.gauges]]) over time into "
        "RUN_DIR/gauges.png",
    )
    p.add_argument("--fps", type=float, default=10.0, help="movie frames per second (10)")
    p.add_argument(
        "--scale",
        type=float,
        default=None,
        help="pixels per cell (default 1, more for grids under 600 cells wide)",
    )
    p.add_argument(
        "--max-frames",
        type=int,
        default=None,
        metavar="N",
        help="at most N frames, evenly spread over the run",
    )
    p.add_argument("--vmin", type=float, default=None, help="colour range minimum (SI units)")
    p.add_argument("--vmax", type=float, default=None, help="colour range maximum (SI units)")
    p.add_argument("--no-shade", action="store_true", help="no relief shading")
    p.add_argument("--no-annotate", action="store_true", help="no time stamp / scale bar")
    p.add_argument("--json", action="store_true", help="print a JSON summary")
    p.set_defaults(func=run)


def run(args) -> int:
    from ...post.render.movie import refuse_link, render_run
    from ...post.render.probability import probability_source

    source = probability_source(args.run_dir)
    if source is not None:
        return _render_probability(args, source)
    try:
        field = canonical_field(args.field or "phi")
    except ValueError as exc:
        raise InputError(str(exc)) from None
    if args.scale is not None and not (args.scale > 0 and math.isfinite(args.scale)):
        raise InputError(f"--scale={args.scale!r} must be a positive number")
    if (args.vmin is None) != (args.vmax is None):
        raise InputError("give both --vmin and --vmax, or neither")
    vrange = None
    if args.vmin is not None:
        if not args.vmax > args.vmin:
            raise InputError(f"--vmax={args.vmax} must be above --vmin={args.vmin}")
        vrange = (args.vmin, args.vmax)
    movie = args.movie
    chosen = (args.movie, args.gif, args.frames, args.panels)
    if all(c is None for c in chosen) and not (args.raster or args.gauges or args.peaks):
        movie = str(Path(args.run_dir) / f"{field}.mp4")  # a sensible default
    for target in (movie, args.gif, args.frames, args.panels):  # before anything is written
        if target is not None:
            refuse_link(Path(target))
    summary = {"field": field, "outputs": []}
    with reading(args.run_dir):  # a damaged data block: one line, not a traceback
        if movie is not None or args.gif is not None or args.frames is not None:
            res = render_run(
                args.run_dir,
                field=field,
                movie=movie,
                frames=args.frames,
                gif=args.gif,
                fps=args.fps,
                max_frames=args.max_frames,
                shade=not args.no_shade,
                scale=args.scale,
                vrange=vrange,
                annotate=not args.no_annotate,
            )
            summary.update(res)
        if args.panels is not None:
            from ...post.render.panels import plot_panels

            plot_panels(
                args.run_dir,
                args.times,
                field,
                args.panels,
                shade=not args.no_shade,
                vrange=vrange,
                scale=args.scale or 1.0,
            )
            summary["outputs"] = list(summary["outputs"]) + [args.panels]
        if args.gauges:
            from ...post.render.gauge_plot import plot_gauges

            summary["outputs"] = list(summary["outputs"]) + [str(plot_gauges(args.run_dir))]
        if args.peaks:
            from ...post.render.movie import _fields_path
            from ...post.render.peak_maps import plot_peak_fields

            target = _fields_path(args.run_dir).parent / "peaks.png"
            plot_peak_fields(
                args.run_dir, target, shade=not args.no_shade, scale_bar=not args.no_annotate
            )
            summary["outputs"] = list(summary["outputs"]) + [str(target)]
        if args.raster:
            from ...post.render.peak_grids import export_peak_grids

            grids = export_peak_grids(args.run_dir)
            summary["peak_time"] = grids["peak_time"]
            summary["outputs"] = list(summary["outputs"]) + grids["outputs"]
    if args.json:
        print_json(summary)
    else:
        if "frames" in summary:
            h, w = summary["size"]
            print(f"rendered {summary['frames']} frames of {field} ({w} x {h} px)")
        for out in summary["outputs"]:
            print(f"wrote {out}")
    return 0


def _render_probability(args, source: Path) -> int:
    """The figure of a sweep's probability.nc (`tiseg.post.render.probability`)."""
    from ...post.render.movie import refuse_link
    from ...post.render.probability import plot_probability

    given = [
        flag
        for flag, value in (
            ("--field", args.field),
            ("--movie", args.movie),
            ("--gif", args.gif),
            ("--frames", args.frames),
            ("--times", args.times),
            ("--max-frames", args.max_frames),
            ("--raster", args.raster or None),
            ("--gauges", args.gauges or None),
            ("--peaks", args.peaks or None),
            ("--vmin", args.vmin),
            ("--vmax", args.vmax),
        )
        if value is not None
    ]
    if given:
        raise InputError(
            f"{', '.join(given)}: not for probability maps ({source} holds maps, not "
            "snapshots); give --panels OUT.png or nothing"
        )
    target = Path(args.panels) if args.panels else source.parent / "probability.png"
    refuse_link(target)
    with reading(source):  # a damaged data block: one line, not a traceback
        plot_probability(source, target, scale_bar=not args.no_annotate, shade=not args.no_shade)
    if args.json:
        print_json({"probability": str(source), "outputs": [str(target)]})
    else:
        print(f"wrote {target}")
    return 0
