"""Draw the pictures of docs/first-hour.md (and the figures it shares with the probability and
calibration pages) from real runs of the commands that page shows.

    python docs/first_hour_pictures.py [STEP ...]     # STEP: run, sweep, calibrate

Each step runs its commands in a temporary folder, as the page tells a new user to, and writes
small PNGs (well under 200 kB each) into ``docs/images/``:

* run: ``first-hour-frame.png``, the movie's last frame of a 200 cells/m fingers run, and
  ``first-hour-panels.png``, its panels at 2.5, 5 and 7.5 s;
* sweep: ``probability.png``, the maps of the built-in ``gate-probability`` sweep in two
  columns, readable at page width;
* calibrate: ``calibration-misfit.png``, the misfit plot of the calibration of the Coulomb
  friction of a dam break that docs/calibration.md walks through.

The pictures are committed; run this again after the scene, the renderer or the commands
change. It takes five to ten minutes on two cores.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
IMAGES = ROOT / "docs" / "images"
ENV = dict(os.environ, TI_SKIP_VERSION_CHECK="ON", ENABLE_TAICHI_HEADER_PRINT="0", MPLBACKEND="Agg")

# the page's commands, after `tiseg` (the page shows them with the same arguments)
RUN = ["run", "fingers", "--set", "domain.resolution=200", "--movie", "fingers.mp4"]
SWEEP = ["sweep", "gate-probability", "--out", "runs/sweeps/gate-probability"]
CALIBRATE = [
    "calibrate", "dam-break", "--set", "effects.friction=coulomb",
    "--set", "numerics.friction_scheme=projected", "--set", "domain.nx=200",
    "--set", "domain.Lx=0.3", "--set", "initial.x0=0.05", "--set", "initial.h_left=0.02",
    "--set", "time.t_end=1.0", "--set", "output.interval=0.05",
    "--param", "effects.coulomb_mu=0.12:0.25", "--target", "deposit.run_out=0.26325+-0.0015",
    "--budget", "10", "--out", "mu",
]  # fmt: skip


def tiseg(args: list[str], cwd: Path) -> str:
    """Run one command as the page shows it; its standard output."""
    cmd = [sys.executable, "-m", "tiseg", *args]
    print("$ tiseg " + " ".join(args), flush=True)
    out = subprocess.run(cmd, cwd=cwd, env=ENV, check=True, capture_output=True, text=True)
    print(out.stdout, flush=True)
    return out.stdout


def _shrink(path: Path, limit: int = 200_000) -> None:
    """Fail loudly on a picture too large for the pages (the limit of the docs' pictures)."""
    size = path.stat().st_size
    if size > limit:
        raise SystemExit(f"{path.name} is {size} bytes, over {limit}: draw it smaller")
    print(f"wrote {path.relative_to(ROOT)} ({size // 1000} kB)")


def step_run(work: Path) -> None:
    import imageio.v3 as iio

    tiseg(RUN, work)
    tiseg(["fingers", "runs/fingers", "--time", "7.5"], work)
    frames = iio.imread(work / "fingers.mp4", index=None)
    iio.imwrite(IMAGES / "first-hour-frame.png", frames[-1])
    _shrink(IMAGES / "first-hour-frame.png")
    from tiseg.post.render import plot_panels  # what `tiseg render --panels` draws

    fig = plot_panels(work / "runs/fingers", times=[2.5, 5.0, 7.5], field="phi", width=7.0)
    fig.savefig(IMAGES / "first-hour-panels.png", dpi=90)
    _shrink(IMAGES / "first-hour-panels.png")


def step_sweep(work: Path) -> None:
    from tiseg.post.render.probability import plot_probability

    tiseg(SWEEP, work)
    plot_probability(work / SWEEP[-1], IMAGES / "probability.png", width=7.5, columns=2, dpi=90)
    _shrink(IMAGES / "probability.png")


def step_calibrate(work: Path) -> None:
    tiseg(CALIBRATE + ["--workers", "1"], work)
    shutil.copyfile(work / "mu" / "misfit.png", IMAGES / "calibration-misfit.png")
    _shrink(IMAGES / "calibration-misfit.png")


STEPS = {"run": step_run, "sweep": step_sweep, "calibrate": step_calibrate}


def main(argv: list[str]) -> None:
    IMAGES.mkdir(parents=True, exist_ok=True)
    for name in argv or list(STEPS):
        with tempfile.TemporaryDirectory() as tmp:
            STEPS[name](Path(tmp))


if __name__ == "__main__":
    main(sys.argv[1:])
