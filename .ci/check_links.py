"""Check every link and image of a built documentation site, so that it works opened from disk.

    python .ci/check_links.py SITE_DIR [--allow-network SUBSTRING ...]

For every HTML page under SITE_DIR:

* a link or resource with a relative address must name a file that exists in the site (a folder
  is refused: opened from disk it shows a directory listing, not its ``index.html``), and a
  ``#fragment`` must name an ``id`` (or ``name``) in the page it points to;
* an address that starts with ``/`` is refused: it needs a web server at the site's root;
* nothing may be loaded from the network (scripts, style sheets, pictures, fonts, frames,
  media, ``preconnect`` hints, ``url(...)`` and ``@import`` in the site's CSS) unless the address
  contains one of the ``--allow-network`` substrings (by default only MathJax's). Hyperlinks to
  other web sites (``<a href="https://...">``) are not loads and are not fetched.

``404.html`` is skipped: a web server shows it, with addresses from the server's root.
Exits with status 1 and one line per problem if anything fails, else prints a one-line summary.
"""

from __future__ import annotations

import argparse
import re
import sys
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import unquote, urlsplit

DEFAULT_ALLOW = ("mathjax",)
SKIP_PAGES = ("404.html",)
# (tag, attribute) pairs whose address the browser loads when it shows the page
_LOADS = {
    ("img", "src"),
    ("script", "src"),
    ("iframe", "src"),
    ("embed", "src"),
    ("source", "src"),
    ("video", "src"),
    ("video", "poster"),
    ("audio", "src"),
    ("track", "src"),
    ("object", "data"),
    ("input", "src"),
}
# <link rel=...> kinds that load something (the others, such as prev/next/canonical, are links)
_LOADING_RELS = {
    "stylesheet",
    "icon",
    "shortcut",
    "apple-touch-icon",
    "preload",
    "prefetch",
    "modulepreload",
    "preconnect",
    "dns-prefetch",
    "manifest",
    "mask-icon",
}
_CSS_URL = re.compile(r"""url\(\s*['"]?([^'")\s]+)['"]?\s*\)|@import\s+['"]([^'"]+)['"]""")
_EXTERNAL = re.compile(r"^(?:[a-zA-Z][a-zA-Z0-9+.-]*:|//)")


class _Page(HTMLParser):
    """The addresses a page refers to, and the fragment names it defines."""

    def __init__(self):
        super().__init__(convert_charrefs=True)
        self.refs: list[tuple[str, str, bool]] = []  # (what, address, loaded by the browser)
        self.ids: set[str] = set()

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        for key in ("id", "name") if tag in ("a", "map") else ("id",):
            if a.get(key):
                self.ids.add(a[key])
        rels = set((a.get("rel") or "").lower().split())
        for attr, value in attrs:
            if value is None:
                continue
            if attr == "srcset":
                for part in value.split(","):
                    if part.strip():
                        self.refs.append((f"<{tag} srcset>", part.split()[0], True))
            elif (tag, attr) in _LOADS:
                self.refs.append((f"<{tag} {attr}>", value, True))
            elif tag == "link" and attr == "href":
                self.refs.append((f"<link rel={a.get('rel')}>", value, bool(rels & _LOADING_RELS)))
            elif tag in ("a", "area") and attr == "href":
                self.refs.append((f"<{tag} href>", value, False))
            elif attr == "style" and "url(" in value:
                for m in _CSS_URL.finditer(value):
                    self.refs.append((f"<{tag} style>", m.group(1) or m.group(2), True))


def _allowed(address: str, allow: tuple[str, ...]) -> bool:
    return any(s.lower() in address.lower() for s in allow)


def _check_ref(page: Path, site: Path, what: str, address: str, loaded: bool, allow, ids_of):
    """The problem with one address, or None."""
    address = address.strip()
    if not address or address.startswith(("javascript:", "data:", "mailto:", "tel:")):
        return None
    if _EXTERNAL.match(address):
        if loaded and not _allowed(address, allow):
            return f"{what} {address}: loaded from the network"
        return None
    parts = urlsplit(address)
    if parts.path.startswith("/"):
        return f"{what} {address}: an address from the server's root (needs a web server)"
    target = (page.parent / unquote(parts.path)).resolve() if parts.path else page
    try:
        target.relative_to(site)
    except ValueError:
        return f"{what} {address}: points outside the site"
    if parts.path.endswith("/") or target.is_dir():
        return f"{what} {address}: a folder (opened from disk it is a listing, not a page)"
    if not target.is_file():
        return f"{what} {address}: no such file"
    if parts.fragment and target.suffix == ".html":
        if unquote(parts.fragment) not in ids_of(target):
            return f"{what} {address}: no anchor #{parts.fragment} in {target.relative_to(site)}"
    return None


def check_site(site, allow=DEFAULT_ALLOW) -> tuple[list[str], int]:
    """(problems, number of addresses checked) of the built site in the folder ``site``."""
    site = Path(site).resolve()
    if not site.is_dir():
        raise FileNotFoundError(f"{site} is not a folder (build the site first)")
    parsed: dict[Path, _Page] = {}

    def parse(path: Path) -> _Page:
        if path not in parsed:
            p = _Page()
            p.feed(path.read_text(encoding="utf-8", errors="replace"))
            parsed[path] = p
        return parsed[path]

    problems, checked = [], 0
    pages = sorted(p for p in site.rglob("*.html") if p.name not in SKIP_PAGES)
    if not pages:
        problems.append(f"{site}: no HTML pages")
    for page in pages:
        for what, address, loaded in parse(page).refs:
            checked += 1
            bad = _check_ref(page, site, what, address, loaded, allow, lambda t: parse(t).ids)
            if bad:
                problems.append(f"{page.relative_to(site)}: {bad}")
    for css in sorted(site.rglob("*.css")):
        for m in _CSS_URL.finditer(css.read_text(encoding="utf-8", errors="replace")):
            checked += 1
            bad = _check_ref(css, site, "css url", m.group(1) or m.group(2), True, allow, set)
            if bad:
                problems.append(f"{css.relative_to(site)}: {bad}")
    return problems, checked


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("site", help="the built site's folder (mkdocs build -d SITE)")
    ap.add_argument(
        "--allow-network",
        action="append",
        metavar="SUBSTRING",
        help="allow network loads whose address contains SUBSTRING (repeatable; "
        f"default: {', '.join(DEFAULT_ALLOW)})",
    )
    a = ap.parse_args(argv)
    allow = tuple(a.allow_network) if a.allow_network else DEFAULT_ALLOW
    try:
        problems, checked = check_site(a.site, allow)
    except FileNotFoundError as exc:
        print(f"check_links: {exc}", file=sys.stderr)
        return 2
    for p in problems:
        print(p)
    if problems:
        print(f"check_links: {len(problems)} problems in {checked} addresses", file=sys.stderr)
        return 1
    print(f"check_links: {checked} addresses, all resolve offline")
    return 0


if __name__ == "__main__":
    sys.exit(main())
