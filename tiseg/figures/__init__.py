"""Figures of the paper regenerated from the library (matplotlib, Agg backend, no pyplot state).

* `stability` -- figures 8-11 (steady Froude number, growth rates, sigma_Max and k_c).
* `fingers` -- figures 12-18 and beyond, from the grid, width and viscosity studies.

Modules are imported on demand so that ``import tiseg.figures`` does not load matplotlib.
"""

from pathlib import Path


def new_figure(nrows=1, ncols=1, size=(6.0, 4.2), layout=None, **subplots_kw):
    """(figure, 2D array of axes) on an Agg canvas of its own (no pyplot state)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=size, layout=layout)
    FigureCanvasAgg(fig)
    return fig, fig.subplots(nrows, ncols, squeeze=False, **subplots_kw)


def save_figure(fig, path, dpi: int, tight: bool = False) -> Path:
    """Write fig as PNG (folders made as needed); ``tight``: tight_layout first."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    if tight:
        fig.tight_layout()
    fig.savefig(path, dpi=dpi)
    return path
