"""The GGUI viewer: clear refusal without display/Vulkan, headless frames equal to the off-screen
renderer's, controls, and a live window under Xvfb.

GGUI needs Vulkan. Where software Vulkan (mesa-vulkan-drivers + libvulkan1) or Xvfb is missing
the tests that need them are skipped; the CI script installs both, so there they run.
"""

import math
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from solver_helpers import child_env

from tiseg.apps.viewer.app import display_problem, vulkan_problem

ROOT = Path(__file__).resolve().parents[1]
TINY = {"domain.resolution": 40, "time.t_end": 1.0, "output.times": []}
TINY_ARGS = ["--set", "domain.resolution=40", "--set", "time.t_end=0.6", "--set", "output.times=[]"]

VULKAN = vulkan_problem()
needs_vulkan = pytest.mark.skipif(VULKAN is not None, reason=f"no Vulkan: {VULKAN}")


def test_no_display_one_line_exit_2(monkeypatch, capsys):
    """Without a display: one line naming the off-screen path, exit status 2, no traceback."""
    from tiseg.apps.cli import main

    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    assert display_problem(True) == "no display (DISPLAY is not set)"
    assert main(["view", "fingers"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "DISPLAY" in err and "tiseg run SCENE --movie" in err
    # the module entry point, in a fresh process
    env = child_env()
    env.pop("DISPLAY", None)
    env.pop("WAYLAND_DISPLAY", None)
    # the package's module anywhere, and the source checkout's `python -m viewer` alias
    for module, cwd in (("tiseg.apps.viewer", ROOT / "tests"), ("viewer", ROOT)):
        p = subprocess.run(
            [sys.executable, "-m", module, "fingers"],
            cwd=cwd,
            env=env,
            capture_output=True,
            text=True,
            timeout=60,
        )
        assert p.returncode == 2, (module, p.stderr)
        assert p.stderr.count("\n") == 1 and "Traceback" not in p.stderr
        assert "tiseg render" in p.stderr


def test_no_vulkan_one_line_exit_2(monkeypatch, capsys):
    """With a display but no Vulkan the viewer refuses before any window exists."""
    import tiseg.apps.viewer.app as app
    from tiseg.apps.cli import main

    monkeypatch.setenv("DISPLAY", ":97")
    monkeypatch.setattr(app, "_x_display_opens", lambda name: True)
    monkeypatch.setattr(app, "vulkan_problem", lambda: "no Vulkan loader (libvulkan.so.1)")
    assert main(["view", "fingers"] + TINY_ARGS) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Vulkan" in err and "--movie" in err


# a release upstream of a gaussian bump and a post (solid cells), on the empty chute at t = 0
RELIEF_SCENE = {
    "domain": {"Lx": 0.3, "Ly": 0.15, "resolution": 200},
    "boundary": {"x_lo": "wall", "x_hi": "outflow", "y_lo": "wall", "y_hi": "wall"},
    "initial": {"kind": "release", "x0": 0.02, "x1": 0.08, "y0": 0.04, "y1": 0.11, "h": 0.003},
    "time": {"t_end": 0.05},
    "output": {"times": []},
}
BUMP = {"kind": "gaussian", "x": 0.18, "y": 0.075, "radius": 0.02, "height": 0.004}
POST = {"kind": "cylinder", "x": 0.25, "y": 0.035, "radius": 0.012}


def relief_scene(shapes):
    from tiseg.setup.reading import scene_from_dict

    terrain = {"terrain": {"shapes": shapes}} if shapes else {}
    return scene_from_dict({**RELIEF_SCENE, **terrain}, name="bump")


def test_frames_shade_the_relief_under_the_colours(ti_cpu):
    """The viewer's map (the frame kernel of FrameRenderer, painted straight from the state;
    no window needed) over a gaussian bump: changed where the bump's slope faces towards or
    away from the light, unchanged where the bed is flat, the post's cells in the walls'
    colour; the same picture as the off-screen renderer draws from fields.nc. A flat scene's
    renderer holds no bed at all."""
    from tiseg.post.render import FrameRenderer, render_fields
    from tiseg.post.render import colours as C
    from tiseg.post.render.relief import SOLID_RGB
    from tiseg.run.simulation import Simulation

    maps = {}
    for name, shapes in (("flat", []), ("bump", [BUMP, POST])):
        sim = Simulation(relief_scene(shapes))
        r = FrameRenderer(sim, field="phi", scale=2)
        assert r.painter.has_bed == bool(shapes) and hasattr(r.painter, "bed") == bool(shapes)
        maps[name] = r.to_numpy(colourbar=False)
        r.shade = 0.0  # the viewer's "relief shading" box off: the walls stay
        maps[name, "plain"] = r.to_numpy(colourbar=False)
        r.shade = 0.35
        if shapes:
            b, solid = sim.scene.bed_arrays()  # (nx, ny)
            ref = render_fields(
                {**sim.fields(), "b": b.T, "solid": solid.T},
                sim.scene.numerics.h_min,
                scale=2,
                dx=sim.scene.dx,
                dy=sim.scene.dy,
            )
            assert np.abs(r.to_numpy(colourbar=False).astype(int) - ref.astype(int)).max() <= 1
    a, c = maps["flat"], maps["bump"]
    assert a.shape == c.shape
    per_cell = lambda img: img[::-1].transpose(1, 0, 2)[::2, ::2]  # noqa: E731  (nx, ny, 3)
    diff = np.any(per_cell(c) != per_cell(a), axis=2)
    # the bed's slope towards the light (the upper left of the picture), per cell
    sc = relief_scene([BUMP])
    gx, gy = np.gradient(sc.bed_arrays()[0], sc.dx, sc.dy)
    towards_light = (-gx + gy) / math.sqrt(2.0)
    x, y = sc.domain.cell_centres()

    def distance(shape):  # of each cell's centre from a shape's, (nx, ny)
        return np.hypot(*np.meshgrid(x - shape["x"], y - shape["y"], indexing="ij"))

    steep = np.abs(towards_light) > 0.02
    assert steep.sum() > 20 and diff[steep].all()
    flat = (distance(BUMP) > 5 * BUMP["radius"]) & (distance(POST) > 2 * POST["radius"])
    assert flat.sum() > 0.3 * flat.size and not diff[flat].any()
    walls = relief_scene([POST]).bed_arrays()[1]
    assert walls.sum() >= 9
    assert (per_cell(c)[walls] == C.to_uint8(SOLID_RGB)).all()
    assert not (per_cell(a)[walls] == C.to_uint8(SOLID_RGB)).all(axis=-1).any()
    # without shading only the walls differ from the flat picture
    plain = [per_cell(maps[name, "plain"]) for name in ("flat", "bump")]
    assert np.array_equal(np.any(plain[0] != plain[1], axis=2), walls)


@needs_vulkan
def test_the_window_shows_the_relief(ti_cpu, tmp_path):
    """The live window draws the map of the test above: relief and walls as the off-screen
    renderer draws them, and the "relief shading" setting turns the hill-shading off."""
    from tiseg.post.render import render_fields
    from tiseg.apps.viewer.app import Viewer

    v = Viewer(relief_scene([BUMP, POST]), show_window=False, save_dir=tmp_path)
    try:
        v.paused = True
        sim = v.sim
        b, solid = sim.scene.bed_arrays()
        shown = {}
        for shade in (0.35, 0.0):
            v.renderer.shade = shade
            v.run_frames(1)
            got = v.capture_map().astype(int)
            ref = render_fields(
                {**sim.fields(), "b": b.T, "solid": solid.T},
                sim.scene.numerics.h_min,
                shade=shade,
                scale=v.renderer.scale,
                dx=sim.scene.dx,
                dy=sim.scene.dy,
            )
            assert got.shape == ref.shape
            # GGUI quantises floats itself: allow a few levels
            assert (np.abs(got - ref).max(axis=2) <= 3).mean() > 0.99, shade
            shown[shade] = got
        assert np.abs(shown[0.35] - shown[0.0]).max() > 20  # the bump's slopes
    finally:
        v.close()


@needs_vulkan
def test_headless_window_matches_offscreen_frames(ti_cpu, tmp_path):
    import imageio.v2 as iio2

    from tiseg.model.physics.pointwise import Params, slot_bases
    from tiseg.post.render import colours as C
    from tiseg.post.render import render_fields
    from tiseg.apps.viewer.app import Viewer

    v = Viewer("fingers", TINY, show_window=False, save_dir=tmp_path)
    try:
        v.run_frames(4)
        assert v.sim.t > 0 and v.frames == 4
        cap = v.capture()
        assert cap.shape == (v.height, v.width, 3)
        sim = v.sim
        for field in ("phi", "h"):
            if field != "phi":
                v.set_field(field)
                v.paused = True
                v.run_frames(1)
            got = v.capture_map().astype(int)
            ref = render_fields(
                sim.fields(),
                sim.scene.numerics.h_min,
                field=field,
                scale=v.renderer.scale,
                dx=sim.scene.dx,
                vrange=v.renderer.vrange,
                colourbar=False,
            )
            assert got.shape == ref.shape
            # GGUI quantises floats itself: allow a few levels, require nearly all pixels
            assert (np.abs(got - ref).max(axis=2) <= 3).mean() > 0.95, field
            assert np.abs(got.reshape(-1, 3).mean(0) - ref.reshape(-1, 3).mean(0)).max() < 2
        # the colour bar beside the map shows the viridis table for h
        bar = v.capture()[: v.map_h, v.map_w + 12 + 8].astype(int)
        rows = np.nonzero(bar.max(axis=1) - bar.min(axis=1) > 30)[0]
        assert abs(bar[rows[0]] - C.to_uint8(C.viridis_table()[-1])).max() < 25

        # pause, single step, reset
        t = sim.t
        v.run_frames(2)
        assert sim.t == t
        steps = sim.stats.steps
        v.step(1)
        assert sim.stats.steps == steps + 1
        v.reset()
        assert sim.t == 0.0

        # run-time parameters, no recompilation: nu, slope (g cos, g sin) and inflow
        v.set_params(nu=0.02, zeta=math.radians(30.0), inflow_h=0.003)
        par = sim.op.par.to_numpy()[0]
        assert par[slot_bases(sim.op.cfg)["viscosity"]] == pytest.approx(0.02)
        assert par[Params.G_SIN] == pytest.approx(sim.op.cfg.g * math.sin(math.radians(30)))
        assert par[Params.G_COS] == pytest.approx(sim.op.cfg.g * math.cos(math.radians(30)))
        v.paused = False
        v.run_frames(1)
        assert sim.op.par[0, Params.IN_H] > 0
        assert sim.op.cfg.inflow_h == 0.003

        # screenshot and recording
        png = v.screenshot()
        assert png.is_file() and png.suffix == ".png"
        # recording is a callback of the simulation: a frame per steps_per_frame steps,
        # none while paused
        rec = v.start_recording(tmp_path / "rec.mp4", fps=5)
        v.paused = True
        v.run_frames(2)
        v.paused = False
        v.steps_per_frame = 1
        v.run_frames(3)
        v.stop_recording()
        r = iio2.get_reader(str(rec))
        frames = [f for f in r]
        r.close()
        assert len(frames) == 3
    finally:
        v.close()


@needs_vulkan
def test_window_shows_the_captions(ti_cpu, tmp_path):
    """The colour bar column, the caption strip (time stamp, scale bar, the whole status line,
    the keys' hint) and the help box are in the window as tiseg.apps.viewer.captions draws them."""
    from tiseg.apps.viewer import captions as cap
    from tiseg.apps.viewer.app import Viewer

    v = Viewer("fingers", TINY, show_window=False, save_dir=tmp_path)
    try:
        v.set_field("h")
        v.run_frames(3)
        top = v.height - (v.map_y0 + v.map_h)  # the map's top row in the picture

        def close(got, ref):  # GGUI quantises floats itself: a few levels
            return (np.abs(got.astype(int) - ref.astype(int)).max(axis=2) <= 3).mean() > 0.99

        img = v.capture()
        bar = cap.colour_bar_column("h", *v.renderer.vrange, v.map_h)
        assert close(img[top : top + v.map_h, v.map_w : v.map_w + v.BAR_W], bar)
        strip = img[top + v.map_h : top + v.map_h + v.STRIP_H]
        texts = v.caption_texts()
        assert texts["stamp"].startswith(f"t = {v.sim.t:.2f} s of 1 s")
        assert texts["bar"] is not None and texts["hint"] == cap.hint_line()
        assert close(strip, cap.caption_strip(v.width, v.map_w, **texts, height=v.STRIP_H))

        # a status line longer than the window is wrapped, not cut
        v.message = "saved " + "/a-long-folder-name" * 12 + "/tiseg-fingers-h-t000.123.png"
        v.paused = True
        v.run_frames(1)
        lines = cap.wrap_text(v.message, v.width - 12, cap.text_width)
        assert 2 <= len(lines) <= cap.STATUS_LINES and "".join(lines) == v.message
        img = v.capture()
        strip = img[top + v.map_h : top + v.map_h + v.STRIP_H]
        texts = v.caption_texts()
        assert texts["status"] == v.message and "paused" in texts["stamp"]
        assert close(strip, cap.caption_strip(v.width, v.map_w, **texts, height=v.STRIP_H))

        # h: the keys' box over the map's top left, blended with the map; again: gone
        box = cap.help_box()
        bh, bw = box.shape[:2]
        plain = img[8 : 8 + bh, 8 : 8 + bw].astype(float)
        v.toggle_help()
        v.run_frames(1)
        got = v.capture()[8 : 8 + bh, 8 : 8 + bw].astype(float)
        assert np.abs(got - (0.9 * box + 0.1 * plain)).max() <= 4
        v.toggle_help()
        v.run_frames(1)
        assert np.abs(v.capture()[8 : 8 + bh, 8 : 8 + bw] - plain).max() <= 3

        # f: every field of the run in turn, back to the first
        names = v.available_fields()
        assert names == ["phi", "h", "speed", "u", "v"]
        seen = [v.next_field() for _ in names]
        assert seen == names[2:] + names[:2]
    finally:
        v.close()


@needs_vulkan
@pytest.mark.skipif(shutil.which("xvfb-run") is None, reason="xvfb-run is not installed")
def test_live_window_under_xvfb(tmp_path):
    """A real window on a virtual X display starts, steps, records and closes by itself."""
    rec = tmp_path / "live.mp4"
    cmd = [
        "xvfb-run",
        "-a",
        "-s",
        "-screen 0 1280x1024x24",
        sys.executable,
        "-m",
        "tiseg.apps.viewer",
        "fingers",
        *TINY_ARGS,
        "--frames",
        "5",
        "--record",
        str(rec),
        "--save-dir",
        str(tmp_path),
    ]
    p = subprocess.run(cmd, cwd=ROOT, env=child_env(), capture_output=True, text=True, timeout=180)
    assert p.returncode == 0, p.stderr[-2000:]
    assert "viewer: 5 frames" in p.stdout
    import imageio.v2 as iio2

    r = iio2.get_reader(str(rec))
    n = sum(1 for _ in r)
    r.close()
    assert n == 5
