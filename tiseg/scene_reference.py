"""The scenes reference, generated from the scene schema itself (for the documentation site).

Every key a scene file accepts is in :data:`tiseg.scene.SECTION_KEYS`; what it means is the
comment after the field of the configuration dataclass that holds it (``FlowConfig.h0`` for
``flow.h0``, ...), its allowed values are the tuples the validator checks against, and its
value in the built-in scenes is read from them. So the page cannot drift from the code:
``tests/test_docs.py`` checks that every key has a description.
"""

from __future__ import annotations

import inspect
import re

from . import scene as S
from .material import Material, Species

# the dataclass that holds the keys of each section
SECTION_CLASSES = {
    "material": Material,
    "flow": S.FlowConfig,
    "effects": S.EffectsConfig,
    "domain": S.DomainConfig,
    "boundary": S.BoundaryConfig,
    "inflow": S.InflowConfig,
    "initial": S.InitialConfig,
    "numerics": S.NumericsConfig,
    "time": S.TimeConfig,
    "output": S.OutputConfig,
}

# the allowed values of the keys that take a word
CHOICES = {
    "material.transport": S.TRANSPORTS,
    "effects.friction": S.FRICTION_LAWS,
    "boundary.x_lo": S.BOUNDARY_KINDS,
    "boundary.x_hi": S.BOUNDARY_KINDS,
    "boundary.y_lo": S.BOUNDARY_KINDS,
    "boundary.y_hi": S.BOUNDARY_KINDS,
    "initial.kind": S.INITIAL_KINDS,
    "initial.mode": S.PERTURBATION_MODES,
    "numerics.reconstruction": S.RECONSTRUCTIONS,
    "numerics.flux": S.FLUXES,
    "numerics.phi_flux": S.PHI_FLUXES,
    "numerics.stepper": S.STEPPERS,
    "numerics.step_rule": tuple(S.STEP_RULES),
    "numerics.friction_scheme": S.FRICTION_SCHEMES,
    "numerics.precision": S.PRECISIONS,
    "output.precision": S.OUTPUT_PRECISIONS,
}

_FIELD = re.compile(r"^\s+(\w+)\s*:\s*[^#]*?#\s?(.*)$")
_MORE = re.compile(r"^\s+#\s?(.*)$")


def field_comments(cls) -> dict[str, str]:
    """{field: the comment after its declaration, continued on following comment lines}."""
    out: dict[str, str] = {}
    last = None
    for line in inspect.getsource(cls).splitlines():
        m = _FIELD.match(line)
        if m:
            last = m.group(1)
            out[last] = m.group(2).strip()
            continue
        m = _MORE.match(line)
        if m and last is not None:  # a comment line right after a field continues its comment
            out[last] += " " + m.group(1).strip()
            continue
        last = None
    return out


def descriptions() -> dict[str, str]:
    """{"section.key": description} for every key of :data:`tiseg.scene.SECTION_KEYS`."""
    out = {}
    species = field_comments(Species)
    for section, keys in S.SECTION_KEYS.items():
        comments = field_comments(SECTION_CLASSES[section])
        for key in keys:
            text = comments.get(key, "")
            if section == "material" and key in ("small", "large"):
                text = f"table of the {key} grains' friction constants: " + "; ".join(
                    f"``{k}``: {v}" for k, v in species.items()
                )
            out[f"{section}.{key}"] = text
    return out


def _builtin_values() -> dict[str, dict[str, object]]:
    """{scene name: {"section.key": value as written in the resolved scene}}."""
    vals = {}
    for name in S.list_builtin_scenes():
        d = S.load_scene(name).to_dict()
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


def markdown() -> str:
    """The scenes reference page."""
    desc = descriptions()
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
        "*This page is generated from the scene schema (`tiseg.scene_reference`).*",
        "",
    ]
    for section, keys in S.SECTION_KEYS.items():
        doc = inspect.getdoc(SECTION_CLASSES[section]) or ""
        lines += [
            f"## `[{section}]`",
            "",
            doc.split("\n\n")[0].replace("\n", " "),
            "",
            "| key | meaning | allowed | in `fingers` |",
            "|---|---|---|---|",
        ]
        for key in keys:
            full = f"{section}.{key}"
            allowed = ", ".join(f"`{c}`" for c in CHOICES.get(full, ()))
            val = f"`{_show(fingers[full])}`" if full in fingers else ""
            text = desc[full].replace("|", "\\|")
            lines.append(f"| `{key}` | {text} | {allowed} | {val} |")
        lines.append("")
    return "\n".join(lines) + "\n"
