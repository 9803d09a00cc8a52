"""Run output: NetCDF snapshots of the fields, a CSV of per-step diagnostics, atomic text files.

* `FieldsWriter` / `read_fields`: CF-1.8 NetCDF-4 file of h, u, v, phi on the
  cell-centre grid, one record per output time, synced after every snapshot so a killed run
  keeps everything written so far.
* `DiagnosticsWriter` / `read_diagnostics`: CSV, one row per step, flushed per row.
* `write_text_atomic`: resolved scene TOML and JSON summaries, never half-written.
"""

from .diagnostics import (
    DEFAULT_COLUMNS,
    DiagnosticsWriter,
    read_diagnostics,
    write_json_atomic,
    write_text_atomic,
)
from .netcdf import FIELD_ATTRS, FieldsWriter, read_fields

__all__ = [
    "FieldsWriter",
    "read_fields",
    "FIELD_ATTRS",
    "DiagnosticsWriter",
    "read_diagnostics",
    "DEFAULT_COLUMNS",
    "write_text_atomic",
    "write_json_atomic",
]
