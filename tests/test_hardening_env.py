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
    # a temp folder of that name that others may write to (made by someone else) is not used,
    # also where it is Taichi's default (HOME unset)
    os.chmod(_fallback_cache(tmp_path).parents[1], 0o777)
    with pytest.raises(TisegError, match="TI_OFFLINE_CACHE_FILE_PATH"):
        backend.cache_folder()
    monkeypatch.setenv("XDG_CACHE_HOME", str(_fallback_cache(tmp_path).parents[1]))
    with pytest.raises(TisegError, match="TI_OFFLINE_CACHE_FILE_PATH"):
        backend.cache_folder()
    monkeypatch.setenv("XDG_CACHE_HOME", str(blocked))
    os.chmod(_fallback_cache(tmp_path).parents[1], 0o700)
    assert backend.cache_folder() == str(_fallback_cache(tmp_path))
    # nothing writable at all: one line that says what to do
    monkeypatch.setattr(backend, "_private_temp_dir", lambda: str(blocked))
    with pytest.raises(TisegError, match="TI_OFFLINE_CACHE_FILE_PATH"):
        backend.cache_folder()


# ------------------------------------------------------------------------ movies and frames
@pytest.fixture(scope="module")
def fake_run(tmp_path_factory):
    """A run folder with a small fields.nc of made-up snapshots (no simulation to wait for)."""
    import numpy as np

    from tiseg.output.netcdf import FieldsWriter

    out = tmp_path_factory.mktemp("fake_run")
    nx, ny = 12, 6
    x, y = (np.arange(nx) + 0.5) * 0.01, (np.arange(ny) + 0.5) * 0.01
    with FieldsWriter(out / "fields.nc", x, y) as w:
        for k in range(3):
            h = np.where(np.arange(nx)[None, :] < 4 + 3 * k, 0.004, 0.0) * np.ones((ny, 1))
            w.write(0.1 * k, h=h, u=h * 10, v=0 * h, phi=np.full((ny, nx), 0.5))
    return out


def _limit_ffmpeg_file_size(monkeypatch, limit):
    """Children started from here may write files of at most ``limit`` bytes (writes past it
    fail with EFBIG, as on a full disk), so ffmpeg cannot finish a movie."""
    import resource
    import signal

    real = subprocess.Popen

    def popen(*args, **kw):
        before = kw.get("preexec_fn")

        def small_files():
            if before is not None:
                before()
            signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # EFBIG instead of being killed
            resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

        kw["preexec_fn"] = small_files
        return real(*args, **kw)

    monkeypatch.setattr(subprocess, "Popen", popen)


def test_movie_that_cannot_be_finished_is_an_error(tmp_path, monkeypatch):
    """ffmpeg failing to write the movie (here: a file-size limit, like a full disk) was not
    noticed: "wrote", exit status 0 and an unplayable file."""
    import numpy as np

    from tiseg.post.render.movie import MovieWriter

    _limit_ffmpeg_file_size(monkeypatch, 2000)
    path = tmp_path / "m.mp4"
    noise = np.random.default_rng(1).integers(0, 256, (5, 64, 64, 3), dtype=np.uint8)
    with pytest.raises(TisegError, match=r"cannot write the movie .*m\.mp4.*: File too large"):
        with MovieWriter(path) as w:
            for frame in noise:
                w.append(frame)
    assert not path.exists()  # the broken file is removed


@pytest.mark.parametrize("kind", ["--movie", "--gif", "--frames", "--panels"])
def test_render_to_an_unwritable_place_is_one_line(ti_cpu, fake_run, tmp_path, kind, capsys):
    """A path under a regular file cannot be made; /dev/full takes no byte (ENOSPC): one line
    each, no traceback, and /dev/full is left alone. (Not --panels /dev/full: matplotlib
    adds .png to a name without a suffix.)"""
    from tiseg.apps.cli import main

    blocked = tmp_path / "file"
    blocked.write_text("")
    names = {"--movie": "x.mp4", "--gif": "x.gif", "--frames": "fr", "--panels": "p.png"}
    targets = [str(blocked / names[kind])]
    full = kind in ("--movie", "--gif") and os.path.exists("/dev/full")  # Linux
    if full:
        targets.append("/dev/full")
    for target in targets:
        assert main(["render", str(fake_run), "--field", "h", kind, target]) == 2
        err = capsys.readouterr().err
        assert err.startswith("tiseg render: error: ") and err.count("\n") == 1, err
    assert not full or not os.path.isfile("/dev/full")  # still the device


def test_run_movie_that_cannot_be_written(ti_cpu, tmp_path, monkeypatch, capsys):
    """`tiseg run --movie` on a disk that fills up: one line and exit status 2, no movie left;
    the run's own files are kept."""
    from tiseg.apps.cli import main

    _limit_ffmpeg_file_size(monkeypatch, 2000)
    movie = tmp_path / "m.mp4"
    args = ["run", "dam-break", "--set", "domain.nx=40", "--out", str(tmp_path / "run")]
    assert main([*args, "--movie", str(movie), "--movie-field", "h", "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("tiseg run: error: cannot write the movie ") and err.count("\n") == 1
    assert "File too large" in err and not movie.exists()
    assert (tmp_path / "run" / "fields.nc").is_file()


# ------------------------------------------------------------------ top-level error handling
STEADY = ["steady", "--h0", "0.005", "--phi0", "0.5", "--json"]


def _cli(argv, **kw):
    """``tiseg ARGV`` in a child process, started as the installed ``tiseg`` script starts it."""
    code = f"import sys; sys.argv = {['tiseg', *argv]!r}\n" + kw.pop("before", "")
    code += "from tiseg.apps.cli import main\nsys.exit(main())\n"
    if "stdout" not in kw:
        kw["capture_output"] = True
    return subprocess.run([sys.executable, "-c", code], text=True, timeout=120, **kw)


def test_ctrl_c_while_importing(tmp_path):
    """Ctrl-C while tiseg imports NumPy (here raised by an import hook at that moment) ends in
    one line and status 130; `import tiseg` imported NumPy before the handler was in place."""
    hook = (
        "class CtrlC:\n"
        "    def find_spec(self, name, path=None, target=None):\n"
        "        if name == 'numpy':\n"
        "            raise KeyboardInterrupt\n"
        "sys.meta_path.insert(0, CtrlC())\n"
    )
    res = _cli(STEADY, before=hook)
    assert (res.returncode, res.stderr, res.stdout) == (130, "tiseg: interrupted\n", "")


def test_deleted_working_folder_is_one_line(tmp_path, monkeypatch, capsys):
    from tiseg.apps.cli import main

    gone = tmp_path / "gone"
    gone.mkdir()
    monkeypatch.chdir(gone)
    gone.rmdir()
    assert main(["run", "dam-break", "--out", str(tmp_path / "run")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "current folder no longer exists" in err
    assert not (tmp_path / "run").exists()


def test_closed_pipe_on_stdout_is_quiet():
    """A reader that has gone (`tiseg ... | head -c0`): Python's documented exit status 1 for
    EPIPE, and no BrokenPipeError traceback."""
    read_end, write_end = os.pipe()
    os.close(read_end)  # closed before the child writes: its first write fails with EPIPE
    try:
        res = _cli(STEADY, stdout=write_end, stderr=subprocess.PIPE)
    finally:
        os.close(write_end)
    assert (res.returncode, res.stderr) == (1, "")


def test_closed_stdout_is_quiet():
    """`tiseg ... >&-`: the results go nowhere, as print() does without a stdout, no traceback."""
    res = _cli(STEADY, preexec_fn=lambda: os.close(1))
    assert (res.returncode, res.stderr) == (0, "")


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="needs Linux's /dev/full")
@pytest.mark.parametrize(
    "argv", [STEADY, ["scenes", "show", "fingers"], ["--help"], ["steady", "--help"]]
)
def test_a_full_stdout_is_one_line(argv):
    """`tiseg ... > /dev/full` (stdout on a full disk): one line and exit status 2, not an
    OSError traceback (issue 48)."""
    with open("/dev/full", "w") as full:
        res = _cli(argv, stdout=full, stderr=subprocess.PIPE)
    assert res.returncode == 2, res.stderr
    assert res.stderr.endswith("cannot write to standard output: No space left on device\n")
    assert res.stderr.count("\n") == 1, res.stderr


def test_an_argument_that_is_not_utf8_is_one_line(tmp_path):
    """`--out $'bad\\xff'`: a UnicodeEncodeError traceback from NetCDF after the run's start."""
    res = subprocess.run(
        [
            sys.executable,
            "-c",
            "import sys; from tiseg.apps.cli import main; sys.exit(main())",
            "run",
            "dam-break",
            "--out",
            os.fsencode(tmp_path) + b"/bad\xff",
        ],
        capture_output=True,
        timeout=120,
    )
    err = res.stderr.decode()
    assert res.returncode == 2 and err.count("\n") == 1, err
    assert "bad\\xff' is not valid UTF-8" in err
    assert os.listdir(tmp_path) == []


# ------------------------------------------------------------------ symbolic links at outputs
@pytest.mark.parametrize("kind", ["default movie", "--movie", "--gif", "--panels", "--frames"])
def test_render_does_not_write_through_links(fake_run, tmp_path, kind, capsys):
    """A link at an output (the default RUN/phi.mp4, a frames folder, ...) pointing outside:
    one line, and the file (or folder) it points to is left as it was."""
    from tiseg.apps.cli import main

    outside = tmp_path / "outside"
    outside.mkdir()
    victim = outside / "precious"
    victim.write_text("keep me")
    run = tmp_path / "run"
    run.mkdir()
    (run / "fields.nc").symlink_to(fake_run / "fields.nc")
    name = {"--gif": "x.gif", "--panels": "p.png", "--frames": "fr"}.get(kind, "phi.mp4")
    link = run / name
    link.symlink_to(outside if kind == "--frames" else victim)
    argv = ["render", str(run)] + ([] if kind == "default movie" else [kind, str(link)])
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "symbolic link" in err, err
    assert victim.read_text() == "keep me" and sorted(outside.iterdir()) == [victim]
    assert link.is_symlink()


def test_frames_do_not_write_through_links(ti_cpu, fake_run, tmp_path):
    from tiseg.post.render.movie import render_run

    victim = tmp_path / "precious"
    victim.write_text("keep me")
    (tmp_path / "fr").mkdir()
    (tmp_path / "fr" / "frame_00001.png").symlink_to(victim)
    with pytest.raises(TisegError, match="symbolic link"):
        render_run(fake_run, field="h", frames=tmp_path / "fr")
    assert victim.read_text() == "keep me"


# ------------------------------------------------------------------------ panels, no Taichi
def test_render_panels_needs_no_taichi(fake_run, tmp_path, monkeypatch):
    """`tiseg render --panels` drew its pictures with the Taichi kernel: it started Taichi
    (seconds, a cache folder, and the abort without HOME) for a matplotlib figure."""
    from tiseg.apps.cli import main

    def no_taichi(*args, **kw):
        raise AssertionError("render --panels used Taichi")

    monkeypatch.setattr(backend, "init", no_taichi)
    monkeypatch.setattr(backend, "state", no_taichi)  # what a kernel asks for its runtime
    assert main(["render", str(fake_run), "--panels", str(tmp_path / "p.png")]) == 0
    assert (tmp_path / "p.png").stat().st_size > 1000


def test_numpy_pictures_match_the_kernel(ti_cpu):
    """The panels' NumPy pictures are the frame kernel's, to one 8-bit level: every field, with
    and without relief shading, up- and down-scaled, 2D and 1D, empty cells and a NaN phi."""
    import numpy as np

    from tiseg.post.render import render_fields
    from tiseg.post.render.raster import render_fields_numpy

    rng = np.random.default_rng(3)
    for ny, nx in ((7, 13), (1, 20)):
        h = np.abs(rng.normal(0.0, 0.003, (ny, nx)))
        h[:, :3] = 0.0  # an empty chute
        fields = {
            "h": h,
            "phi": rng.uniform(-0.2, 1.2, (ny, nx)),
            "u": rng.normal(0.0, 1.0, (ny, nx)),
            "v": rng.normal(0.0, 1.0, (ny, nx)),
            "x": np.arange(nx) * 0.01,
            "y": np.arange(ny) * 0.01,
        }
        fields["phi"][0, 5] = np.nan
        for field in ("phi", "h", "speed", "u", "v"):
            for shade in (True, False):
                for scale, aspect in ((3, 1.0), (0.5, 0.7)):
                    kw = dict(field=field, shade=shade, scale=scale, aspect=aspect)
                    a = render_fields(fields, 1e-3, colourbar=False, **kw)
                    b = render_fields_numpy(fields, 1e-3, **kw)
                    assert a.shape == b.shape, kw
                    assert np.abs(a.astype(int) - b).max() <= 1, kw


def test_a_stale_cache_lock_is_removed_and_a_fresh_one_kept(tmp_path):
    """A process killed while it held the kernel cache's lock left ticache.lock behind, and
    every later process warned 'Lock ... failed' and compiled every kernel anew."""
    import time

    from tiseg.backend import STALE_LOCK_S, clear_stale_lock

    lock = tmp_path / "ticache.lock"
    lock.write_text("")
    assert not clear_stale_lock(str(tmp_path))  # just taken: another process may hold it
    assert lock.exists()
    old = time.time() - STALE_LOCK_S - 60
    os.utime(lock, (old, old))
    assert clear_stale_lock(str(tmp_path))
    assert not lock.exists()
    assert not clear_stale_lock(str(tmp_path))  # no lock: nothing to do


def test_a_run_after_a_killed_one_uses_the_kernel_cache(tmp_path):
    cache = tmp_path / "cache"
    cache.mkdir()
    lock = cache / "ticache.lock"
    lock.write_text("")
    old = os.path.getmtime(lock) - 3600
    os.utime(lock, (old, old))
    res = _python(TINY_TAICHI, _env(tmp_path, TI_OFFLINE_CACHE_FILE_PATH=str(cache)))
    assert res.returncode == 0, res.stderr[-2000:]
    assert "Lock" not in res.stderr, res.stderr[-2000:]
    assert any(p.suffix == ".tic" for p in cache.iterdir())  # the kernel was cached
