"""Bad input, fuzz style: every malformed scene, value or option given to `tiseg run` ends in
exit status 2 with exactly one line on stderr that starts with "tiseg" and names the problem;
never a traceback, never a run, and nothing is silently ignored.

The cases go through the command-line entry point (``tiseg.apps.cli.main``) and, for the scene
files, through ``load_scene`` too. None of them gets as far as building a simulation, so the
whole file runs in a few seconds.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from tiseg.errors import InputError
from tiseg.setup.scene import load_scene

from solver_helpers import MINIMAL_SCENE, exit_code as _call

GOOD = '\nname = "good"' + MINIMAL_SCENE

# (scene file text, a word the message must contain)
BAD_SCENES = [
    ("[flow\nh0 = 0.002", "not valid TOML"),
    ("", "time.t_end"),  # empty file
    (GOOD + "[mystery]\nx = 1\n", "mystery"),  # unknown section
    (GOOD + "[flow]\nh00 = 0.002\n", "flow.h00"),  # unknown key (typo)
    (GOOD + "[flow]\nh0 = 'thick'\n", "flow.h0"),  # wrong type
    (GOOD + "[flow]\nh0 = -0.002\n", "flow.h0"),  # negative size
    (GOOD + "[flow]\nh0 = 0\n", "flow.h0"),
    (GOOD + "[flow]\nphi0 = 1.2\n", "flow.phi0"),  # phi0 outside [0, 1]
    (GOOD + "[flow]\nphi0 = -0.2\n", "flow.phi0"),
    (GOOD + "[flow]\nphi0 = 0.1\n", "phi0*"),  # no steady flow, inflow
    (GOOD + "[flow]\nnu = -1\n", "flow.nu"),
    (GOOD + "[flow]\nnu = nan\n", "flow.nu"),
    (GOOD.replace("Lx = 0.2", "Lx = -0.2"), "domain.Lx"),
    (GOOD.replace("resolution = 200", "resolution = 0"), "domain.resolution"),
    (GOOD.replace("resolution = 200", "resolution = 20"), "domain.ny"),  # 1 cell across
    (GOOD.replace("resolution = 200", "nx = 40\nny = 2"), "domain.ny"),
    (GOOD.replace("resolution = 200", "nx = 40.5\nny = 10"), "domain.nx"),
    (GOOD + "[inflow]\nmodes = 5\n", "inflow.modes"),  # cannot resolve the inflow
    (GOOD + "[inflow]\nphi = 1.5\n", "inflow.phi"),
    (GOOD + "[inflow]\nu = -0.1\n", "inflow.u"),
    (GOOD + "[inflow]\nramp_rate = -10\n", "inflow.ramp_rate"),
    (GOOD + "[inflow]\nperturbation = 0.5\n", "inflow.perturbation"),
    (GOOD + "[output]\ntimes = [-0.1]\n", "output.times"),
    (GOOD + "[output]\ninterval = 0\n", "output.interval"),
    (GOOD + "[output]\ncheckpoint_interval = -5\n", "output.checkpoint_interval"),
    (GOOD + "[output]\ntimes = 'often'\n", "output.times"),
    (GOOD.replace("t_end = 0.5", "t_end = 0"), "time.t_end"),
    (GOOD.replace("t_end = 0.5", "t_end = '1 s'"), "time.t_end"),
    (GOOD + "[numerics]\nprecision = 'f16'\n", "numerics.precision"),
    (GOOD + "[numerics]\ncfl = 2\n", "numerics.cfl"),
    (GOOD + "[numerics]\nstepper = 'rk4'\n", "numerics.stepper"),
    (GOOD + "[numerics]\nh_min = 0.01\n", "numerics.h_min"),
    (GOOD + "[numerics]\nmax_stages = 1\n", "numerics.max_stages"),
    (GOOD + "[boundary]\nx_hi = 'periodic'\n", "boundary"),
    (GOOD + "[boundary]\ny_lo = 'inflow'\n", "boundary.y_lo"),
    (GOOD + "[effects]\nfriction = 'glue'\n", "effects.friction"),
    (GOOD + "[effects]\nsegregation = 'yes'\n", "effects.segregation"),
    (GOOD + "[material]\nzeta_deg = 95\n", "material.zeta_deg"),
    (GOOD + "[material.small]\nzeta1_deg = 45\n", "material.small"),
    (GOOD + "[initial]\nkind = 'volcano'\n", "initial.kind"),
    (GOOD + "[initial]\nkind = 'dam-break'\nx0 = 3.0\n", "initial.x0"),
    (GOOD + "[initial]\nkind = 'release'\nx0 = 0.1\nx1 = 0.05\n", "initial.x1"),
    (GOOD + "[initial]\nx0 = 0.1\n", "initial.x0"),  # not used by 'empty'
    ("name = 'a/b'\n" + GOOD.replace('name = "good"', ""), "name"),
    ("[[flow]]\nh0 = 1\n" + GOOD, "flow"),
]

# (argv after `run`, a word the message must contain); "{tmp}" is a scratch folder
BAD_ARGS = [
    (["fingers", "--threads", "-1"], "--threads"),
    (["fingers", "--threads", "two"], "--threads"),
    (["fingers", "--precision", "f16"], "--precision"),
    (["fingers", "--arch", "tpu"], "--arch"),
    (["fingers", "--set"], "--set"),
    (["fingers", "--set", "flow.h0"], "flow.h0"),  # no '='
    (["fingers", "--set", "=0.002"], "override"),
    (["fingers", "--set", ".h0=1"], "override"),
    (["fingers", "--set", "flow..h0=1"], "override"),
    (["fingers", "--set", "flow.h0=1 2"], "flow.h0"),
    (["fingers", "--set", "flow.phi0=1.5"], "flow.phi0"),
    (["fingers", "--set", "flow.h0=-1"], "flow.h0"),
    (["fingers", "--set", "domain.resolution=-750"], "domain.resolution"),
    (["fingers", "--set", "domain.nx=100"], "domain.nx"),
    (["fingers", "--set", "numerics.cfl=0"], "numerics.cfl"),
    (["fingers", "--set", "inflow.modes=1000"], "inflow.modes"),
    (["fingers", "--set", "colour=blue"], "colour"),
    (["fingers", "--set", "flow.h0=[1]"], "flow.h0"),
    (["fingerz"], "did you mean 'fingers'"),
    (["{tmp}/missing.toml"], "not found"),
    (["{tmp}"], "{tmp}"),  # a folder, not a file
    (["fingers", "--out", "{tmp}/file.txt"], "--out"),  # a file, not a folder
    (["fingers", "--out", "{tmp}/file.txt/sub"], "--out"),  # cannot be created
    (["fingers", "--out", "/proc/tiseg-cannot-write-here"], "--out"),
    (["fingers", "--fps", "0", "--movie", "{tmp}/m.mp4"], "--fps"),
    (["fingers", "--fps", "nan", "--movie", "{tmp}/m.mp4"], "--fps"),
    (["fingers", "--fps", "12"], "without --movie"),  # would be ignored
    (["fingers", "--movie-field", "h"], "without --movie"),
    (["fingers", "--movie", "{tmp}/m.mp4", "--movie-field", "vorticity"], "--movie-field"),
    (["fingers", "--movie", "{tmp}/m.txt"], "--movie"),
    (["fingers", "--bogus"], "--bogus"),
    ([], "SCENE"),  # nothing to run
    (["--resume", "{tmp}/nowhere"], "no such folder"),
    (["--resume", "{tmp}/file.txt"], "no such folder"),
    (["--resume", "{tmp}"], "not a tiseg run folder"),
    (["--resume", "{run}"], "checkpoint.npz"),  # a finished run
    (["--resume", "{broken}"], "not a readable checkpoint"),
    (["--resume", "{edited}"], "scene.toml was changed"),
    (["fingers", "--out", "{broken}"], "unfinished run"),  # would overwrite a killed run
    (["fingers", "--resume", "{tmp}"], "SCENE"),
    (["--resume", "{tmp}", "--set", "flow.h0=0.003"], "--set"),
    (["--resume", "{tmp}", "--precision", "f32"], "--precision"),
    (["--resume", "{tmp}", "--out", "{tmp}/elsewhere"], "--out"),
    (["--resume", "{tmp}", "--movie", "{tmp}/m.mp4"], "--movie"),
]


@pytest.fixture(scope="module", autouse=True)
def _imported():
    """Import every command (and Taichi) once before the cases: Taichi announces itself on
    stderr at its first import under pytest's capture, which is not a message of ours."""
    import tiseg.run.simulation  # noqa: F401  (the kernels' modules: Taichi logs when it meets them)
    from tiseg.apps.cli import build_parser

    build_parser()


def _one_line_error(capfd, rc_or_exit) -> str:
    out, err = capfd.readouterr()
    assert rc_or_exit == 2, (out, err)
    assert "Traceback" not in err and "Traceback" not in out
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("tiseg") and "error:" in lines[0], err
    return lines[0]


@pytest.fixture(scope="module")
def folders(tmp_path_factory):
    """A scratch folder with a file in it, a finished run folder and two spoilt ones."""
    tmp = tmp_path_factory.mktemp("bad")
    (tmp / "file.txt").write_text("not a folder\n")
    run = tmp / "run"
    run.mkdir()
    (run / "scene.toml").write_text(load_scene("fingers").to_toml())
    (run / "fields.nc").write_bytes(b"")
    (run / "diagnostics.csv").write_text("time\n")
    broken = tmp / "broken"
    broken.mkdir()
    for name in ("scene.toml", "fields.nc", "diagnostics.csv"):
        (broken / name).write_bytes((run / name).read_bytes())
    (broken / "checkpoint.npz").write_bytes(b"PK\x03\x04 half a zip")
    edited = tmp / "edited"
    edited.mkdir()
    for name in ("fields.nc", "diagnostics.csv"):
        (edited / name).write_bytes((run / name).read_bytes())
    (edited / "scene.toml").write_text(load_scene("fingers", ["flow.nu=0.02"]).to_toml())
    from tiseg.run.checkpoint import FORMAT, VERSION, write_npz_atomic

    write_npz_atomic(
        edited / "checkpoint.npz",
        {
            "format": np.array(FORMAT),
            "version": np.array(VERSION),
            "scene": np.array(load_scene("fingers").to_toml()),
            "precision": np.array("f64"),
            "t": np.array(0.1),
        },
    )
    return {"tmp": str(tmp), "run": str(run), "broken": str(broken), "edited": str(edited)}


@pytest.mark.parametrize("text, word", BAD_SCENES)
def test_bad_scene_file(text, word, tmp_path, capfd, monkeypatch):
    monkeypatch.chdir(tmp_path)
    path = tmp_path / "scene.toml"
    path.write_text(text)
    with pytest.raises(InputError) as info:
        load_scene(str(path))
    assert word in str(info.value)
    line = _one_line_error(
        capfd, _call(["run", str(path), "--out", str(tmp_path / "out"), "--no-progress"])
    )
    assert word in line and str(path) in line, line
    assert not (tmp_path / "out").exists()  # refused before anything was made


@pytest.mark.parametrize("argv, word", BAD_ARGS)
def test_bad_command_line(argv, word, folders, capfd, monkeypatch, tmp_path):
    monkeypatch.chdir(tmp_path)  # a default runs/ folder would land here
    argv = [a.format(**folders) for a in argv]
    line = _one_line_error(capfd, _call(["run"] + argv))
    assert word.format(**folders) in line, line
    assert not (tmp_path / "runs").exists()


def test_gpu_where_there_is_none(capfd, tmp_path):
    """--arch gpu on a machine without CUDA/Metal: one line, exit 2, no output folder."""
    from tiseg.backend import _probe_gpu
    import taichi as ti

    if _probe_gpu(ti) is not None:
        pytest.skip("this machine has a GPU")
    out, err = capfd.readouterr()
    rc = _call(["run", "fingers", "--arch", "gpu", "--out", str(tmp_path / "out")])
    out, err = capfd.readouterr()
    assert rc == 2 and "Traceback" not in err
    # Taichi itself may log a C++ warning line ("libcuda.so lib not found") on the real stderr
    ours = [ln for ln in err.splitlines() if ln.startswith("tiseg")]
    assert len(ours) == 1 and "no CUDA or Metal GPU" in ours[0], err
    assert not (tmp_path / "out").exists()


def test_enough_cases():
    assert len(BAD_SCENES) + len(BAD_ARGS) >= 50


def test_good_scene_runs_nothing_ignored(tmp_path, capfd):
    """The base of the malformed scenes is itself valid (so each case fails for its own reason)."""
    path = tmp_path / "good.toml"
    path.write_text(GOOD)
    s = load_scene(str(path))
    assert (s.domain.nx, s.domain.ny) == (40, 10)
    assert os.path.getsize(path) > 0 and Path(path).suffix == ".toml"
