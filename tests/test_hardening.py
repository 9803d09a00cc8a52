"""Hardening: runs stay inside their folder, one writer per folder, limits before work."""
from __future__ import annotations

import os
import subprocess
import sys

import pytest

from tiseg.cli import main
from tiseg.errors import InputError
from tiseg.paths import RunLock, safe_name
from tiseg.scene import load_scene
from tiseg.simulation import Simulation

TINY = {"domain.resolution": 40, "domain.Lx": 0.3, "domain.Ly": 0.1, "time.t_end": 0.05,
        "output.times": [], "output.interval": None}


def tiny():
    return load_scene("fingers", TINY)


def _cli(*args) -> list[str]:
    out = ["run", "fingers"]
    for k, v in TINY.items():
        if v is not None:
            out += ["--set", f"{k}={v}"]
    return out + ["--no-progress", *args]


# ------------------------------------------------------------------ limits
def test_more_threads_than_cores_are_refused(capsys):
    from tiseg import backend
    cores = backend.available_cores()
    assert main(["run", "fingers", "--threads", "100000"]) == 2
    assert f"offers {cores} core(s)" in capsys.readouterr().err
    with pytest.raises(InputError, match="core"):
        backend.init("cpu", "f64", cores + 1)


# ------------------------------------------------------------------ names
@pytest.mark.parametrize("name", ["..", ".", ".hidden", "-rf", "a/b", "a b", ""])
def test_unsafe_scene_names_are_refused(name, capsys):
    assert main(["run", "fingers", "--set", f"name={name!r}"]) == 2
    assert "starting with a letter or digit" in capsys.readouterr().err


def test_scene_file_stem_is_made_safe(tmp_path):
    src = load_scene("fingers").to_toml().replace('name = "fingers"\n', "")
    path = tmp_path / "my scene (v2).toml"
    path.write_text(src)
    assert load_scene(str(path)).name == "my_scene_v2_"
    assert safe_name("..") == "scene" and safe_name("../etc") == "etc"


# ------------------------------------------------------------------ the output folder
def test_symlinks_inside_the_output_folder_are_not_followed(ti_cpu, tmp_path):
    target = tmp_path / "precious.txt"
    target.write_text("keep me")
    out = tmp_path / "run"
    out.mkdir()
    (out / "diagnostics.csv").symlink_to(target)
    with pytest.raises(InputError, match="symbolic link"):
        Simulation(tiny()).run(out_dir=out, progress=False)
    assert target.read_text() == "keep me"


def test_foreign_files_and_finished_runs_need_overwrite(ti_cpu, tmp_path, capsys):
    out = tmp_path / "run"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    assert main(_cli("--out", str(out))) == 2
    assert "notes.txt" in capsys.readouterr().err and (out / "notes.txt").read_text() == "mine"
    (out / "notes.txt").unlink()
    assert main(_cli("--out", str(out))) == 0
    capsys.readouterr()
    assert main(_cli("--out", str(out))) == 2                    # a finished run
    assert "finished run" in capsys.readouterr().err
    assert main(_cli("--out", str(out), "--overwrite")) == 0
    with pytest.raises(InputError, match="finished run"):
        Simulation(tiny()).run(out_dir=out, progress=False)       # the API alike


HOLD = """
import sys, time
from tiseg.paths import RunLock
lock = RunLock(sys.argv[1]).acquire()
print("held", flush=True)
time.sleep(60)
"""


@pytest.fixture
def held_folder(tmp_path):
    """A folder whose run lock another process holds."""
    d = tmp_path / "busy"
    d.mkdir()
    p = subprocess.Popen([sys.executable, "-c", HOLD, str(d)], stdout=subprocess.PIPE, text=True)
    assert p.stdout.readline().strip() == "held"
    yield d, p.pid
    p.kill()
    p.wait()


def test_a_second_writer_is_refused_naming_the_holder(ti_cpu, held_folder):
    d, pid = held_folder
    with pytest.raises(InputError, match=f"in use by another tiseg run \\(pid {pid} on"):
        Simulation(tiny()).run(out_dir=d, progress=False)
    assert RunLock(d).busy() is not None


def test_a_killed_holder_releases_the_lock(tmp_path):
    d = tmp_path / "x"
    d.mkdir()
    p = subprocess.Popen([sys.executable, "-c", HOLD, str(d)], stdout=subprocess.PIPE, text=True)
    assert p.stdout.readline().strip() == "held"
    assert RunLock(d).busy() is not None
    p.kill()
    p.wait()
    assert RunLock(d).busy() is None
    with RunLock(d):
        pass


def test_sweep_skips_a_run_another_process_holds(held_folder):
    from tiseg.sweep import execute_run
    d, pid = held_folder
    rec = execute_run({"name": "busy", "dir": str(d), "scene_toml": tiny().to_toml(),
                       "fingerprint": "x"})
    assert rec["status"] == "busy" and f"pid {pid}" in rec["holder"]


def test_resume_removes_stale_temporaries(ti_cpu, tmp_path):
    from tiseg import checkpoint
    out = tmp_path / "run"
    sc = load_scene("fingers", {**TINY, "time.t_end": 0.2, "output.interval": 0.05})
    sim = Simulation(sc)
    sim.run(out_dir=out, progress=False, t_end=0.1)
    stale = out / ".checkpoint.npz.abc123.tmp"
    stale.write_bytes(b"half")
    assert (out / checkpoint.CHECKPOINT_NAME).is_file()
    Simulation.resume(out).run(out_dir=out, progress=False)
    assert not stale.exists()
    assert not [p for p in os.listdir(out) if p.endswith(".tmp")]
