"""The probability maps of a sweep (``probability.nc``, `tiseg.apps.sweep.probability`) as one
figure: a panel per threshold of P(h_max > threshold) and of P(speed_max > threshold), the
probability that the flow arrives, and the mean and quantiles of h_max and of the arrival time.

A 2D sweep gives maps (axes in metres, a scale bar, one colour bar with its units per row, cells
without a value in the empty-chute grey of the renderer's maps; `tiseg.post.render.maps`), over
the members' shaded relief and walls where they ran on terrain (probability.nc then holds their
bed ``b`` and ``solid``); a 1D sweep (ny = 1) gives curves against x, the quantiles as a band
around the median.
"""

from __future__ import annotations

from ...output.names import FIELDS_FILE, PROBABILITY_FILE

from pathlib import Path

import numpy as np

from ...errors import InputError
from .lengths import format_length
from .maps import bed_of_dataset, maps_figure
from .movie import save_figure

# a variable that only probability.nc holds: how `probability_source` recognises the file
MARKER_VARIABLE = "p_arrival"
H_FACTOR, H_UNIT = 1e3, "mm"  # h_max in mm, as the renderer's thickness maps (colours.FIELD_LABELS)
# the figure's rows, by name: what `plot_probability`'s ``rows`` chooses from
ROWS = ("probability", "speed", "h_max", "arrival_time")


def probability_source(path) -> Path | None:
    """The probability.nc that ``path`` names: the file itself (any .nc holding the maps) or a
    sweep folder with probability.nc and no fields.nc of a run; None otherwise."""
    p = Path(path)
    if p.is_dir():
        if (p / FIELDS_FILE).exists() or not (p / PROBABILITY_FILE).is_file():
            return None
        return p / PROBABILITY_FILE
    if not p.is_file() or p.suffix != ".nc" or p.name == FIELDS_FILE:
        return None
    import netCDF4

    try:
        with netCDF4.Dataset(p, "r") as ds:
            return p if MARKER_VARIABLE in ds.variables else None
    except OSError:
        return None  # not NetCDF: the run renderer says so


def _quantile_label(q: float) -> str:
    return f"{100 * q:g} % quantile"


def _rows(ds) -> list[dict]:
    """The figure's rows: panels (title, values (ny, nx)) sharing a colour range and a label."""
    rows = []
    probs = []
    if "p_h_max_above" in ds:
        for t in ds["h_threshold"].values:
            v = ds["p_h_max_above"].sel(h_threshold=t).values
            probs.append((f"P(h_max > {format_length(float(t))})", v))
    probs.append(("P(flow arrives)", ds["p_arrival"].values))
    rows.append(
        {
            "panels": probs,
            "range": (0.0, 1.0),
            "label": "probability [1]",
            "kind": "p",
            "name": "probability",
        }
    )
    if "p_speed_max_above" in ds:
        speeds = [
            (
                f"P(speed_max > {float(t):g} m/s)",
                ds["p_speed_max_above"].sel(speed_threshold=t).values,
            )
            for t in ds["speed_threshold"].values
        ]
        rows.append(
            {
                "panels": speeds,
                "range": (0.0, 1.0),
                "label": "probability [1]",
                "kind": "p",
                "name": "speed",
            }
        )
    for name, label, factor, unit in (
        ("h_max", "h_max", H_FACTOR, H_UNIT),
        ("arrival_time", "arrival time", 1.0, "s"),
    ):
        panels = [(f"mean {label}", ds[f"{name}_mean"].values * factor)]
        for q in ds["quantile_level"].values:
            panels.append(
                (
                    f"{_quantile_label(float(q))} of {label}",
                    ds[f"{name}_quantile"].sel(quantile_level=q).values * factor,
                )
            )
        finite = np.concatenate([v[np.isfinite(v)].ravel() for _, v in panels])
        hi = float(finite.max()) if finite.size else 1.0
        lo = 0.0
        if name == "arrival_time" and finite.size:
            lo = float(finite.min())
        if not hi > lo:
            hi = lo + 1.0
        rows.append(
            {
                "panels": panels,
                "range": (lo, hi),
                "label": f"{label} [{unit}]",
                "kind": name,
                "name": name,
                "quantiles": [float(q) for q in ds["quantile_level"].values],
            }
        )
    return rows


def plot_probability(
    source,
    path=None,
    width: float | None = None,
    scale_bar: bool = True,
    columns: int | None = None,
    dpi: float = 150,
    rows=None,
    shade=True,
):
    """Draw ``source`` (a probability.nc path, a sweep folder holding one, or an open
    `xarray.Dataset`) and save it to ``path`` (PNG, PDF, SVG, ... by suffix) if given.
    ``columns``: at most this many maps side by side (a row of more continues below, with
    its colour bar), so that a narrow figure, as on a page of the documentation, keeps
    maps and labels large enough to read. ``rows``: which rows to draw, some of `ROWS`
    ("probability": P(h_max > threshold) and P(flow arrives); "speed": P(speed_max >
    threshold); "h_max" and "arrival_time": their mean and quantiles); default all the file
    has. ``shade``: True, False or the strength of the hill-shading of the members' bed under
    the maps, where they ran on terrain (the walls are drawn either way). Returns the
    matplotlib Figure."""
    if rows is not None:
        rows = [rows] if isinstance(rows, str) else list(rows)
        unknown = [r for r in rows if r not in ROWS]
        if unknown or not rows:
            raise InputError(f"rows={rows!r}: choose some of {', '.join(ROWS)}")
    import xarray as xr

    opened = False
    if hasattr(source, "data_vars"):
        ds = source
    else:
        p = probability_source(source)
        if p is None:
            raise InputError(
                f"no probability maps at {str(source)!r}: give a sweep folder with "
                "probability.nc (a sweep with a [probability] table) or the file itself"
            )
        ds = xr.open_dataset(p)
        opened = True
    try:
        if MARKER_VARIABLE not in ds:
            raise InputError("this dataset holds no probability maps (no p_arrival)")
        chosen = [r for r in _rows(ds) if rows is None or r["name"] in rows]
        if not chosen:
            raise InputError(f"rows={rows!r}: this dataset holds none of them")
        if ds.sizes["y"] == 1:
            fig = _curves(ds, chosen, width)
        else:
            fig = maps_figure(
                chosen,
                ds["x"].values,
                ds["y"].values,
                width=width,
                scale_bar=scale_bar,
                columns=columns,
                bed=bed_of_dataset(ds),
                shade=shade,
            )
            _title(fig, ds)
        if path is not None:
            save_figure(fig, path, dpi)
        return fig
    finally:
        if opened:
            ds.close()


def _title(fig, ds) -> None:
    n = int(ds.attrs.get("members", ds.sizes.get("member", 0)))
    name = str(ds.attrs.get("title", "probability maps")).replace("tiseg probability maps of ", "")
    fig.suptitle(f"{name}: {n} members", fontsize=11)


def _curves(ds, rows, width):
    """1D members: each row one axes, the probabilities as curves, the quantiles as a band."""
    from matplotlib.figure import Figure

    x = ds["x"].values
    width = width or 7.0
    fig = Figure(figsize=(width, 2.0 * len(rows) + 0.5), layout="constrained")
    axes = fig.subplots(len(rows), 1, squeeze=False, sharex=True)[:, 0]
    for ax, row in zip(axes, rows):
        panels = row["panels"]
        if row["kind"] == "p":
            for title, values in panels:
                ax.plot(x, values[0], drawstyle="steps-mid", label=title)
            ax.set_ylim(-0.02, 1.02)
        else:
            (mean_t, mean), *qs = panels
            lo, mid, hi = (v[0] for _, v in qs)
            ax.fill_between(
                x,
                lo,
                hi,
                step="mid",
                alpha=0.3,
                label=f"{100 * row['quantiles'][0]:g} % to "
                f"{100 * row['quantiles'][-1]:g} % quantiles",
            )
            ax.plot(x, mid, drawstyle="steps-mid", label=qs[1][0])
            ax.plot(x, mean[0], drawstyle="steps-mid", linestyle="--", label=mean_t)
        ax.set_ylabel(row["label"], fontsize=9)
        ax.legend(fontsize=7, loc="best")
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("x [m]")
    _title(fig, ds)
    return fig
