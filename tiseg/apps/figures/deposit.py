"""The deposit of a finite release (scene ``finite-release-deposit``), next to the paper's
description of figures 3(b) and 4(b).

Panels: (a) the concentration seen from above at the cut-off time and (b) at the last output
time, coloured like the experiments (white fines, brown coarse, turquoise empty chute); (c) the
thickness of the deposit. The caption holds the deposit numbers of
`tiseg.post.analysis.deposit.deposit_metrics` (when the flow stopped, the run-out and the
thickness of channels and levees) and, for comparison, what section 2 of the paper says the
experiments show.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ...errors import InputError
from ...post.analysis.fingers import _fields_path, analyse_run
from ...post.render.colours import CHUTE_RGB, phi_colours
from ...post.analysis.fingers import _stored_scene
from ...post.analysis.deposit import deposit_when, still_moving

FILE = "deposit.png"
# What the paper reports of the finite-release experiments (section 2, figures 3b and 4b),
# paraphrased: what the simulated deposit is to be compared with.
PAPER = (
    "Paper, figs. 3(b), 4(b): once the supply is cut off, the coarse regions at the rear of the "
    "levees come to rest and the remaining material runs down the established channels, which "
    "lengthens distinct fingers with grain-free zones between them; they arrest as the flow "
    "wanes."
)


def deposit_figure(run_dir, out_dir, dpi: int = 90) -> Path:
    """Write ``deposit.png`` for the run in ``run_dir`` into ``out_dir``; returns its path."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ...output import read_fields

    res = analyse_run(run_dir)
    if not res["segregation"]:  # (tiseg fingers reads such a run: fronts and deposit)
        raise InputError(
            f"{str(run_dir)!r} is a run without segregation (no phi): the deposit figure "
            "draws phi; `tiseg fingers` reports its run-out and thickness"
        )
    dep = res["deposit"]
    path = _fields_path(run_dir)
    with read_fields(path) as ds:
        times = np.asarray(ds["time"].values, dtype=float)
        x = np.asarray(ds["x"].values, dtype=float)
        y = np.asarray(ds["y"].values, dtype=float)
        stop = _stop_of_inflow(ds, path)
        first = int(np.argmin(np.abs(times - stop))) if stop is not None else 0
        snaps = []
        for i in (first, times.size - 1):
            h = np.asarray(ds["h"].isel(time=i).values, dtype=float)
            phi = np.asarray(ds["phi"].isel(time=i).values, dtype=float)
            snaps.append((times[i], h, phi))
    h_min = res["h_min"]
    ext = (x[0], x[-1], y[0], y[-1])
    fig, axes = plt.subplots(3, 1, figsize=(9, 8.2), constrained_layout=True)
    for ax, (t, h, phi), tag in zip(axes[:2], snaps, "ab"):
        rgb = phi_colours(phi)
        rgb[h < h_min] = CHUTE_RGB
        ax.imshow(rgb, origin="lower", extent=ext, aspect="equal", interpolation="nearest")
        ax.set_title(f"({tag}) t = {t:g} s: concentration (white fines, brown coarse)", loc="left")
        ax.set_ylabel("y [m]")
    t, h, _ = snaps[1]
    hm = np.where(h >= h_min, 1e3 * h, np.nan)
    im = axes[2].imshow(hm, origin="lower", extent=ext, aspect="equal", cmap="viridis")
    fig.colorbar(im, ax=axes[2], label="h [mm]", orientation="horizontal", shrink=0.5, aspect=40)
    axes[2].set_title(f"(c) t = {t:g} s: thickness", loc="left")
    axes[2].set_xlabel("x [m]")
    axes[2].set_ylabel("y [m]")
    for ax in axes:
        if dep["run_out"] is not None:
            ax.axvline(dep["run_out"], color="k", lw=0.8, ls="--")
    fig.text(
        0.01,
        -0.01,
        _wrap(_caption(dep), 120) + "\n" + _wrap(PAPER, 120),
        ha="left",
        va="top",
        fontsize=8,
    )
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    dest = out / FILE
    fig.savefig(dest, dpi=dpi, bbox_inches="tight")
    plt.close(fig)
    return dest


def _stop_of_inflow(ds, path) -> float | None:
    """inflow.stop_time of the scene stored with the run, if any."""

    sc = _stored_scene(ds, path)
    return None if sc is None or sc.inflow is None else sc.inflow.stop_time


def _caption(d: dict) -> str:

    if not d["settled"]:
        last = d["max_speed"][-1] if d["max_speed"] else None
        speed = "no wet cell" if last is None else f"max |u| = {last:.3g} m/s"
        return f"tiseg: the flow has not come to rest by the last output time ({speed})."

    def mm(v):
        return "-" if v is None else f"{1e3 * v:.2f} mm"

    end = " (reaches the end of the chute)" if d["run_out_at_domain_end"] else ""
    run_out = "-" if d["run_out"] is None else f"{d['run_out']:.3f} m{end}"
    state = "at rest" if d["stopped"] else "settled"
    tail = "" if d["stopped"] else f" ({still_moving(d)})"
    return (
        f"tiseg: {state} {deposit_when(d)}{tail}; run-out x_f+ = {run_out} (dashed); deposit "
        f"thickness: mean {mm(d['thickness_mean'])}, channels {mm(d['channel_thickness'])}, "
        f"levees {mm(d['levee_thickness'])}, max {mm(d['thickness_max'])}."
    )


def _wrap(text: str, width: int) -> str:
    import textwrap

    return "\n".join(textwrap.wrap(text, width))
