"""`tiseg scenes schema`: the JSON Schema of a scene (draft 2020-12) accepts every built-in
scene and refuses the mistakes that the scene reader refuses key by key."""

from __future__ import annotations

import json
import tomllib

import pytest

from tiseg.apps.cli import main
from tiseg.data import SCENE_DIR, builtin_names
from tiseg.errors import InputError
from tiseg.setup.json_schema import scene_schema
from tiseg.setup.reading import load_scene, scene_from_dict
from tiseg.setup.sections import section_keys

jsonschema = pytest.importorskip("jsonschema")
SCHEMA = scene_schema()
VALIDATOR = jsonschema.Draft202012Validator(SCHEMA)


def test_the_schema_is_a_draft_2020_12_schema_of_every_key():
    jsonschema.Draft202012Validator.check_schema(SCHEMA)
    assert SCHEMA["$schema"] == "https://json-schema.org/draft/2020-12/schema"
    for section, keys in section_keys().items():
        assert list(SCHEMA["properties"][section]["properties"]) == list(keys)


@pytest.mark.parametrize("name", builtin_names(SCENE_DIR))
def test_every_builtin_scene_validates(name):
    data = tomllib.loads((SCENE_DIR / f"{name}.toml").read_text(encoding="utf-8"))
    assert list(VALIDATOR.iter_errors(data)) == []
    assert list(VALIDATOR.iter_errors(load_scene(name).to_dict())) == []  # every key resolved


def _fingers() -> dict:
    return tomllib.loads((SCENE_DIR / "fingers.toml").read_text(encoding="utf-8"))


BAD = {
    "an unknown key": ("flow", "nuu", 0.01),
    "an unknown section": (None, "flwo", {}),
    "a string for a number": ("flow", "nu", "0.01"),
    "a negative viscosity": ("flow", "nu", -0.01),
    "a float for an integer": ("inflow", "seed", 1.5),
    "a word that is no choice": ("numerics", "reconstruction", "wenoo"),
    "a number for a boolean": ("effects", "viscosity", 1),
    "a number for an array": ("output", "times", 0.5),
    "a gauge without a table": ("output", "gauges", [1.0]),
}


@pytest.mark.parametrize("what", BAD)
def test_a_bad_scene_is_refused_by_the_schema_and_the_reader(what):
    section, key, value = BAD[what]
    data = _fingers()
    scene_from_dict(data)  # the scene as shipped is read
    (data.setdefault(section, {}) if section else data)[key] = value
    assert list(VALIDATOR.iter_errors(data)), what
    with pytest.raises(InputError):  # the schema refuses no scene that tiseg would run
        scene_from_dict(data)


def test_the_command_prints_the_schema(capsys):
    assert main(["scenes", "schema"]) == 0
    assert json.loads(capsys.readouterr().out) == json.loads(json.dumps(SCHEMA))
