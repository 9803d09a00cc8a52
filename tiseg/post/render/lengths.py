"""Scale-bar lengths for pictures of the chute: a round length and its text.

Shared by the saved frames (`tiseg.post.render.frame`) and the live viewer's captions
(`tiseg.apps.viewer.captions`); no Taichi, so the captions can use it without a runtime."""

from __future__ import annotations

import math


def nice_length(target: float) -> float:
    """The largest 1, 2 or 5 x 10^k not above target (> 0): a scale-bar length; 0 for a target
    that is not a positive finite number."""
    if not (target > 0 and math.isfinite(target)):
        return 0.0
    e = math.floor(math.log10(target))
    for m in (5.0, 2.0, 1.0):
        if m * 10.0**e <= target * (1 + 1e-9):
            return m * 10.0**e
    return 10.0**e


def format_length(metres: float) -> str:
    """A length in the unit that keeps its number between 1 and 999: "2 m", "5 cm", "1 mm"
    (rounded to 9 decimals in that unit, so 0.07 m reads "7 cm", not "7.000000000000001 cm")."""
    if metres >= 1.0:
        return f"{metres:g} m"
    if metres >= 0.01:
        return f"{round(metres * 100, 9):g} cm"
    return f"{round(metres * 1000, 9):g} mm"
