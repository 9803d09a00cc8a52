"""`tiseg run SCENE`: simulate a scene and write scene.toml, fields.nc, diagnostics.csv.

`tiseg run --resume DIR` continues a run that was killed, from its checkpoint.npz (see
`tiseg.run.checkpoint`), appending to its fields.nc and diagnostics.csv.

Every user mistake is refused before anything heavy starts (Taichi, compilation) with one line
naming the option, the value and what is allowed.
"""

from __future__ import annotations

import math
from pathlib import Path

from ...errors import TisegError
from .common import (
    add_json,
    add_out,
    add_overwrite,
    add_scene_arguments,
    check_output_folder,
    check_threads,
    load_scene_args,
    print_json,
)
from ...errors import InputError
from ... import backend
from .estimate import print_estimate
from ...post.render.colours import canonical_field
from ...output.numbers import measured_all


# `tiseg run --help` ends with these (`tiseg.apps.examples`); a test parses each.
EXAMPLES = [
    ("tiseg run fingers", "the paper's fingers experiment into runs/fingers"),
    (
        "tiseg run fingers --set domain.resolution=200 --movie fingers.mp4",
        "a coarser, quicker run and its movie",
    ),
    ("tiseg run my.toml --out runs/mine --json", "a scene file of your own; the summary as JSON"),
    ("tiseg run --resume runs/fingers", "continue a killed run from its checkpoint"),
]


def register(sub) -> None:
    p = sub.add_parser(
        "run",
        help="run a scene; writes scene.toml, fields.nc, diagnostics.csv",
        description="Simulate a scene (built-in name or TOML file) and write the "
        "resolved scene, NetCDF snapshots at the output times and a "
        "diagnostics table into the output folder.",
    )
    add_scene_arguments(p, scene_optional=True)
    add_out(p, "output folder (default: runs/<scene name>)")
    p.add_argument(
        "--resume",
        default=None,
        metavar="DIR",
        help="continue the killed run in DIR from its checkpoint.npz (no SCENE, "
        "--set, --precision, --out or --movie: the run keeps its own settings)",
    )
    add_overwrite(p, "write into an --out folder that holds another run or other files")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument(
        "--estimate",
        action="store_true",
        help="print the predicted steps, RKC stages and wall time (as `tiseg "
        "estimate`) and exit without running",
    )
    add_json(
        p,
        "print a JSON summary at the end (shape: [ny, nx], the order of the arrays in "
        "fields.nc; grid: the same as [nx, ny], its older name)",
    )
    p.add_argument(
        "--movie",
        default=None,
        metavar="OUT.mp4",
        help="also write a movie (mp4, or .gif), one frame per output time, rendered "
        "from the running simulation (no display or Vulkan needed)",
    )
    p.add_argument(
        "--movie-field",
        default=None,
        metavar="FIELD",
        help="field of the movie: phi (default), h, speed, u or v",
    )
    p.add_argument("--fps", type=float, default=None, help="movie frames per second (10)")
    p.set_defaults(func=run)


def _check_args(args) -> None:
    """Options that are wrong whatever the scene."""

    check_threads(args.threads)
    if args.movie is None:
        unused = [
            n
            for n, v in (("--movie-field", args.movie_field), ("--fps", args.fps))
            if v is not None
        ]
        if unused:
            raise InputError(
                f"{', '.join(unused)} given without --movie (they only set up the "
                "movie): add --movie OUT.mp4 or leave them out"
            )
    else:
        args.movie_field = "phi" if args.movie_field is None else args.movie_field
        args.fps = 10.0 if args.fps is None else args.fps
        if not (args.fps > 0 and math.isfinite(args.fps)):
            raise InputError(f"--fps={args.fps!r} must be a positive number")
    if args.resume is not None:
        given = [
            name
            for name, v in (
                ("SCENE", args.scene),
                ("--set", args.overrides),
                ("--precision", args.precision),
                ("--out", args.out),
                ("--movie", args.movie),
                ("--overwrite", getattr(args, "overwrite", False)),
                ("--estimate", getattr(args, "estimate", False)),
            )
            if v
        ]
        if given:
            raise InputError(
                f"--resume {args.resume!r} continues the run with its own scene and "
                f"files; {', '.join(given)} cannot be given with it"
            )
    elif args.scene is None:
        raise InputError(
            "give a SCENE (a built-in name such as fingers, or a .toml file), or "
            "--resume DIR to continue a killed run"
        )
    if args.movie is not None:
        try:
            canonical_field(args.movie_field)
        except ValueError as exc:
            raise InputError(f"--movie-field: {exc}") from None
        suffix = Path(args.movie).suffix.lower()
        if suffix not in (".mp4", ".gif", ".mov", ".mkv", ".avi", ".webm"):
            raise InputError(
                f"--movie={args.movie!r}: the file name must end in .mp4 or .gif "
                "(or .mov, .mkv, .avi, .webm)"
            )


def _backend_first(args, precision: str) -> None:
    """Refuse --arch gpu where there is no GPU before any folder is made (this initialises
    Taichi for gpu/auto; the CPU is left to Simulation)."""

    if args.arch != "cpu":
        backend.init(args.arch, precision, args.threads)


def _prepare(args):
    """The simulation of the command with its scene and output folder: ``(sim, scene, out)``."""
    from ...run.run_folder import check_fresh_folder
    from ...run.simulation import Simulation

    _check_args(args)
    if args.resume is not None:
        from ...run.checkpoint import CHECKPOINT_NAME, open_run_dir

        out = Path(args.resume)
        scene, ck = open_run_dir(out)  # a clear error if DIR is not a killed run
        _backend_first(args, ck["precision"])
        check_output_folder(out, "--resume")
        sim = Simulation.resume(out, arch=args.arch, threads=args.threads)
        scene = sim.scene
        if not args.json:  # keep --json output pure JSON
            print(
                f"{scene.name}: resuming from {out / CHECKPOINT_NAME} at t = {sim.t:.6g} s "
                f"(step {sim.stats.steps})"
            )
    else:
        scene = load_scene_args(args)
        out = Path(args.out) if args.out else Path("runs") / scene.name
        check_fresh_folder(out, args.overwrite)
        _backend_first(args, scene.numerics.precision)
        check_output_folder(out)
        if args.movie is not None:
            check_output_folder(Path(args.movie).parent, "--movie")
        sim = Simulation(scene, arch=args.arch, threads=args.threads)
    return sim, scene, out


def run(args) -> int:
    from ...run.held_signals import held_signals

    if args.resume is None and args.estimate:  # measures for seconds: Ctrl-C acts at once
        _check_args(args)
        print_estimate(load_scene_args(args), args.arch, args.threads, as_json=args.json)
        return 0
    # imports, kernel definitions and compiles: Ctrl-C there could be swallowed by Taichi's
    # kernel decorator (tiseg.run.held_signals), so it is held and acts once they are done
    with held_signals():
        sim, scene, out = _prepare(args)
    before = sim.initial_totals
    movie = _movie(args, sim)
    try:
        stats = sim.run(
            out_dir=out,
            progress=not args.no_progress,
            on_output=None if movie is None else movie,
            overwrite=bool(getattr(args, "overwrite", False)),
            signals=True,
        )
    finally:
        movie_error = _close_movie(movie)
    after = sim.totals()
    bud = sim.budget()
    summary = {
        "scene": scene.name,
        "out": str(out),
        "t_end": sim.t,
        "steps": stats.steps,
        "rhs_evaluations": stats.stages,
        "wall_time_s": stats.wall,
        "arch": sim.backend.arch,
        "precision": sim.backend.precision,
        "shape": [scene.domain.ny, scene.domain.nx],  # as the arrays of fields.nc: (y, x)
        "grid": [scene.domain.nx, scene.domain.ny],  # older: (nx, ny), kept for scripts
        "mass": after["mass"],
        "mass_in": bud["mass_in"],
        "resumed": args.resume is not None,
        "mass_balance_error": after["mass"] - before["mass"] - bud["mass_in"],
        "cell_updates_per_s": scene.domain.nx
        * scene.domain.ny
        * stats.stages
        / max(stats.wall, 1e-12),
    }
    if movie is not None and movie_error is None:
        summary["movie"] = str(movie.path)
        summary["movie_frames"] = movie.count
    if args.json:
        print_json(measured_all(summary))  # 12 significant digits (tiseg.output.numbers)
    else:
        print(
            f"{scene.name}: t = {sim.t:.4g} s in {stats.steps} steps ({stats.stages} operator "
            f"evaluations), wall {stats.wall:.1f} s on {sim.backend.arch}/{sim.backend.precision}; "
            f"{summary['cell_updates_per_s'] / 1e6:.2f} M cell-updates/s"
        )
        rel = summary["mass_balance_error"] / max(abs(after["mass"]), 1e-300)
        print(
            f"mass balance error {summary['mass_balance_error']:.3g} m^3 (relative {rel:.2g}); "
            f"output in {out}/"
        )
        if movie is not None and movie_error is None:
            print(f"movie: {movie.path} ({movie.count} frames)")
    if movie_error is not None:  # the run itself is complete and saved
        raise movie_error
    return 0


def _close_movie(movie):
    """Finish the movie of a run (also of a stopped one: its frames so far); the TisegError when
    it could not be written, to be raised after the run's summary (the run's files are fine)."""
    if movie is None:
        return None
    try:
        movie.close()
    except TisegError as exc:
        return exc
    return None


def _movie(args, sim):
    """The movie recorder asked for with --movie (one frame per output time), or None."""
    if getattr(args, "movie", None) is None:
        return None
    from ...post.render.movie import MovieRecorder

    try:
        field = canonical_field(args.movie_field)
    except ValueError as exc:
        raise InputError(f"--movie-field: {exc}") from None
    if field == "v" and sim.layout.is_1d:
        raise InputError("--movie-field=v: a 1D run has no v")
    return MovieRecorder.for_simulation(sim, Path(args.movie), field, args.fps)
