"""Figures of maps on a run's grid: the probability maps of a sweep
(`tiseg.post.render.probability`) and the peak fields of a run (`tiseg.post.render.peak_maps`).

Rows of panels, each row sharing a colour range, its colour map and one colour bar with its
label; axes in metres, a scale bar, cells without a value in the empty-map grey of the
renderer's maps. Where the run had terrain (``b`` and ``solid`` on the same grid, as fields.nc
and probability.nc hold them), the bed is hill-shaded under the colours and the solid cells are
drawn as walls, as in the renderer's frames (`tiseg.post.render.relief.with_relief`): the
colours of a cell then mix its value with the slope of the bed under it, so the colour bar
reads true on flat ground and within the shading's ±35 % brightness on slopes. Without terrain
the maps are drawn from the values as before.
"""

from __future__ import annotations

import numpy as np

from . import colours as C
from .lengths import format_length, nice_length
from .raster import _shade_strength
from .relief import SOLID_RGB, with_relief


def bed_of_dataset(ds):
    """(b, solid) (ny, nx) of a dataset on (y, x) with the terrain's static variables
    (fields.nc, probability.nc), solid None when absent; None for a flat run."""
    if "b" not in ds or ds["b"].dims != ("y", "x"):
        return None
    b = np.nan_to_num(np.asarray(ds["b"].values, dtype=np.float64))
    solid = None
    if "solid" in ds and ds["solid"].dims == ("y", "x"):
        solid = np.nan_to_num(np.asarray(ds["solid"].values, dtype=np.float64)) > 0.5
    return b, solid


def wrapped(rows: list[dict], columns: int | None) -> list[dict]:
    """The rows with at most ``columns`` panels each: a longer row goes on below, its pieces
    sharing its colour range."""
    if not columns or columns < 1:
        return rows
    out = []
    for row in rows:
        panels = row["panels"]
        for i in range(0, len(panels), columns):
            out.append({**row, "panels": panels[i : i + columns]})
    return out


def relief_picture(values, cmap, norm, bed, dx: float, dy: float, strength: float) -> np.ndarray:
    """The map of ``values`` (ny, nx; NaN: no value, drawn in the colour map's "bad" colour)
    in ``cmap`` and ``norm`` with the bed ``bed = (b, solid)`` shaded under it: uint8
    (ny, nx, 3), one pixel per cell, row 0 at the top (the last y row)."""
    rgba = cmap(norm(np.ma.masked_invalid(np.asarray(values, dtype=np.float64))))
    img = C.to_uint8(rgba[::-1, :, :3])
    return with_relief(img, *bed, dx, dy, strength)  # b, solid with y upwards, as stored


def maps_figure(
    rows: list[dict],
    x,
    y,
    width: float | None = None,
    scale_bar: bool = True,
    columns: int | None = None,
    bed=None,
    shade=True,
    title: str | None = None,
):
    """A matplotlib Figure of ``rows``: dicts with "panels" (a list of (title, values
    (ny, nx))), "range" (lo, hi), "label" (the colour bar's) and optionally "cmap" (a
    matplotlib colour map; default the renderer's viridis). ``x``, ``y``: the cell centres
    [m]. ``columns``: at most this many maps side by side (see `wrapped`). ``bed``: (b,
    solid) (ny, nx) of the run's terrain, or None; ``shade``: True, False or the strength of
    its hill-shading (walls are drawn either way)."""
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize
    from matplotlib.figure import Figure
    from matplotlib.patches import Patch
    from mpl_toolkits.axes_grid1.anchored_artists import AnchoredSizeBar

    rows = wrapped(rows, columns)
    x, y = np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)
    dx = float(x[1] - x[0]) if x.size > 1 else 1.0
    dy = float(y[1] - y[0]) if y.size > 1 else dx
    Lx, Ly = float(x[-1] + 0.5 * dx), float(y[-1] + 0.5 * dy)
    ncols = max(len(r["panels"]) for r in rows)
    width = width or min(4.0 * ncols, 16.0)
    panel_w = width / ncols
    panel_h = max(panel_w * 0.85 * Ly / Lx, 0.8) + 0.55
    walls = bed is not None and bed[1] is not None and bool(np.any(bed[1]))
    legend_h = 0.3 if walls else 0.0
    fig = Figure(figsize=(width, len(rows) * panel_h + 0.5 + legend_h), layout="constrained")
    axes = fig.subplots(len(rows), ncols, squeeze=False)
    bar = nice_length(0.2 * Lx)
    strength = _shade_strength(shade)
    for r, row in enumerate(rows):
        cmap = row.get("cmap") or C.matplotlib_cmap("h")
        cmap = cmap.with_extremes(bad=C.EMPTY_MAP_RGB)
        norm = Normalize(*row["range"])
        for c in range(ncols):
            ax = axes[r, c]
            if c >= len(row["panels"]):
                ax.set_visible(False)
                continue
            panel_title, values = row["panels"][c]
            common = {"extent": (0.0, Lx, 0.0, Ly), "interpolation": "nearest"}
            if bed is None:
                ax.imshow(
                    np.ma.masked_invalid(values), origin="lower", cmap=cmap, norm=norm, **common
                )
            else:  # the colours over the shaded relief, as an RGB picture
                ax.imshow(relief_picture(values, cmap, norm, bed, dx, dy, strength), **common)
            ax.set_title(panel_title, fontsize=9)
            ax.set_xlabel("x [m]", fontsize=8)
            if c == 0:
                ax.set_ylabel("y [m]", fontsize=8)
            ax.tick_params(labelsize=7)
            if scale_bar and 0 < bar <= Lx:
                sizebar = AnchoredSizeBar(
                    ax.transData,
                    bar,
                    format_length(bar),
                    "lower right",
                    pad=0.2,
                    borderpad=0.3,
                    color="black",
                    frameon=True,
                    size_vertical=0.015 * Ly,
                    fontproperties={"size": 7},
                )
                sizebar.patch.set_alpha(0.7)
                ax.add_artist(sizebar)
        cb = fig.colorbar(
            ScalarMappable(norm=norm, cmap=cmap), ax=list(axes[r, :]), shrink=0.9, pad=0.01
        )
        cb.set_label(row["label"], fontsize=8)
        cb.ax.tick_params(labelsize=7)
    if walls:
        fig.legend(
            handles=[
                Patch(color=SOLID_RGB, label="solid cells (walls)"),
                Patch(color=C.EMPTY_MAP_RGB, label="no value"),
            ],
            loc="outside lower center",
            ncols=2,
            frameon=False,
            fontsize=8,
        )
    if title:
        fig.suptitle(title, fontsize=11)
    return fig
