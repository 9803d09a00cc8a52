"""What the live viewer writes around its map, and the pixels of it.

The first half is plain Python (no Taichi, no window), so every rule can be tested on its own:

* `nice_ticks` / `tick_labels` / `colour_bar_ticks`: round tick values for a
  colour range ("nice numbers": steps of 1, 2 or 5 x 10^k, at most a given count), labelled with
  the same number of decimals;
* `field_title`: the field's name and display unit for the colour bar (h in mm);
* `scale_bar`: a 1-2-5 length (1 mm, 2 mm, 5 mm, 1 cm, ...) that spans between two given
  fractions of the map's width;
* `time_text`: the time stamp;
* `wrap_text`: a status line broken to a pixel width, every character kept;
* `KEYS`, `hint_line`, `help_lines`: the keyboard keys.

The second half rasterises them with Pillow (the DejaVu Sans glyphs the saved frames of
`tiseg.post.render.frame` use, no matplotlib figure) into uint8 pictures, row 0 at the top,
which the viewer copies into its window image: the colour-bar column, the caption strip under
the map and the help box.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from tiseg.post.render import colours as C
from tiseg.post.render.lengths import format_length, nice_length

# =================================================================================================
# Keys
# =================================================================================================
# (key as shown, what it does, short word for the one-line hint)
KEYS = (
    ("space", "pause / resume", "pause"),
    ("s", "one time step (pauses)", "step"),
    ("r", "reset to the initial state", "reset"),
    ("f", "next field (phi, h, |u|, u, v)", "field"),
    ("p", "screenshot (PNG)", "PNG"),
    ("m", "start / stop recording (mp4)", "record"),
    ("h", "show / hide this help", "help"),
    ("Esc", "close the window", "quit"),
)


def hint_line() -> str:
    """The one-line reminder of the keys shown under the map."""
    return "keys: " + "  ".join(f"{k} {word}" for k, _, word in KEYS)


def help_lines() -> list[str]:
    """The lines of the help box (key, then what it does)."""
    width = max(len(k) for k, _, _ in KEYS)
    return ["keys"] + [f"{k.ljust(width)}  {what}" for k, what, _ in KEYS]


# =================================================================================================
# Colour-bar ticks
# =================================================================================================
_MANTISSAS = (1.0, 2.0, 5.0, 10.0)


def nice_step(raw: float) -> float:
    """The smallest 1, 2 or 5 x 10^k not below ``raw`` (> 0)."""
    if not (raw > 0 and math.isfinite(raw)):
        raise ValueError(f"step {raw!r}: must be a positive finite number")
    e = math.floor(math.log10(raw))
    for m in _MANTISSAS:
        step = m * 10.0**e
        if step >= raw * (1 - 1e-9):
            return step
    return 10.0 ** (e + 1)  # pragma: no cover (m = 10 always qualifies)


def _finer(step: float) -> float:
    """The next 1-2-5 step below ``step`` (itself a 1-2-5 step)."""
    e = math.floor(math.log10(step) + 1e-9)
    m = round(step / 10.0**e)
    return {1: 0.5 * 10.0**e, 2: 10.0**e, 5: 2 * 10.0**e}[m]


def nice_ticks(lo: float, hi: float, max_ticks: int = 6) -> list[float]:
    """Round values inside [lo, hi] for a colour bar's ticks: multiples of a 1-2-5 step, the
    smallest such step that gives at most ``max_ticks`` (>= 3) of them, and at least two when
    lo < hi (where two need a finer step, up to five ticks, more than ``max_ticks`` < 5). An empty
    range gives the one value; a range that is not finite gives none."""
    if max_ticks < 3:
        raise ValueError(f"max_ticks={max_ticks}: must be at least 3")
    if not (math.isfinite(lo) and math.isfinite(hi)):
        return []
    if hi < lo:
        lo, hi = hi, lo
    if hi == lo:
        return [lo]
    step = nice_step((hi - lo) / (max_ticks - 1))
    tol = 1e-9 * (hi - lo)
    while True:
        k0 = math.ceil((lo - tol) / step)
        k1 = math.floor((hi + tol) / step)
        if k1 > k0:
            break
        step = _finer(step)  # one tick or none in the range: the next smaller 1-2-5 step
    digits = max(0, -math.floor(math.log10(step)) + 1)
    ticks = [round(k * step, digits) for k in range(k0, k1 + 1)]
    return [0.0 if t == 0 else t for t in ticks]  # no "-0"


def tick_labels(ticks) -> list[str]:
    """Labels of evenly spaced ticks, all with the decimals their spacing needs ("0.5", "1.0")."""
    ticks = list(ticks)
    if not ticks:
        return []
    if len(ticks) > 1:
        step = min(abs(b - a) for a, b in zip(ticks, ticks[1:]))
    else:
        step = abs(ticks[0]) or 1.0
    decimals = max(0, -math.floor(math.log10(step) + 1e-9)) if step > 0 else 0
    if decimals > 6 or max(abs(t) for t in ticks) >= 1e6:
        return [f"{t:.3g}" for t in ticks]
    out = []
    for t in ticks:
        s = f"{t:.{decimals}f}"
        out.append(s.lstrip("-") if float(s) == 0 else s)  # no "-0.0"
    return out


def field_title(field: str) -> str:
    """The colour bar's title: the field's name and the unit its numbers are in."""
    name, _, unit = C.FIELD_LABELS[C.canonical_field(field)]
    return f"{name} [{unit}]" if unit else name


def colour_bar_ticks(
    field: str, vmin: float, vmax: float, height_px: int, spacing_px: int = 36
) -> list[tuple[float, str]]:
    """Ticks of a colour bar ``height_px`` tall for ``field`` over [vmin, vmax] (SI units):
    (fraction of the bar from its low end, label in display units), about one per
    ``spacing_px`` pixels and never fewer than the two that a range needs."""
    _, factor, _ = C.FIELD_LABELS[C.canonical_field(field)]
    lo, hi = vmin * factor, vmax * factor
    n = max(3, min(8, int(height_px // spacing_px) + 1))
    ticks = nice_ticks(lo, hi, n)
    if hi == lo:
        return [(0.5, tick_labels(ticks)[0])] if ticks else []
    return [((t - lo) / (hi - lo), s) for t, s in zip(ticks, tick_labels(ticks))]


# =================================================================================================
# Scale bar and time stamp
# =================================================================================================
@dataclass(frozen=True)
class ScaleBar:
    metres: float  # the bar's length on the chute
    pixels: int  # its length on the map
    label: str  # "5 cm"


def scale_bar(
    map_width_px: int, metres_per_px: float, lo: float = 0.1, hi: float = 0.25
) -> ScaleBar | None:
    """The longest 1-2-5 length (1, 2 or 5 x 10^k m) that is at most ``hi`` of the map's width;
    it is then at least ``lo`` of it (``hi / lo >= 2.5`` makes sure of that: the 1-2-5 steps
    grow by at most 2.5). None when the map is too narrow for a bar of two pixels."""
    if not (0 < lo < hi <= 1 and hi / lo >= 2.5 - 1e-12):
        raise ValueError(f"scale_bar: need 0 < lo < hi <= 1 and hi/lo >= 2.5, got {lo}, {hi}")
    if not (map_width_px > 0 and metres_per_px > 0 and math.isfinite(metres_per_px)):
        return None
    span = map_width_px * metres_per_px
    top = hi * span
    length = float(f"{nice_length(top):.12g}")  # 5e-2, not 0.05000000000000001
    pixels = int(round(length / metres_per_px))
    if pixels < 2:
        return None
    return ScaleBar(length, pixels, format_length(length))


def time_text(t: float, t_end: float | None = None) -> str:
    """The time stamp: "t = 1.25 s", with the scene's end when given ("t = 1.25 s of 3 s")."""
    s = f"t = {t:.2f} s"
    if t_end is not None and math.isfinite(t_end):
        s += f" of {t_end:g} s"
    return s


# =================================================================================================
# Status line
# =================================================================================================
_CHUNK = re.compile(r"[^\s/]*/|\S+\s*|\s+")


def wrap_text(text: str, max_width: float, width_of=len) -> list[str]:
    """Break ``text`` into lines no wider than ``max_width`` as measured by ``width_of`` (a
    function of a string; default: its length in characters).

    Lines break after spaces, and after the slashes of a path; a piece wider than a line is cut
    between characters. A newline always ends a line. Every character is kept, the whitespace at
    a break staying at the end of its line: ``"".join(wrap_text(s, w)) == s``. The widths are
    measured without that trailing whitespace."""
    if max_width <= 0:
        raise ValueError(f"max_width={max_width!r}: must be positive")
    lines: list[str] = []
    for para in text.splitlines(keepends=True):
        line = ""
        for chunk in _CHUNK.findall(para):
            if width_of((line + chunk).rstrip()) <= max_width:
                line += chunk
                continue
            if line:
                lines.append(line)
                line = ""
            while width_of(chunk.rstrip()) > max_width:  # a piece longer than a line: cut it
                n = 1
                while n < len(chunk) and width_of(chunk[: n + 1]) <= max_width:
                    n += 1
                lines.append(chunk[:n])
                chunk = chunk[n:]
            line = chunk
        if line:
            lines.append(line)
    return lines


def fit_lines(lines: list[str], n: int, ellipsis: str = "…") -> list[str]:
    """At most ``n`` lines to draw: the first n, the last of them ending in an ellipsis when
    lines were left out; trailing whitespace (and newlines) removed."""
    out = [ln.rstrip() for ln in lines[:n]]
    if len(lines) > n and out:
        out[-1] = out[-1][: max(0, len(out[-1]) - len(ellipsis))] + ellipsis
    return out


# =================================================================================================
# Pixels (Pillow, the glyphs of tiseg.post.render.frame)
# =================================================================================================
LINE_H = 16  # pixels per text line at the caption size
SIZE = 12  # caption text size in pixels
STATUS_LINES = 3  # lines of status under the map
STRIP_H = 8 + LINE_H * (2 + STATUS_LINES) + 4  # time/scale row, status, hint
BAR_W = 100  # colour-bar column right of the map
BAR_X = 12  # the bar's left edge in the column
BAR_STRIP = 16  # the bar's width


def _rgb(colour) -> np.ndarray:
    return C.to_uint8(colour)


def _canvas(height: int, width: int) -> np.ndarray:
    out = np.empty((height, width, 3), dtype=np.uint8)
    out[...] = C.to_uint8(C.BACKGROUND_RGB)
    return out


def text_width(s: str, size: int = SIZE) -> int:
    from tiseg.post.render.frame import text_width as tw

    return tw(s, size)


class _Writer:
    """Text onto a uint8 picture through one Pillow image: a single conversion each way for all
    the texts of a picture (`tiseg.post.render.frame.draw_text` converts per text)."""

    def __init__(self, img: np.ndarray):
        from PIL import Image, ImageDraw

        from tiseg.post.render.frame import _font

        self.img = img
        self.pil = Image.fromarray(np.ascontiguousarray(img))
        self.draw = ImageDraw.Draw(self.pil)
        self.font = _font(SIZE)

    def text(self, s: str, x: int, baseline: int, colour=None) -> int:
        """s with its left end at column x on the given baseline row; returns the x after it."""
        fill = tuple(int(round(float(c) * 255.0)) for c in (colour or C.TEXT_RGB))
        self.draw.text((x, baseline), s, font=self.font, fill=fill, anchor="ls")
        return x + text_width(s)

    def done(self) -> np.ndarray:
        self.img[...] = np.asarray(self.pil)
        return self.img


def colour_bar_column(field: str, vmin: float, vmax: float, height: int, width: int = BAR_W):
    """The column right of the map, uint8 (height, width, 3): the bar (same colours as the frame
    kernel, high values at the top), ticks with their numbers in display units, and the field's
    name and unit written upwards along its right edge where the column is tall enough."""
    from PIL import Image, ImageDraw

    from tiseg.post.render.frame import _font

    out = _canvas(height, width)
    top, bot = 8, height - 8
    if bot - top < 4:
        return out
    n = bot - top
    x0, x1 = BAR_X, BAR_X + BAR_STRIP
    t = (np.arange(n)[::-1] + 0.5) / n
    out[top:bot, x0:x1] = _rgb(C.colours_for(field, t))[:, None, :]
    white = _rgb(C.TEXT_RGB)
    ticks = colour_bar_ticks(field, vmin, vmax, n)
    if n < 4 * LINE_H and len(ticks) > 2:  # a low bar (a 1D run's band): the outer two only
        ticks = [ticks[0], ticks[-1]]
    rows = [int(round(bot - 1 - frac * (n - 1))) for frac, _ in ticks]
    for row in rows:
        out[row, x1 : x1 + 4] = white
    pen = _Writer(out)
    for row, (_, label) in zip(rows, ticks):
        pen.text(label, x1 + 6, min(max(row + SIZE // 3, top + SIZE - 2), height - 2))
    out = pen.done()
    title = field_title(field)
    font = _font(SIZE)
    tw = int(math.ceil(font.getlength(title)))
    if tw <= height - 4:  # written upwards, centred on the bar
        fill = tuple(int(v) for v in white)
        im = Image.new("RGB", (tw + 2, SIZE + 6), tuple(int(v) for v in out[0, 0]))
        ImageDraw.Draw(im).text((1, SIZE + 2), title, font=font, fill=fill, anchor="ls")
        rot = np.asarray(im.rotate(90, expand=True))
        h, w = rot.shape[:2]
        y = max(0, (height - h) // 2)
        out[y : y + h, width - w - 2 : width - 2] = rot[: height - y]
    return out


def caption_strip(
    width: int,
    map_width: int,
    stamp: str,
    bar: ScaleBar | None,
    status: str = "",
    hint: str | None = None,
    height: int = STRIP_H,
):
    """The strip under the map, uint8 (height, width, 3): time stamp on the left and scale bar
    under the map's right end, then the status (wrapped to the width, up to STATUS_LINES lines)
    and the keys' hint.

    Everything but the time stamp is kept from the last calls (it changes rarely), so a new
    time stamp costs one line of text."""
    x = 6 + text_width(stamp) + 12
    fits = bar is not None and map_width - 6 - bar.pixels - text_width(bar.label) - 6 > x
    out = _strip_without_stamp(width, map_width, bar if fits else None, status, hint, height)
    pen = _Writer(out.copy())
    pen.text(stamp, 6, 8 + SIZE)
    return pen.done()


@lru_cache(maxsize=4)
def _strip_without_stamp(width, map_width, bar, status, hint, height) -> np.ndarray:
    out = _canvas(height, width)
    base = 8 + SIZE
    pen = _Writer(out)
    if bar is not None:
        x1 = map_width - 6
        x0 = x1 - bar.pixels
        pen.text(bar.label, x0 - text_width(bar.label) - 6, base)
    lines = fit_lines(wrap_text(status, width - 12, text_width), STATUS_LINES) if status else []
    for k, line in enumerate(lines):
        pen.text(line, 6, base + LINE_H * (k + 1))
    if hint:
        grey = tuple(0.6 * c for c in C.TEXT_RGB)
        pen.text(hint, 6, base + LINE_H * (STATUS_LINES + 1), colour=grey)
    out = pen.done()
    if bar is not None:
        white = _rgb(C.TEXT_RGB)
        row = base - SIZE // 3
        out[row - 1 : row + 2, x0:x1] = white
        out[row - 5 : row + 6, x0 : x0 + 1] = white
        out[row - 5 : row + 6, x1 - 1 : x1] = white
    out.setflags(write=False)
    return out


def help_box():
    """The help overlay, uint8: the keys and what they do, on a framed dark box."""
    lines = help_lines()
    from tiseg.post.render.frame import _font

    font = _font(SIZE)
    # the key column aligned by pixels (the font is proportional)
    kw = max(font.getlength(k) for k, _, _ in KEYS)
    ww = max(font.getlength(w) for _, w, _ in KEYS)
    w = int(kw + ww + 36)
    h = LINE_H * len(lines) + 12
    out = _canvas(h, w)
    white = _rgb(C.TEXT_RGB)
    out[0, :], out[-1, :], out[:, 0], out[:, -1] = white, white, white, white
    pen = _Writer(out)
    pen.text(lines[0], 10, 6 + SIZE)
    for k, (key, what, _) in enumerate(KEYS):
        base = 6 + SIZE + LINE_H * (k + 1)
        pen.text(key, 10, base)
        pen.text(what, int(10 + kw + 16), base)
    return pen.done()
