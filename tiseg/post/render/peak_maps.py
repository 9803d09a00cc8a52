"""A run's peak fields as a figure (``tiseg render RUN_DIR --peaks``): a map per field of
fields.nc's peak fields (`tiseg.output.fields`, kind "peak": ``h_max``, ``speed_max``,
``arrival_time``, ``deposit_h`` and, with segregation, ``deposit_phi``), each with its colour
bar in the units the pictures use (thickness in mm).

The maps are those of the probability maps (`tiseg.post.render.maps`): axes in metres, a scale
bar, missing cells (never reached, no deposit) in the empty-map grey, and over the shaded relief
and walls of a run with terrain. A 1D run (one row of cells) gives curves against x.
"""

from __future__ import annotations


import numpy as np

from ...errors import InputError
from ...output.fields import OUTPUT_FIELDS, specs
from . import colours as C
from .maps import bed_of_dataset, maps_figure
from .movie import _fields_path, save_figure


def _label(name: str) -> str:
    spec = OUTPUT_FIELDS[name]
    label = spec.label or name
    return f"{label} [{spec.unit}]" if spec.unit else label


def _row(ds, name: str) -> dict:
    """The figure's row of one peak field: its values in display units, their range, its
    colour bar label and colour map."""
    spec = OUTPUT_FIELDS[name]
    values = np.asarray(ds[name].values, dtype=np.float64) * spec.factor
    finite = values[np.isfinite(values)]
    if spec.colours == "phi":
        lo, hi = 0.0, 1.0
    else:
        hi = float(finite.max()) if finite.size else 1.0
        lo = float(finite.min()) if finite.size and name == "arrival_time" else 0.0
        if not hi > lo:
            hi = lo + 1.0
    cmap = C.matplotlib_cmap("phi" if spec.colours == "phi" else "h")
    return {"panels": [(name, values)], "range": (lo, hi), "label": _label(name), "cmap": cmap}


def peak_names(ds) -> list[str]:
    """The peak fields the dataset holds on (y, x), in the registry's order."""
    return [n for n in specs("peak") if n in ds.variables and ds[n].dims == ("y", "x")]


def plot_peak_fields(
    run,
    path=None,
    fields=None,
    width: float | None = None,
    shade=True,
    scale_bar: bool = True,
    dpi: float = 150,
):
    """Draw the peak fields of ``run`` (its folder, its fields.nc or an open
    `xarray.Dataset` from `tiseg.output.netcdf.read_fields`) and save the figure to
    ``path`` (PNG, PDF, SVG, ... by suffix) if given. ``fields``: which (names of
    `peak_names`), default all the run has, a row each with its colour bar. ``shade``: True,
    False or the strength of the hill-shading of the run's bed (walls are drawn either way).
    Returns the matplotlib Figure; an InputError when the run kept no peak fields."""
    opened = False
    if hasattr(run, "data_vars"):
        ds = run
    else:
        from ...output.netcdf import read_fields

        ds = read_fields(_fields_path(run))
        opened = True
    try:
        have = peak_names(ds)
        if not have:
            raise InputError("this run holds no peak fields (it had output.peak_fields = false)")
        names = have if fields is None else ([fields] if isinstance(fields, str) else fields)
        missing = [n for n in names if n not in have]
        if missing or not names:
            raise InputError(
                f"fields={list(names)!r}: this run's peak fields are {', '.join(have)}"
            )
        t = float(ds["peak_time"].values) if "peak_time" in ds.variables else float("nan")
        title = f"peak fields to t = {t:.3g} s" if np.isfinite(t) else "peak fields"
        rows = [_row(ds, n) for n in names]
        if ds.sizes["y"] == 1:
            fig = _curves(ds["x"].values, rows, width, title)
        else:
            fig = maps_figure(
                rows,
                ds["x"].values,
                ds["y"].values,
                width=width,
                scale_bar=scale_bar,
                bed=bed_of_dataset(ds),
                shade=shade,
                title=title,
            )
        if path is not None:
            save_figure(fig, path, dpi)
        return fig
    finally:
        if opened:
            ds.close()


def _curves(x, rows: list[dict], width, title: str):
    """A 1D run: one axes per field, its values against x."""
    from matplotlib.figure import Figure

    width = width or 7.0
    fig = Figure(figsize=(width, 1.8 * len(rows) + 0.5), layout="constrained")
    axes = fig.subplots(len(rows), 1, squeeze=False, sharex=True)[:, 0]
    for ax, row in zip(axes, rows):
        (name, values), *_ = row["panels"]
        ax.plot(x, values[0], drawstyle="steps-mid")
        ax.set_ylabel(row["label"], fontsize=9)
        ax.set_title(name, fontsize=9)
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("x [m]")
    fig.suptitle(title, fontsize=11)
    return fig


__all__ = ["plot_peak_fields", "peak_names"]
