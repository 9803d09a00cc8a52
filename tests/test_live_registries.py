"""Registries are read when asked, never frozen at import: a transport, a slope or a stepper that
user code registers (here, from this file) is a valid choice of a scene, reaches the operator's
config and the reference operator, and the choice lists of before show it; an unknown name is an
InputError naming the key (not an assert, which ``python -O`` drops)."""

from __future__ import annotations

import numpy as np
import pytest

from tiseg.errors import InputError
from tiseg.model.physics.segregation import TRANSPORTS, Linear
from tiseg.setup import scene as S
from tiseg.solver.numerics import config
from tiseg.solver.numerics.config import config_from_scene
from tiseg.solver.timestepping import STEPPERS, stepper_for
from tiseg.solver.timestepping.ssprk import SSPRK3

DRY = {"domain.ny": 1, "domain.nx": 20, "effects.segregation": True}


class HalfLinear(Linear):
    """A user's transport: half the linear G."""

    name = "test-half-linear"

    def values(self, alpha):
        return [0.5 * (1.0 - alpha)]

    def G_np(self, phi, alpha):
        return 0.5 * super().G_np(phi, alpha)

    def dG_np(self, phi, alpha):
        return 0.5 * super().dG_np(phi, alpha)


class CappedSSPRK3(SSPRK3):
    """A user's stepper that says its stages follow the stiffness up to a cap."""

    name = "test-capped"
    stage_cap = True

    def __init__(self, max_stages: int = 200):
        self.max_stages = max_stages


@pytest.fixture
def half_linear():
    TRANSPORTS[HalfLinear.name] = HalfLinear()
    try:
        yield TRANSPORTS[HalfLinear.name]
    finally:
        del TRANSPORTS[HalfLinear.name]


@pytest.fixture
def capped():
    STEPPERS[CappedSSPRK3.name] = CappedSSPRK3
    try:
        yield CappedSSPRK3
    finally:
        del STEPPERS[CappedSSPRK3.name]


def test_a_transport_registered_after_import_is_a_choice_everywhere(half_linear):
    sc = S.load_scene("dam-break", {**DRY, "material.transport": HalfLinear.name})
    assert sc.material.transport == HalfLinear.name
    cfg = config_from_scene(sc)  # checked against the registry as it stands now
    assert cfg.transport == HalfLinear.name
    from tiseg.solver.reference import ReferenceOperator

    assert ReferenceOperator(cfg).transport is half_linear
    assert HalfLinear.name in config.TRANSPORTS and HalfLinear.name in S.TRANSPORTS
    phi = np.linspace(0.0, 1.0, 5)
    np.testing.assert_allclose(sc.material.G(phi), 0.5 * TRANSPORTS["linear"].G_np(phi, 1 / 7))


def test_an_unregistered_transport_is_an_input_error_in_the_scene_and_the_config():
    with pytest.raises(InputError, match=r"material\.transport='test-half-linear'"):
        S.load_scene("dam-break", {**DRY, "material.transport": HalfLinear.name})
    cfg = config_from_scene(S.load_scene("dam-break", DRY))
    from dataclasses import replace

    with pytest.raises(InputError, match=r"material\.transport='nope': choose one of linear"):
        replace(cfg, transport="nope")
    with pytest.raises(InputError, match=r"numerics\.flux='nope'"):
        replace(cfg, flux="nope")
    with pytest.raises(InputError, match=r"boundary='nope'"):
        replace(cfg, bc=("nope", "outflow", "wall", "wall"))


def test_a_stepper_with_a_stage_cap_gets_the_scenes(capped):
    """`stepper_for` asks the stepper class, not its name, whether it takes the cap."""
    sc = S.load_scene(
        "dam-break", {**DRY, "numerics.stepper": CappedSSPRK3.name, "numerics.max_stages": 17}
    )
    assert stepper_for(sc.numerics).max_stages == 17
    assert stepper_for(sc.numerics, "rkc").max_stages == 17
    assert not hasattr(stepper_for(sc.numerics, "ssprk3"), "max_stages")
    assert CappedSSPRK3.name in S.STEPPERS
