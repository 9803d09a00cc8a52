"""`tiseg estimate SCENE [--set ...]`: predicted steps, RKC stages and wall time, before running.

The prediction combines a model of the flow's wave speeds and stiffness over time (from the
scene's steady state h0, u0) with a quick calibration of the scene's kernels on its own grid in
this process; see `tiseg.apps.estimate`. ``tiseg run SCENE --estimate`` prints the same.
"""

from __future__ import annotations

from .common import add_scene_arguments, check_threads, load_scene_args, print_json, stdout_for_json


# `tiseg estimate --help` ends with these (`tiseg.apps.examples`); a test parses each.
EXAMPLES = [
    ("tiseg estimate fingers", "steps and wall time of the fingers run on this machine"),
    ("tiseg estimate fingers --set domain.resolution=375 --json", "a coarser grid, as JSON"),
]


def register(sub) -> None:
    p = sub.add_parser(
        "estimate",
        help="predict steps, RKC stages and wall time of a run",
        description="Predict the steps, RKC stages and wall time of a run of "
        "SCENE on this machine before running it: a model of the "
        "flow's wave speeds and stiffness over time from the scene's "
        "steady state, and a quick calibration of the scene's kernels "
        "on its own grid (see tiseg/apps/estimate.py).",
    )
    add_scene_arguments(p)
    p.add_argument(
        "--no-output",
        action="store_true",
        help="estimate a run without files (no snapshots, checkpoints, diagnostics)",
    )
    p.add_argument("--json", action="store_true", help="print the estimate as JSON")
    p.set_defaults(func=run)


def run(args) -> int:
    check_threads(args.threads)
    scene = load_scene_args(args)
    print_estimate(scene, args.arch, args.threads, output=not args.no_output, as_json=args.json)
    return 0


def print_estimate(
    scene, arch: str, threads: int, output: bool = True, as_json: bool = False
) -> None:
    """Compute and print the estimate of a scene (shared with ``tiseg run --estimate``)."""
    from ..estimate import estimate

    with stdout_for_json(as_json):
        est = estimate(scene, arch=arch, threads=threads, output=output)
    if as_json:
        print_json(est.as_dict())
    else:
        print("\n".join(est.lines()))
