"""Draw the small pictures of the built-in scenes shown on the docs' scene pages.

    python docs/scene_pictures.py [SCENE ...]

Each scene runs on a coarse grid (the overrides below, stated under the picture on its page)
and one picture of its last snapshot is written to ``docs/scenes/<name>.png``: the
concentration map for the two-dimensional scenes (the colours of figure 12), profiles for the
one-dimensional ones. The pictures are committed; run this again after a scene changes. It
takes a few minutes on two cores.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "docs" / "scenes"

# scene -> (overrides for a quick coarse run, kind of picture); the scene pages quote these
RUNS: dict[str, tuple[list[str], str]] = {
    "fingers": (["domain.resolution=100"], "map"),
    "finite-release": (["domain.resolution=100"], "map"),
    "finite-release-deposit": (["domain.resolution=100", "time.t_end=30"], "map"),
    "monodisperse-front": (["domain.resolution=150"], "map"),
    "levees": (["domain.resolution=100"], "map"),
    "obstacle": (["domain.resolution=100"], "map"),
    "runout": (["domain.resolution=100"], "map"),
    "channel": (["domain.resolution=250"], "channel"),
    "dam-break": ([], "profile"),
    "uniform-flow": ([], "mode"),
    "roll-waves": (["domain.nx=1000", "time.t_end=12"], "profile"),
    "roll-waves-forced": (["domain.resolution=500", "time.t_end=10"], "profile"),
    "erosion-deposition": ([], "profile"),
}


def _run(name: str, overrides: list[str], out: Path) -> None:
    env = dict(
        os.environ, TI_SKIP_VERSION_CHECK="ON", ENABLE_TAICHI_HEADER_PRINT="0", MPLBACKEND="Agg"
    )
    cmd = [sys.executable, "-m", "tiseg.apps.cli", "run", name, "--out", str(out), "--no-progress"]
    for o in overrides:
        cmd += ["--set", o]
    subprocess.run(cmd, check=True, env=env, cwd=ROOT)


def _map(run: Path, path: Path) -> None:
    from tiseg.post.render import plot_panels

    ds_times = _times(run)
    fig = plot_panels(run, times=[ds_times[-1]], field="phi", width=6.0)
    fig.savefig(path, dpi=80)


def _times(run: Path) -> list[float]:
    from tiseg.output.netcdf import read_fields

    ds = read_fields(run / "fields.nc")
    try:
        return [float(t) for t in ds["time"].values]
    finally:
        ds.close()


def _profiles(run: Path, path: Path, kind: str) -> None:
    """Two panels at the first and the last snapshot: h and u along x ("profile"); u and phi
    across y ("channel"); h and u minus their means along x ("mode": a small perturbation)."""
    from matplotlib.figure import Figure

    from tiseg.output.netcdf import read_fields

    ds = read_fields(run / "fields.nc")
    try:
        fig = Figure(figsize=(6.0, 2.6))
        axes = fig.subplots(1, 2)
        first, last = ds.isel(time=0), ds.isel(time=-1)
        coord, other = ("y", "x") if kind == "channel" else ("x", "y")
        panels = {
            "profile": (("h", "h [m]"), ("u", "u [m/s]")),
            "channel": (("u", "u [m/s]"), ("phi", "φ")),
            "mode": (("h", "h − mean [m]"), ("u", "u − mean [m/s]")),
        }[kind]
        for ax, (var, label) in zip(axes, panels):
            for snap, style in ((first, "--"), (last, "-")):
                prof = snap[var].isel({other: 0})
                values = prof.values - (prof.values.mean() if kind == "mode" else 0.0)
                ax.plot(
                    prof[coord].values,
                    values,
                    style,
                    label=f"t = {float(snap['time']):.2f} s",
                )
            ax.ticklabel_format(axis="y", style="sci", scilimits=(-3, 3), useOffset=False)
            ax.set_xlabel(f"{coord} [m]")
            ax.set_ylabel(label)
        axes[0].legend(fontsize=8)
        fig.tight_layout()
        fig.savefig(path, dpi=80)
    finally:
        ds.close()


def main(names: list[str]) -> None:
    OUT.mkdir(exist_ok=True)
    for name in names or list(RUNS):
        overrides, kind = RUNS[name]
        with tempfile.TemporaryDirectory() as tmp:
            run = Path(tmp) / name
            _run(name, overrides, run)
            path = OUT / f"{name}.png"
            if kind == "map":
                _map(run, path)
            else:
                _profiles(run, path, kind)
        print(f"{path.relative_to(ROOT)}: {path.stat().st_size // 1024} kB")


if __name__ == "__main__":
    main(sys.argv[1:])
