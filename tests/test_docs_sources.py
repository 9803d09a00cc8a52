"""The documentation's sources: what the site renders from them, checked without building it.

The full build (`mkdocs build --strict`, run by CI) runs the examples and takes a while; these
checks cover the sources themselves: docstrings free of Sphinx roles (the site shows them as
raw text), every equation of the model page numbered as in the paper, formula blocks and lists
that Python-Markdown renders as intended, a page and a picture for every built-in scene, and a
site that needs no network (MathJax from the site, the offline plugin, file URLs).
"""

from __future__ import annotations

import importlib.util
import re
from pathlib import Path

import pytest

from tiseg.setup.scene import list_builtin_scenes

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
ROLE = re.compile(r":(?:py:)?(?:class|func|mod|meth|attr|data|obj|exc|const|ref):`")
DISPLAY = re.compile(r"^[ \t]*\$\$\n(.*?)\n[ \t]*\$\$[ \t]*$", re.S | re.M)


def _hooks_site():
    pytest.importorskip("mkdocs")
    spec = importlib.util.spec_from_file_location("hooks_site", DOCS / "hooks_site.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _render(path: Path) -> str:
    """The page's HTML from Python-Markdown with the site's extensions for body text."""
    markdown = pytest.importorskip("markdown")
    pytest.importorskip("pymdownx")
    return markdown.markdown(
        path.read_text(),
        extensions=[
            "admonition",
            "attr_list",
            "md_in_html",
            "tables",
            "pymdownx.superfences",
            "pymdownx.arithmatex",
        ],
        extension_configs={"pymdownx.arithmatex": {"generic": True}},
    )


def test_no_sphinx_roles_in_docstrings():
    hits = []
    for path in sorted([*(ROOT / "tiseg").rglob("*.py"), *(ROOT / "viewer").rglob("*.py")]):
        for i, line in enumerate(path.read_text().splitlines(), 1):
            if ROLE.search(line):
                hits.append(f"{path.relative_to(ROOT)}:{i}: {line.strip()}")
    assert not hits, "Sphinx roles render as raw text on the site; use `name`:\n" + "\n".join(
        hits[:20]
    )


def test_every_display_equation_of_the_model_is_numbered():
    text = (DOCS / "model.md").read_text()
    blocks = DISPLAY.findall(text)
    assert text.count("$$") == 2 * len(blocks), "an unpaired $$ in docs/model.md"
    untagged = [b for b in blocks if "\\tag" not in b]
    assert not untagged, f"display equations without \\tag: {untagged}"
    tags = set()
    for b in blocks:
        tags.update(re.findall(r"\\tag\{([^}]*)\}", b))
    # the governing equations of section 6.1 and the friction and transport laws they use
    for number in ["6.1", "6.2", "6.3", "6.5", "6.6", "3.4", "3.7", "2.17", "2.18", "4.9"]:
        assert number in tags, f"equation ({number}) is not shown with its number"
    # no equation left as Unicode in an indented code block
    assert not re.search(r"\n\n    \S[^\n]*=", text), "an indented code block holds a formula"


@pytest.mark.parametrize("page", ["model.md", "numerics.md"])
def test_formulas_and_lists_render(page):
    html = _render(DOCS / page)
    source = (DOCS / page).read_text()
    # every $$ block became typeset math, none became a code block or running text
    assert "<pre" not in html, f"{page}: a block renders as code"
    n_display = len(re.findall(r"^[ \t]*\$\$[ \t]*$", source, re.M)) // 2
    assert html.count('<div class="arithmatex">') == n_display
    assert "$$" not in re.sub(r'<div class="arithmatex">.*?</div>', "", html, flags=re.S)
    # a bullet written on the line after a paragraph merges into it
    merged = [p for p in re.findall(r"<p>(.*?)</p>", html, re.S) if re.search(r"\n- \S", p)]
    assert not merged, f"{page}: bullets merged into a paragraph: {merged[:2]}"
    # an asterisk of a superscript (beta*, phi*) pairing into italics
    for em in re.findall(r"<em>(.*?)</em>", html, re.S):
        assert "β" not in em and "φ" not in em, f"{page}: italics from paired asterisks: {em!r}"


def test_a_page_and_a_picture_for_every_builtin_scene():
    hooks = _hooks_site()
    names = list_builtin_scenes()
    assert sorted(hooks.scene_names()) == sorted(names)
    spec = importlib.util.spec_from_file_location("scene_pictures", DOCS / "scene_pictures.py")
    pictures = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(pictures)
    assert sorted(pictures.RUNS) == sorted(names), "docs/scene_pictures.py misses a scene"
    index = hooks.scenes_index()
    total = 0
    for name in names:
        page = hooks.scene_page(name)
        assert page.startswith(f"# Scene `{name}`")
        assert f"tiseg run {name}\n" in page
        assert f"![{name}]({name}.png)" in page
        assert f"]({name}.md)" in index
        picture = DOCS / "scenes" / f"{name}.png"
        assert picture.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        total += picture.stat().st_size
    assert total < 1_000_000, f"the scene pictures take {total} bytes"


def test_scene_comments_become_paragraphs_and_commands():
    hooks = _hooks_site()
    text = (
        "# First line of the purpose\n"
        "# goes on here.\n"
        "#\n"
        "# A second paragraph.\n"
        "#   tiseg run x --set a.b=1\n"
        "name = 'x'\n"
        "# not part of the header\n"
    )
    assert hooks._comment_blocks(text) == [
        ("text", "First line of the purpose goes on here."),
        ("text", "A second paragraph."),
        ("code", "tiseg run x --set a.b=1"),
    ]


def test_the_site_needs_no_network():
    yaml = pytest.importorskip("yaml")
    cfg = yaml.safe_load((ROOT / "mkdocs.yml").read_text())
    assert cfg["use_directory_urls"] is False
    assert cfg["theme"].get("font") is False, "the theme would load its fonts from the network"
    plugins = [p if isinstance(p, str) else next(iter(p)) for p in cfg["plugins"]]
    assert "offline" in plugins
    scripts = cfg["extra_javascript"]
    assert scripts and not [s for s in scripts if "://" in s]
    hooks = _hooks_site()
    for s in scripts:
        if s.startswith("javascripts/mathjax/"):
            assert s.removeprefix("javascripts/mathjax/") in hooks.MATHJAX_PARTS
        else:
            assert (DOCS / s).is_file(), s
    handlers = next(p for p in cfg["plugins"] if isinstance(p, dict) and "mkdocstrings" in p)
    options = handlers["mkdocstrings"]["handlers"]["python"]["options"]
    assert options["docstring_style"] == "numpy"


def test_the_search_worker_shim_is_served_by_the_site():
    hooks = _hooks_site()
    network = "https://unpkg.com/iframe-worker/shim"
    assert hooks.local_polyfills([network, "javascripts/other.js"]) == [
        "javascripts/other.js",
        hooks.LOCAL_WORKER,
    ]
    assert hooks.local_polyfills([]) == [hooks.LOCAL_WORKER]
    # the offline plugin adds its network shim unless an entry names "iframe-worker"
    assert "iframe-worker" in hooks.LOCAL_WORKER and "://" not in hooks.LOCAL_WORKER
    shim = (DOCS / hooks.LOCAL_WORKER).read_text()
    assert "window.Worker = " in shim and 'location.protocol !== "file:"' in shim


def test_new_pages_join_the_navigation_once():
    hooks = _hooks_site()
    nav = [{"Scenes reference": "reference/scenes.md"}, {"Command line": "reference/cli.md"}]
    hooks.add_to_nav(nav, {"The live viewer": "viewer.md"}, after="reference/cli.md")
    assert nav[-1] == {"The live viewer": "viewer.md"}
    hooks.add_to_nav(nav, {"Viewer": "viewer.md"}, after="reference/scenes.md")  # listed
    assert len(nav) == 3
    hooks.add_to_nav(nav, {"S": [{"Overview": "scenes/index.md"}]}, after="reference/scenes.md")
    assert nav[1] == {"S": [{"Overview": "scenes/index.md"}]}


def test_the_viewer_page_names_every_key_and_slider():
    page = (DOCS / "viewer.md").read_text()
    app = (ROOT / "tiseg" / "apps" / "viewer" / "app.py").read_text()
    keys = re.findall(r'e\.key == "(\w)"', app) + re.findall(r"e\.key == ti\.ui\.(\w+)", app)
    assert keys, "no key handling found in tiseg/apps/viewer/app.py"
    names = {"SPACE": "space", "ESCAPE": "Esc"}
    for key in keys:
        label = names.get(key, key.lower())
        assert f"| `{label}` |" in page, f"key {key} of the viewer is not on docs/viewer.md"
    for label in re.findall(r'slider_(?:float|int)\("([^"]+)"', app):
        assert label in page, f"slider {label!r} of the viewer is not on docs/viewer.md"
    for label in re.findall(r'w\.button\("([^"{]+)"', app):
        assert label in page, f"button {label!r} of the viewer is not on docs/viewer.md"
