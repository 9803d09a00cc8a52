"""Run output: NetCDF snapshots of the fields, a CSV of per-step diagnostics, atomic text files.

* `FieldsWriter` / `read_fields`: CF-1.8 NetCDF-4 file of h, u, v, phi on the
  cell-centre grid, one record per output time, synced after every snapshot so a killed run
  keeps everything written so far.
* `FieldSpec` / `register_field`: the output fields, each declared once (`tiseg.output.fields`).
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
from .fields import OUTPUT_FIELDS, FieldSpec, register_field
from .netcdf import FieldsWriter, read_fields


def __getattr__(name: str):
    if name == "FIELD_ATTRS":  # the snapshot variables' CF attributes, from the registry now
        from . import netcdf

        return netcdf.FIELD_ATTRS
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = [
    "FieldsWriter",
    "read_fields",
    "FieldSpec",
    "register_field",
    "OUTPUT_FIELDS",
    "DiagnosticsWriter",
    "read_diagnostics",
    "DEFAULT_COLUMNS",
    "write_text_atomic",
    "write_json_atomic",
]
