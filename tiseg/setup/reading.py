"""Reading a scene: a built-in name, a TOML file, TOML text or a dict, with overrides.

Loading is strict, because a typo in a scene would otherwise silently run the wrong experiment:
unknown sections and keys, wrong types, out-of-range values and inconsistent combinations all
raise `tiseg.errors.InputError` with a message that names the full dotted key, the bad
value and what is allowed, prefixed by the scene it is in. The allowed keys are derived from
the declarations (`tiseg.setup.sections.section_keys`) and the registries as they stand
when the scene is read.
"""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Mapping

from ..data import SCENE_DIR, builtin_file, builtin_names
from ..errors import InputError
from .overrides import apply_overrides
from .resolved import Scene, build_labelled
from .table import deep_copy, toml_float, type_name


def list_builtin_scenes() -> list[str]:
    """Names of the scenes shipped in the package (``tiseg/data/scenes``)."""
    return builtin_names(SCENE_DIR)


def load_scene(name_or_path, overrides=None) -> Scene:
    """Load and validate a scene.

    ``name_or_path``: a built-in scene name (no '/' and no '.toml', see
    `list_builtin_scenes`), a path to a TOML file, or a `Scene` (then only the
    overrides are applied). ``overrides``: a dict ``{"section.key": value}`` (a value of None
    removes the key) or a list of ``"section.key=value"`` strings (``--set``).
    """
    if isinstance(name_or_path, Scene):
        return name_or_path.with_overrides(overrides) if overrides else name_or_path
    path = _resolve_scene_path(name_or_path)
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError as exc:
        raise InputError(f"scene file {str(path)!r} is not UTF-8 text: {exc}") from None
    except OSError as exc:
        raise InputError(
            f"cannot read scene file {str(path)!r}: {exc.strerror or exc}; "
            f"built-in scenes: {', '.join(list_builtin_scenes())}"
        ) from None
    # error messages name a built-in scene by its name, any other file by its path
    builtin = path.resolve().parent == SCENE_DIR
    return scene_from_text(
        text,
        name=path.stem,
        overrides=overrides,
        source=str(path),
        label=repr(path.stem) if builtin else None,
    )


def scene_from_text(
    text: str,
    name: str = "scene",
    overrides=None,
    source: str | None = None,
    label: str | None = None,
) -> Scene:
    """Validate a scene given as TOML text (``name`` is the default for the top-level name)."""
    where = source or "<text>"
    try:
        data = tomllib.loads(text, parse_float=toml_float)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"scene file {where!r} is not valid TOML: {exc}") from None
    except RecursionError:
        raise InputError(f"scene file {where!r} nests arrays or tables too deeply") from None
    return scene_from_dict(data, name=name, overrides=overrides, source=source, label=label)


def scene_from_dict(
    data: Mapping,
    name: str = "scene",
    overrides=None,
    source: str | None = None,
    label: str | None = None,
) -> Scene:
    """Validate a scene given as the nested dict a TOML file parses to."""
    if not isinstance(data, Mapping):
        raise InputError(f"a scene must be a table of sections, got {type_name(data)}")
    label = label or (repr(source) if source else repr(name))
    try:
        data = deep_copy(data)
        apply_overrides(data, overrides)
    except InputError as exc:
        raise InputError(f"scene {label}: {exc}") from None
    return build_labelled(data, name, source, label)


def _resolve_scene_path(name_or_path) -> Path:
    if not isinstance(name_or_path, (str, Path)):
        raise InputError(f"scene {name_or_path!r}: expected a built-in scene name or a path")
    found = builtin_file(name_or_path, SCENE_DIR, "scene")
    if found is not None:
        return found
    text = str(name_or_path)
    builtins = list_builtin_scenes()
    path = Path(text).expanduser()
    if path.is_dir():
        raise InputError(
            f"scene {text!r} is a folder, not a scene file (give a .toml file; "
            "to continue a run in a folder: tiseg run --resume DIR)"
        )
    if path.exists() and not path.is_file():
        raise InputError(
            f"scene {text!r} is not a regular file (a pipe or device?); give a .toml file"
        )
    if not path.is_file():
        raise InputError(
            f"scene file {text!r} not found; built-in scenes: {', '.join(builtins) or '(none)'}"
        )
    return path
