"""`tiseg` command line: one sub-command per module in :mod:`tiseg.commands`.

User mistakes (:class:`tiseg.errors.TisegError`) end in one line on stderr and exit status 2;
anything else is a bug and shows its traceback.
"""

from __future__ import annotations

import argparse
import importlib
import sys

from .errors import RunInterrupted, TisegError

# Sub-command modules, each with ``register(subparsers)``; imported lazily so that
# `tiseg steady` does not pay for importing Taichi.
COMMAND_MODULES = [
    "steady",
    "stability",
    "figures",
    "run",
    "fingers",
    "render",
    "view",
    "demo",
    "sweep",
    "bench",
    "estimate",
]


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # argparse's own errors: one line (no usage block), exit 2
        sys.stderr.write(f"{self.prog}: error: {message} (see '{self.prog} --help')\n")
        raise SystemExit(2)


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="tiseg",
        description=(
            "tiseg: segregation-induced finger formation in granular avalanches "
            "(Baker, Johnson & Gray 2016). Run `tiseg COMMAND --help` for each command."
        ),
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True
    from . import __version__

    parser.add_argument("--version", action="version", version=f"tiseg {__version__}")
    _verbosity_options(parser, 0)
    for name in COMMAND_MODULES:
        try:
            mod = importlib.import_module(f"tiseg.commands.{name}")
        except ModuleNotFoundError as exc:
            if exc.name == f"tiseg.commands.{name}":
                continue  # command not built yet
            raise
        mod.register(sub)
    for p in _subparsers(parser):  # -q / -v also after the command's name
        _verbosity_options(p, argparse.SUPPRESS)
    return parser


def _verbosity_options(p, default) -> None:
    g = p.add_argument_group("messages")
    g.add_argument(
        "-q",
        "--quiet",
        dest="quiet",
        action="store_true",
        default=default,
        help="only results and errors: no notes, progress lines or bars",
    )
    g.add_argument(
        "-v",
        "--verbose",
        dest="verbose",
        action="count",
        default=default,
        help="more detail on stderr",
    )


def _subparsers(parser):
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for p in action.choices.values():
                yield p
                yield from _subparsers(p)


def main(argv: list[str] | None = None) -> int:
    from .log import configure

    parser = build_parser()
    args = parser.parse_args(argv)
    configure(-1 if getattr(args, "quiet", False) else min(int(getattr(args, "verbose", 0)), 1))
    try:
        result = args.func(args)
    except RunInterrupted as exc:
        sys.stderr.write(f"tiseg {args.command}: {exc}\n")
        return exc.exit_code
    except TisegError as exc:
        sys.stderr.write(f"tiseg {args.command}: error: {exc}\n")
        return 2
    except KeyboardInterrupt:
        sys.stderr.write("tiseg: interrupted\n")
        return 130
    return int(result or 0)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
