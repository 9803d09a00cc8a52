"""`tiseg view SCENE`: the live GGUI viewer (see `tiseg.apps.viewer.app`)."""

from __future__ import annotations
from tiseg.apps.viewer.app import add_arguments
from tiseg.apps.viewer.app import run_from_args


# `tiseg view --help` ends with these (`tiseg.apps.examples`); a test parses each.
EXAMPLES = [
    ("tiseg view fingers", "fingers live, at the resolution this machine runs in real time"),
    (
        "tiseg view fingers --set domain.resolution=300 --steps-per-frame 5",
        "a finer grid of your choice",
    ),
    ("tiseg view dam-break --field h", "the thickness of a dam break"),
]


def register(sub) -> None:
    p = sub.add_parser(
        "view",
        help="watch a scene run live in a window (GGUI, needs Vulkan)",
        description="Run a scene and show it as it evolves, with controls "
        "(pause, step, reset, field, steps per frame, screenshot, "
        "recording, inflow/nu/slope). Needs Vulkan and a display; "
        "without them use `tiseg run SCENE --movie out.mp4`.",
    )

    add_arguments(p)
    p.set_defaults(func=run)


def run(args) -> int:

    return run_from_args(args)
