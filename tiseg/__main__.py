"""``python -m tiseg`` and the ``tiseg`` console script: the command line
(`tiseg.apps.cli.main`), imported only when `main` runs.

The console script calls `main` after importing this module and `tiseg` alone, which import
nothing heavy: Ctrl-C during the slow imports of the command line (NumPy, Taichi) then ends in
one line and status 130, as everywhere after them. With the console script pointing at
`tiseg.apps.cli.main`, those imports ran before any handler of tiseg, and a Ctrl-C 0.05 s
after the start ended in a traceback."""

import sys


def main(argv: list[str] | None = None) -> int:
    """The command line's exit status."""
    try:
        from tiseg.apps.cli import main as cli_main
    except KeyboardInterrupt:
        sys.stderr.write("tiseg: interrupted\n")
        return 130
    return cli_main(argv)


def build_parser():
    """The command line's argument parser (`tiseg.apps.cli.build_parser`)."""
    from tiseg.apps.cli import build_parser as build

    return build()


if __name__ == "__main__":
    sys.exit(main())
