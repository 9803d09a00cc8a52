"""Messages to the user through the standard `logging` module (logger ``tiseg``).

* `note`: tiseg did something the user may not expect but that is not an error (e.g.
  dropping output times past a shortened ``time.t_end``); a warning-level record, so Python's
  last-resort handler prints it on stderr even where nothing configured logging;
* `info`: progress lines (sweeps, benchmarks); shown by the command line unless ``-q``;
* `debug`: details for ``-v``.

The command line prints them on stderr as ``tiseg: ...`` (`configure`, with the
verbosity of ``-q`` / ``-v``); stdout carries results and JSON only. Progress bars show only
on a terminal and not with ``-q`` (`bar_disable`). An application may route or silence
the ``tiseg`` logger as it likes.
"""

from __future__ import annotations

import logging
import sys

logger = logging.getLogger("tiseg")


_quiet = False


def note(message: str) -> None:
    """Tell the user ``message`` in one line."""
    logger.warning("note: %s", message)


def stderr_line(text: str) -> None:
    """One line on stderr, flushed, without the logger (where nothing configured it)."""
    sys.stderr.write(text + "\n")
    sys.stderr.flush()


def info(message: str) -> None:
    """A progress line (shown by the command line unless -q)."""
    logger.info("%s", message)


def debug(message: str) -> None:
    logger.debug("%s", message)


def bar_disable():
    """tqdm's ``disable`` for a progress bar: True with -q, else None (tqdm then switches a
    bar off itself when stderr is not a terminal: redirected into a file, a bar is a pile of
    carriage returns)."""
    return True if _quiet else None


def configure(verbosity: int = 0) -> None:
    """The command line's logging: -1 (-q) errors only, 0 notes and progress, 1 (-v) debug."""
    global _quiet
    cli_handler()
    _quiet = verbosity < 0
    logger.setLevel(
        logging.ERROR if verbosity < 0 else logging.INFO if verbosity == 0 else logging.DEBUG
    )


class _Stderr(logging.Handler):
    """Writes to whatever sys.stderr is at the time (a test's capture, a redirected stream)."""

    def emit(self, record):
        try:
            sys.stderr.write(self.format(record) + "\n")
        except Exception:
            self.handleError(record)


def cli_handler() -> None:
    """Print the ``tiseg`` logger's messages on stderr as ``tiseg: ...`` (once per process)."""
    if any(isinstance(h, _Stderr) for h in logger.handlers):
        return
    h = _Stderr()
    h.setFormatter(logging.Formatter("tiseg: %(message)s"))
    logger.addHandler(h)
