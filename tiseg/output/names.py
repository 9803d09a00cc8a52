"""The names of the files in a run folder, one constant each: every module that writes, reads
or checks one of them names it here, so a file is renamed (or a new one added) in one place.

A run writes `SCENE_FILE`, `FIELDS_FILE`, `DIAGNOSTICS_FILE` (with its units in
``DIAGNOSTICS_FILE + UNITS_SUFFIX``), `GAUGES_FILE` (likewise), `CHECKPOINT_FILE` while it is
unfinished and `FAILURE_DIR` when a guard stops it; a sweep member adds `FINGERS_FILE` and
`DONE_FILE`, and a sweep folder holds `PROBABILITY_FILE`.
"""

from __future__ import annotations

SCENE_FILE = "scene.toml"
FIELDS_FILE = "fields.nc"
DIAGNOSTICS_FILE = "diagnostics.csv"
GAUGES_FILE = "gauges.csv"
UNITS_SUFFIX = "-metadata.json"  # the CSV-on-the-Web units of a table: NAME + this
CHECKPOINT_FILE = "checkpoint.npz"
FAILURE_DIR = "failure"
FINGERS_FILE = "fingers.json"
DONE_FILE = "done.json"
PROBABILITY_FILE = "probability.nc"
