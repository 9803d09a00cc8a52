"""Every command's ``--help`` ends with an examples section whose command lines work: they
parse, and the scenes, sweeps and ``--set`` overrides they name load and validate."""

from __future__ import annotations

import shlex

import pytest

from tiseg.apps import examples
from tiseg.apps.cli import build_parser
from tiseg.apps.cli_reference import _children
from tiseg.apps.sweep.spec import list_builtin_sweeps
from tiseg.setup.reading import list_builtin_scenes, load_scene

PARSER = build_parser()
COMMANDS = dict(_children(PARSER))


def _argv(line: str) -> list[str]:
    words = shlex.split(line)
    if ">" in words:  # a shell redirection is not the command's
        words = words[: words.index(">")]
    assert words[0] == "tiseg"
    return words[1:]


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_help_has_examples_that_parse(name):
    text = COMMANDS[name].format_help()
    assert "\nexamples:\n" in text
    lines = examples.command_lines(COMMANDS[name])
    assert len(lines) >= 2
    for line in lines:
        assert line in " ".join(text.replace("\\\n", " ").split()), line  # shown as declared
        args = PARSER.parse_args(_argv(line))
        assert args.command == name, line
        scene = getattr(args, "scene", None)
        if scene is not None and not scene.endswith(".toml"):
            assert scene in list_builtin_scenes(), line
            load_scene(scene, getattr(args, "overrides", None) or getattr(args, "set", None))
        sweep = getattr(args, "sweep", None)
        if isinstance(sweep, str):
            assert sweep in list_builtin_sweeps(), line


def _nested(parser, prog):
    for name, sub in _children(parser):
        yield f"{prog} {name}", sub
        yield from _nested(sub, f"{prog} {name}")


@pytest.mark.parametrize("prog", sorted(p for p, _ in _nested(PARSER, "tiseg") if p.count(" ") > 1))
def test_every_sub_command_shows_the_examples_that_use_it(prog):
    """`tiseg bench throughput --help` ends with the bench examples of throughput, and so on
    for every sub-command: each has at least one."""
    sub = dict(_nested(PARSER, "tiseg"))[prog]
    lines = examples.command_lines(sub)
    assert lines and all(f"{line} ".startswith(f"{prog} ") for line in lines), prog
    assert "\nexamples:\n" in sub.format_help()


def test_a_stale_example_would_be_caught():
    """What the test above relies on: an unknown option or scene key is refused."""
    with pytest.raises(SystemExit):
        PARSER.parse_args(_argv("tiseg run fingers --no-such-option"))
    with pytest.raises(Exception, match="no_such_key"):
        load_scene("fingers", ["domain.no_such_key=1"])


def test_long_example_lines_break_before_options():
    text = examples.epilog([("tiseg run fingers " + "--set flow.nu=0.001 " * 6, "x")])
    lines = text.splitlines()
    assert all(len(line) <= 80 for line in lines)
    assert all(line.endswith("\\") for line in lines[1:-2])  # continued, as a shell reads it
    assert all(line.strip().startswith("--set ") for line in lines[2:-1])  # an option, a value
    command = "tiseg run fingers " + " ".join(["--set flow.nu=0.001"] * 6)
    assert examples.command_lines_from(text) == [command]
