"""Post-processing of saved runs.

* `tiseg.analysis.fingers`: finger diagnostics of section 6.3 -- front positions
  x_f^+, x_f^- and elongation x_l (6.10)-(6.12), finger count and mean wavelength
  Lambda = Ly / count, front speed and channel speed relative to u0.
"""

from .fingers import (
    DEFAULT_MIN_PERSISTENCE,
    DEFAULT_NOISE_CELLS,
    RUN_KEYS,
    analyse_run,
    finger_metrics,
    front_max,
    front_min,
    front_speed,
    periodic_runs,
)

__all__ = [
    "finger_metrics",
    "analyse_run",
    "front_max",
    "front_min",
    "front_speed",
    "periodic_runs",
    "RUN_KEYS",
    "DEFAULT_MIN_PERSISTENCE",
    "DEFAULT_NOISE_CELLS",
]
