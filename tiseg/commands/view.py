"""`tiseg view SCENE`: the live GGUI viewer (see `tiseg.viewer.app`)."""

from __future__ import annotations


def register(sub) -> None:
    p = sub.add_parser(
        "view",
        help="watch a scene run live in a window (GGUI, needs Vulkan)",
        description="Run a scene and show it as it evolves, with controls "
        "(pause, step, reset, field, steps per frame, screenshot, "
        "recording, inflow/nu/slope). Needs Vulkan and a display; "
        "without them use `tiseg run SCENE --movie out.mp4`.",
    )
    from tiseg.viewer.app import add_arguments

    add_arguments(p)
    p.set_defaults(func=run)


def run(args) -> int:
    from tiseg.viewer.app import run_from_args

    return run_from_args(args)
