"""MkDocs hooks for the parts of the site that work offline and are built from data files.

* MathJax (from the ``django-static-mathjax`` package of the ``docs`` extra) is copied into
  ``javascripts/mathjax/``, so the equations render from disk without a network;
* one page per built-in scene, ``scenes/<name>.md``, from ``tiseg/data/scenes/<name>.toml``:
  its description, the comment at its top (what it is for), the picture
  ``docs/scenes/<name>.png`` (drawn by ``docs/scene_pictures.py``), the command and the file;
  the pages are added to the navigation after "Scenes reference";
* the theme's offline mode loads a Worker shim for the search from the network; the pages
  load the site's own, ``javascripts/iframe-worker.js``, instead, so the search works from
  disk;
* the gallery page (``gallery.md``, written by ``docs/hooks.py``) gets a grid of thumbnails of
  the figures in ``assets/figures`` and the finger movie (``assets/fingers.gif``, also as MP4),
  and the example scripts as downloads.
"""

from __future__ import annotations

import importlib.metadata
import io
import re
import sys
import tomllib
from pathlib import Path

from mkdocs.exceptions import PluginError
from mkdocs.structure.files import File

ROOT = Path(__file__).resolve().parents[1]
SCENES = ROOT / "tiseg" / "data" / "scenes"
PICTURES = ROOT / "docs" / "scenes"
MATHJAX_DIST = "django-static-mathjax"
# the parts of MathJax's es5 build the pages use: the TeX-to-SVG bundle (its fonts are inside
# it), the TeX extensions it loads on demand, the menu and the assistive MathML
MATHJAX_PARTS = ("tex-svg.js", "input/tex/extensions", "ui", "a11y")

# gallery captions: file stem in assets/figures -> what the picture shows
FIGURES = {
    "fig12_phi": "Figure 12: the concentration φ as the front breaks into fingers",
    "fig12_phi_750": "The same times drawn by `tiseg render --panels` from a run at 750 cells/m",
    "fig13_speed": "Figure 13: the speed |u|, fast channels between still levees",
    "fig14_h": "Figure 14: the thickness h",
    "fig15_phi_runs": "Figure 15: φ at t = 7.5 s for other grids and widths",
    "fig16_grid_width": "Figure 16: wavelength and elongation against the grid",
    "fig17_nu": "Figure 17: the effect of the viscosity ν",
    "fig18_fronts": "Figure 18: the front positions x_f⁺ and x_f⁻",
    "inviscid_limit": "The ill-posed limit: with ν = 0 the fingers keep narrowing on finer grids",
    "fig08_froude": "Figure 8: the steady Froude number F(h0, φ0)",
    "fig09_growth_rates": "Figure 9: linear growth rates σ_M(k)",
    "fig10_critical": "Figure 10: growth rates near the critical Froude number",
    "fig11_sigma_max": "Figure 11: the largest growth rate over (h0, φ0)",
    "beyond_finite_release_phi": "A finite release: φ after the inflow stops",
    "beyond_finite_release_fronts": "A finite release: the front positions",
    "beyond_monodisperse_phi": "A monodisperse front (φ0 = 1) stays straight",
    "deposit": "The deposit of a finite release that comes to rest",
    "roll_waves": "Roll waves: growth, merging into fewer and larger waves, a forced wave train",
    "erosion_deposition": "Erosion-deposition waves on static layers of six thicknesses",
    "levees_channel": "A self-channelised flow from a gate: cross-sections at three mass fluxes",
    "demo_fig12_phi": "`tiseg demo`: φ at a coarse grid",
    "demo_fig13_speed": "`tiseg demo`: the speed",
    "demo_fig14_h": "`tiseg demo`: the thickness",
}
THUMB_WIDTH = 360
# the site's Worker stand-in for pages opened from disk; material's offline plugin adds a
# network one to extra.polyfills unless an entry there already names "iframe-worker"
LOCAL_WORKER = "javascripts/iframe-worker.js"


def scene_names() -> list[str]:
    """The built-in scenes (file stems of ``tiseg/data/scenes/*.toml``), sorted."""
    return sorted(p.stem for p in SCENES.glob("*.toml"))


def _comment_blocks(text: str) -> list[tuple[str, str]]:
    """The comment at the top of a scene file as ("text" | "code", block) pairs: comment lines
    join into paragraphs (an empty ``#`` line ends one); lines indented past ``# `` are
    commands, kept as code."""
    blocks: list[tuple[str, list[str]]] = []
    for line in text.splitlines():
        if not line.startswith("#"):
            break
        body = line[1:]
        if not body.strip():
            blocks.append(("text", []))
            continue
        kind = "code" if body.startswith("   ") else "text"
        item = body.strip()
        if not blocks or blocks[-1][0] != kind or (kind == "text" and not blocks[-1][1]):
            if blocks and blocks[-1][0] == "text" and not blocks[-1][1]:
                blocks.pop()
            blocks.append((kind, []))
        blocks[-1][1].append(item)
    return [(k, (" " if k == "text" else "\n").join(b)) for k, b in blocks if b]


def _picture_runs() -> dict[str, tuple[list[str], str]]:
    """``scene_pictures.RUNS``: scene -> (the overrides of its picture's run, kind of picture)."""
    sys.path.insert(0, str(ROOT / "docs"))
    try:
        from scene_pictures import RUNS
    finally:
        sys.path.pop(0)
    return RUNS


def _picture_note(name: str) -> str:
    overrides, kind = _picture_runs().get(name, ([], ""))
    what = {
        "map": "The concentration φ at the end of the run (white fines, brown coarse grains, "
        "turquoise empty chute)",
        "channel": "Downslope speed u and concentration φ across the slope at the start "
        "(dashed) and the end of the run",
        "mode": "The perturbation of h and u (each minus its mean) along the slope at the start "
        "(dashed) and the end of the run",
        "profile": "Thickness h and downslope speed u along the slope at the start (dashed) and "
        "the end of the run",
    }.get(kind, "The end of the run")
    grid = (
        " from a quick run with " + ", ".join(f"`{o}`" for o in overrides)
        if overrides
        else " from a run of the scene as it is"
    )
    return f"{what},{grid} (drawn by `docs/scene_pictures.py`)."


def scene_page(name: str) -> str:
    """The markdown of one scene's page."""
    path = SCENES / f"{name}.toml"
    text = path.read_text()
    data = tomllib.loads(text)
    out = [f"# Scene `{name}`", "", f"**{data.get('description', name)}**", ""]
    for kind, block in _comment_blocks(text):
        out += [block, ""] if kind == "text" else ["```sh", block, "```", ""]
    if (PICTURES / f"{name}.png").exists():
        out += [f"![{name}]({name}.png)", "", f"*{_picture_note(name)}*", ""]
    t_end = data.get("time", {}).get("t_end")
    quick = _picture_runs().get(name, ([], ""))[0]
    out += ["## Run it", "", "```sh", f"tiseg run {name}"]
    if quick:
        sets = " ".join(f"--set {o}" for o in quick)
        out.append(f"tiseg run {name} {sets} --out runs/{name}-quick")
    out += [
        "```",
        "",
        ("The second line is the quick run of the picture. " if quick else "")
        + (f"The run ends at t = {t_end} s (`time.t_end`). " if t_end is not None else "")
        + "Any value below can be changed with `--set SECTION.KEY=VALUE`; to start your own "
        "scene, save the file below as `my.toml`, edit it and run `tiseg run my.toml`. Every key "
        "is described in the [scenes reference](../reference/scenes.md).",
        "",
        "## The scene file",
        "",
        f"`tiseg/data/scenes/{name}.toml`:",
        "",
        "```toml",
        text.rstrip("\n"),
        "```",
        "",
    ]
    return "\n".join(out)


def scenes_index() -> str:
    out = [
        "# Built-in scenes",
        "",
        "Each scene is a TOML file shipped with tiseg; `tiseg run NAME` runs it. The pictures "
        "come from quick runs on coarse grids (stated on each page).",
        "",
        "| Scene | What it is | |",
        "| --- | --- | --- |",
    ]
    for name in scene_names():
        desc = tomllib.loads((SCENES / f"{name}.toml").read_text()).get("description", "")
        pic = (
            f'[![{name}]({name}.png){{ width="220" }}]({name}.md)'
            if (PICTURES / f"{name}.png").exists()
            else ""
        )
        out.append(f"| [`{name}`]({name}.md) | {desc} | {pic} |")
    return "\n".join(out) + "\n"


def _mathjax_root() -> Path:
    try:
        dist = importlib.metadata.distribution(MATHJAX_DIST)
    except importlib.metadata.PackageNotFoundError:
        raise PluginError(
            f"MathJax is missing: install the docs extra (pip install -e '.[docs]', which brings "
            f"{MATHJAX_DIST})"
        ) from None
    root = Path(dist.locate_file("mathjax/static/mathjax/es5"))
    if not (root / "tex-svg.js").is_file():
        raise PluginError(f"{MATHJAX_DIST} has no es5/tex-svg.js under {root}")
    return root


def _thumbnail(src: Path, width: int = THUMB_WIDTH, last_frame: bool = False) -> bytes:
    from PIL import Image

    with Image.open(src) as im:
        if last_frame:
            im.seek(getattr(im, "n_frames", 1) - 1)
        im = im.convert("RGB")
        if im.width > width:
            im = im.resize((width, round(im.height * width / im.width)), Image.LANCZOS)
        buf = io.BytesIO()
        im.save(buf, format="PNG", optimize=True)
    return buf.getvalue()


def _gif_to_mp4(src: Path) -> bytes:
    """The GIF's frames as an H.264 MP4 (imageio with its ffmpeg), same frame rate."""
    import tempfile

    import imageio.v2 as imageio
    import numpy as np

    reader = imageio.get_reader(src)
    duration = reader.get_meta_data().get("duration", 100) or 100
    fps = 1000.0 / duration
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "movie.mp4"
        with imageio.get_writer(
            out, fps=fps, codec="libx264", pixelformat="yuv420p", macro_block_size=2
        ) as w:
            for frame in reader:
                frame = np.asarray(frame)[..., :3]
                h, wd = frame.shape[0] // 2 * 2, frame.shape[1] // 2 * 2
                w.append_data(frame[:h, :wd])
        reader.close()
        return out.read_bytes()


def _gallery_extra() -> str:
    figs = [s for s in FIGURES if (ROOT / "assets" / "figures" / f"{s}.png").exists()]
    out = [
        "## Pictures and movies",
        "",
        "The finger movie of the paper's set-up (`assets/fingers.gif`; also as "
        "[MP4](gallery/fingers.mp4)):",
        "",
        '<video controls loop muted width="600" poster="gallery/thumbs/fingers.png">'
        '<source src="gallery/fingers.mp4" type="video/mp4"></video>',
        "",
        "![fingers movie](gallery/fingers.gif)",
        "",
        "Pictures drawn by `tiseg figures` and `tiseg demo` (select one for the full size):",
        "",
        '<div class="grid" markdown>',
        "",
    ]
    for s in figs:
        out += [
            f'<figure markdown="span">[![{s}](gallery/thumbs/{s}.png)](gallery/figures/{s}.png)'
            f"<figcaption>{FIGURES[s]}</figcaption></figure>",
            "",
        ]
    out += ["</div>", "", "## The example scripts", ""]
    for script in sorted((ROOT / "examples").glob("*.py")):
        out.append(
            f"- [`{script.name}`](gallery/scripts/{script.name}) (download; its run is shown below)"
        )
    return "\n".join(out) + "\n"


def local_polyfills(polyfills: list) -> list:
    """The theme's polyfill scripts with the Worker shim served by the site itself."""
    kept = [p for p in polyfills if "iframe-worker" not in str(p)]
    return [*kept, LOCAL_WORKER]


def _nav_paths(nav) -> set[str]:
    """Every page path in a navigation (nested lists and dicts)."""
    if isinstance(nav, str):
        return {nav}
    if isinstance(nav, dict):
        return set().union(*(_nav_paths(v) for v in nav.values()))
    if isinstance(nav, list):
        return set().union(set(), *(_nav_paths(v) for v in nav))
    return set()


def add_to_nav(nav: list, entry: dict, after: str) -> None:
    """Insert ``entry`` after the item whose page is ``after`` (or at the end), unless the
    navigation already holds its pages (mkdocs.yml may list them itself)."""
    if _nav_paths(entry) & _nav_paths(nav):
        return
    at = next(
        (i + 1 for i, item in enumerate(nav) if isinstance(item, dict) and after in item.values()),
        len(nav),
    )
    nav.insert(at, entry)


def on_config(config):
    """Serve the Worker shim from the site; put the scene pages (after the scenes reference)
    and the viewer page (after the command line) into the navigation where mkdocs.yml does
    not list them."""
    config.extra["polyfills"] = local_polyfills(config.extra.get("polyfills", []))
    if config.nav is not None:
        scenes = [{"Overview": "scenes/index.md"}]
        scenes += [{name: f"scenes/{name}.md"} for name in scene_names()]
        add_to_nav(config.nav, {"Built-in scenes": scenes}, after="reference/scenes.md")
        add_to_nav(config.nav, {"The live viewer": "viewer.md"}, after="reference/cli.md")
    return config


def on_files(files, config):
    def add(path: str, content=None, src: Path | None = None):
        files.append(
            File.generated(config, path, content=content, abs_src_path=str(src) if src else None)
        )

    mathjax = _mathjax_root()
    for part in MATHJAX_PARTS:
        p = mathjax / part
        for f in sorted(p.rglob("*.js")) if p.is_dir() else [p]:
            add(f"javascripts/mathjax/{f.relative_to(mathjax).as_posix()}", src=f)

    add("scenes/index.md", scenes_index())
    for name in scene_names():
        add(f"scenes/{name}.md", scene_page(name))

    figures = ROOT / "assets" / "figures"
    for stem in FIGURES:
        src = figures / f"{stem}.png"
        if src.exists():
            add(f"gallery/figures/{stem}.png", src=src)
            add(f"gallery/thumbs/{stem}.png", _thumbnail(src))
    gif = ROOT / "assets" / "fingers.gif"
    add("gallery/fingers.gif", src=gif)
    add("gallery/fingers.mp4", _gif_to_mp4(gif))
    add("gallery/thumbs/fingers.png", _thumbnail(gif, 600, last_frame=True))
    for script in sorted((ROOT / "examples").glob("*.py")):
        add(f"gallery/scripts/{script.name}", src=script)
    return files


_H1 = re.compile(r"^# .*\n", re.M)


def on_page_markdown(markdown, page, config, files):
    """Insert the pictures, the movie and the script downloads under the gallery's title."""
    if page.file.src_uri != "gallery.md":
        return markdown
    m = _H1.search(markdown)
    at = m.end() if m else 0
    return markdown[:at] + "\n" + _gallery_extra() + "\n" + markdown[at:]
