"""Alias of `tiseg.viewer` in a source checkout, so that ``python -m viewer SCENE`` keeps
working from the repository root. The package itself is ``tiseg.viewer`` (installed with tiseg);
this folder is not part of the wheel."""

from tiseg.viewer import DisplayUnavailable, Viewer, display_problem, vulkan_problem

__all__ = ["Viewer", "DisplayUnavailable", "display_problem", "vulkan_problem"]
