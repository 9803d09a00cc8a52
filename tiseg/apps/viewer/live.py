"""The viewer's default grid and steps per frame: the finest grid this machine runs in real
time, from `tiseg estimate`'s model (`tiseg.apps.estimate`).

A scene's own grid is often far too fine to watch live (the fingers scene's 750 cells/m runs
at a tenth of real time on two cores), and too coarse a grid shows nothing (below about
200 cells/m the fingers scene forms no fingers by 7.5 s). So, unless ``--set
domain.resolution`` (or ``domain.nx``/``ny``) is given, `tiseg view` measures this machine
once (`tiseg.apps.estimate.calibrate` on the scene at the coarsest grid it would show, without
output) and predicts, for each grid of `RESOLUTIONS` between that floor and the scene's own
resolution, the wall time of the scene's stepping to its end (`tiseg.apps.estimate.estimate`
with that calibration: its costs are linear in the active cells, so one calibration prices
every grid) plus the drawing of the frames. It takes the finest grid that keeps up with real
time, or the floor when none does (and says how far behind it will be).

Steps per frame follow from the predicted steps per wall second: enough that the window is
redrawn about `FRAMES_PER_S` times a second, each frame costing `FRAME_S`; redrawing after
every step would spend most of the time drawing.

"Machine speed" below is what the calibration measures: cells advanced by one stage per second
on a wet grid (`speed_of`); `synthetic_calibration` makes the calibration of a machine of a
given speed, for the table of docs/viewer.md and its test.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

# cells per metre the viewer chooses from (coarse to fine)
RESOLUTIONS = (100, 150, 200, 250, 300, 375, 500, 750, 1000)
FINGERS_FLOOR = 200  # the split sweeps form no fingers by 7.5 s below this (issue 52)
TARGET_REALTIME = 1.0  # simulated seconds per wall second the choice keeps up with
FRAMES_PER_S = 6.0  # redraws per wall second aimed at
FRAME_S = 0.04  # one redraw (map, captions, GGUI) on a 2-core CPU with software Vulkan [s]
OVERHEAD_STAGES = 1.0  # per-step work of a synthetic machine, in stages of the same grid


@dataclass(frozen=True)
class LiveSetting:
    """The grid and steps per frame chosen, and what the model predicts for them."""

    resolution: float
    nx: int
    ny: int
    steps_per_frame: int
    steps: int  # to the scene's end
    t_end: float
    wall_s: float  # predicted wall time to t_end, stepping and drawing
    speed: float  # the machine: cells advanced by one stage per second
    scene_resolution: float

    @property
    def realtime(self) -> float:
        """Simulated seconds per wall second."""
        return self.t_end / max(self.wall_s, 1e-12)

    def text(self) -> str:
        """The line `tiseg view` prints."""
        return (
            f"{self.resolution:g} cells/m ({self.nx} x {self.ny} cells), "
            f"{self.steps_per_frame} steps per frame: t = {self.t_end:g} s in about "
            f"{self.wall_s:.0f} s, x{self.realtime:.2g} real time on this machine "
            f"({self.speed / 1e6:.2g} M cell-stages/s); the scene's own grid is "
            f"{self.scene_resolution:g} cells/m (--set domain.resolution=...)"
        )

    def status(self) -> str:
        """The viewer's status line at the start."""
        return (
            f"live grid {self.resolution:g} cells/m, {self.steps_per_frame} steps/frame "
            f"(x{self.realtime:.2g} real time expected)"
        )


def applies(scene, overrides) -> bool:
    """Whether the viewer chooses the grid: a 2D scene given by its resolution, which the
    command line does not set."""
    keys = {str(o).partition("=")[0].strip() for o in overrides or ()}
    if keys & {"domain.resolution", "domain.nx", "domain.ny"}:
        return False
    return scene.domain.resolution is not None and not scene.is_1d


def floor_of(scene) -> float:
    """The coarsest grid shown: FINGERS_FLOOR for a segregating flow (fingers need it), else
    the coarsest of RESOLUTIONS; never finer than the scene's own."""
    floor = FINGERS_FLOOR if scene.effects.segregation else RESOLUTIONS[0]
    return min(floor, scene.domain.resolution)


def candidates(scene) -> list[float]:
    """The grids considered, coarse to fine: the floor, then RESOLUTIONS up to the scene's."""
    floor, own = floor_of(scene), scene.domain.resolution
    return sorted({floor, *(r for r in RESOLUTIONS if floor < r <= own)})


def at_resolution(scene, resolution: float):
    return scene.with_overrides({"domain.resolution": resolution})


def speed_of(cal) -> float:
    """Cells advanced by one stage per second, on the calibration's wetter state."""
    return cal.active_cells[-1] / max(cal.stage_s[-1], 1e-12)


def synthetic_calibration(speed: float, overhead_stages: float = OVERHEAD_STAGES):
    """The calibration of a machine that advances ``speed`` cells by one stage per second, with
    per-step work of ``overhead_stages`` stages, no output and no compilation."""
    from ..estimate import Calibration

    cells = (1.0e4, 1.0e6)
    stage = tuple(c / speed for c in cells)
    over = tuple(overhead_stages * s for s in stage)
    return Calibration(
        cells=int(cells[-1]),
        active_cells=cells,
        stage_s=stage,
        step_overhead_s=over,
        stage_idle_s=stage,
        step_overhead_idle_s=over,
        diagnostics_s=0.0,
        output_s=0.0,
        compile_s=0.0,
        setup_s=0.0,
        wall_s=0.0,
    )


def predict(scene, resolution: float, cal) -> LiveSetting:
    """The model's steps, wall time and steps per frame for ``scene`` at ``resolution``."""
    from ..estimate import estimate

    sc = at_resolution(scene, resolution)
    est = estimate(sc, calibration=cal, output=False)
    stepping = max(est.wall_steps_s, 1e-9)
    per_frame = max(1, math.ceil(est.steps / stepping / FRAMES_PER_S))
    wall = stepping + math.ceil(est.steps / per_frame) * FRAME_S
    return LiveSetting(
        resolution=float(resolution),
        nx=sc.domain.nx,
        ny=sc.domain.ny,
        steps_per_frame=per_frame,
        steps=est.steps,
        t_end=sc.t_end,
        wall_s=wall,
        speed=speed_of(cal),
        scene_resolution=float(scene.domain.resolution),
    )


def choose(scene, cal) -> LiveSetting:
    """The finest candidate grid that keeps up with real time, else the floor."""
    best = None
    for r in candidates(scene):
        s = predict(scene, r, cal)
        if best is None or s.realtime >= TARGET_REALTIME:
            best = s
        if s.realtime < TARGET_REALTIME:
            break  # finer grids only run slower
    return best


def probe(scene, arch=None, precision=None, threads: int = 0):
    """The Simulation of ``scene`` at its floor grid that `measure` times: the grid the
    viewer shows on a machine too slow for a finer one, so that it can be shown after a
    reset without compiling its kernels again."""
    from ...run.simulation import Simulation

    sc = at_resolution(scene, floor_of(scene))
    if precision:
        sc = sc.with_overrides({"numerics.precision": precision})
    return Simulation(sc, arch=arch, threads=threads)


def measure(sim):
    """Calibrate this machine on ``sim`` (from `probe`; a few seconds, most of them the
    compilation that the viewer needs anyway) and put it back to its initial state."""
    from ..estimate import calibrate

    cal = calibrate(sim.scene, output=False, repeats=3, sim=sim)
    sim.reset()
    return cal
