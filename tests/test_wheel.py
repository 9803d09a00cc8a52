"""The wheel as a user installs it: built from this tree, unpacked away from it, it finds its
built-in scenes, sweeps and problems through importlib.resources (no assets/ folder beside
it), holds no top-level package but tiseg, and runs from there. (.ci/run also installs it into a fresh venv
with its dependencies and runs scenes with it.)"""

import json
import os
import subprocess
import sys
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

PROBE = """
import json, tiseg
from tiseg.setup.scene import list_builtin_scenes, load_scene
from tiseg.apps.sweep import list_builtin_sweeps, load_sweep
from tiseg.post.problems import builtin_problems
sc = load_scene("fingers")
print(json.dumps({"file": tiseg.__file__, "scenes": list_builtin_scenes(),
                  "sweeps": list_builtin_sweeps(), "fingers_nx": sc.domain.nx,
                  "grid_runs": len(load_sweep("grid-study").runs),
                  "problems": list(builtin_problems())}))
"""


def test_wheel_finds_its_scenes_and_sweeps_outside_the_tree(tmp_path):
    wheels = tmp_path / "wheels"
    p = subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "wheel",
            "-q",
            "--no-deps",
            "--no-build-isolation",
            "-w",
            str(wheels),
            str(ROOT),
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert p.returncode == 0, p.stderr[-2000:]
    (whl,) = wheels.glob("tiseg-*.whl")
    names = zipfile.ZipFile(whl).namelist()
    top = {n.split("/")[0] for n in names if ".dist-info" not in n.split("/")[0]}
    assert top == {"tiseg"}, top  # no top-level `viewer`
    site = tmp_path / "site"
    zipfile.ZipFile(whl).extractall(site)
    env = dict(os.environ, PYTHONPATH=str(site))  # ahead of this checkout's install
    p = subprocess.run(
        [sys.executable, "-c", PROBE],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert p.returncode == 0, p.stderr[-2000:]
    got = json.loads(p.stdout.strip().splitlines()[-1])
    assert Path(got["file"]).resolve().is_relative_to(site.resolve())
    assert {"fingers", "channel", "dam-break", "finite-release"} <= set(got["scenes"])
    assert {"grid-study", "nu-study", "width-study", "tiny"} <= set(got["sweeps"])
    assert got["fingers_nx"] == 1125 and got["grid_runs"] == 20
    assert {"transport", "ritter", "growth", "fingers", "channel"} <= set(got["problems"])
