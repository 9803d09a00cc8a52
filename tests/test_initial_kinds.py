"""Initial states as a registry (`tiseg.setup.initial.INITIAL_KINDS`): a kind registered from
this file, with its own keys and check, is accepted by the scene, refused where its check
says so, written back to scene.toml and built by the simulation; an unknown kind names the
registered ones."""

from __future__ import annotations

import numpy as np
import pytest

from tiseg.errors import InputError
from tiseg.setup import initial
from tiseg.setup.initial import InitialKind, register_initial
from tiseg.setup.scene import load_scene, scene_from_dict, scene_to_dict


def _wedge(scene, X, Y):
    """A wedge at rest: h falls linearly from initial.h at x = 0 to 0 at initial.x1."""
    ini = scene.initial
    h = np.clip(ini.h * (1.0 - X / ini.x1), 0.0, None)
    return h, np.zeros_like(X), np.zeros_like(X), np.full_like(X, scene.flow.phi0)


def _check_wedge(values, domain):
    if values["x1"] > domain.Lx:
        raise InputError(f"initial.x1={values['x1']!r}: the wedge must end inside Lx={domain.Lx}")


@pytest.fixture
def wedge():
    kind = register_initial(InitialKind("wedge", _wedge, keys=("h", "x1"), check=_check_wedge))
    yield kind
    initial.INITIAL_KINDS.pop("wedge")


WEDGE = {"kind": "wedge", "h": 0.004, "x1": 0.1}


def _scene(**initial):
    """The 1D dam-break scene (60 cells) with ``initial`` as its whole initial section."""
    data = scene_to_dict(load_scene("dam-break", {"domain.nx": 60}))
    data["initial"] = initial
    return scene_from_dict(data)


def test_a_registered_kind_runs_through_the_scene_and_the_simulation(wedge, ti_cpu):
    from tiseg.run.simulation import Simulation

    scene = _scene(**WEDGE)
    assert scene.initial.kind == "wedge" and scene.initial.x1 == 0.1
    # written back and read again as the same scene
    again = scene_from_dict(scene_to_dict(scene))
    assert again.initial.kind == "wedge" and again.initial.h == 0.004
    sim = Simulation(scene)
    h = sim.fields()["h"][0]
    x = scene.domain.cell_centres()[0]
    np.testing.assert_array_equal(h, np.clip(0.004 * (1.0 - x / 0.1), 0.0, None))
    assert sim.totals()["mass"] > 0


def test_a_registered_kind_refuses_keys_it_does_not_read_and_runs_its_check(wedge):
    with pytest.raises(InputError, match="x0"):
        _scene(**WEDGE, x0=0.05)  # a dam-break key, not its own
    with pytest.raises(InputError, match="inside Lx"):
        _scene(**{**WEDGE, "x1": 5.0})


def test_an_unknown_kind_names_the_registered_ones(wedge):
    with pytest.raises(InputError, match="wedge"):
        _scene(kind="wdge")


def test_the_built_in_kinds_keep_their_keys():
    from tiseg.setup.sections import initial_keys

    keys = initial_keys()
    assert tuple(keys)[:7] == (
        "empty",
        "uniform",
        "dam-break",
        "release",
        "channel",
        "layer",
        "cap",
    )
    assert keys["empty"] == ("kind",)
    assert set(keys["cap"]) == {"kind", "x0", "h", "half_width", "u", "phi"}
    assert set(keys["dam-break"]) == {"kind", "x0", "h_left", "h_right", "phi"}
