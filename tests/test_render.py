"""Off-screen pictures: colours, orientation, shading, colour bars, captions, movies, CLI.

Everything here runs without Vulkan or a display (colour kernel -> NumPy -> imageio).
"""

import json

import numpy as np
import pytest

from tiseg.post.render import colours as C

H_MIN = 1e-4


def u8(rgb):
    return C.to_uint8(rgb).astype(int)


def close(a, b, tol=1):
    return np.all(np.abs(np.asarray(a, dtype=int) - np.asarray(b, dtype=int)) <= tol)


@pytest.fixture
def strips():
    """ny x nx = 4 x 8: columns 0-1 phi = 1, 2-3 phi = 0.5, 4-5 phi = 0, 6-7 empty chute."""
    ny, nx = 4, 8
    h = np.full((ny, nx), 2e-3)
    h[:, 6:] = 0.0
    phi = np.zeros((ny, nx))
    phi[:, 0:2] = 1.0
    phi[:, 2:4] = 0.5
    return {"h": h, "phi": phi, "u": np.full((ny, nx), 0.2), "v": np.zeros((ny, nx))}


def test_known_colours_and_size(ti_cpu, strips):
    from tiseg.post.render import render_fields

    img = render_fields(strips, H_MIN, field="phi", shade=False, scale=3)
    assert img.dtype == np.uint8 and img.shape == (4 * 3, 8 * 3, 3)
    row = img[5]
    assert close(row[0 * 3 + 1], u8(C.FINES_RGB))  # phi = 1: white
    assert close(row[2 * 3 + 1], u8(0.5 * (np.array(C.FINES_RGB) + C.COARSE_RGB)))  # blend
    assert close(row[4 * 3 + 1], u8(C.COARSE_RGB))  # phi = 0: brown
    assert close(row[6 * 3 + 1], u8(C.CHUTE_RGB), 0)  # empty: turquoise
    # the constants are what the docs say: white-ish, brown, turquoise
    assert min(u8(C.FINES_RGB)) > 225
    r, g, b = u8(C.COARSE_RGB)
    assert r > g > b
    r, g, b = u8(C.CHUTE_RGB)
    assert g > r and b > r
    # scale keeps square blocks: every pixel of a cell's 3 x 3 block is the same
    assert (img[0:3, 0:3] == img[0, 0]).all()


def test_thin_film_below_h_min_is_turquoise(ti_cpu, strips):
    from tiseg.post.render import render_fields

    f = dict(strips)
    f["h"] = strips["h"].copy()
    f["h"][:, 0] = 0.99 * H_MIN  # a film thinner than h_min counts as empty chute
    img = render_fields(f, H_MIN, shade=True)
    assert close(img[0, 0], u8(C.CHUTE_RGB), 0)


def test_orientation_x_right_y_up(ti_cpu):
    """Figure 12's orientation: x downslope to the right, y up (row 0 is y = Ly)."""
    from tiseg.post.render import render_fields

    ny, nx = 3, 5
    h = np.full((ny, nx), 2e-3)
    phi = np.zeros((ny, nx))
    phi[ny - 1, nx - 1] = 1.0  # the cell at the largest x and y
    img = render_fields({"h": h, "phi": phi}, H_MIN, shade=False)
    assert close(img[0, nx - 1], u8(C.FINES_RGB))  # top right
    assert close(img[ny - 1, 0], u8(C.COARSE_RGB))  # bottom left


def test_shading_changes_brightness_only_where_h_varies(ti_cpu):
    from tiseg.post.render import render_fields

    ny, nx = 20, 30
    h = np.full((ny, nx), 2e-3)
    h[:, 24:] = 0.0  # empty chute on the right
    y, x = np.mgrid[0:ny, 0:nx]
    h += 1e-3 * np.exp(-((x - 8) ** 2 + (y - 10) ** 2) / 4.0) * (x < 20)  # a bump
    f = {"h": h, "phi": np.full((ny, nx), 0.4)}
    flat = render_fields(f, H_MIN, shade=False, dx=1e-3)
    shaded = render_fields(f, H_MIN, shade=True, dx=1e-3)
    diff = np.abs(shaded.astype(int) - flat).max(axis=2)
    # far from the bump and the front the thickness is uniform: identical colours
    assert (diff[:, 15:22] == 0).all()
    assert (diff[0:2, 0:4] == 0).all()
    # the empty chute is never shaded
    assert (diff[:, 24:] == 0).all()
    # on the bump the brightness changes: the lit side (upper left) brighter, the other darker
    bump = diff[6:15, 4:13]
    assert bump.max() > 10
    lum_flat, lum_shaded = flat.sum(axis=2).astype(int), shaded.sum(axis=2).astype(int)
    assert lum_shaded[8, 6] > lum_flat[8, 6]  # faces the light (up-left of the peak)
    assert lum_shaded[12, 10] < lum_flat[12, 10]  # faces away
    # shading scales the colour, it does not change the hue: channel ratios stay put (darkening)
    dark = shaded[12, 10].astype(float)
    base = flat[12, 10].astype(float)
    assert np.allclose(dark / dark.sum(), base / base.sum(), atol=0.02)


@pytest.mark.parametrize("field", ["h", "speed", "|u|", "u", "v"])
def test_mapped_fields_have_a_colourbar(ti_cpu, strips, field):
    from tiseg.post.render import render_fields

    phi_img = render_fields(strips, H_MIN, field="phi", scale=10)
    img = render_fields(strips, H_MIN, field=field, scale=10)
    assert img.shape[0] == phi_img.shape[0]
    assert img.shape[1] > phi_img.shape[1] + 40  # the bar strip on the right
    # the bar shows the viridis table: yellow at the top, dark violet at the bottom
    bar = img[:, phi_img.shape[1] + 6 : phi_img.shape[1] + 18]
    col = bar[:, bar.shape[1] // 2].astype(int)
    rows = np.nonzero(col.max(axis=1) - col.min(axis=1) > 30)[0]  # coloured, not text
    top, bottom = col[rows[0]], col[rows[-1]]
    assert close(top, u8(C.viridis_table()[-1]), 20)  # half a row from the end
    assert close(bottom, u8(C.viridis_table()[0]), 20)
    # empty cells are grey in the maps (viridis has teal shades)
    assert close(img[5, 65], u8(C.EMPTY_MAP_RGB), 0)


def test_h_map_values(ti_cpu, strips):
    from tiseg.post.render import render_fields

    f = dict(strips)
    f["h"] = strips["h"].copy()
    f["h"][:, 0] = 4e-3
    img = render_fields(f, H_MIN, field="h", shade=False, vrange=(0.0, 4e-3), colourbar=False)
    assert img.shape == (4, 8, 3)
    assert close(img[0, 0], u8(C.viridis_table()[-1]))  # h = vmax
    assert close(img[0, 1], u8(C.map_values(0.5)))  # h = vmax / 2
    with pytest.raises(ValueError):
        render_fields({"h": f["h"]}, H_MIN, field="phi")  # no phi array
    with pytest.raises(ValueError):
        render_fields(f, H_MIN, field="vorticity")


def test_annotate_adds_caption_strip(ti_cpu, strips):
    from tiseg.post.render import annotate, render_fields

    img = render_fields(strips, H_MIN, scale=60)  # 480 x 240
    out = annotate(img, 1.9, dx=1e-3 / 60)
    assert out.shape == (img.shape[0] + 20, img.shape[1], 3)
    assert (out[: img.shape[0]] == img).all()  # the map is untouched
    strip = out[img.shape[0] :].astype(int)
    bright = np.abs(strip - u8(C.BACKGROUND_RGB)).max(axis=2) > 100
    assert bright[:, :80].sum() > 30  # "t = 1.90 s" text
    assert bright[:, -120:].sum() > 30  # scale bar and its label


def test_nice_scale_bar_lengths():
    from tiseg.post.render.frame import format_length, nice_length

    assert nice_length(0.3) == 0.2 and nice_length(0.07) == pytest.approx(0.05)
    assert nice_length(1.0) == 1.0
    assert format_length(0.1) == "10 cm" and format_length(0.005) == "5 mm"
    assert format_length(2.0) == "2 m"


# ------------------------------------------------------------------------------- simulations
@pytest.fixture(scope="module")
def tiny(ti_cpu, tmp_path_factory):
    """The brief's tiny run (fingers at 40 cells per metre to t = 0.4 s, snapshots every 0.2 s),
    kept as a simulation too (one build shared by the tests: each build compiles kernels)."""
    from tiseg.run.simulation import Simulation

    out = tmp_path_factory.mktemp("tiny_run")
    sim = Simulation.from_scene(
        "fingers",
        {"domain.resolution": 40, "time.t_end": 0.4, "output.times": [], "output.interval": 0.2},
    )
    sim.run(out_dir=out, progress=False)
    return sim, out


@pytest.fixture(scope="module")
def tiny_run(tiny):
    return tiny[1]


@pytest.mark.slow  # a long run: the slow set (README), which CI runs after the suite
def test_frame_renderer_matches_render_fields(tiny):
    """Rendering from the Taichi state in place gives the same picture as the NumPy path."""
    from tiseg.post.render import FrameRenderer, render_fields

    sim = tiny[0]
    fr = FrameRenderer(sim, scale=2)
    for field in ("phi", "h", "speed", "u", "v"):
        fr.set_field(field)
        a = fr.to_numpy()
        b = render_fields(
            sim.fields(),
            sim.scene.numerics.h_min,
            field=field,
            scale=2,
            dx=sim.scene.dx,
            vrange=fr.vrange,
        )
        assert a.shape == b.shape
        assert np.abs(a.astype(int) - b).max() <= 1, field
    # something flows in and something is still empty
    fr.set_field("phi")
    img = fr.to_numpy(annotate_frame=True)
    assert img.shape == (fr.height + 20, fr.width, 3)
    assert (np.abs(img[: fr.height].astype(int) - u8(C.CHUTE_RGB)).max(axis=2) == 0).any()
    assert (np.abs(img[: fr.height].astype(int) - u8(C.CHUTE_RGB)).max(axis=2) > 20).any()


def _decode(path):
    import imageio.v2 as iio2

    reader = iio2.get_reader(str(path))
    try:
        return [np.asarray(f) for f in reader]
    finally:
        reader.close()


def test_movie_writer_pads_to_even_and_decodes(tmp_path):
    from tiseg.post.render.movie import FrameFolderWriter, MovieWriter

    rng = np.random.default_rng(0)
    frames = [np.full((21, 33, 3), 40 * k, dtype=np.uint8) for k in range(4)]
    frames[1] = rng.integers(0, 255, (21, 33, 3), dtype=np.uint8)
    with MovieWriter(tmp_path / "m.mp4", fps=5) as w:
        for f in frames:
            w.append(f)
    got = _decode(tmp_path / "m.mp4")
    assert len(got) == 4 and got[0].shape == (22, 34, 3)
    assert np.abs(got[3][:21, :33].astype(int) - 120).max() <= 6  # lossy but close
    with MovieWriter(tmp_path / "m.gif", fps=5) as w:
        for f in frames:
            w.append(f)
    import imageio.v3 as iio

    gif = iio.imread(tmp_path / "m.gif", index=None)
    assert gif.shape[:3] == (4, 21, 33)
    with FrameFolderWriter(tmp_path / "frames") as w:
        for f in frames:
            w.append(f)
    pngs = sorted((tmp_path / "frames").glob("frame_*.png"))
    assert len(pngs) == 4
    assert (iio.imread(pngs[1])[:, :, :3] == frames[1]).all()  # PNG is lossless


def test_render_run_outputs(tiny_run, tmp_path):
    from tiseg.post.render import render_run

    res = render_run(
        tiny_run,
        movie=tmp_path / "phi.mp4",
        gif=tmp_path / "phi.gif",
        frames=tmp_path / "png",
        fps=4,
    )
    assert res["frames"] == 3
    H, W = res["size"]
    got = _decode(tmp_path / "phi.mp4")
    assert len(got) == 3 and got[0].shape == (H + H % 2, W + W % 2, 3)
    assert len(list((tmp_path / "png").glob("*.png"))) == 3
    res = render_run(tiny_run, field="h", movie=tmp_path / "h.mp4", max_frames=2, scale=2)
    assert res["frames"] == 2 and res["vrange"][1] > 0


def test_cli_render(tiny_run, tmp_path, capsys):
    from tiseg.apps.cli import main

    rc = main(
        [
            "render",
            str(tiny_run),
            "--field",
            "|u|",
            "--movie",
            str(tmp_path / "u.mp4"),
            "--gif",
            str(tmp_path / "u.gif"),
            "--frames",
            str(tmp_path / "fr"),
            "--fps",
            "3",
            "--no-shade",
            "--panels",
            str(tmp_path / "panels.png"),
            "--times",
            "0.2",
            "0.4",
            "--json",
        ]
    )
    out, err = capsys.readouterr()
    assert rc == 0, err
    o = json.loads(out)
    assert o["frames"] == 3 and o["field"] == "speed"
    for name in ("u.mp4", "u.gif", "panels.png"):
        assert (tmp_path / name).stat().st_size > 0
    assert len(_decode(tmp_path / "u.mp4")) == 3
    # user mistakes: one line, exit status 2
    assert main(["render", str(tmp_path / "nowhere"), "--movie", str(tmp_path / "x.mp4")]) == 2
    assert main(["render", str(tiny_run), "--field", "vorticity"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 2 and "Traceback" not in err


def test_plot_panels(tiny_run, tmp_path):
    from tiseg.post.render import plot_panels

    fig = plot_panels(tiny_run, [0.2, 0.4], "phi", tmp_path / "fig12.png")
    assert len([a for a in fig.axes if a.get_title()]) == 2
    assert [a.get_title() for a in fig.axes if a.get_title()] == ["t = 0.20 s", "t = 0.40 s"]
    assert (tmp_path / "fig12.png").stat().st_size > 1000


@pytest.mark.slow  # a long run: the slow set (README), which CI runs after the suite
def test_cli_run_movie(ti_cpu, tmp_path, capsys):
    from tiseg.apps.cli import main

    movie = tmp_path / "run.mp4"
    from tiseg import backend

    rc = main(
        [
            "run",
            "fingers",
            "--set",
            "domain.resolution=40",
            "--set",
            "time.t_end=0.3",
            "--set",
            "output.times=[]",
            "--set",
            "output.interval=0.1",
            "--arch",
            backend.requested_arch(backend.state().arch),  # the tests' backend
            "--out",
            str(tmp_path / "out"),
            "--no-progress",
            "--movie",
            str(movie),
            "--json",
        ]
    )
    out, err = capsys.readouterr()
    assert rc == 0, err
    o = json.loads(out)
    assert o["movie_frames"] == 4  # t = 0, 0.1, 0.2, 0.3
    frames = _decode(movie)
    assert len(frames) == 4
    assert frames[0].shape[1] % 2 == 0 and frames[0].shape[0] % 2 == 0
    # more than a pixel per cell: the map is at least 600 pixels wide, whole pixels per cell
    from tiseg.setup.scene import load_scene

    d = load_scene("fingers", ["domain.resolution=40"]).domain
    per_cell = -(-600 // d.nx)
    assert per_cell > 1
    map_w = d.nx * per_cell
    H, W = frames[0].shape[:2]
    assert W == map_w + 70 + (map_w + 70) % 2  # the map and a colour bar 70 pixels wide
    assert H - 20 in (d.ny * per_cell, d.ny * per_cell + 1)  # and the caption strip
    # the colour bar: phi's ramp, fines (white) at the top, coarse (brown) at the bottom
    ramp = frames[-1][:, map_w + 9 : map_w + 15].astype(int).mean(axis=1)
    coloured = np.abs(ramp - u8(C.BACKGROUND_RGB)).max(axis=1) > 30
    runs = np.split(np.arange(H), np.nonzero(np.diff(coloured))[0] + 1)
    bar = max((r for r in runs if coloured[r[0]]), key=len)  # the bar, not the φ above it
    assert len(bar) > 0.7 * (H - 20)
    assert close(ramp[bar[2]], u8(C.FINES_RGB), 25)
    assert close(ramp[bar[-3]], u8(C.COARSE_RGB), 25)


def test_text_is_drawn_where_asked_with_pillow():
    """Caption text (Pillow, DejaVu Sans): ink only inside the box the text should occupy,
    left end at x, on the baseline (caps above it, at most descenders below), in the colour
    asked for; widths add up."""
    import numpy as np

    from tiseg.post.render.frame import draw_text, text_width

    img = np.zeros((60, 200, 3), np.uint8)
    end = draw_text(img, "t = 7.50 s", 20, 40, colour=(1.0, 1.0, 1.0), size=14)
    ink = np.nonzero(img.max(axis=2) > 60)
    assert ink[0].size > 50
    assert ink[1].min() >= 20 and ink[1].max() <= end + 1
    assert ink[0].min() >= 40 - 14 and ink[0].max() <= 40 + 4
    assert end - 20 == text_width("t = 7.50 s", 14) > text_width("t = 7.5", 14) > 0
    assert img.max() == 255 and (img[..., 0] == img[..., 2]).all()  # white, no tint


def test_the_painter_cache_does_not_hold_the_runtime(ti_cpu):
    """render_fields keeps a painter per grid size and runtime; that cache rebuilds itself
    after a Taichi reset, so it must not count as holding fields: it kept every later test
    and command in the process from a fresh runtime (and so from the kernel cache)."""
    from tiseg.post.render.frame import render_fields
    from tiseg.solver import field_tree

    before = field_tree.live()
    h = np.full((6, 9), 2e-3)
    img = render_fields({"h": h, "phi": np.full_like(h, 0.5)}, h_min=1e-4)
    assert img.ndim == 3 and img.shape[2] == 3
    assert field_tree.live() == before
