"""Live GGUI viewer of tiseg simulations: ``tiseg view SCENE`` or ``python -m tiseg.viewer SCENE``.

Shows the simulation as it runs, painted by tiseg's frame kernel (`tiseg.render`), with
controls for running, the field shown, recording and run-time parameters. Needs Vulkan (and a
display for a visible window); without them it says so in one line and exits with status 2.
See `tiseg.viewer.app`.
"""

from .app import DisplayUnavailable, Viewer, display_problem, vulkan_problem

__all__ = ["Viewer", "DisplayUnavailable", "display_problem", "vulkan_problem"]
