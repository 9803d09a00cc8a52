"""Errors that mean "the user asked for something we cannot do".

The command line turns a `TisegError` into one line on stderr and a non-zero exit code;
anything else is a bug and is allowed to show its traceback.
"""


class TisegError(Exception):
    """A user mistake or an impossible request (bad input, no steady state, no GPU, ...)."""


class InputError(TisegError, ValueError):
    """A value given by the user is outside what is allowed; the message names key, value and rule."""


def require(condition: bool, message: str) -> None:
    """Raise `InputError` with ``message`` unless ``condition`` holds."""
    if not condition:
        raise InputError(message)


class RunInterrupted(TisegError):
    """SIGTERM or SIGINT stopped a run at a step boundary; ``exit_code`` is 128 + the signal."""

    def __init__(self, message: str, signum: int):
        super().__init__(message)
        self.signum = signum
        self.exit_code = 128 + signum
