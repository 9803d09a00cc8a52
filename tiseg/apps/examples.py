"""The ``examples:`` section at the end of each command's ``--help``.

Each command module declares its examples once, as ``EXAMPLES``: a list of
``(command line, what it does)`` pairs. `tiseg.apps.cli.build_parser` hands them to
`attach`, which writes them as the parser's epilog. argparse re-wraps an epilog into
one paragraph, which would run the command lines together, so the parser gets
`ExamplesFormatter`: the description and options are wrapped as before, the examples
keep their lines. ``tests/test_cli_examples.py`` parses every example line, so an option that
is renamed cannot leave a stale example behind.
"""

from __future__ import annotations

import argparse

HEADING = "examples:"


class ExamplesFormatter(argparse.HelpFormatter):
    """argparse's formatter, except that text starting with ``examples:`` keeps its lines."""

    def _fill_text(self, text, width, indent):
        if text.startswith(HEADING):
            return "\n".join(indent + line for line in text.splitlines())
        return super()._fill_text(text, width, indent)


def epilog(examples: list[tuple[str, str]]) -> str:
    """The epilog text: each command line, then what it does indented below it."""
    lines = [HEADING]
    for command, what in examples:
        lines.append("  " + " \\\n        ".join(_broken(command)))
        lines.append(f"      {what}")
    return "\n".join(lines)


def _broken(command: str, width: int = 68) -> list[str]:
    """A long command line in pieces of at most ``width`` characters where it can, broken
    (with backslashes, as a shell reads them) only before an option, so that an option stays
    on the line of its value."""
    groups: list[str] = []
    for word in command.split(" "):
        if word.startswith("-") or not groups:
            groups.append(word)
        else:
            groups[-1] += " " + word
    pieces = [groups[0]]
    for group in groups[1:]:
        if len(pieces[-1]) + 1 + len(group) <= width:
            pieces[-1] += " " + group
        else:
            pieces.append(group)
    return pieces


def attach(
    parser: argparse.ArgumentParser, examples: list[tuple[str, str]], prog: str = ""
) -> None:
    """Give ``parser`` (the command ``prog``, "tiseg bench") the examples section (after the
    options, as in man pages), and each of its sub-commands the examples that use it
    (``tiseg bench throughput --help`` those that start with ``tiseg bench throughput``)."""
    parser.epilog = epilog(examples)
    parser.formatter_class = ExamplesFormatter
    for action in parser._actions:
        if not isinstance(action, argparse._SubParsersAction):
            continue
        for name, sub in action.choices.items():
            full = f"{prog} {name}"
            mine = [e for e in examples if f"{e[0]} ".startswith(f"{full} ")]
            if mine:
                attach(sub, mine, full)


def command_lines(parser: argparse.ArgumentParser) -> list[str]:
    """The command lines of ``parser``'s examples section (empty if it has none)."""
    return command_lines_from(parser.epilog or "")


def command_lines_from(text: str) -> list[str]:
    """The command lines of an examples section's text, continuation lines joined."""
    if not text.startswith(HEADING):
        return []
    commands: list[str] = []
    continued = False
    for line in text.splitlines()[1:]:
        if continued:
            commands[-1] += " " + line.strip()
        elif line.startswith("  tiseg "):
            commands.append(line.strip())
        else:
            continue
        continued = commands[-1].endswith("\\")
        commands[-1] = commands[-1].removesuffix("\\").rstrip()
    return commands
