"""One-line notes to the user, through the standard :mod:`logging` module (logger ``tiseg``).

A note says that tiseg did something the user may not expect but that is not an error (e.g.
dropping output times past a shortened ``time.t_end``). With no logging configured, Python
prints it on stderr (its last-resort handler shows warnings); the command line prints it as
``tiseg: note: ...``; an application may route or silence the ``tiseg`` logger as it likes.
"""
from __future__ import annotations

import logging
import sys

logger = logging.getLogger("tiseg")


def note(message: str) -> None:
    """Tell the user ``message`` in one line."""
    logger.warning("note: %s", message)


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
