"""The numbers a component declares for the scene, and access to their values by name.

Every component with numbers of its own (a friction law of `tiseg.model.physics.friction`, a
source term of `tiseg.model.physics.sources`, an auxiliary field of
`tiseg.model.physics.aux_fields`) declares each as a `Constant`: the scene key that sets it,
its default, its doc text and its checks. The scene reads and writes the key through the
component, so a component registered by user code brings its keys with it, and the scenes
reference lists them.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Constant:
    """A number a component declares, once: the scene key ``<section>.<name>`` that sets
    it, its default, the doc text of the scenes reference and its checks (inclusive bounds
    ``lo``/``hi``, or ``positive``/``nonneg``), which the scene applies with the one-line
    messages of every other key. ``section`` "effects" keeps the value with the effects;
    "material" names a field of `tiseg.model.material.Material` of the same name."""

    name: str
    default: float
    doc: str
    section: str = "effects"
    positive: bool = False
    nonneg: bool = False
    lo: float | None = None
    hi: float | None = None


class ConstantsByName:
    """Attribute access to the components' constants held in a ``constants`` field of (name, value)
    pairs: ``fric.coulomb_mu``."""

    constants: tuple[tuple[str, float], ...]

    def __getattr__(self, name: str) -> float:
        # only reached for names that are not fields (never while unpickling, where
        # ``constants`` is not set yet and asking for it must not recurse)
        if not name.startswith("_") and name != "constants":
            for key, value in self.constants:
                if key == name:
                    return value
        raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")
