"""The command-line reference, generated from the argparse parser (for the documentation site):
one section per command and sub-command with its ``--help`` text, so the page lists exactly
the options the installed ``tiseg`` accepts."""

from __future__ import annotations

import argparse
import os
from .cli import build_parser


def _children(parser: argparse.ArgumentParser):
    """(name, parser) of each sub-command, in the order they were registered."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            yield from action.choices.items()


def markdown() -> str:

    old = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = "78"  # argparse wraps at COLUMNS - 2: 76 characters fit
    # a code block of the site at page width, with no scroll bar
    try:
        root = build_parser()
        lines = [
            "# Command-line reference",
            "",
            "*Generated from the argparse parser of `tiseg` (`tiseg.apps.cli_reference`): the "
            "same text as `tiseg COMMAND --help`.*",
            "",
            "## `tiseg`",
            "",
            "```text",
            root.format_help().rstrip(),
            "```",
            "",
        ]

        def walk(parser, prefix, depth):
            for name, sub in _children(parser):
                full = f"{prefix} {name}"
                lines.extend(
                    [
                        f"{'#' * depth} `{full}`",
                        "",
                        "```text",
                        sub.format_help().rstrip(),
                        "```",
                        "",
                    ]
                )
                walk(sub, full, min(depth + 1, 4))

        walk(root, "tiseg", 2)
    finally:
        if old is None:
            os.environ.pop("COLUMNS", None)
        else:
            os.environ["COLUMNS"] = old
    return "\n".join(lines) + "\n"
