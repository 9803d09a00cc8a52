"""`tiseg demo`: the main job in one command.

Runs the paper's finger experiment (section 6.2, figure 12 set-up) at a reduced resolution,
writes its movie (coloured like the experiments), the paper-style panels of phi, |u| and h
(figures 12-14), the finger diagnostics (6.10)-(6.12), and the linear-stability figures 8-11.

The demo's finger count and wavelength are those of one run (the scene's inflow seed) at a
resolution below the one where the statistics converge, so it prints them beside the converged
values (`CONVERGED`) and says where those come from.
"""

from __future__ import annotations

from ...output.names import FIELDS_FILE, FINGERS_FILE

from pathlib import Path

from .common import add_arch, add_out, add_overwrite
from ...post.analysis import analyse_run
from ...post.analysis.fingers import count_text
from ...errors import InputError

PAPER_TIMES = (1.9, 3.3, 5.1, 6.2, 7.5)
# what the demo writes beside the run's files (a rerun replaces them without asking)
DEMO_FILES = ("fingers.mp4", "fig12_phi.png", "fig13_speed.png", "fig14_h.png", "stability")

# The converged finger statistics of the fingers scene at t = 7.5 s, with its default numerics
# (the split sweeps at cfl 0.9, a pair of half steps around the viscous sub-step, films
# thinner than h_min flowing): mean and standard deviation over seeded runs (seeds 1-5) at 375
# cells/m, where they agree with the 750 cells/m ensemble (the row "pair, cfl 0.9, films flow"
# of section 7 of the file named by "source"; the runs: ensembles/pair-cfl0.9-films).
CONVERGED = {
    "resolution": 375.0,  # cells per metre
    "time": 7.5,  # s
    "runs": 5,
    "finger_count": (10.0, 0.71),  # mean, sd
    "wavelength_cm": (5.02, 0.36),  # mean, sd; Lambda = Ly / count (6.12)
    "source": "benchmarks/split_fingers/README.md",
    "runs_folder": "ensembles/pair-cfl0.9-films",
}


# `tiseg demo --help` ends with these (`tiseg.apps.examples`); a test parses each.
EXAMPLES = [
    ("tiseg demo", "the fingers run, its movie, figures 8-14 and diagnostics in runs/demo"),
    ("tiseg demo --resolution 200 --out runs/demo-small", "the same, coarser and quicker"),
]


def register(sub) -> None:
    p = sub.add_parser(
        "demo",
        help="run a small finger simulation; write a movie and figures",
        description=__doc__.splitlines()[0] + " Runs the fingers scene, writes a "
        "movie, figures 8-14 and the finger diagnostics into the output folder.",
    )
    add_out(p, "output folder (runs/demo)", default="runs/demo")
    p.add_argument(
        "--resolution",
        type=float,
        default=200.0,
        help="cells per metre (paper: 750; 200 forms fingers in about a minute on 2 cores)",
    )
    p.add_argument("--t-end", type=float, default=7.5, help="end time [s] (7.5 as in the paper)")
    add_arch(p)
    add_overwrite(p, "write into an --out folder that holds files other than the demo's")
    p.add_argument("--no-progress", action="store_true")
    p.set_defaults(func=run)


def run(args) -> int:
    from ..figures.stability import make_all
    from ...output import write_json_atomic
    from ...output.numbers import measured_all
    from ...run.run_folder import check_fresh_folder
    from .common import check_output_folder
    from ...post.render.movie import MovieRecorder
    from ...post.render.panels import plot_panels
    from ...setup.scene import load_scene
    from ...run.simulation import Simulation

    if not (20 <= args.resolution <= 3000):
        raise InputError(
            f"--resolution={args.resolution!r}: choose between 20 and 3000 cells per metre"
        )
    out = Path(args.out)
    check_output_folder(out)
    check_fresh_folder(out, args.overwrite or _is_demo_folder(out), also=DEMO_FILES)
    times = [t for t in PAPER_TIMES if t < args.t_end] + [args.t_end]
    scene = load_scene(
        "fingers",
        {
            "domain.resolution": args.resolution,
            "time.t_end": args.t_end,
            "output.times": times,
            "output.interval": args.t_end / 75,
        },
    )
    sim = Simulation(scene, arch=args.arch)
    movie_path = out / "fingers.mp4"
    out.mkdir(parents=True, exist_ok=True)
    movie = MovieRecorder.for_simulation(sim, movie_path, "phi", fps=12)
    try:
        stats = sim.run(
            out_dir=out, progress=not args.no_progress, on_output=movie, overwrite=True
        )  # checked above
    finally:
        movie.close()
    written = [movie_path]
    for field, fig in (("phi", 12), ("speed", 13), ("h", 14)):
        path = out / f"fig{fig}_{field}.png"
        plot_panels(
            out,
            times=times,
            field=field,
            path=path,
            title=f"{field} at {args.resolution:g} cells/m (cf. figure {fig})",
        )
        written.append(path)
    metrics = measured_all(analyse_run(out))  # 12 significant digits (output.numbers)
    write_json_atomic(out / FINGERS_FILE, metrics)
    written.append(out / FINGERS_FILE)
    written += make_all(out / "stability", scene.material)
    last = {
        k: metrics[k][-1]
        for k in ("time", "finger_count", "wavelength", "wavelength_spectral", "elongation")
    }
    print(
        f"simulated {sim.t:g} s of the fingers scene at {args.resolution:g} cells/m in "
        f"{stats.wall:.1f} s ({stats.steps} steps)"
    )

    def cm(v):
        return "-" if v is None else f"{v * 100:.1f} cm"

    print(
        f"at t = {last['time']:g} s: {count_text(last['finger_count'])}, wavelength "
        f"{cm(last['wavelength'])} (spectral {cm(last['wavelength_spectral'])}), elongation "
        f"{last['elongation'] or 0:.3f} m"
    )
    print(what_the_numbers_are(args.resolution, last["time"]))
    for p in written:
        print(p)
    return 0


def what_the_numbers_are(resolution: float, time: float) -> str:
    """The lines that say what the demo's finger numbers are: one run, beside the
    converged values of `CONVERGED` and their source."""
    c = CONVERGED
    (n, n_sd), (wl, wl_sd) = c["finger_count"], c["wavelength_cm"]
    run = f"  one run (the scene's inflow seed) at {resolution:g} cells/m"
    if abs(time - c["time"]) > 1e-9:
        run += f" to t = {time:g} s"
    if resolution < c["resolution"]:
        run += f", coarser than the {c['resolution']:g} cells/m where the statistics converge"
    return (
        f"{run}\n"
        f"  converged at t = {c['time']:g} s: {n:.1f} ± {n_sd:.1f} fingers, wavelength "
        f"{wl:.2f} ± {wl_sd:.2f} cm\n"
        f"  (mean ± sd of {c['runs']} seeded runs at {c['resolution']:g} cells/m; "
        f"tiseg repository, {c['source']})"
    )


def _is_demo_folder(out: Path) -> bool:
    """An earlier demo's folder (its movie is there): the demo may replace its own run."""
    return (out / "fingers.mp4").is_file() and (out / FIELDS_FILE).is_file()
