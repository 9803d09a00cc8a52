"""Scenes: a simulation set-up as a TOML file, validated into one frozen `Scene`.

A scene describes everything a run needs: the material (Table 1), the reference steady uniform
flow of section 4, which physical effects are switched on, the domain and its boundaries, the
inflow (6.8)-(6.9), the initial state (e.g. the empty slope (6.7)), the numerics, the end time and
the output times. Built-in scenes live in ``tiseg/data/scenes/*.toml`` (see `list_builtin_scenes`);
any other TOML file can be given by path.

Loading is strict, because a typo in a scene would otherwise silently run the wrong experiment:
unknown sections and keys, wrong types, out-of-range values and inconsistent combinations all raise
`tiseg.errors.InputError` with a message that names the full dotted key, the bad value and
what is allowed. Nothing given is ever ignored without saying so.

Command-line style overrides (``--set section.key=value``) are applied to the raw TOML data
before validation, so an override is checked exactly like the same value written in the file::

    scene = load_scene("fingers", ["domain.resolution=250", "time.t_end=2.0"])

`Scene.to_toml` writes the fully resolved scene (every default filled in) as TOML that
`load_scene` turns back into an equal `Scene`; a run stores it next to its output so
that the run can be repeated exactly.

Each key is declared once, on its section's dataclass field (`tiseg.setup`); the reader,
the writer, the allowed-key lists, the compiled keys and the scenes reference page are derived
from that declaration. This module keeps the public names.
"""

from __future__ import annotations

from ..data import SCENE_DIR
from ..errors import InputError
from ..solver.numerics.config import CHOICE_NAMES, FRICTION_SCHEMES, STEP_RULES, registered
from ..model.physics.friction import DEFAULT_COULOMB_MU
from .overrides import parse_override
from .reading import list_builtin_scenes, load_scene, scene_from_dict, scene_from_text
from .resolved import Scene
from .initial import INITIAL_KINDS as _INITIAL_KINDS
from .sections import (
    OUTPUT_PRECISIONS,
    PERTURBATION_MODES,
    PRECISIONS,
    RECONSTRUCTION_ALIASES,
    SPECIES_KEYS,
    BoundaryConfig,
    DomainConfig,
    EffectsConfig,
    FlowConfig,
    InflowConfig,
    InitialConfig,
    NumericsConfig,
    OutputConfig,
    TimeConfig,
    initial_keys,
    section_keys,
    top_level_keys,
)
from .validators import (
    MAX_CELLS,
    MAX_NU,
    MAX_OUTPUT_TIMES,
    MIN_CELLS,
    MIN_CELLS_PER_PERTURBATION,
    MIN_CFL,
    MIN_H_EPS,
)
from .table import MAX_NESTING
from .writing import scene_to_dict

# ---- the allowed choices and keys --------------------------------------------------------------
# The registered choices, read when asked (a component registered by user code counts): the
# names of before, each the keys of its registry (`tiseg.solver.numerics.config.REGISTRIES`).
_CHOICES = tuple(CHOICE_NAMES)


_LIVE = ("INITIAL_KINDS", "INITIAL_KEYS")


def __getattr__(name: str):
    if name in _CHOICES:
        return registered(name)
    if name == "INITIAL_KINDS":  # the registered initial states (tiseg.setup.initial)
        return tuple(_INITIAL_KINDS)
    if name == "INITIAL_KEYS":
        return initial_keys()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


SECTION_KEYS = section_keys()
TOP_LEVEL_KEYS = top_level_keys()

__all__ = [
    "Scene",
    "FlowConfig",
    "EffectsConfig",
    "DomainConfig",
    "BoundaryConfig",
    "InflowConfig",
    "InitialConfig",
    "NumericsConfig",
    "TimeConfig",
    "OutputConfig",
    "load_scene",
    "scene_from_text",
    "scene_from_dict",
    "scene_to_dict",
    "parse_override",
    "list_builtin_scenes",
    "SCENE_DIR",
    "InputError",
    # the choices and limits, for code that read them from here before
    "RECONSTRUCTION_ALIASES",
    "FRICTION_SCHEMES",
    "STEP_RULES",
    "PRECISIONS",
    "OUTPUT_PRECISIONS",
    "PERTURBATION_MODES",
    *_LIVE,  # the registered initial kinds and their keys, read when asked
    "SECTION_KEYS",
    "TOP_LEVEL_KEYS",
    "SPECIES_KEYS",
    "DEFAULT_COULOMB_MU",
    "MIN_CELLS",
    "MIN_CELLS_PER_PERTURBATION",
    "MAX_CELLS",
    "MAX_NU",
    "MIN_CFL",
    "MIN_H_EPS",
    "MAX_NESTING",
    "MAX_OUTPUT_TIMES",
    *_CHOICES,  # the registered choices, read when asked
]
