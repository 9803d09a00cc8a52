"""`tiseg run SCENE`: simulate a scene and write scene.toml, fields.nc, diagnostics.csv."""
from __future__ import annotations

import math
from pathlib import Path

from .common import print_json


def add_scene_arguments(p) -> None:
    p.add_argument("scene", help="built-in scene name (e.g. fingers) or path to a TOML file")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="SECTION.KEY=VALUE",
                   help="override a scene value, e.g. --set domain.resolution=250 (repeatable)")
    p.add_argument("--arch", choices=("cpu", "gpu", "auto"), default="cpu",
                   help="Taichi backend: cpu, gpu (CUDA/Metal; error if none) or auto (default cpu)")
    p.add_argument("--precision", choices=("f32", "f64"), default=None,
                   help="floating-point precision (default: the scene's numerics.precision)")
    p.add_argument("--threads", type=int, default=0, help="CPU threads (0 = all cores)")


def register(sub) -> None:
    p = sub.add_parser("run", help="run a scene; writes scene.toml, fields.nc, diagnostics.csv",
                       description="Simulate a scene (built-in name or TOML file) and write the "
                                   "resolved scene, NetCDF snapshots at the output times and a "
                                   "diagnostics table into the output folder.")
    add_scene_arguments(p)
    p.add_argument("--out", default=None, metavar="DIR",
                   help="output folder (default: runs/<scene name>)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--json", action="store_true", help="print a JSON summary at the end")
    p.add_argument("--movie", default=None, metavar="OUT.mp4",
                   help="also write a movie (mp4, or .gif), one frame per output time, rendered "
                        "from the running simulation (no display or Vulkan needed)")
    p.add_argument("--movie-field", default="phi", metavar="FIELD",
                   help="field of the movie: phi (default), h, speed, u or v")
    p.add_argument("--fps", type=float, default=10.0, help="movie frames per second (10)")
    p.set_defaults(func=run)


def load(args):
    from ..scene import load_scene
    overrides = list(args.overrides)
    if args.precision:
        overrides.append(f"numerics.precision={args.precision}")
    return load_scene(args.scene, overrides)


def run(args) -> int:
    from ..errors import InputError
    from ..simulation import Simulation

    if args.threads < 0:
        raise InputError(f"--threads={args.threads}: must be >= 0")
    scene = load(args)
    out = Path(args.out) if args.out else Path("runs") / scene.name
    sim = Simulation(scene, arch=args.arch, threads=args.threads)
    before = sim.totals()
    movie = _movie(args, sim)
    try:
        stats = sim.run(out_dir=out, progress=not args.no_progress,
                        on_output=None if movie is None else movie.on_output)
    finally:
        if movie is not None:
            movie.close()
    after = sim.totals()
    bud = sim.budget()
    summary = {
        "scene": scene.name, "out": str(out), "t_end": sim.t, "steps": stats.steps,
        "rhs_evaluations": stats.stages, "wall_time_s": stats.wall,
        "arch": sim.backend.arch, "precision": sim.backend.precision,
        "grid": [scene.domain.nx, scene.domain.ny],
        "mass": after["mass"], "mass_in": bud["mass_in"],
        "mass_balance_error": after["mass"] - before["mass"] - bud["mass_in"],
        "cell_updates_per_s": scene.domain.nx * scene.domain.ny * stats.stages / max(stats.wall, 1e-12),
    }
    if movie is not None:
        summary["movie"] = str(movie.path)
        summary["movie_frames"] = movie.count
    if args.json:
        print_json(summary)
    else:
        print(f"{scene.name}: t = {sim.t:.4g} s in {stats.steps} steps ({stats.stages} operator "
              f"evaluations), wall {stats.wall:.1f} s on {sim.backend.arch}/{sim.backend.precision}; "
              f"{summary['cell_updates_per_s'] / 1e6:.2f} M cell-updates/s")
        rel = summary["mass_balance_error"] / max(abs(after["mass"]), 1e-300)
        print(f"mass balance error {summary['mass_balance_error']:.3g} m^3 (relative {rel:.2g}); "
              f"output in {out}/")
        if movie is not None:
            print(f"movie: {movie.path} ({movie.count} frames)")
    return 0


class _MovieRecorder:
    """Renders one annotated frame per output time straight from the simulation's state."""

    def __init__(self, sim, path, field: str, fps: float):
        from ..render import FrameRenderer
        from ..render.movie import MovieWriter
        self.path = path
        self.renderer = FrameRenderer(sim, field=field)
        self.writer = MovieWriter(path, fps)

    @property
    def count(self) -> int:
        return self.writer.count

    def on_output(self, sim) -> None:
        self.writer.append(self.renderer.to_numpy(annotate_frame=True))

    def close(self) -> None:
        self.writer.close()


def _movie(args, sim):
    """The movie recorder asked for with --movie, or None."""
    if getattr(args, "movie", None) is None:
        return None
    from ..errors import InputError
    from ..render.colours import canonical_field
    try:
        field = canonical_field(args.movie_field)
    except ValueError as exc:
        raise InputError(f"--movie-field: {exc}") from None
    if field == "phi" and not sim.layout.segregation:
        field = "h"                      # no concentration without segregation
    if field == "v" and sim.layout.is_1d:
        raise InputError("--movie-field=v: a 1D run has no v")
    if not (args.fps > 0 and math.isfinite(args.fps)):
        raise InputError(f"--fps={args.fps!r} must be a positive number")
    return _MovieRecorder(sim, Path(args.movie), field, args.fps)
