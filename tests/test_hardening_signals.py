"""Ctrl-C and SIGTERM while Taichi defines and compiles kernels (issue 48, item 12).

Each test runs `tiseg run` in a child process that sends itself a real signal (os.kill) at
the moment that went wrong: inside the ``try`` of Taichi's kernel decorator, whose bare
``except: pass`` swallowed the KeyboardInterrupt (the run then finished with status 0), and
twice inside Taichi's compiler, which turned the second SIGTERM's stop into a
TaichiCompilationError traceback."""

from __future__ import annotations

import subprocess
import sys

TINY = [
    "--set=domain.resolution=40",
    "--set=domain.Lx=0.3",
    "--set=domain.Ly=0.1",
    "--set=time.t_end=0.1",
    "--set=output.times=[]",
    "--no-progress",
]

# sends SIGNAL to the child itself, COUNT times, at the N-th call of a function Taichi calls
# inside a try block (patched at the module it is looked up in)
CHILD = """
import os, signal, sys
import {module} as where
real = where.{name}
calls = [0]

def spy(*a, **k):
    calls[0] += 1
    if calls[0] == {n}:
        for _ in range({count}):
            os.kill(os.getpid(), signal.{signal})
    return real(*a, **k)

where.{name} = spy
from tiseg.apps.cli import main
status = main({argv!r})
print("calls", calls[0], file=sys.stderr)
sys.exit(status)
"""


def _child(tmp_path, module, name, n, signal, count=1):
    argv = ["run", "fingers", "--out", str(tmp_path / "run"), *TINY]
    code = CHILD.format(module=module, name=name, n=n, count=count, signal=signal, argv=argv)
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)


def test_ctrl_c_while_taichi_defines_kernels_is_not_swallowed(tmp_path):
    """The signal arrives inside `inspect.getframeinfo`, which Taichi's kernel decorator calls
    under a bare except: the run went on to the end and exited 0."""
    res = _child(tmp_path, "inspect", "getframeinfo", 20, "SIGINT")
    assert "calls" in res.stderr and int(res.stderr.split("calls")[-1]) >= 20, res.stderr
    assert res.returncode == 130, res.stderr
    assert res.stderr.splitlines()[0] == "tiseg: interrupted", res.stderr
    assert "Traceback" not in res.stderr
    assert not (tmp_path / "run" / "fields.nc").exists()


def test_sigterm_while_taichi_defines_kernels_is_one_line(tmp_path):
    res = _child(tmp_path, "inspect", "getframeinfo", 20, "SIGTERM")
    assert res.returncode == 143, res.stderr
    first = res.stderr.splitlines()[0]
    assert first == "tiseg run: stopped by SIGTERM before the run began; nothing was written"


COMPILING = """
import os, signal, sys
import taichi.lang.ast.ast_transformer_utils as utils
import tiseg.run.simulation as S

real_pos, real_step = utils.ASTTransformerContext.get_pos_info, S.Simulation.step
calls, stepping = [0], [False]

def pos_info(self, node):  # called inside the try of Taichi's AST builder
    if stepping[0]:
        calls[0] += 1
        if calls[0] == 50:
            os.kill(os.getpid(), signal.SIGTERM)
            os.kill(os.getpid(), signal.SIGTERM)
    return real_pos(self, node)

def step(self, *a, **k):  # the first step compiles the step's kernels
    stepping[0] = True
    return real_step(self, *a, **k)

utils.ASTTransformerContext.get_pos_info = pos_info
S.Simulation.step = step
from tiseg.apps.cli import main
status = main({argv!r})
print("calls", calls[0], file=sys.stderr)
sys.exit(status)
"""


def test_two_sigterms_while_taichi_compiles_are_one_line(tmp_path):
    """Two SIGTERMs inside Taichi's AST builder as the first step's kernels compile: the second
    one's stop became a TaichiCompilationError traceback with status 1."""
    argv = ["run", "fingers", "--out", str(tmp_path / "run"), *TINY]
    res = subprocess.run(
        [sys.executable, "-c", COMPILING.format(argv=argv)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert "Traceback" not in res.stderr and "TaichiCompilationError" not in res.stderr, res.stderr
    assert res.returncode == 143, res.stderr
    assert "stopped at once by a second SIGTERM" in res.stderr.splitlines()[0], res.stderr
    assert int(res.stderr.split("calls")[-1]) >= 50  # the signals came while it compiled


# a real SIGINT at the moment the console script's entry begins to import the command line
EARLY = """
import importlib.abc, os, signal, sys

class Interrupt(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path=None, target=None):
        if name == "tiseg.apps.cli":
            os.kill(os.getpid(), signal.SIGINT)
        return None

sys.meta_path.insert(0, Interrupt())
from tiseg.__main__ import main
sys.exit(main(["--version"]))
"""


def test_ctrl_c_while_the_command_line_is_imported_is_one_line():
    """Ctrl-C 0.05 s after the start lands in the command line's imports, before any handler
    of tiseg could be in place: the console script's entry (tiseg.__main__.main, light to
    import) turns it into one line and status 130, not a traceback."""
    import signal

    # as from a terminal: a parent started in the background (`cmd &` in a script) ignores
    # SIGINT, and Python then keeps ignoring it
    r = subprocess.run(
        [sys.executable, "-c", EARLY],
        capture_output=True,
        text=True,
        timeout=60,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    assert r.returncode == 130, r.stderr
    assert r.stderr.strip() == "tiseg: interrupted", r.stderr
    import tomllib
    from pathlib import Path

    meta = tomllib.loads((Path(__file__).parents[1] / "pyproject.toml").read_text())
    assert meta["project"]["scripts"]["tiseg"] == "tiseg.__main__:main"
