"""Files shipped inside the package, read through importlib.resources so that an installed
wheel finds them as well as a source checkout: the built-in scenes (``scenes/*.toml``, see
`tiseg.setup.scene.list_builtin_scenes`) sweeps (``sweeps/*.toml``, see
`tiseg.apps.sweep.load_sweep`), verification problems (``problems/*.toml``, see
`tiseg.post.problems.load_problem`) and example bed rasters (``terrain/*.asc``, see
`tiseg.setup.rasters.read_raster`).
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

from ..errors import InputError

# A wheel installs packages as plain folders, so these are real paths (pathlib.Path).
SCENE_DIR = Path(str(resources.files(__name__) / "scenes"))
SWEEP_DIR = Path(str(resources.files(__name__) / "sweeps"))
PROBLEM_DIR = Path(str(resources.files(__name__) / "problems"))
TERRAIN_DIR = Path(str(resources.files(__name__) / "terrain"))


def builtin_names(folder: Path) -> list[str]:
    """Stems of the TOML files in one of the folders above."""
    return sorted(p.stem for p in folder.glob("*.toml")) if folder.is_dir() else []


def builtin_file(path, folder: Path, kind: str) -> Path | None:
    """The built-in file ``path`` names, or None when it is a plain path to use as it is.

    A str without '/', '\\' and '.toml' is a name: the ``kind`` ("scene", "sweep") of that
    name in ``folder``, or an InputError naming the closest one."""
    import difflib

    text = str(path)
    if (
        isinstance(path, str)
        and "/" not in text
        and "\\" not in text
        and not text.endswith(".toml")
    ):
        names = builtin_names(folder)
        if text in names:
            return folder / f"{text}.toml"
        close = difflib.get_close_matches(text, names, n=1)
        hint = f" (did you mean {close[0]!r}?)" if close else ""
        raise InputError(
            f"unknown built-in {kind} {text!r}{hint}; built-in {kind}s: "
            f"{', '.join(names) or '(none)'}; or give a path to a .toml file"
        )
    return None
