"""Broken environments around the command line (issue 31): Taichi's kernel cache folder, movies
that cannot be written, symbolic links at render's outputs, and the top-level error handling
(interrupts during imports, a deleted working folder, a closed stdout).

Most tests run tiseg in a child process, because what they guard against kills the process
(SIGABRT, SIGSEGV) or depends on its environment variables and start-up."""

import os
import subprocess
import sys

import pytest

from tiseg import backend
from tiseg.errors import TisegError

# Taichi initialised in a child process, one tiny kernel compiled and run (which fills the cache)
TINY_TAICHI = (
    "import tiseg, taichi as ti; tiseg.init('cpu', 'f64'); "
    "f = ti.field(float, shape=2); f[1] = 2.0; print(f.to_numpy()[1])"
)


def _env(tmp_path, drop=(), **extra):
    """This process's environment without ``drop``, with its own temp folder (the fallback
    cache lands there, not in the machine's /tmp) and ``extra``."""
    env = {k: v for k, v in os.environ.items() if k not in drop}
    env.pop("TI_OFFLINE_CACHE_FILE_PATH", None)
    env["TMPDIR"] = str(tmp_path)
    env.update(extra)
    return env


def _python(code, env, **kw):
    return subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120, **kw
    )


def _fallback_cache(tmp_path):
    return tmp_path / f"tiseg-{os.getuid()}" / "taichi" / "ticache"


# ------------------------------------------------------------------- Taichi's kernel cache
def test_taichi_without_home_uses_a_temp_cache(tmp_path):
    """With neither HOME nor XDG_CACHE_HOME, loading Taichi aborted the process (exit 134)."""
    res = _python(TINY_TAICHI, _env(tmp_path, drop=("HOME", "XDG_CACHE_HOME")))
    assert res.returncode == 0, res.stderr[-2000:]
    assert res.stdout.strip() == "2.0"
    assert any(_fallback_cache(tmp_path).iterdir())  # the kernels were cached there


def test_taichi_with_an_unwritable_cache_exits_cleanly(tmp_path):
    """HOME (and so ~/.cache/taichi) under a regular file, which even root cannot make a folder
    of: a finished run printed its result and then crashed at exit (SIGSEGV, 139)."""
    home = tmp_path / "home-is-a-file"
    home.write_text("")
    res = _python(TINY_TAICHI, _env(tmp_path, drop=("XDG_CACHE_HOME",), HOME=str(home)))
    assert res.returncode == 0, res.stderr[-2000:]
    assert res.stdout.strip() == "2.0"
    assert any(_fallback_cache(tmp_path).iterdir())


def test_cache_folder_choice(tmp_path, monkeypatch):
    blocked = tmp_path / "file"
    blocked.write_text("")
    monkeypatch.setenv("TMPDIR", str(tmp_path))
    monkeypatch.setattr("tempfile.tempdir", None)  # gettempdir() reads TMPDIR again
    monkeypatch.delenv("TI_OFFLINE_CACHE_FILE_PATH", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert backend.cache_folder() == str(tmp_path / "xdg" / "taichi" / "ticache")
    # a chosen folder is used when it can be written, passed over when not
    monkeypatch.setenv("TI_OFFLINE_CACHE_FILE_PATH", str(tmp_path / "mine"))
    assert backend.cache_folder() == str(tmp_path / "mine")
    monkeypatch.setenv("TI_OFFLINE_CACHE_FILE_PATH", str(blocked / "mine"))
    monkeypatch.setenv("XDG_CACHE_HOME", str(blocked))
    assert backend.cache_folder() == str(_fallback_cache(tmp_path))
    # nothing writable at all: one line that says what to do
    monkeypatch.setattr(backend, "_private_temp_dir", lambda: str(blocked))
    with pytest.raises(TisegError, match="TI_OFFLINE_CACHE_FILE_PATH"):
        backend.cache_folder()
