"""`tiseg bench accuracy|throughput|steppers`: what accuracy costs in time, how fast the operator
runs, and what each time stepper costs and loses on a run's own states.

accuracy and throughput measure every precision (and the GPU where there is one) in child
processes of their own, because Taichi's precision is fixed per process; see `tiseg.apps.bench`.
"""

from __future__ import annotations

from pathlib import Path

from ...solver.numerics.config import REGISTRIES, is_split
from .common import (
    add_arch,
    add_json,
    add_out,
    add_threads,
    check_threads,
    print_json,
    stdout_for_json,
)
from ...errors import InputError


# `tiseg bench --help` ends with these (`tiseg.apps.examples`); a test parses each.
EXAMPLES = [
    ("tiseg bench throughput --quick", "cell-updates per second of this machine"),
    ("tiseg bench accuracy --quick --out runs/bench", "error against wall time, Pareto fronts"),
    (
        "tiseg bench steppers runs/fingers --times 5",
        "what each time stepper costs on a run's state",
    ),
    ("tiseg bench gpu --quick", "on a GPU machine: throughput in f32 and f64 against the CPU"),
]


def register(sub) -> None:
    p = sub.add_parser(
        "bench",
        help="benchmarks: accuracy against wall time, operator "
        "throughput, time steppers on a run's states",
        description="What accuracy costs in time (accuracy), how fast the "
        "operator and the steps run (throughput), and what each "
        "time stepper costs and loses on a run's own states "
        "(steppers).",
    )
    bsub = p.add_subparsers(dest="bench_command", metavar="BENCHMARK")
    bsub.required = True

    a = bsub.add_parser(
        "accuracy",
        help="error against wall time on problems with known answers, Pareto fronts",
        description="Error against wall time on reference problems with known answers (T6b "
        "transport, Ritter dam break, linear growth rate, fingers front position early and late, "
        "the channel's contacts and speed profile) "
        "for every resolution x reconstruction x stepper x precision x backend; "
        "writes accuracy.csv, one PNG per problem with the Pareto front, and "
        "summary.json/summary.md (do the scene defaults sit on the front?).",
    )
    add_out(a, "output folder", required=True)
    a.add_argument(
        "--quick",
        action="store_true",
        help="a small subset for CI: two resolutions per problem, minmod/weno x rkc/ssprk3, "
        "fingers to t = 1 s (late: 5.5 s)",
    )
    a.add_argument(
        "--problems",
        nargs="+",
        default=None,
        metavar="NAME",
        help="transport, ritter, growth, fingers, fingers-late, channel, channel-speed "
        "(default: all)",
    )
    _add_machine_options(a, precisions=["f32", "f64"])
    a.add_argument(
        "--reconstructions", nargs="+", default=None, choices=("first-order", "minmod", "weno")
    )
    a.add_argument(
        "--thetas",
        nargs="+",
        type=float,
        default=[1.5],
        metavar="THETA",
        help="minmod theta values in [1, 2] (default 1.5)",
    )
    a.add_argument(
        "--fluxes",
        nargs="+",
        default=["kt"],
        choices=tuple(REGISTRIES["numerics.flux"]),
        help="numerics.flux values (default kt)",
    )
    a.add_argument(
        "--phi-fluxes",
        nargs="+",
        default=["upwind"],
        choices=tuple(REGISTRIES["numerics.phi_flux"]),
        help="numerics.phi_flux values (default upwind, the scenes' default)",
    )
    a.add_argument(
        "--steppers",
        nargs="+",
        default=None,
        # the split sweeps are left out: every problem of this bench has friction
        choices=tuple(c for c in REGISTRIES["numerics.stepper"] if not is_split(c)),
    )
    a.add_argument("--cfl", nargs="+", type=float, default=[0.25], help="Courant numbers (0.25)")
    add_json(a)
    a.set_defaults(func=run_accuracy)

    t = bsub.add_parser(
        "throughput",
        help="cell-updates/s and steps/s per effect vs NumPy and a bandwidth bound",
        description="Cell-updates per second of the operator (one evaluation per cell) and full "
        "steps per second, for the full physics and with each effect switched off "
        "in turn, on each backend and precision, against the NumPy reference and a "
        "memory-bandwidth bound measured in the same run; plus the cost of each "
        "effect per step.",
    )
    t.add_argument(
        "--nx", type=int, default=None, help="cells downslope (default 1125, the paper's)"
    )
    t.add_argument("--ny", type=int, default=None, help="cells across (default 375)")
    t.add_argument("--quick", action="store_true", help="small grid and few repeats, for CI")
    _add_machine_options(t, precisions=["f64", "f32"])
    add_out(t, "also write throughput.json, throughput.md and effects.md there")
    add_json(t, "print the full report as JSON")
    t.set_defaults(func=run_throughput)

    s = bsub.add_parser(
        "steppers",
        help="time-stepping error and cost of each stepper from a run's own states",
        description="Restart from snapshots of a run (its grid, physics and precision), advance "
        "each stepper over the same short span at the run's Courant number and "
        "compare with SSP-RK3 at a five times smaller one: the time-stepping error "
        "alone, against wall time, where the run's own stiffness sets the steps. "
        "Writes steppers.json and steppers.md; says whether the run's stepper is on "
        "the Pareto front.",
    )
    s.add_argument(
        "run_dir", metavar="RUN_DIR", help="folder of a tiseg run (scene.toml, fields.nc)"
    )
    s.add_argument(
        "--times",
        nargs="+",
        type=float,
        default=None,
        metavar="T",
        help="snapshot times to start from (default: the last snapshot and the one half-way)",
    )
    s.add_argument(
        "--span",
        type=float,
        default=None,
        metavar="S",
        help="seconds to advance (default: about 40 steps of the run's stepper)",
    )
    s.add_argument(
        "--steppers",
        nargs="+",
        default=None,
        choices=tuple(REGISTRIES["numerics.stepper"]),
        help="default: rkc, ssprk3, ssprk2, ssprk4_2, ssprk10_4, euler, and the run's own",
    )
    s.add_argument("--repeats", type=int, default=2, help="timed repeats, the minimum is kept (2)")
    add_arch(s)
    add_threads(s)
    add_out(s, "where steppers.json/.md go (default: RUN_DIR/bench-steppers)")
    add_json(s, "print the report as JSON")
    s.set_defaults(func=run_steppers)

    g = bsub.add_parser(
        "gpu",
        help="the GPU check: throughput against the CPU, the paper's run, the viewer",
        description="On a GPU machine: operator and step throughput in f32 and f64 against the "
        "CPU in the same run, the fingers scene at 750 cells/m to t = 7.5 s with its "
        "wall time, the headless viewer's simulated seconds per wall second at "
        "250 cells/m, and Vulkan against CUDA where both exist. Prints a table, "
        "writes gpu_check.json and gpu_check.md.",
    )
    g.add_argument(
        "--arch",
        choices=("gpu", "vulkan", "cpu"),
        default="gpu",
        help="the device to check (default gpu: CUDA or Metal; vulkan runs the same "
        "check on software Vulkan)",
    )
    g.add_argument(
        "--quick",
        action="store_true",
        help="small grids and short runs (about a minute on software Vulkan)",
    )
    add_out(g, "where gpu_check.json and gpu_check.md go (default: not written)")
    add_json(g, "print the report as JSON")
    g.set_defaults(func=run_gpu)


def _add_machine_options(p, precisions) -> None:
    """Where a benchmark measures: precisions (each in a child process), backends, threads."""
    p.add_argument("--precisions", nargs="+", default=precisions, choices=("f32", "f64"))
    p.add_argument(
        "--backends",
        nargs="+",
        default=None,
        choices=("cpu", "gpu", "vulkan"),
        help="default: cpu, and gpu where one is present (vulkan only when named)",
    )
    add_threads(p)


def run_accuracy(args) -> int:
    from ..bench import accuracy, log_stderr

    check_threads(args.threads)
    for c in args.cfl:
        if not 0 < c <= 1:
            raise InputError(f"--cfl {c!r}: must be in (0, 1]")
    for th in args.thetas:
        if not 1.0 <= th <= 2.0:
            raise InputError(f"--thetas {th!r}: minmod theta must lie in [1, 2]")
    with stdout_for_json(args.json):
        summary = accuracy.run_study(
            args.out,
            quick=args.quick,
            problems=args.problems,
            precisions=args.precisions,
            backends=args.backends,
            reconstructions=args.reconstructions,
            steppers=args.steppers,
            cfls=args.cfl,
            threads=args.threads,
            log=log_stderr,
            fluxes=args.fluxes,
            phi_fluxes=args.phi_fluxes,
            thetas=args.thetas,
        )
    if args.json:
        print_json(summary)
    else:
        print(
            f"{summary['points']} points in {summary['study_wall_s']:.0f} s; "
            f"written to {Path(args.out)}/: {', '.join(summary['files'])}"
        )
        print("Do the defaults (weno + rkc + f64, cfl 0.25) sit on the Pareto front?")
        print(summary["verdict"])
    return 0


def run_throughput(args) -> int:
    from ..bench import log_stderr, throughput

    for name in ("nx", "ny"):
        v = getattr(args, name)
        if v is not None and v < 1:
            raise InputError(f"--{name}={v}: must be >= 1")
    check_threads(args.threads)
    with stdout_for_json(args.json):
        report = throughput.run_benchmark(
            nx=args.nx,
            ny=args.ny,
            quick=args.quick,
            precisions=args.precisions,
            backends=args.backends,
            threads=args.threads,
            out_dir=args.out,
            log=log_stderr,
        )
    if args.json:
        print_json(report)
    else:
        print(throughput.markdown(report))
    return 0


def run_steppers(args) -> int:
    from ..bench import log_stderr, steppers

    check_threads(args.threads)
    run_dir = Path(args.run_dir)
    if not run_dir.is_dir():
        raise InputError(f"{run_dir}: not a folder; give the folder of a tiseg run")
    with stdout_for_json(args.json):
        report = steppers.measure(
            run_dir,
            times=args.times,
            span=args.span,
            steppers=args.steppers or steppers.STEPPERS,
            repeats=args.repeats,
            arch=args.arch,
            threads=args.threads,
            log=log_stderr,
        )
        files = steppers.write(report, args.out or run_dir / "bench-steppers")
    if args.json:
        print_json(report)
    else:
        print(steppers.markdown(report))
        print(f"written: {', '.join(str(f) for f in files)}")
    return 0


def run_gpu(args) -> int:
    from ..bench import gpu, log_stderr

    with stdout_for_json(args.json):
        report = gpu.run_check(args.arch, quick=args.quick, out_dir=args.out, log=log_stderr)
    if args.json:
        print_json(report)
    else:
        print(gpu.markdown(report))
    return 0
