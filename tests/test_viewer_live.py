"""The viewer's default grid (`tiseg.apps.viewer.live`): the setting docs/viewer.md documents
for each machine speed, the model's step count against a real run, when the choice applies,
and (slow) that the grid chosen on this machine forms fingers."""

from __future__ import annotations

import re
from argparse import Namespace
from pathlib import Path

import pytest

from tiseg.apps.viewer import live
from tiseg.apps.viewer.app import vulkan_problem
from tiseg.setup.scene import load_scene

DOC = Path(__file__).resolve().parents[1] / "docs" / "viewer.md"
VULKAN = vulkan_problem()
ROW = re.compile(r"^\| (\d+) \| (\d+) \| (\d+) \| ([\d.]+) \|$")


def _documented() -> list[tuple[float, float, int, float]]:
    rows = [ROW.match(line) for line in DOC.read_text(encoding="utf-8").splitlines()]
    return [
        (float(a), float(b), int(c), float(d)) for a, b, c, d in (m.groups() for m in rows if m)
    ]


def test_the_choice_is_the_documented_one_for_each_machine_speed():
    fingers = load_scene("fingers")
    rows = _documented()
    assert len(rows) >= 5
    for speed, grid, per_frame, realtime in rows:
        s = live.choose(fingers, live.synthetic_calibration(speed * 1e6))
        assert (s.resolution, s.steps_per_frame) == (grid, per_frame), speed
        assert s.realtime == pytest.approx(realtime, rel=0.05), speed
        # above the floor only a grid that keeps up with real time, the next finer one does not
        if grid > live.FINGERS_FLOOR:
            assert s.realtime >= live.TARGET_REALTIME
        finer = [r for r in live.candidates(fingers) if r > grid]
        if finer:
            slower = live.predict(fingers, finer[0], live.synthetic_calibration(speed * 1e6))
            assert slower.realtime < live.TARGET_REALTIME
    grids = [g for _, g, _, _ in rows]
    assert grids == sorted(grids) and grids[0] == live.FINGERS_FLOOR == 200


def test_the_model_counts_the_steps_of_a_real_run():
    """`tiseg run fingers --set domain.resolution=200` took 355 steps to 7.5 s (the run of
    docs/first-hour.md); the model the choice rests on predicts that count."""
    s = live.predict(load_scene("fingers"), 200, live.synthetic_calibration(4e6))
    assert abs(s.steps - 355) <= 0.05 * 355
    assert (s.nx, s.ny) == (300, 100)


def test_the_choice_applies_only_where_the_command_line_leaves_the_grid():
    fingers = load_scene("fingers")
    assert live.applies(fingers, [])
    assert live.applies(fingers, ["flow.nu=0.01"])
    for key in ("domain.resolution=300", "domain.nx=100", "domain.ny=40"):
        assert not live.applies(fingers, [key])
    assert not live.applies(load_scene("dam-break"), [])  # 1D: nothing to choose
    assert live.candidates(load_scene("levees")) == [100]  # never finer than the scene's own
    no_fingers = load_scene("fingers", ["effects.segregation=false"])
    assert live.floor_of(no_fingers) == live.RESOLUTIONS[0] < live.FINGERS_FLOOR


def test_the_status_line_says_what_was_chosen():
    s = live.choose(load_scene("fingers"), live.synthetic_calibration(16e6))
    assert s.status() == "live grid 300 cells/m, 17 steps/frame (x1.1 real time expected)"
    assert s.text().startswith("300 cells/m (450 x 150 cells), 17 steps per frame: t = 7.5 s")


@pytest.mark.slow
def test_the_grid_chosen_on_this_machine_forms_fingers(ti_cpu):
    """The viewer's own path (`_live_setting`: time this machine on the probe, choose), then
    the chosen setting run headless to 7.5 s: at least four fingers (the finger analysis of
    `tiseg fingers`)."""
    from tiseg.apps.viewer.app import _live_setting
    from tiseg.post.analysis.fingers import finger_metrics

    args = Namespace(scene="fingers", arch=None, precision=None, threads=0)
    chosen, sim = _live_setting(args, [])
    assert chosen is not None and chosen.resolution >= live.FINGERS_FLOOR
    if sim.scene.domain.nx != chosen.nx:
        from tiseg.run.simulation import Simulation

        sim = Simulation(live.at_resolution(load_scene("fingers"), chosen.resolution))
    assert sim.t == 0.0 and sim.stats.steps == 0  # measured, then put back
    sim.advance(7.5)
    f = sim.fields()
    x, y = sim.scene.domain.cell_centres()
    sc = sim.scene
    m = finger_metrics(
        f["h"], f["u"], f["v"], f["phi"], x, y, sc.numerics.h_min, sc.flow.phi0, sc.flow.u0
    )
    assert m["finger_count"] >= 4, m


@pytest.mark.skipif(VULKAN is not None, reason=f"no Vulkan: {VULKAN}")
def test_view_prints_the_choice_and_shows_it(capsys):
    """`tiseg view fingers` (off-screen, two frames) prints the grid it chose and runs on it;
    --set domain.resolution takes the choice away."""
    from tiseg.apps.cli import main

    assert main(["view", "fingers", "--offscreen", "--frames", "2"]) == 0
    out = capsys.readouterr().out
    assert "viewer: timing this machine" in out
    chosen = re.search(r"viewer: (\d+) cells/m \((\d+) x (\d+) cells\), (\d+) steps per frame", out)
    assert chosen and int(chosen[1]) >= live.FINGERS_FLOOR
    steps = int(re.search(r"(\d+) steps in", out)[1])
    assert steps == 2 * int(chosen[4])  # two frames of the chosen steps each
    assert (
        main(
            ["view", "fingers", "--offscreen", "--frames", "1"] + ["--set", "domain.resolution=60"]
        )
        == 0
    )
    assert "timing this machine" not in capsys.readouterr().out


def test_view_passes_the_choice_to_the_window(monkeypatch, capsys):
    """The wiring of `tiseg view` without a window: the grid chosen goes into the scene, its
    steps per frame into the viewer, its line to stdout and its status to the status line; the
    Simulation timed is shown where the choice is its grid, and --steps-per-frame wins."""
    from types import SimpleNamespace

    from tiseg.apps.cli import build_parser
    from tiseg.apps.viewer import app

    made = []

    class FakeViewer:
        def __init__(self, scene, sim=None, overrides=(), steps_per_frame=1, **kw):
            made.append(self)
            self.sim_given, self.overrides, self.steps_per_frame = sim, overrides, steps_per_frame
            self.sim = SimpleNamespace(t=0.0, stats=SimpleNamespace(steps=0))
            self.frames, self.message = 0, ""

        def run(self, max_frames=None):
            pass

    probe = SimpleNamespace(scene=live.at_resolution(load_scene("fingers"), 200))
    monkeypatch.setattr(app, "display_problem", lambda show: None)
    monkeypatch.setattr(app, "Viewer", FakeViewer)
    monkeypatch.setattr(live, "probe", lambda *a: probe)
    for speed, grid, per_frame, given in (
        (16e6, 300, 17, None),
        (4e6, 200, 9, None),
        (4e6, 200, 3, 3),
    ):
        monkeypatch.setattr(live, "measure", lambda sim, s=speed: live.synthetic_calibration(s))
        argv = ["view", "fingers", "--offscreen"] + (
            ["--steps-per-frame", str(given)] if given else []
        )
        assert app.run_from_args(build_parser().parse_args(argv)) == 0
        v = made[-1]
        assert v.overrides[-1] == f"domain.resolution={grid}"
        assert v.steps_per_frame == per_frame
        assert v.sim_given is (probe if grid == 200 else None)
        assert v.message.startswith(f"live grid {grid} cells/m")
        assert f"viewer: {grid} cells/m" in capsys.readouterr().out
    argv = ["view", "fingers", "--offscreen", "--set", "domain.resolution=60"]
    assert app.run_from_args(build_parser().parse_args(argv)) == 0
    assert made[-1].steps_per_frame == 1 and made[-1].overrides == ["domain.resolution=60"]
    assert made[-1].message == "" and "cells/m" not in capsys.readouterr().out
