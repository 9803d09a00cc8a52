"""Files shipped inside the package, read through importlib.resources so that an installed
wheel finds them as well as a source checkout: the built-in scenes (``scenes/*.toml``, see
`tiseg.scene.list_builtin_scenes`) sweeps (``sweeps/*.toml``, see
`tiseg.sweep.load_sweep`) and verification problems (``problems/*.toml``, see
`tiseg.problems.load_problem`).

Up to version 0.1.0 they lived in ``assets/scenes`` and ``assets/sweeps`` beside the package;
`legacy_path` maps those paths onto the built-ins, so scripts that name them still work.
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path, PurePath

# A wheel installs packages as plain folders, so these are real paths (pathlib.Path).
SCENE_DIR = Path(str(resources.files(__name__) / "scenes"))
SWEEP_DIR = Path(str(resources.files(__name__) / "sweeps"))
PROBLEM_DIR = Path(str(resources.files(__name__) / "problems"))
LEGACY_DIRS = {"scenes": SCENE_DIR, "sweeps": SWEEP_DIR}


def builtin_names(folder: Path) -> list[str]:
    """Stems of the TOML files in one of the folders above."""
    return sorted(p.stem for p in folder.glob("*.toml")) if folder.is_dir() else []


def builtin_file(path, folder: Path, kind: str) -> Path | None:
    """The built-in file ``path`` names, or None when it is a plain path to use as it is.

    A str without '/', '\\' and '.toml' is a name: the ``kind`` ("scene", "sweep") of that
    name in ``folder``, or an InputError naming the closest one. An old ``assets/...`` path
    that no longer exists maps onto its built-in (`legacy_path`), with a note."""
    import difflib

    from ..errors import InputError

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
    old = legacy_path(text)
    if old is not None:
        from ..log import note

        note(f"{text} moved into the package: using the built-in {kind} {old.stem!r}")
    return old


def legacy_path(text: str) -> Path | None:
    """The built-in file an old ``assets/scenes/<name>.toml`` or ``assets/sweeps/<name>.toml``
    path meant, when no such file exists any more; else None."""
    parts = PurePath(text).parts
    if len(parts) < 3 or parts[-3] != "assets" or parts[-2] not in LEGACY_DIRS:
        return None
    if Path(text).expanduser().exists():
        return None
    candidate = LEGACY_DIRS[parts[-2]] / parts[-1]
    return candidate if candidate.is_file() else None
