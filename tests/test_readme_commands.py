"""Every shell command of the README and the documentation runs as written.

The commands are taken from the ```bash blocks of README.md and docs/*.md (and the Python
examples from their ```python blocks), in the order a reader meets them: the blocks of one page
run one after another in one empty folder, so a command may use what an earlier one on the
same page wrote (`tiseg fingers runs/f250` after `tiseg run ... --out runs/f250`). `.venv/bin/`
stands for the interpreter running this test, and `tiseg ARGS` is the function behind the console
script that pyproject.toml declares, `main(ARGS)`, called in this process (so that Taichi and the
kernels compiled for one command serve the next; the Python examples run here too). A command
that appears again on a later page, word for word, is not run twice.

Every command must match one rule of RULES below, or this test fails: a new command in the
docs is run or explicitly excused, never skipped silently. A rule either runs the command
(made tiny where a full run takes minutes; each such change is stated in the rule and touches
only the grid, the end time or the demo's size, never what the command does), or, where it
cannot run here, says why and checks it as far as it can: every `tiseg` command is parsed by
the real command-line parser (a wrong option, choice or command name fails), an extra named in
`pip install -e ".[...]"` must exist in pyproject.toml, and other tools must accept their
options.
"""

from __future__ import annotations

import importlib
import os
import re
import shlex
import subprocess
import sys
import tomllib
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text())
CLI_MODULE = PYPROJECT["project"]["scripts"]["tiseg"].split(":")[0]
ENV = dict(
    os.environ,
    PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]).rstrip(os.pathsep),
    TI_SKIP_VERSION_CHECK="ON",
    ENABLE_TAICHI_HEADER_PRINT="0",
    MPLBACKEND="Agg",
)
TIMEOUT = 120

# tiny runs: the grid and the end time only (a full run of the fingers scene takes minutes)
TINY_RESOLUTION = 40  # cells per metre, for the scenes sized by domain.resolution in metres
TINY_T_END = "0.25"  # seconds: a few dozen steps, output written, diagnostics and all
SCENES_BY_RESOLUTION = ("fingers", "finite-release", "finite-release-deposit", "monodisperse-front")


def _blocks(path: Path, lang: str) -> list[str]:
    """The bodies of the fenced code blocks of one language in a markdown file."""
    pat = re.compile(rf"^([ \t]*)```{lang}[ \t]*\n(.*?)^\1```", re.M | re.S)
    return [
        "\n".join(ln[len(m.group(1)) :] for ln in m.group(2).splitlines())
        for m in pat.finditer(path.read_text())
    ]


def _commands(block: str) -> list[list[str]]:
    """The simple commands of a bash block: continuation lines joined, comments dropped, `&&`
    chains split. Other shell syntax (pipes, redirection, `;`) is refused: add support here."""
    out = []
    for line in block.replace("\\\n", " ").splitlines():
        lex = shlex.shlex(line, posix=True, punctuation_chars=True)
        lex.whitespace_split, lex.commenters = True, "#"
        tokens = list(lex)
        bad = [t for t in tokens if set(t) <= set("|&;<>()") and t != "&&"]
        assert not bad, f"shell syntax {bad} in {line!r}: teach tests/test_readme_commands.py"
        cmd: list[str] = []
        for t in [*tokens, "&&"]:
            if t == "&&":
                if cmd:
                    out.append(cmd)
                cmd = []
            else:
                cmd.append(t)
    return out


def _page_commands(path: Path) -> list[list[str]]:
    return [c for b in _blocks(path, "bash") for c in _commands(b)]


def _program(cmd: list[str]) -> str:
    return cmd[0].removeprefix(".venv/bin/")


def _set(args: list[str], key: str, value, add: bool) -> list[str]:
    """``args`` with ``--set key=...`` given ``value`` (added if absent and ``add``)."""
    out, found = [], False
    for i, a in enumerate(args):
        if i and args[i - 1] == "--set" and a.startswith(f"{key}="):
            a, found = f"{key}={value}", True
        out.append(a)
    return out if found or not add else [*out, "--set", f"{key}={value}"]


def _tiny_scene_run(args: list[str]) -> list[str]:
    """`tiseg run|estimate SCENE ...`: at most TINY_RESOLUTION cells per metre (scenes sized in
    metres) and TINY_T_END seconds (runs only)."""
    scene = args[1]
    given = any(a.startswith("domain.resolution=") for a in args)
    if scene in SCENES_BY_RESOLUTION or given:
        args = _set(args, "domain.resolution", TINY_RESOLUTION, add=True)
    if args[0] == "run":
        args = _set(args, "time.t_end", TINY_T_END, add=True)
    return args


@dataclass
class Rule:
    """How one kind of command is checked: ``run(args)`` gives the argv to run (None: not run,
    with ``reason``); ``check`` is the lighter check of a command that is not run."""

    pattern: str  # a regular expression on the command as written
    run: object = None
    reason: str = ""


TISEG_RULES = [
    Rule(
        r"^tiseg demo\b",
        lambda a: [*a, "--resolution", str(TINY_RESOLUTION), "--t-end", TINY_T_END],
        "the demo at 200 cells/m to 7.5 s takes about a minute: run at 40 cells/m to 0.25 s, "
        "every part of it (run, movie, figures 8-14, finger diagnostics)",
    ),
    Rule(r"^tiseg (run|estimate) ", _tiny_scene_run, "tiny grid and end time, see _tiny_scene_run"),
    Rule(r"^tiseg sweep \S+ --check\b", lambda a: a),
    Rule(
        r"^tiseg sweep ",
        None,
        "starts a Dask cluster and runs every member (20 s for the tiny sweep on 2 cores); "
        "tests/test_sweep.py runs the built-in sweeps",
    ),
    Rule(
        r"^tiseg calibrate ",
        None,
        "starts a Dask cluster and runs a search of several members; tests/test_calibration.py "
        "recovers a friction coefficient this way (slow set) and checks the search on stand-ins",
    ),
    Rule(
        r"^tiseg bench (throughput|accuracy|steppers)\b",
        None,
        "a benchmark: minutes even with --quick; tests/test_bench.py runs each on tiny cases",
    ),
    Rule(r"^tiseg view\b", None, "opens a window; tests/test_viewer.py drives it under Xvfb"),
    Rule(
        r"^python -m (tiseg\.apps\.)?viewer\b",
        None,
        "the viewer's window without the CLI; tests/test_viewer.py drives it under Xvfb",
    ),
    Rule(r"^tiseg .*--help\b", lambda a: a),
    Rule(
        r"^tiseg render runs/sweeps/",
        None,
        "draws the probability.nc of a sweep, which the page's sweep (not run here) writes; "
        "tests/test_sweep_probability.py renders one",
    ),
    Rule(
        r"^tiseg fingers \S+ --time ",
        lambda a: [*a[: a.index("--time") + 1], TINY_T_END, *a[a.index("--time") + 2 :]],
        "the time asked for is that of the full run; the tiny run's last time is TINY_T_END",
    ),
    Rule(r"^tiseg --version$", lambda a: a),
    Rule(r"^tiseg (fingers|render|steady|stability|scenes)\b", lambda a: a),
]
OTHER_RULES = [
    Rule(r"^python3 -m venv \S+$", None, "a new virtual environment: the test runs in one"),
    Rule(r"^pip install -e \S+$", None, "installs from the network; the extras are checked"),
    Rule(r"^python -m pytest\b", None, "the test suite itself; the options are checked"),
    Rule(r"^mkdocs (build|serve)\b", None, "builds the site with every example (minutes), CI"),
]


def _rule(cmd: list[str]) -> Rule:
    text = " ".join([_program(cmd), *cmd[1:]])
    hits = [r for r in TISEG_RULES + OTHER_RULES if re.search(r.pattern, text)]
    assert hits, f"no rule for the documented command {text!r}: add one to RULES"
    return hits[0]


def _tiseg(args: list[str], cwd: Path, monkeypatch, capsys) -> tuple[int, str]:
    """``tiseg ARGS`` run in ``cwd``: (exit status, what it wrote on stderr)."""
    main = importlib.import_module(CLI_MODULE).main
    monkeypatch.chdir(cwd)
    try:
        rc = main(args)
    except SystemExit as exc:  # argparse's errors
        rc = exc.code
    return rc, capsys.readouterr().err


def _parse(args: list[str]) -> None:
    """The real command-line parser accepts ``args`` (a wrong option or value exits 2)."""
    parser = importlib.import_module(CLI_MODULE).build_parser()
    try:
        parser.parse_args(args)
    except SystemExit as exc:
        assert exc.code == 0, f"tiseg {' '.join(args)}: the parser refuses it"


def _check_other(cmd: list[str], tmp: Path) -> None:
    """A command that is not run: check what can be checked without running it."""
    prog, args = _program(cmd), cmd[1:]
    if prog == "pip":
        m = re.fullmatch(r"\.?\[(.*)\]", args[-1].lstrip("."))
        extras = [e.strip() for e in m.group(1).split(",")] if m else []
        known = PYPROJECT["project"]["optional-dependencies"]
        assert args[:2] == ["install", "-e"] and extras, cmd
        assert set(extras) <= set(known), f"{cmd}: extras {set(extras) - set(known)} unknown"
    elif prog == "python3":
        assert (
            subprocess.run([sys.executable, "-m", "venv", "--help"], capture_output=True).returncode
            == 0
        )
    elif prog == "python" and args[:1] == ["-m"] and args[1] in ("viewer", "tiseg.apps.viewer"):
        # the viewer's own entry point: its parser must take the arguments (--help stops it)
        p = subprocess.run(
            [sys.executable, *args, "--help"], env=ENV, capture_output=True, text=True, cwd=ROOT
        )
        assert p.returncode == 0 and "usage:" in p.stdout, f"{cmd}: {p.stderr}"
    elif prog == "python":  # python -m pytest OPTIONS: the options, on an empty test file
        (tmp / "test_nothing.py").write_text("")
        p = subprocess.run(
            [sys.executable, *args, "-n", "0", "-p", "no:cacheprovider", "--co", "test_nothing.py"],
            cwd=tmp,
            env=ENV,
            capture_output=True,
            text=True,
            timeout=TIMEOUT,
        )
        assert p.returncode == 5, f"{cmd}: pytest refused the options\n{p.stdout}{p.stderr}"
    elif prog == "mkdocs":
        pytest.importorskip("mkdocs", reason="the docs extra is not installed here")
        p = subprocess.run(
            [sys.executable, "-m", "mkdocs", *args, "--help"], capture_output=True, text=True
        )
        assert p.returncode == 0, f"{cmd}: {p.stderr}"
    else:
        raise AssertionError(f"no check for {cmd}")


def _page_id(path: Path) -> str:
    return path.relative_to(ROOT).as_posix()


def test_the_pages_hold_the_commands_this_test_expects():
    """The extraction works: the README's two commands are found, the set-up chain split."""
    readme = _page_commands(ROOT / "README.md")
    assert readme[:3] == [
        ["python3", "-m", "venv", ".venv"],
        [".venv/bin/pip", "install", "-e", ".[test,sweep]"],
        [".venv/bin/tiseg", "demo", "--out", "runs/demo"],
    ]
    assert [".venv/bin/python", "-m", "pytest", "-q"] in readme
    assert _blocks(ROOT / "README.md", "python"), "the README's Python example is gone"
    assert _commands("a x \\\n  --y 1  # note\n\nb && c 'd # e'") == [
        ["a", "x", "--y", "1"],
        ["b"],
        ["c", "d # e"],
    ]


def test_every_tiseg_command_parses():
    """Every documented `tiseg` command, run or not, is accepted by the parser as written."""
    for page in PAGES:
        for cmd in _page_commands(page):
            if _program(cmd) == "tiseg" and "--help" not in cmd:
                _parse(cmd[1:])


RAN: set[tuple[str, ...]] = set()  # commands run already, by any page


@pytest.mark.parametrize("page", [p for p in PAGES if _page_commands(p)], ids=_page_id)
def test_page_commands_run_as_written(page, tmp_path, monkeypatch, capsys):
    for cmd in _page_commands(page):
        rule = _rule(cmd)
        if _program(cmd) != "tiseg":
            _check_other(cmd, tmp_path)
            continue
        if rule.run is None:
            assert rule.reason  # not run: parsed by test_every_tiseg_command_parses
            continue
        args = rule.run(list(cmd[1:]))
        if tuple(args) in RAN:
            continue
        RAN.add(tuple(args))
        rc, err = _tiseg(args, tmp_path, monkeypatch, capsys)
        assert rc == 0, f"{page.name}: tiseg {' '.join(args)} exited {rc}\n{err[-3000:]}"


def _tiny_python(src: str) -> str:
    """A Python example with the fingers grid at TINY_RESOLUTION and the end time at TINY_T_END
    (the README's runs 250 cells/m to 3 s, half a minute); nothing else changes."""
    src = re.sub(r'("domain\.resolution":\s*)[0-9.]+', rf"\g<1>{TINY_RESOLUTION}", src)
    return re.sub(r'("time\.t_end":\s*)[0-9.]+', rf"\g<1>{TINY_T_END}", src)


@pytest.mark.parametrize(
    "page", [p for p in PAGES if p.name in ("README.md", "index.md")], ids=_page_id
)
def test_python_examples_run(page, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    for i, src in enumerate(_blocks(page, "python")):
        if ("python", src) in RAN:  # the same example on an earlier page
            continue
        RAN.add(("python", src))
        exec(compile(_tiny_python(src), f"{page.name}, Python block {i + 1}", "exec"), {})
        assert (tmp_path / "runs").is_dir()  # each example writes a run folder


def _slug(heading: str) -> str:
    """The anchor MkDocs gives a heading (Python-Markdown's default slugify)."""
    import unicodedata

    text = unicodedata.normalize("NFKD", heading).encode("ascii", "ignore").decode()
    text = re.sub(r"[^\w\s-]", "", text).strip().lower()
    return re.sub(r"[-\s]+", "-", text)


def test_readme_links_name_files_and_headings():
    """Every relative link and picture of the README names a file of the repository, and a
    `docs/PAGE.md#anchor` link names a heading of that page (the site's link checker sees
    only the site, not the README)."""
    readme = (ROOT / "README.md").read_text()
    links = re.findall(r"!?\[[^\]]*\]\(([^)\s]+)\)", readme)
    assert len(links) >= 10
    for target in links:
        if re.match(r"^[a-z]+:", target):
            continue
        path, _, anchor = target.partition("#")
        assert (ROOT / path).is_file(), f"README links to {path}, which is not a file"
        if anchor:
            text = (ROOT / path).read_text()
            slugs = {_slug(h) for h in re.findall(r"^#+\s+(.*?)\s*$", text, re.M)}
            assert anchor in slugs, f"README links to {target}: no such heading in {path}"
