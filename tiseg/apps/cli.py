"""`tiseg` command line: one sub-command per module in `tiseg.apps.commands`.

User mistakes (`tiseg.errors.TisegError`) end in one line on stderr and exit status 2;
anything else is a bug and shows its traceback.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys

from ..errors import RunInterrupted, TisegError
from .._version import __version__
from ..log import configure
from . import examples

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
    "calibrate",
    "bench",
    "estimate",
    "scenes",
]


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # argparse's own errors: one line (no usage block), exit 2
        hint = _set_hint(sys.argv[1:] if _ARGV is None else _ARGV)
        sys.stderr.write(f"{self.prog}: error: {message}{hint} (see '{self.prog} --help')\n")
        raise SystemExit(2)


_ARGV: list[str] | None = None  # the arguments main() parses (None: sys.argv)


def _set_hint(argv: list[str]) -> str:
    """'; did you mean --set K=V?' where ``--set K V`` was given: --set takes one word."""
    for i in range(len(argv) - 2):
        key, value = argv[i + 1], argv[i + 2]
        if argv[i] == "--set" and "=" not in key and not value.startswith("-"):
            return f"; did you mean --set {key}={value}? (--set KEY=VALUE)"
    return ""


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

    parser.add_argument("--version", action="version", version=f"tiseg {__version__}")
    _verbosity_options(parser, 0)
    for name in COMMAND_MODULES:
        try:
            mod = importlib.import_module(f"tiseg.apps.commands.{name}")
        except ModuleNotFoundError as exc:
            if exc.name == f"tiseg.apps.commands.{name}":
                continue  # command not built yet
            raise
        mod.register(sub)
        if getattr(mod, "EXAMPLES", None):
            examples.attach(sub.choices[name], mod.EXAMPLES, f"tiseg {name}")
    for p in _subparsers(parser):  # -q / -v also after the command's name
        _verbosity_options(p, argparse.SUPPRESS)
        _short_choice_lists(p)
    return parser


def _short_choice_lists(p: argparse.ArgumentParser) -> None:
    """An option that takes several words from a list (``--steppers rkc euler``) shows NAME in
    the usage, and the list once, in its help: argparse writes the list twice per mention, a
    line of 200 characters that no terminal or page shows whole."""
    for action in p._actions:
        if action.choices is None or action.metavar is not None or action.nargs not in ("+", "*"):
            continue
        if isinstance(action, argparse._SubParsersAction):
            continue
        words = ", ".join(map(str, action.choices))
        action.metavar = "NAME"
        action.help = f"{action.help}; one or more of {words}" if action.help else words


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
    """The command line; its exit status. Ctrl-C at any time after ``import tiseg`` (which
    imports nothing heavy, so that this handler is in place before the slow imports) ends in
    one line and status 130, a reader that closes the pipe early (``| head``) in silence."""
    guard = None
    try:
        _usable_std_streams()
        # Taichi takes a sys.stdout that is not sys.__stdout__ for a notebook's and then
        # copies its kernels' print buffer after every kernel call: the guard is no notebook
        os.environ.setdefault("TI_ENABLE_PYBUF", "0")
        guard = sys.stdout = _StdoutGuard(sys.stdout)
        try:
            os.getcwd()  # Taichi and relative paths need it
        except OSError:
            sys.stderr.write(
                "tiseg: error: the current folder no longer exists (or cannot be read); "
                "cd into one that does\n"
            )
            return 2
        status = _main(argv)
        sys.stdout.flush()  # a closed pipe shows here, not as a traceback at exit
        return status
    except KeyboardInterrupt:
        sys.stderr.write("tiseg: interrupted\n")
        return 130
    except BrokenPipeError:
        # as Python's documentation of SIGPIPE advises: stdout to /dev/null, so that the
        # interpreter's own flush at exit raises nothing again, and exit status 1
        null = os.open(os.devnull, os.O_WRONLY)
        os.dup2(null, sys.stdout.fileno())
        return 1
    except StdoutError as exc:  # the final flush
        sys.stderr.write(f"tiseg: error: {exc}\n")
        return 2
    finally:
        if guard is not None and sys.stdout is guard:
            sys.stdout = guard.stream


class StdoutError(TisegError):
    """Standard output cannot take what tiseg prints (a full disk, ``> /dev/full``)."""


class _StdoutGuard:
    """sys.stdout for the length of a command: a write or flush that fails with an OSError
    (other than a closed pipe, which `main` handles) becomes a `StdoutError`, one line like any
    other error rather than a traceback. What could not be written is dropped (stdout then
    goes to /dev/null), so that the interpreter's own flush at exit does not fail again."""

    def __init__(self, stream):
        self.stream = stream

    def _failed(self, exc: OSError):
        try:
            null = os.open(os.devnull, os.O_WRONLY)
            os.dup2(null, self.stream.fileno())
            os.close(null)
        except (OSError, ValueError, AttributeError):
            pass  # not a file descriptor (a test's capture): nothing left to flush at exit
        return StdoutError(f"cannot write to standard output: {exc.strerror or exc}")

    def write(self, text):
        try:
            return self.stream.write(text)
        except BrokenPipeError:
            raise
        except OSError as exc:
            raise self._failed(exc) from None

    def writelines(self, lines):
        for line in lines:
            self.write(line)

    def flush(self):
        try:
            return self.stream.flush()
        except BrokenPipeError:
            raise
        except OSError as exc:
            raise self._failed(exc) from None

    def __getattr__(self, name):
        return getattr(self.stream, name)


def _usable_std_streams() -> None:
    """Put /dev/null on a standard descriptor that is closed (``tiseg ... >&-``): output then
    goes nowhere instead of failing, and no file opened later takes descriptor 1 or 2 (which
    would receive what is meant for stdout or stderr, from tiseg, Taichi or ffmpeg)."""
    for fd, name in ((0, "stdin"), (1, "stdout"), (2, "stderr")):
        try:
            os.fstat(fd)
        except OSError:
            null = os.open(os.devnull, os.O_RDWR)
            if null != fd:
                os.dup2(null, fd)
                os.close(null)
        if getattr(sys, name) is None:  # Python found the descriptor closed at start-up
            setattr(sys, name, open(fd, "r" if fd == 0 else "w", closefd=False))


def _undecodable(argv: list[str]) -> str | None:
    """The first argument that is not valid UTF-8 (Python keeps its bytes as lone surrogates),
    or None. NetCDF, Matplotlib and ffmpeg take file names as UTF-8 only, so such a name would
    fail deep inside a run instead of here."""
    for arg in argv:
        try:
            arg.encode("utf-8")
        except UnicodeEncodeError:
            return arg
    return None


def _main(argv: list[str] | None) -> int:

    bad = _undecodable(sys.argv[1:] if argv is None else list(argv))
    if bad is not None:
        shown = os.fsencode(bad).decode("utf-8", "backslashreplace")  # bad\xff
        sys.stderr.write(
            f"tiseg: error: the argument '{shown}' is not valid UTF-8 text; file and folder "
            "names must be (NetCDF cannot open others): rename it\n"
        )
        return 2
    global _ARGV
    _ARGV = list(argv) if argv is not None else None
    parser = build_parser()
    args = parser.parse_args(argv)
    configure(-1 if getattr(args, "quiet", False) else min(int(getattr(args, "verbose", 0)), 1))
    _renew_idle_runtime()
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


def _renew_idle_runtime() -> None:
    """Start this command on a fresh Taichi runtime when an earlier command in this process
    (``main`` called again, as scripts and tests do) made field trees and nothing holds Taichi
    fields any more. Taichi's offline cache keys hold the fields' SNode ids, which grow with
    every tree a runtime makes and start again from the same numbers only after a reset: a
    second run in a used runtime compiles its kernels again (about 2 s for a small fingers
    run), one in a fresh runtime loads them from the cache. The reset (0.1 s) keeps the
    settings in force; the first command of a process finds nothing made and skips it."""
    from .. import backend
    from ..solver import field_tree

    if field_tree.made_since_init() == 0:
        return
    if field_tree.live():
        import gc

        gc.collect()  # simulations that only reference cycles still hold
    if field_tree.live() == 0:
        st = backend.state()
        backend.init(backend.requested_arch(st.arch), st.precision, st.threads, force=True)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
