"""Calibration: the scene parameters whose run reproduces target numbers.

``tiseg calibrate SCENE --param KEY=LO:HI ... --target NAME=VALUE ...`` searches the box of the
ranges for the values whose run gives the targets, any number that ``tiseg fingers --json``
reports: a per-time number (``wavelength``, ``x_front_max``, ``elongation``, ...) at the time
``--time T`` (default: the last output time), or one of its deposit block (``deposit.run_out``,
``deposit.thickness_mean``, ...; also spelled ``deposit_run_out``, ``run_out`` or ``runout``).

* The misfit of a run is sqrt(mean(((m_i - y_i) / s_i)^2)) over the targets, s_i the target's
  tolerance (``NAME=VALUE+-TOL``) or else |y_i|; `search.PENALTY` where the run does not give
  the number (no deposit by the end of the run, no fingers).
* The search (`search.search`): scipy's bounded Brent method for one parameter, a seeded Latin
  hypercube then Nelder-Mead with bounds for several, at most ``--budget`` runs.
* Each point is a member of a sweep (`tiseg.apps.sweep`): a folder ``OUT/<key>-<value>...``
  named after its values, run by `tiseg.apps.sweep.execute_run` on Dask and reused when it
  holds a finished run of the same scene. The search is deterministic, so a calibration that
  was killed asks for the same points again when restarted, finds the finished ones and runs
  the rest: no run is repeated and no member duplicated.
* The uncertainty (`search.uncertainty`): linearised least squares at the best point from the
  sensitivity of each target to each parameter (central differences) and the spread of each
  target (its tolerance, the standard deviation over ``--seeds N`` seeds, or the residual).

Results: ``OUT/calibration.json`` (the definition, the methods in words, the best values, their
misfit and numbers, the interval of each parameter, the sensitivities, and every evaluation)
and ``OUT/misfit.png`` (the misfit against each parameter over the search).
"""

from .runner import (  # noqa: F401
    PLOT_FILE,
    RESULT_FILE,
    CalibrationResult,
    check_calibration_folder,
    plot_misfit,
    run_calibration,
)
from .search import FD_STEP, PENALTY, Evaluation, Evaluator, misfit, outputs_of, search, uncertainty  # noqa: F401
from .spec import (  # noqa: F401
    Calibration,
    Param,
    Target,
    calibration_from_args,
    parse_param,
    parse_target,
    target_names,
)

__all__ = [
    "Calibration",
    "CalibrationResult",
    "calibration_from_args",
    "run_calibration",
    "target_names",
]
