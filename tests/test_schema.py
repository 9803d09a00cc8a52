"""The scene schema: each key declared once, and everything else derived from that declaration.

A friction law registered by user code brings its own constant, which a scene reads with the
law's default and checks; the allowed keys, the compiled keys, the reference page and the
written TOML follow the declarations (and the registries as they stand when a scene is read).
"""

from __future__ import annotations

import dataclasses
import pickle

import numpy as np
import pytest

from tiseg.setup import scene as S
from tiseg.errors import InputError
from tiseg.solver.numerics.config import (
    FIELD_KEYS,
    OperatorConfig,
    compiled_fields,
    config_from_scene,
)
from tiseg.model.physics.friction import FRICTION_LAWS, Constant, FrictionLaw, FrictionParams
from tiseg.setup import reference, sections
from tiseg.setup.schema import compiled_keys, key_fields, key_of
from tiseg.setup.sections import SECTIONS, NumericsConfig, section_keys

from solver_helpers import MINIMAL_SCENE

# a small 1D dam break, with a stepper that takes friction
DRY = {"domain.ny": 1, "domain.nx": 20, "numerics.stepper": "rkc"}


class Plateau(FrictionLaw):
    """A user's law: one constant coefficient of its own, ``effects.plateau_mu``."""

    name = "test-plateau"
    constants = (Constant("plateau_mu", 0.4, "the plateau's friction coefficient", lo=0.0, hi=2.0),)
    slots = ("mu",)

    def values(self, fric):
        return [fric.plateau_mu]

    def least_mu(self, fric):
        return fric.plateau_mu

    def mu_np(self, c, h, speed, phi):
        return np.full_like(h, c.fric.plateau_mu)


@pytest.fixture
def plateau():
    FRICTION_LAWS[Plateau.name] = Plateau()
    try:
        yield FRICTION_LAWS[Plateau.name]
    finally:
        del FRICTION_LAWS[Plateau.name]


def _dam(**sets):
    return S.load_scene("dam-break", {**DRY, **sets})


# ---- a user-registered friction law and its constant ------------------------------------------
def test_a_registered_law_and_its_constant_are_read_from_a_scene(plateau):
    sc = _dam(**{"effects.friction": "test-plateau", "effects.plateau_mu": 0.7})
    assert sc.effects.friction == "test-plateau" and sc.effects.plateau_mu == 0.7
    assert sc.friction_constants["plateau_mu"] == 0.7
    cfg = config_from_scene(sc)  # the operator sees it through the chosen law
    assert cfg.fric.plateau_mu == 0.7 and plateau.values(cfg.fric) == [0.7]
    from tiseg.model.physics.param_layout import ParamLayout

    assert ParamLayout.of(cfg).values[-1] == 0.7
    # the law's default when the key is left out, and the resolved TOML round trip
    assert _dam(**{"effects.friction": "test-plateau"}).effects.plateau_mu == 0.4
    assert S.scene_to_dict(sc)["effects"]["plateau_mu"] == 0.7
    assert S.scene_from_text(sc.to_toml(), name=sc.name) == sc


def test_a_registered_constant_is_checked_with_its_declared_range(plateau):
    with pytest.raises(InputError, match=r"effects\.plateau_mu=3: must lie in \[0, 2\]"):
        _dam(**{"effects.friction": "test-plateau", "effects.plateau_mu": 3})
    with pytest.raises(InputError, match=r"effects\.plateau_mu='a': expected a number"):
        _dam(**{"effects.plateau_mu": "a"})
    with pytest.raises(InputError, match=r"did you mean 'effects\.plateau_mu'"):
        _dam(**{"effects.plateau_m": 0.5})


def test_an_unregistered_law_and_its_constant_are_unknown():
    """The registry is read when a scene is read: before registering, neither is allowed."""
    with pytest.raises(InputError, match=r"unknown key 'effects\.plateau_mu'"):
        _dam(**{"effects.plateau_mu": 0.5})
    with pytest.raises(InputError, match=r"effects\.friction='test-plateau': allowed values"):
        _dam(**{"effects.friction": "test-plateau"})
    assert "plateau_mu" not in section_keys()["effects"]


def test_a_registered_law_reaches_the_reference_operator(plateau):
    """The user's constant acts as the friction coefficient: its rates are those of a Coulomb
    law of the same coefficient."""
    from tiseg.solver.reference import ReferenceOperator

    q = None
    rates = []
    for law, key in (("test-plateau", "plateau_mu"), ("coulomb", "coulomb_mu")):
        sc = _dam(**{"effects.friction": law, f"effects.{key}": 0.55, "material.zeta_deg": 30})
        cfg = config_from_scene(sc)
        ref = ReferenceOperator(cfg)
        if q is None:
            lay = cfg.layout
            q = np.zeros((lay.nc, lay.NX, lay.NY))
            q[lay.H] = 0.002
            q[lay.HU] = 0.002 * 0.1
        rates.append(ref.rhs(q.copy(), 0.0))
    np.testing.assert_array_equal(rates[0], rates[1])


def test_friction_params_take_the_laws_constants_by_name():
    m = S.load_scene("dam-break").material
    fric = FrictionParams.of(m, coulomb_mu=0.3)
    assert fric.coulomb_mu == 0.3 and fric.beta_star == m.beta_star and fric.kappa == m.kappa
    assert fric.mu3_l == m.large.mu3
    with pytest.raises(TypeError, match="no registered friction law"):
        FrictionParams.of(m, nonsense=1.0)
    with pytest.raises(AttributeError):
        fric.nonsense  # noqa: B018


def test_scenes_and_friction_params_pickle(plateau):
    """Scenes travel to sweep workers: the laws' constants survive a pickle round trip."""
    sc = _dam(**{"effects.friction": "test-plateau", "effects.plateau_mu": 0.9})
    back = pickle.loads(pickle.dumps(sc))
    assert back == sc and back.effects.plateau_mu == 0.9
    fric = pickle.loads(pickle.dumps(config_from_scene(sc).fric))
    assert fric.plateau_mu == 0.9


# ---- the derived lists ---------------------------------------------------------------------
def test_allowed_keys_are_the_declared_fields():
    """Each section's allowed keys are its dataclass fields with key metadata (and the laws'
    constants kept there); the unknown-key message lists exactly those."""
    keys = section_keys()
    for name, cls in SECTIONS.items():
        declared = {f.name for f in key_fields(cls)}
        extra = set(keys[name]) - declared
        if name == "effects":
            assert extra == {"coulomb_mu"}  # Coulomb's constant
        elif name == "material":
            assert extra == {"beta_star", "kappa"}  # the extended law's constants
        else:
            assert not extra, name
        assert declared <= set(keys[name]), name
    assert S.SECTION_KEYS == keys
    assert "F" not in keys["flow"] and "output_times" not in keys["output"]  # derived, no keys
    with pytest.raises(InputError) as exc:
        _dam(**{"numerics.bogus": 1})
    assert str(exc.value).endswith("allowed: " + ", ".join(keys["numerics"]))


def test_initial_keys_come_from_the_kinds_each_field_declares():
    keys = sections.initial_keys()
    assert set(keys) == set(key_of(sections.InitialConfig.__dataclass_fields__["kind"]).allowed())
    for f in key_fields(sections.InitialConfig):
        for kind in key_of(f).kinds:
            assert f.name in keys[kind]
    assert keys["dam-break"] == ("kind", "x0", "h_left", "h_right", "phi")


def test_compiled_lists_come_from_the_declarations():
    """The simulation refuses changes of what the kernels were compiled for: the operator's
    fields made from a key the schema declares compiled "operator", and the scene keys the
    simulation builds itself. The operator's fields name real keys, and every key compiled
    for the operator reaches one of its fields."""
    operator_keys = compiled_keys(SECTIONS, "operator")
    compiled = compiled_fields(operator_keys)
    assert {"reconstruction", "friction", "bc", "layout", "inflow_rows", "sources"} <= set(compiled)
    assert not {"nu", "g", "zeta", "inflow_h", "constants"} & set(compiled)  # run-time numbers
    named = {k for keys, _ in FIELD_KEYS.values() for k in keys}
    all_keys = {f"{s}.{f.name}" for s in SECTIONS for f in sections.section_fields(s)}
    assert named <= all_keys, named - all_keys
    assert set(operator_keys) <= named, set(operator_keys) - named
    for name in compiled:  # a compiled field is made from compiled keys only
        assert set(FIELD_KEYS[name][0]) <= set(operator_keys), name
    assert compiled_keys(SECTIONS, "simulation") == (
        "numerics.stepper",
        "numerics.precision",
        "numerics.max_stages",
        "output.peak_fields",
        "output.gauges",
    )
    assert "numerics.reconstruction" in operator_keys
    assert "flow.nu" not in compiled_keys(SECTIONS)


def test_reference_page_rows_come_from_the_declarations(plateau):
    """Every key's row holds its declared doc and its allowed words, read from the registry
    when the page is made (so a registered law is listed, with its constant)."""
    page = reference.markdown()
    for name in SECTIONS:
        for f in sections.section_fields(name):
            k = key_of(f)
            row = next(
                ln for ln in page.splitlines() if ln.startswith(f"| `{f.name}` | {k.doc[:30]}")
            )
            for word in k.allowed():
                assert f"`{word}`" in row, (name, f.name, word)
    assert "`test-plateau`" in page and "| `plateau_mu` | the plateau's friction" in page
    assert reference.descriptions()["effects.plateau_mu"] == "the plateau's friction coefficient"


def test_numerics_defaults_are_declared_once():
    """A scene that gives no numerics gets the declared defaults; the operator has none of its
    own for them (it takes the scene's)."""
    sc = S.scene_from_text(MINIMAL_SCENE)
    n = sc.numerics
    for f in key_fields(NumericsConfig):
        if f.name != "cfl":  # its default depends on the step rule
            assert getattr(n, f.name) == f.default, f.name
    cfg = config_from_scene(sc)
    assert (cfg.reconstruction, cfg.theta, cfg.friction_scheme) == (
        n.reconstruction,
        n.theta,
        n.friction_scheme,
    )
    required = {
        f.name
        for f in dataclasses.fields(OperatorConfig)
        if f.default is dataclasses.MISSING and f.kw_only
    }
    assert required == {
        "reconstruction",
        "theta",
        "flux",
        "phi_flux",
        "h_min",
        "h_eps",
        "u_eps",
        "friction_scheme",
    }
