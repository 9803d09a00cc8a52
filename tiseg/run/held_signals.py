"""Ctrl-C and SIGTERM held back while Taichi defines and compiles kernels.

Taichi's kernel decorator looks for an enclosing class with a bare ``except: pass``
(``taichi.lang.kernel_impl._inside_class``), so a KeyboardInterrupt that arrives while a module
of tiseg's kernels is being imported is swallowed, and the command runs on to its end as if the
user had not pressed Ctrl-C. `held_signals` puts tiseg's own handlers in place for such a
stretch: they only note the signal, which then acts when the stretch ends, where nothing can
swallow it.
"""

from __future__ import annotations

import contextlib
import signal
import threading

from ..errors import RunInterrupted


@contextlib.contextmanager
def held_signals(what: str = "before the run began; nothing was written"):
    """SIGINT and SIGTERM in the block are noted, and the first of them acts when the block
    ends: KeyboardInterrupt for SIGINT (the command line's "interrupted", status 130),
    `RunInterrupted` for SIGTERM (status 143, saying ``what``). An error raised in the block
    goes on as it is. Outside the main thread (where Python cannot set handlers), or when a
    handler is one Python cannot put back, the block runs with the signals as they are."""
    sigs = (signal.SIGINT, signal.SIGTERM)
    if threading.current_thread() is not threading.main_thread() or any(
        signal.getsignal(s) is None for s in sigs
    ):
        yield
        return
    caught: list[int] = []
    old = {s: signal.signal(s, lambda signum, frame: caught.append(signum)) for s in sigs}
    try:
        yield
    finally:
        for s, handler in old.items():
            signal.signal(s, handler)
    if caught:
        if caught[0] == signal.SIGINT:
            raise KeyboardInterrupt
        raise RunInterrupted(f"stopped by SIGTERM {what}", caught[0])
