"""Parameter sweeps: many runs of one scene, on Dask, collected into one table and one dataset.

A sweep file (TOML) names a base scene, overrides applied to every run and a grid of overrides
whose Cartesian product gives the runs::

    name = "grid-study"                    # optional; default: the file name without .toml
    description = "Figure 16: wavelength and elongation against the grid resolution"
    scene = "fingers"                      # built-in scene name, or a path (relative to this file)
    times = [2.5, 5.0, 7.5]                # optional: also tabulate the metrics at these times

    [set]                                  # overrides applied to every run (any scene key)
    "time.t_end" = 7.5
    output.interval = 0.25                 # dotted keys may be written bare or quoted

    [grid]                                 # each key takes a non-empty list; runs = product
    "domain.resolution" = [250, 375, 500]
    "flow.nu" = [0.005, 0.01]

Beside the grid (or instead of it), a ``[sample]`` table draws the values of continuous keys
from a design (`tiseg.apps.sweep.design`: Latin hypercube, Saltelli's Sobol' design, or uniform
random draws; ranges uniform or log-uniform), run at every grid combination::

    [sample]
    method = "sobol"                       # "lhs", "sobol" or "random"
    n = 64                                 # points ("sobol": base points, a power of 2)
    seed = 1                               # the same seed draws the same design
    "flow.nu" = {range = [0.005, 0.05], log = true}
    "material.zeta_deg" = [26.0, 29.0]

A sample's members are named ``member-0000``, ... (after the grid values, if any), so a re-run
draws the same design, finds the same folders and reuses them. A sampled key must be a numeric
scene key that takes any value in its range (not a whole-number, true/false or text key: those
go in ``[grid]``), and in neither ``[set]`` nor ``[grid]``.

Every run writes its own folder ``OUT/<run name>/`` (``scene.toml``, ``fields.nc``,
``diagnostics.csv`` as ``tiseg run`` does, ``fingers.json`` with the finger diagnostics of every
output time, and last the completion marker ``done.json``). The run name is built from the grid
values only (``resolution-250_nu-0.01``), so it is stable across re-runs and safe as a file name.

Why a completion marker: a sweep can take hours. ``done.json`` is written atomically after
everything else, so a folder with a marker is complete and is reused on the next invocation,
while a folder without one (an interrupted run) is simply run again. A folder is reused only if
the resolved scene stored in it (``scene.toml``, re-read with the current code) equals the scene
the sweep asks for now; if the sweep file changed so that the same folder name means a different
scene, the run is repeated.

Why validate everything first: a typo in the fifth of eight long runs must not surface after the
first four have run for an hour. `load_sweep` builds and validates the scene of every
combination (and checks the tabulation times against each scene's output times) before anything
is submitted.

Why Dask: runs are independent, and the same code scales from a laptop (a
``LocalCluster(processes=True, threads_per_worker=1)``: one process per concurrent run, because
Taichi's runtime is per process) to an existing cluster (``scheduler=ADDRESS``). Each task
(`execute_run`) re-initialises Taichi (`tiseg.backend.init`, the only place ti.init is
called) with the thread count asked for, so that consecutive runs in one worker do not keep the
previous run's fields alive. Runs report progress as Dask worker events (topic
`PROGRESS_TOPIC`), which reach the client without a shared file system; the run folders
themselves must however be on a file system the workers share with the client for re-runs to be
skipped and for the figures to be drawn.

The table ``OUT/sweep.csv`` has one row per run (grid order): the run name, the grid values,
status (done / reused / failed), grid size, the finger metrics at the final time and at the
extra ``times`` (``wavelength@7.5``), and the run costs (simulation wall time, task time, steps,
operator evaluations, cells). ``OUT/sweep.json`` holds the same plus every run's full time
series of the finger diagnostics and the sweep definition.

When the members have run, ``OUT/sweep.nc`` holds the results as one CF-1.8 dataset (the grid
keys as dimensions, the sample as a ``member`` dimension, the outputs with units, the members'
peak fields stacked: `tiseg.apps.sweep.dataset`), and a "sobol" sample adds
``OUT/sensitivity.csv`` and ``OUT/sensitivity.png``: first-order and total Sobol' indices of
each output with bootstrap intervals (`tiseg.apps.sweep.sensitivity`).

A ``[probability]`` table (`tiseg.apps.sweep.probability`) adds ``OUT/probability.nc``: per
cell, the fraction of the finished members whose peak thickness and peak speed exceed each
threshold, and the mean and quantiles of h_max and of the arrival time::

    [probability]
    h_thresholds = [0.0005, 0.001]         # [m]
    speed_thresholds = [0.1, 0.2]          # [m/s]

The members must share one grid: a sweep over ``domain.resolution`` with ``[probability]`` is
refused before anything runs.

Ensembles: runs that differ only in ``inflow.seed`` (a grid key; see the scene's
``inflow.noise``) are realisations of one experiment. ``OUT/summary.csv`` has one row per
combination of the other grid keys, with ``n`` (finished runs) and, for each metric of
`SUMMARY_METRICS` at the final time and at each extra time (``wavelength@7.5``),
``<metric>_mean``, ``<metric>_std`` (sample standard deviation, ddof = 1; empty for n < 2) and
``<metric>_n`` (runs where the metric is defined: a wavelength is undefined without fingers),
plus the mean wall time per run.

Finished runs keep their diagnostics in ``fingers.json`` with the version of the definitions
(`tiseg.post.analysis.fingers.ANALYSIS_VERSION`); a reused run whose diagnostics are older is
analysed again from its ``fields.nc`` (seconds, not a re-run).
"""

from .spec import (  # noqa: F401
    time_index,
    COST_COLUMNS,
    DONE_MARKER,
    ENSEMBLE_KEYS,
    FINAL_METRICS,
    FINGERS_FILE,
    MARKER_VERSION,
    MAX_NAME,
    MAX_RUNS,
    PROGRESS_TOPIC,
    SUMMARY_METRICS,
    SWEEP_KEYS,
    DEPOSIT_METRICS,
    OUTPUTS,
    Sweep,
    SweepRun,
    TIME_METRICS,
    _canonical,
    _flatten,
    _format_value,
    _resolve_scene_ref,
    _run_names,
    _show,
    list_builtin_sweeps,
    load_sweep,
    log,
    resolve_sweep_path,
    sweep_from_dict,
)
from .members import (  # noqa: F401
    _execute_locked,
    _record_metrics,
    _reporter,
    _worker_threads,
    execute_run,
    read_marker,
    refresh_metrics,
    scene_fingerprint,
)
from .runner import (  # noqa: F401
    SAME_SWEEP_KEYS,
    SWEEP_OUTPUTS,
    SweepResult,
    _run_on_dask,
    _summary,
    check_sweep_folder,
    run_sweep,
    write_results,
)
from .design import METHODS, Range, Sample, parse_sample  # noqa: F401
from .dataset import PEAK_FIELDS, dim_name, sweep_dataset, write_dataset  # noqa: F401
from .sensitivity import indices, sensitivity_rows, sobol_analysis  # noqa: F401
from .table import (  # noqa: F401
    _cell,
    _csv_text,
    _csv_value,
    _parse,
    _write_outputs,
    member_outputs,
    read_table,
    summary_columns,
    summary_groups,
    summary_rows,
    table_columns,
    table_rows,
)

__all__ = [
    "Sweep",
    "SweepRun",
    "SweepResult",
    "load_sweep",
    "sweep_from_dict",
    "run_sweep",
    "check_sweep_folder",
    "execute_run",
    "read_marker",
    "read_table",
    "refresh_metrics",
    "scene_fingerprint",
    "summary_columns",
    "summary_rows",
    "table_columns",
    "DONE_MARKER",
    "FINGERS_FILE",
]
