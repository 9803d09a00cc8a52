"""Paper-style panels (figures 12-14): one panel per time, axes in metres, a colour bar.

The pictures inside the axes are the frame kernel's (`tiseg.post.render.render_fields`), computed
in NumPy (`tiseg.post.render.raster`, so that no Taichi starts), so the panels show exactly the
colours of the movies and the viewer; matplotlib only adds axes,
titles and a colour bar built from the same colour table (`colours.matplotlib_cmap`).
"""

from __future__ import annotations


import numpy as np

from ...errors import InputError
from . import colours as C
from .movie import _fields_path
from ...log import note
from .movie import _snapshot, global_range, run_h_min, save_figure
from .raster import render_fields_numpy


def _open(ds_or_path):
    """(dataset, run folder or None, whether we opened it)."""
    if hasattr(ds_or_path, "data_vars"):
        return ds_or_path, None, False
    from ...output.netcdf import read_fields

    path = _fields_path(ds_or_path)
    return read_fields(path), path.parent, True


def nearest_indices(available, times) -> list[int]:
    """Index of the snapshot nearest to each requested time."""
    available = np.asarray(available, dtype=np.float64)
    if available.size == 0:
        raise InputError("the run holds no snapshot")
    out = []
    for t in times:
        t = float(t)
        if not np.isfinite(t):
            raise InputError(f"time {t!r}: give a finite time in seconds")
        k = int(np.argmin(np.abs(available - t)))
        if abs(available[k] - t) > 1e-9 * max(1.0, abs(t)):
            note(
                f"t = {t:g} s is not a snapshot of the run; showing the nearest, "
                f"t = {available[k]:g} s"
            )
        out.append(k)
    return out


def plot_panels(
    ds,
    times=None,
    field: str = "phi",
    path=None,
    shade=True,
    vrange=None,
    scale: float = 1.0,
    width: float = 7.0,
    title: str | None = None,
):
    """A figure with one panel per time (nearest snapshot), stacked like figures 12-14.

    ``ds``: a dataset from `tiseg.output.netcdf.read_fields`, a run folder or a fields.nc
    path. ``times``: seconds (default: up to five snapshots evenly spread). ``field``: "phi",
    "h", "speed" ("|u|"), "u" or "v". ``vrange``: colour range of a mapped field in SI units
    (default: the data's over the panels, one range for all). ``path``: where to save (PNG, PDF,
    SVG, ... by suffix). Returns the matplotlib Figure.
    """
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize
    from matplotlib.figure import Figure
    from matplotlib.patches import Patch

    field = C.canonical_field(field)
    ds, run_dir, opened = _open(ds)
    try:
        need = {"phi": "phi", "h": "h", "speed": "u", "u": "u", "v": "v"}[field]
        if need not in ds:
            raise InputError(f"field {field!r} is not in this run")
        t_all = ds["time"].values
        if times is None or len(times) == 0:
            idx = sorted(
                set(np.linspace(0, len(t_all) - 1, min(5, len(t_all))).round().astype(int).tolist())
            )
        else:
            idx = nearest_indices(t_all, times)
        h_min = run_h_min(ds, run_dir)
        if field != "phi" and vrange is None:
            vrange = global_range(ds, field, h_min, idx)
        x, y = ds["x"].values, ds["y"].values
        dx = float(x[1] - x[0]) if x.size > 1 else 1.0
        dy = float(y[1] - y[0]) if y.size > 1 else dx
        Lx, Ly = x[-1] + 0.5 * dx, (y[-1] + 0.5 * dy if y.size > 1 else dy)
        aspect = Ly / Lx
        n = len(idx)
        panel_h = max(width * 0.82 * aspect, 0.6)
        fig = Figure(figsize=(width, n * (panel_h + 0.45) + 0.6), layout="constrained")
        axes = fig.subplots(n, 1, squeeze=False)[:, 0]
        for ax, k in zip(axes, idx):
            img = render_fields_numpy(  # the frame kernel's picture, without starting Taichi
                _snapshot(ds, k),
                h_min,
                field=field,
                shade=shade,
                scale=scale,
                vrange=vrange,
                aspect=dy / dx if y.size > 1 else 1.0,
            )
            ax.imshow(
                img,
                extent=(0.0, Lx, 0.0, Ly),
                interpolation="nearest",
                aspect="equal" if y.size > 1 else "auto",
            )
            ax.set_title(f"t = {float(t_all[k]):.2f} s", fontsize=10)
            ax.set_ylabel("y [m]")
        axes[-1].set_xlabel("x [m]")
        label, factor, unit = C.FIELD_LABELS[field]
        lo, hi = (0.0, 1.0) if field == "phi" else vrange
        sm = ScalarMappable(norm=Normalize(lo * factor, hi * factor), cmap=C.matplotlib_cmap(field))
        cb = fig.colorbar(sm, ax=list(axes), shrink=min(1.0, 0.9 / max(n, 1) + 0.3), pad=0.02)
        cb.set_label(label + (f" [{unit}]" if unit else ""))
        empty = C.CHUTE_RGB if field == "phi" else C.EMPTY_MAP_RGB
        fig.legend(
            handles=[Patch(color=empty, label=f"empty chute, h < {h_min:g} m")],
            loc="outside lower center",
            frameon=False,
            fontsize=9,
        )
        if title:
            fig.suptitle(title)
        if path is not None:
            save_figure(fig, path, 150)
        return fig
    finally:
        if opened:
            ds.close()
