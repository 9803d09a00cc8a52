"""The time series of a run's gauges (gauges.csv, `tiseg.run.gauges`) as one figure:
``tiseg render RUN_DIR --gauges``. A panel per quantity (h, u, v, phi, those the run has),
a line per gauge, against the simulated time; phi is left blank while a gauge is dry."""

from __future__ import annotations

from ...output.names import GAUGES_FILE

from pathlib import Path

import numpy as np

from ...errors import InputError
from ...output.atomic import replacing
from ...output.diagnostics import read_diagnostics
from ...run.gauges import QUANTITIES

LABELS = {
    "h": "h [mm]",
    "u": "u [m/s]",
    "v": "v [m/s]",
    "phi": "φ",
}
SCALE = {"h": 1e3}  # thickness in millimetres, the scale of the paper's flows


def gauges_csv(run_dir) -> Path:
    """gauges.csv of a run folder (or beside its fields.nc); an InputError naming the scene key
    when the run had no gauges."""
    p = Path(run_dir)
    folder = p if p.is_dir() else p.parent
    path = folder / GAUGES_FILE
    if not path.is_file():
        raise InputError(
            f"{str(folder)!r} has no gauges.csv: the run had no gauges; add [[output.gauges]] "
            "entries (x, y, name) to the scene and run it again"
        )
    return path


def plot_gauges(run_dir, target=None, dpi: int = 120) -> Path:
    """Draw the gauges of the run in ``run_dir`` into ``target`` (default RUN_DIR/gauges.png)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path = gauges_csv(run_dir)
    try:
        cols = read_diagnostics(path)
    except (OSError, ValueError, UnicodeDecodeError) as exc:
        raise InputError(f"{str(path)!r} cannot be read as a gauges file ({exc})") from None
    t = cols.get("time")
    names = [c for c in cols if c != "time" and c.rsplit("_", 1)[-1] in QUANTITIES]
    if t is None or not names:
        raise InputError(f"{str(path)!r} holds no gauge columns (time, NAME_h, ...)")
    gauges = list(dict.fromkeys(c.rsplit("_", 1)[0] for c in names))
    quantities = [q for q in QUANTITIES if any(f"{g}_{q}" in cols for g in gauges)]
    fig, axes = plt.subplots(
        len(quantities), 1, sharex=True, figsize=(7, 1.9 * len(quantities) + 0.6), squeeze=False
    )
    for ax, q in zip(axes[:, 0], quantities):
        for k, g in enumerate(gauges):
            y = cols.get(f"{g}_{q}")
            if y is not None:
                ax.plot(t, np.asarray(y) * SCALE.get(q, 1.0), color=f"C{k % 10}", label=g, lw=1.2)
        ax.set_ylabel(LABELS[q])
        ax.grid(alpha=0.3)
    axes[0, 0].legend(loc="best", fontsize="small", ncol=min(4, len(gauges)), title="gauge")
    axes[-1, 0].set_xlabel("t [s]")
    fig.suptitle("gauges: values at points after every step", fontsize="medium")
    fig.tight_layout()
    target = Path(target) if target is not None else path.with_name("gauges.png")
    try:
        with replacing(target) as tmp:  # a reader never sees half a picture
            fig.savefig(tmp, format="png", dpi=dpi)
    except OSError as exc:
        raise InputError(f"cannot write {str(target)!r}: {exc.strerror or exc}") from None
    finally:
        plt.close(fig)
    return target


__all__ = ["plot_gauges", "gauges_csv"]
