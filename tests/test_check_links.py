""".ci/check_links.py on small hand-made sites: a site that works from disk passes, and each
kind of breakage (a missing file or anchor, a folder link, an address from the server's root, a
network load) is reported on the page where it occurs."""

import importlib.util
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parents[1] / ".ci" / "check_links.py"


@pytest.fixture(scope="module")
def checker():
    spec = importlib.util.spec_from_file_location("check_links", SCRIPT)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _site(root: Path, pages: dict[str, str]) -> Path:
    for rel, body in pages.items():
        p = root / rel
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text(body)
    return root


GOOD = {
    "index.html": '<html><head><link rel="stylesheet" href="css/site.css">'
    '<script src="js/app.js"></script></head><body id="top">'
    '<a href="guide/page.html#install">install</a> <a href="#top">top</a>'
    '<a href="https://example.org/paper">paper</a> <a href="mailto:a@b.c">mail</a>'
    '<img src="img/fig.png" srcset="img/fig.png 1x, img/fig@2x.png 2x">'
    '<script src="https://cdn.jsdelivr.net/npm/mathjax@3/es5/tex-mml-chtml.js"></script>'
    '<link rel="canonical" href="https://example.org/site/"></body></html>',
    "guide/page.html": '<h2 id="install">Install</h2><a href="../index.html">home</a>'
    '<a name="old-anchor"></a><a href="../index.html#top">top</a>',
    "css/site.css": "body { background: url('../img/fig.png') }",
    "js/app.js": "",
    "img/fig.png": "png",
    "img/fig@2x.png": "png",
    # a web server shows this page with addresses from its root; it is not checked
    "404.html": '<a href="/index.html">home</a>',
}


def test_a_site_that_works_from_disk_passes(checker, tmp_path):
    problems, checked = checker.check_site(_site(tmp_path, GOOD))
    assert problems == []
    assert checked >= 12  # every address above was looked at, the CSS's included


@pytest.mark.parametrize(
    "page, body, expected",
    [
        ("a.html", '<a href="missing.html">x</a>', "missing.html: no such file"),
        ("a.html", '<img src="img/none.png">', "img/none.png: no such file"),
        ("a.html", '<a href="guide/">x</a>', "a folder"),
        ("a.html", '<a href="guide">x</a>', "a folder"),
        ("a.html", '<a href="guide/page.html#nowhere">x</a>', "no anchor #nowhere"),
        ("a.html", '<a href="#nowhere">x</a>', "no anchor #nowhere"),
        ("a.html", '<a href="/index.html">x</a>', "server's root"),
        ("a.html", '<a href="../outside.html">x</a>', "outside the site"),
        ("a.html", '<script src="https://cdn.example.com/x.js"></script>', "from the network"),
        ("a.html", '<link rel="stylesheet" href="//fonts.example.com/f.css">', "network"),
        ("a.html", '<link rel="preconnect" href="https://fonts.gstatic.com">', "network"),
        ("a.html", '<img src="https://example.org/pic.png">', "from the network"),
        ("a.html", '<div style="background: url(https://x.org/b.png)"></div>', "network"),
        ("css/more.css", "@import 'https://fonts.example.com/f.css';", "network"),
        ("css/more.css", "p { background: url(../img/none.png) }", "no such file"),
    ],
)
def test_each_breakage_is_reported_on_its_page(checker, tmp_path, page, body, expected):
    site = _site(tmp_path, {**GOOD, page: body})
    problems, _ = checker.check_site(site)
    assert len(problems) == 1, problems
    assert problems[0].startswith(f"{page}: ") and expected in problems[0], problems


def test_network_loads_can_be_allowed_by_substring(checker, tmp_path):
    site = _site(tmp_path, {**GOOD, "a.html": '<script src="https://cdn.example.com/k.js">'})
    assert checker.check_site(site, allow=("cdn.example.com", "mathjax"))[0] == []
    # the allowed substrings replace the default (MathJax): GOOD's MathJax is then refused
    only = checker.check_site(site, allow=("cdn.example.com",))[0]
    assert len(only) == 1 and "mathjax" in only[0]
    # the default allows MathJax only
    assert [p for p in checker.check_site(site)[0] if "cdn.example.com" in p]


def test_command_line_exit_status(checker, tmp_path, capsys):
    good = _site(tmp_path / "good", GOOD)
    assert checker.main([str(good)]) == 0
    assert "all resolve offline" in capsys.readouterr().out
    bad = _site(tmp_path / "bad", {**GOOD, "a.html": '<a href="gone.html">x</a>'})
    assert checker.main([str(bad)]) == 1
    out = capsys.readouterr()
    assert "a.html: <a href> gone.html: no such file" in out.out
    assert checker.main([str(tmp_path / "nothing")]) == 2
    assert "not a folder" in capsys.readouterr().err
