"""A run's peak fields and deposit as ESRI ASCII grids (``tiseg render RUN_DIR --raster``).

One ``.asc`` per 2D variable of fields.nc (the peak fields of `tiseg.output.fields`: ``h_max``,
``speed_max``, ``arrival_time``, ``deposit_h`` and, with segregation, ``deposit_phi``), in the
units of fields.nc, missing cells as NODATA (`tiseg.output.ascii_grid`). They hold the run up to
the file's ``peak_time``, the whole run once it finished.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ...errors import InputError
from ...output.ascii_grid import write_asc
from ...output.fields import specs
from ...output.netcdf import read_fields


def export_peak_grids(run_dir, out_dir=None) -> dict:
    """Write the peak fields of the run in ``run_dir`` (its folder or fields.nc) as
    ``<name>.asc`` into ``out_dir`` (default the run folder). Returns {"peak_time": t,
    "outputs": [paths]}. An InputError when the file holds no peak fields (a run with
    ``output.peak_fields = false``)."""
    from .movie import _fields_path, refuse_link

    path = _fields_path(run_dir)
    out = Path(out_dir) if out_dir is not None else path.parent
    if out.exists() and not out.is_dir():
        raise InputError(f"--raster {str(out)!r} is a file, not a folder")
    ds = read_fields(path)
    try:
        names = [n for n in specs("peak") if n in ds.variables and ds[n].dims == ("y", "x")]
        if not names:
            raise InputError(
                f"{str(path)!r} holds no peak fields (the run had output.peak_fields = false)"
            )
        x = ds["x"].values.astype(float)
        y = ds["y"].values.astype(float)
        dy = _cell_width(ds) if y.size == 1 else None
        targets = {n: out / f"{n}.asc" for n in names}
        for target in targets.values():  # before anything is written
            refuse_link(target)
        try:
            out.mkdir(parents=True, exist_ok=True)
            for n, target in targets.items():
                write_asc(target, np.asarray(ds[n].values, dtype=float), x, y, dy=dy)
        except OSError as exc:
            raise InputError(
                f"cannot write the grids into {str(out)!r}: {exc.strerror or exc}"
            ) from None
        t = float(ds["peak_time"].values) if "peak_time" in ds.variables else float("nan")
    finally:
        ds.close()
    return {"peak_time": t, "outputs": [str(p) for p in targets.values()]}


def _cell_width(ds) -> float | None:
    """The cross-slope cell size of a 1D run (one row of cells): its Ly, from the scene the file
    holds; None (square cells) when it cannot be read."""
    from ...setup.scene import scene_from_text

    try:
        return float(scene_from_text(str(ds.attrs["scene"])).domain.Ly)
    except Exception:  # an old or foreign file: draw the row with square cells
        return None


__all__ = ["export_peak_grids"]
