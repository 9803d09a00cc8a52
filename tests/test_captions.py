"""The live viewer's captions without a window: round colour-bar ticks, a 1-2-5 scale bar of
the right size, the time stamp, status wrapping that keeps every character, the keys, and the
caption pictures drawn from them."""

import inspect
import math
import random

import numpy as np
import pytest

from tiseg.post.render import colours as C
from tiseg.apps.viewer import captions as cap


def _mantissa(x: float) -> float:
    return round(x / 10.0 ** math.floor(math.log10(x) + 1e-9), 6)


# ------------------------------------------------------------------ ticks
@pytest.mark.parametrize(
    "lo, hi, n, expected",
    [
        (0.0, 1.0, 6, [0.0, 0.2, 0.4, 0.6, 0.8, 1.0]),  # step 1/5 = 0.2 exactly
        (0.0, 7.5, 8, [0.0, 2.0, 4.0, 6.0]),  # 7.5/7 = 1.07 -> step 2
        (-0.034, 0.034, 6, [-0.02, 0.0, 0.02]),  # 0.068/5 = 0.0136 -> step 0.02
        (0.13, 0.57, 5, [0.2, 0.4]),  # 0.44/4 = 0.11 -> step 0.2
    ],
)
def test_nice_ticks_by_hand(lo, hi, n, expected):
    assert cap.nice_ticks(lo, hi, n) == pytest.approx(expected, abs=1e-12)


def test_nice_ticks_inside_round_and_few():
    rng = random.Random(7)
    for _ in range(2000):
        scale = 10.0 ** rng.uniform(-5, 4)
        lo = rng.uniform(-1, 1) * scale
        hi = lo + rng.uniform(1e-3, 3) * scale
        n = rng.randint(3, 9)
        ticks = cap.nice_ticks(lo, hi, n)
        span = hi - lo
        # at most n; two ticks may need up to five when n is below five
        assert 2 <= len(ticks) <= max(n, 5), (lo, hi, n, ticks)
        if len(ticks) > n:
            step = ticks[1] - ticks[0]
            coarser = step * {1.0: 2.0, 2.0: 2.5, 5.0: 2.0}[_mantissa(step)]
            assert math.floor(hi / coarser) - math.ceil(lo / coarser) < 1, ticks  # < 2 ticks
        assert all(lo - 1e-9 * span <= t <= hi + 1e-9 * span for t in ticks), (lo, hi, ticks)
        steps = np.diff(ticks)
        step = steps[0]
        assert np.allclose(steps, step, rtol=1e-6), ticks
        assert _mantissa(step) in (1.0, 2.0, 5.0), (step, ticks)
        # round: every tick a whole number of steps
        k = np.asarray(ticks) / step
        assert np.allclose(k, np.round(k), atol=1e-6), ticks
        # no more than one step left unused at either end
        assert ticks[0] - lo < step * (1 + 1e-9) and hi - ticks[-1] < step * (1 + 1e-9)


def test_nice_ticks_edge_cases():
    assert cap.nice_ticks(3.0, 3.0) == [3.0]
    assert cap.nice_ticks(0.0, math.inf) == []
    assert cap.nice_ticks(1.0, 0.0, 6) == cap.nice_ticks(0.0, 1.0, 6)
    with pytest.raises(ValueError):
        cap.nice_ticks(0.0, 1.0, 2)
    assert all(math.copysign(1, t) > 0 for t in cap.nice_ticks(-1.0, 1.0) if t == 0)


def test_tick_labels():
    assert cap.tick_labels([0.0, 0.2, 0.4, 0.6, 0.8, 1.0]) == [
        "0.0",
        "0.2",
        "0.4",
        "0.6",
        "0.8",
        "1.0",
    ]
    assert cap.tick_labels([0.0, 2.0, 4.0]) == ["0", "2", "4"]
    assert cap.tick_labels([-0.02, -0.0, 0.02]) == ["-0.02", "0.00", "0.02"]
    assert cap.tick_labels([100.0, 200.0]) == ["100", "200"]


def test_colour_bar_ticks_in_display_units():
    # h from 0 to 5 mm on a 300-pixel bar: about one tick per 36 pixels -> at most 8 ticks,
    # 5/7 = 0.71 -> steps of 1 mm
    ticks = cap.colour_bar_ticks("h", 0.0, 0.005, 300)
    assert [s for _, s in ticks] == ["0", "1", "2", "3", "4", "5"]
    assert [f for f, _ in ticks] == pytest.approx([0.0, 0.2, 0.4, 0.6, 0.8, 1.0])
    # a short bar gets fewer ticks
    assert len(cap.colour_bar_ticks("h", 0.0, 0.005, 60)) < len(ticks)
    assert cap.field_title("h") == "thickness h [mm]"
    assert cap.field_title("|u|") == "speed |u| [m/s]"
    assert cap.field_title("phi") == "concentration φ"


# ------------------------------------------------------------------ scale bar, time stamp
def test_scale_bar_is_125_between_the_fractions():
    rng = random.Random(3)
    for _ in range(2000):
        width = rng.randint(40, 3000)
        dx = 10.0 ** rng.uniform(-6, 0)
        lo, hi = (0.1, 0.25) if rng.random() < 0.5 else (0.05, 0.2)
        bar = cap.scale_bar(width, dx, lo, hi)
        frac = bar.metres / (width * dx)
        assert lo * (1 - 1e-9) <= frac <= hi * (1 + 1e-9), (width, dx, bar)
        assert _mantissa(bar.metres) in (1.0, 2.0, 5.0), bar
        assert abs(bar.pixels - bar.metres / dx) <= 0.5 + 1e-9
    # by hand: 900 pixels of 1/2250 m = 0.4 m; a quarter is 0.1 m exactly
    bar = cap.scale_bar(900, 1 / 2250)
    assert (bar.metres, bar.pixels, bar.label) == (0.1, 225, "10 cm")
    assert cap.scale_bar(3, 1e-3) is None  # a bar of under two pixels
    with pytest.raises(ValueError):
        cap.scale_bar(900, 1e-3, 0.1, 0.2)  # 1-2-5 steps need hi/lo >= 2.5


def test_format_length_and_time_stamp():
    assert [cap.format_length(x) for x in (2.0, 0.5, 0.05, 0.01, 0.005, 0.001)] == [
        "2 m",
        "50 cm",
        "5 cm",
        "1 cm",
        "5 mm",
        "1 mm",
    ]
    assert cap.time_text(1.234) == "t = 1.23 s"
    assert cap.time_text(0.5, 3.0) == "t = 0.50 s of 3 s"


# ------------------------------------------------------------------ status line
def test_wrap_keeps_every_character_and_fits():
    rng = random.Random(11)
    alphabet = "abcdefghij /._-"
    for _ in range(500):
        text = "".join(rng.choice(alphabet) for _ in range(rng.randint(0, 200)))
        width = rng.randint(1, 50)
        lines = cap.wrap_text(text, width)
        assert "".join(lines) == text
        assert all(len(ln.rstrip()) <= width for ln in lines), (text, width, lines)
        assert all(ln for ln in lines)


def test_wrap_breaks_at_spaces_and_slashes():
    msg = "saved /home/someone/runs/fingers/tiseg-fingers-phi-t001.250.png"
    lines = cap.wrap_text(msg, 30)
    assert "".join(lines) == msg
    assert lines[0] == "saved /home/someone/runs/"  # after a slash, not inside a word
    assert all(len(ln) <= 30 for ln in lines)
    # a newline ends a line; the measure can be pixels
    assert cap.wrap_text("ab\ncd", 10) == ["ab\n", "cd"]
    wide = cap.wrap_text("x " * 40, 100, width_of=lambda s: 10 * len(s))
    assert all(10 * len(ln.rstrip()) <= 100 for ln in wide) and "".join(wide) == "x " * 40
    with pytest.raises(ValueError):
        cap.wrap_text("abc", 0)


def test_fit_lines_marks_what_is_left_out():
    assert cap.fit_lines(["ab ", "cd"], 3) == ["ab", "cd"]
    assert cap.fit_lines(["ab ", "cd ", "ef"], 2) == ["ab", "c…"]


# ------------------------------------------------------------------ keys
def test_keys_are_handled_and_shown():
    from tiseg.apps.viewer.app import Viewer

    handler = inspect.getsource(Viewer._events)
    hint = cap.hint_line()
    lines = cap.help_lines()
    assert len(lines) == 1 + len(cap.KEYS)
    for key, what, word in cap.KEYS:
        if len(key) == 1:
            assert f'e.key == "{key}"' in handler, key
        assert f"{key} {word}" in hint
        assert any(ln.startswith(key) and ln.endswith(what) for ln in lines)
    assert "ti.ui.SPACE" in handler and "ti.ui.ESCAPE" in handler


# ------------------------------------------------------------------ pictures
def _bright(a):
    return (a.astype(int).sum(axis=-1) > 3 * 150).any()


def test_colour_bar_column_picture():
    h = 300
    img = cap.colour_bar_column("h", 0.0, 0.005, h)
    assert img.shape == (h, cap.BAR_W, 3) and img.dtype == np.uint8
    col = img[:, cap.BAR_X + cap.BAR_STRIP // 2].astype(int)
    top, bot = 8, h - 8
    # high values at the top: the ends of the viridis table
    assert np.abs(col[top] - C.to_uint8(C.viridis_table()[-1])).max() <= 3
    assert np.abs(col[bot - 1] - C.to_uint8(C.viridis_table()[0])).max() <= 3
    # a tick mark on each tick's row, in the text colour, right of the bar
    x1 = cap.BAR_X + cap.BAR_STRIP
    n = bot - top
    for frac, _ in cap.colour_bar_ticks("h", 0.0, 0.005, n):
        row = int(round(bot - 1 - frac * (n - 1)))
        assert (img[row, x1 : x1 + 4] == C.to_uint8(C.TEXT_RGB)).all(), frac
    # numbers right of the ticks, and the title along the right edge
    assert _bright(img[top:bot, x1 + 6 : x1 + 30])
    assert _bright(img[:, -18:])
    assert not _bright(img[:, x1 + 40 : cap.BAR_W - 20])  # nothing in between


def test_caption_strip_picture():
    width, map_w = 800, 700
    bar = cap.scale_bar(map_w, 1e-3)
    status = "saved " + "/very/long/folder" * 8 + "/tiseg-fingers-phi-t001.250.png"
    img = cap.caption_strip(width, map_w, "t = 1.25 s", bar, status, cap.hint_line())
    assert img.shape == (cap.STRIP_H, width, 3)
    white = C.to_uint8(C.TEXT_RGB)
    # the scale bar: a line of bar.pixels ending 6 pixels left of the map's right edge
    row = 8 + cap.SIZE - cap.SIZE // 3
    on = (img[row] == white).all(axis=1)
    end = int(np.nonzero(on)[0].max())
    start = end
    while on[start - 1]:
        start -= 1
    assert end == map_w - 7 and end - start + 1 == bar.pixels
    # the status takes the lines its wrap says, the hint the last one
    n = len(cap.wrap_text(status, width - 12, cap.text_width))
    assert n == 2
    base = 8 + cap.SIZE
    for k in range(1, cap.STATUS_LINES + 2):
        band = img[base + cap.LINE_H * k - cap.SIZE + 2 : base + cap.LINE_H * k]
        has_text = (band.astype(int).sum(axis=-1) > 3 * 90).any()
        assert has_text == (k <= n or k == cap.STATUS_LINES + 1), k


def test_help_box_lists_every_key():
    box = cap.help_box()
    assert box.shape[0] == cap.LINE_H * (1 + len(cap.KEYS)) + 12
    for k in range(1 + len(cap.KEYS)):
        base = 6 + cap.SIZE + cap.LINE_H * k
        assert _bright(box[base - cap.SIZE + 2 : base, 2:-2]), k


def test_viewer_page_lists_every_key():
    from pathlib import Path

    page = (Path(__file__).resolve().parents[1] / "docs" / "viewer.md").read_text()
    for key, _, _ in cap.KEYS:
        assert f"| `{key}` |" in page, key


def test_low_colour_bar_keeps_the_outer_ticks():
    """A 1D run's band is 40 pixels tall: two tick marks, at the bar's ends, none between."""
    img = cap.colour_bar_column("h", 0.0, 0.005, 40)
    x1 = cap.BAR_X + cap.BAR_STRIP
    marks = np.nonzero((img[:, x1 : x1 + 4] == C.to_uint8(C.TEXT_RGB)).all(axis=(1, 2)))[0]
    assert list(marks) == [8, 40 - 8 - 1]  # 0 mm at the bottom row, 5 mm at the top row
