"""What a package index and a citation tool read: the version written once (and repeated only
in CITATION.cff, where it must agree), the metadata of pyproject.toml, no placeholder URLs."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

import pytest

import tiseg

ROOT = Path(__file__).resolve().parents[1]


def _text(name: str) -> str:
    path = ROOT / name
    if not path.is_file():
        pytest.skip(f"{name} is not here (an installed wheel)")
    return path.read_text(encoding="utf-8")


def test_the_version_is_written_once_and_citation_agrees():
    project = tomllib.loads(_text("pyproject.toml"))
    assert "version" not in project["project"] and project["project"]["dynamic"] == ["version"]
    assert project["tool"]["setuptools"]["dynamic"]["version"] == {
        "attr": "tiseg._version.__version__"
    }
    cff = re.search(r'^version:\s*"?([^"\n]+)"?\s*$', _text("CITATION.cff"), re.M)
    assert cff and cff.group(1) == tiseg.__version__
    written = [
        p.relative_to(ROOT).as_posix()
        for p in (ROOT / "tiseg").rglob("*.py")
        if re.search(r"^__version__\s*=", p.read_text(encoding="utf-8"), re.M)
    ]
    assert written == ["tiseg/_version.py"], written


def test_citation_names_the_software_and_prefers_the_paper():
    cff = _text("CITATION.cff")
    main, preferred = cff.split("\npreferred-citation:", 1)
    assert re.search(r"^type: software$", main, re.M)
    assert "tiseg" in re.search(r"^title: (.+)$", main, re.M).group(1)
    assert "type: article" in preferred and 'doi: "10.1017/jfm.2016.653"' in preferred
    assert "volume: 809" in preferred and "year: 2016" in preferred


def test_the_index_page_has_its_metadata():
    project = tomllib.loads(_text("pyproject.toml"))["project"]
    assert project["readme"] == "README.md" and (ROOT / "README.md").is_file()
    assert project["license"] == "MIT" and (ROOT / "LICENSE").is_file()
    assert "MIT License" in (ROOT / "LICENSE").read_text(encoding="utf-8")
    assert len(project["description"]) > 30 and len(project["keywords"]) >= 5
    classifiers = project["classifiers"]
    assert any(c.startswith("Topic :: Scientific/Engineering") for c in classifiers)
    # PEP 639: the licence is the SPDX expression; a licence classifier beside it is an error
    assert not any(c.startswith("License ::") for c in classifiers)
    python = re.findall(r"Programming Language :: Python :: (3\.\d+)", " ".join(classifiers))
    low, high = re.match(r">=3\.(\d+),<3\.(\d+)", project["requires-python"]).groups()
    assert python == [f"3.{m}" for m in range(int(low), int(high))]


@pytest.mark.parametrize("name", ["pyproject.toml", "CITATION.cff", "CONTRIBUTING.md"])
def test_no_placeholder_addresses(name):
    text = _text(name)
    for url in re.findall(r"https?://[^\s\"')>]+", text):
        host = url.split("/")[2]
        assert not re.search(r"example\.|localhost|your|placeholder|xxx", host, re.I), url
        assert "USER" not in url and "OWNER" not in url and "<" not in url, url


def test_the_repository_address_is_in_the_metadata_and_the_docs():
    """pip show / PyPI link the repository ([project.urls]), and the site links it (repo_url)."""
    import tomllib
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    urls = tomllib.loads((root / "pyproject.toml").read_text())["project"]["urls"]
    assert urls["Source"] == "https://github.com/tiseg/tiseg"
    assert "repo_url: https://github.com/tiseg/tiseg\n" in (root / "mkdocs.yml").read_text()
