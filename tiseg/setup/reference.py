"""The scenes reference page, generated from the declarations (for the documentation site).

Every key, its meaning, its allowed words (read from the registries) or its range, and whether
the kernels are compiled for it come from the one declaration of the key
(`tiseg.setup.sections`, and the friction laws' constants); its value in the ``fingers``
scene is read from the built-in scene. So the page cannot drift from the code.
"""

from __future__ import annotations

import inspect

from .reading import list_builtin_scenes, load_scene
from .schema import key_of
from .sections import SECTIONS, section_fields


def descriptions() -> dict[str, str]:
    """{"section.key": its doc text} for every key a scene accepts now."""
    return {
        f"{section}.{f.name}": key_of(f).doc
        for section in SECTIONS
        for f in section_fields(section)
    }


def _builtin_values() -> dict[str, dict[str, object]]:
    """{scene name: {"section.key": value as written in the resolved scene}}."""
    vals = {}
    for name in list_builtin_scenes():
        d = load_scene(name).to_dict()
        flat = {}
        for section, table in d.items():
            if isinstance(table, dict):
                for k, v in table.items():
                    flat[f"{section}.{k}"] = v
        vals[name] = flat
    return vals


def _show(v) -> str:
    if isinstance(v, dict):
        return "table"
    if isinstance(v, float):
        return f"{v:.6g}"
    if isinstance(v, list) and len(v) > 6:
        return f"[{', '.join(map(_show, v[:5]))}, ...]"
    return f"{v!r}" if isinstance(v, str) else str(v).lower() if isinstance(v, bool) else str(v)


def _allowed(k) -> str:
    """The allowed words, or the range; "compiled" where the kernels are built for the value
    (a change needs a new Simulation)."""
    text = ", ".join(f"`{c}`" for c in k.allowed()) if k.choices is not None else k.range_text()
    if k.compiled:
        text = f"{text} (compiled)" if text else "(compiled)"
    return text


def markdown() -> str:
    """The scenes reference page."""
    values = _builtin_values()
    fingers = values.get("fingers", {})
    lines = [
        "# Scenes reference",
        "",
        "A scene is a TOML file of the sections below (`tiseg run SCENE`, `--set "
        "section.key=value`). Unknown keys, wrong types and impossible values are one-line "
        "errors naming the key. Built-in scenes: "
        + ", ".join(f"`{n}`" for n in values)
        + " (`tiseg/data/scenes/`).",
        "",
        "*This page is generated from the scene schema (`tiseg.setup.sections`): each key is "
        "declared once, with its doc, its allowed values or range, and whether the kernels are "
        "compiled for it (a change then needs a new `Simulation`).*",
        "",
    ]
    for section, cls in SECTIONS.items():
        doc = inspect.getdoc(cls) or ""
        lines += [
            f"## `[{section}]`",
            "",
            doc.split("\n\n")[0].replace("\n", " "),
            "",
            "| key | meaning | allowed | in `fingers` |",
            "|---|---|---|---|",
        ]
        for f in section_fields(section):
            full = f"{section}.{f.name}"
            k = key_of(f)
            val = f"`{_show(fingers[full])}`" if full in fingers else ""
            text = k.doc.replace("|", "\\|")
            allowed = _allowed(k).replace("|", "\\|")
            lines.append(f"| `{f.name}` | {text} | {allowed} | {val} |")
        lines.append("")
    return "\n".join(lines) + "\n"
