"""Draw the pictures of docs/probability.md "Over terrain" from a real run of the sweep that
section shows.

    python docs/relief_pictures.py

The page's two TOML blocks (the scene ``bump-hollow.toml`` and the sweep
``bump-hollow-probability.toml``, each opened by a ``# NAME.toml`` comment) are written into a
temporary folder, the page's ``tiseg sweep`` command runs there, and two small PNGs (well under
200 kB each) go into ``docs/images/``:

* ``relief-probability.png``: the first row of the probability maps, two columns wide;
* ``relief-peaks.png``: the peak thickness and the deposit of the member with mu = 0.5.

Both are drawn over the shaded relief of the members' bed. The pictures are committed; run this
again after the page's files, the scheme or the renderer change. It takes about a minute on two
cores.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "probability.md"
IMAGES = ROOT / "docs" / "images"
ENV = dict(os.environ, TI_SKIP_VERSION_CHECK="ON", ENABLE_TAICHI_HEADER_PRINT="0", MPLBACKEND="Agg")
SWEEP = "bump-hollow-probability.toml"
OUT = "runs/sweeps/bump-hollow"  # the page's --out
MEMBER = "coulomb_mu-0.5"  # the member whose peak fields the page shows
PICTURES = ("relief-probability.png", "relief-peaks.png")
LIMIT = 200_000  # bytes: the docs' pictures stay small


def page_files(page: Path = PAGE) -> dict[str, str]:
    """The TOML files the page shows: name -> text, from each ```toml block whose first line is
    a comment ``# NAME.toml``."""
    out = {}
    for body in re.findall(r"^```toml\n(.*?)^```", page.read_text(), re.M | re.S):
        first, _, rest = body.partition("\n")
        m = re.fullmatch(r"#\s*(\S+\.toml)\s*", first)
        if m:
            out[m.group(1)] = rest
    return out


def write_files(work: Path, page: Path = PAGE) -> Path:
    """The page's files in ``work``; the sweep file's path."""
    files = page_files(page)
    for name, text in files.items():
        (work / name).write_text(text)
    if SWEEP not in files:
        raise SystemExit(f"{page.name} shows no {SWEEP}")
    return work / SWEEP


def draw(sweep_dir: Path, images: Path = IMAGES, member: str = MEMBER) -> list[Path]:
    """Draw the page's two pictures of the sweep in ``sweep_dir`` into ``images``."""
    from tiseg.post.render.peak_maps import plot_peak_fields
    from tiseg.post.render.probability import plot_probability

    images.mkdir(parents=True, exist_ok=True)
    paths = [images / name for name in PICTURES]
    plot_probability(sweep_dir, paths[0], width=7.0, columns=2, dpi=90, rows=["probability"])
    plot_peak_fields(sweep_dir / member, paths[1], fields=["h_max", "deposit_h"], width=6.0, dpi=90)
    for path in paths:
        size = path.stat().st_size
        if size > LIMIT:
            raise SystemExit(f"{path.name} is {size} bytes, over {LIMIT}: draw it smaller")
        print(f"wrote {path} ({size // 1000} kB)")
    return paths


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        sweep = write_files(work)
        cmd = [sys.executable, "-m", "tiseg", "sweep", sweep.name, "--out", OUT]
        print("$ tiseg " + " ".join(cmd[3:]), flush=True)
        subprocess.run(cmd, cwd=work, env=ENV, check=True)
        draw(work / OUT)


if __name__ == "__main__":
    main()
