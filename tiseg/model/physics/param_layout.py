"""The operator's parameter field, laid out once from the components.

The run-time numbers of a scene live in one small field, ``par``, so that they can change
without new kernels: first the slots every scene has (`tiseg.model.physics.params.Params`),
then each component's own, in this order and only for the components that are on:

* the transport function G(phi) (with segregation), (2.17) or (2.18);
* the viscosity of (6.2) (with it);
* the friction law of (6.4);
* each source term of ``effects.sources`` (`tiseg.model.physics.sources`), one slot per
  constant it declares, and then the auxiliary fields those terms read, likewise.

`ParamLayout` is that order, built once per configuration from `parts`: where each
component's slots start (``base``), the field's length and every slot's value, so the Taichi
functions (which read ``par[base + k]``), the parameter vector the operator writes and the
twin's numbers come from one list and cannot disagree.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .friction import FRICTION_LAWS
from .params import Params
from .segregation import TRANSPORTS
from .sources import AUX_FIELDS, SOURCES, chosen_aux
from .viscosity import VISCOSITY


def parts(cfg) -> list[tuple[str, list[float]]]:
    """(part name, its slot values) of every component that is on, in slot order: "transport",
    "viscosity", "friction", then "source:<name>" and "aux:<name>" (``cfg``: the operator's
    configuration)."""
    out = []
    if cfg.layout.segregation:
        out.append(("transport", TRANSPORTS[cfg.transport].values(cfg.alpha)))
    if cfg.viscous:
        out.append(("viscosity", VISCOSITY.values(cfg.nu)))
    law = FRICTION_LAWS[cfg.friction]
    # without friction parameters (a config built by hand for a law without numbers) the
    # law's slots are left at zero
    fric = law.values(cfg.fric) if cfg.fric is not None else [0.0] * len(law.slots)
    out.append(("friction", fric))
    consts = dict(cfg.constants)
    for name in cfg.sources:
        out.append((f"source:{name}", [consts[c.name] for c in SOURCES[name].constants]))
    for name in chosen_aux(cfg.sources):
        out.append((f"aux:{name}", [consts[c.name] for c in AUX_FIELDS[name].constants]))
    return out


@dataclass(frozen=True)
class ParamLayout:
    """Where each part's slots start (`base`), the field's length (``end``) and the values of
    the components' slots (``values``, from ``Params.COUNT`` on)."""

    bases: tuple[tuple[str, int], ...]
    end: int
    values: tuple[float, ...]

    @classmethod
    def of(cls, cfg) -> "ParamLayout":
        bases, values = [], []
        b = Params.COUNT
        for name, vals in parts(cfg):
            bases.append((name, b))
            values += [float(v) for v in vals]
            b += len(vals)
        return cls(tuple(bases), b, tuple(values))

    def base(self, part: str) -> int:
        """The first slot of ``part`` ("friction", "source:<name>", ...)."""
        return dict(self.bases)[part]

    def vector(self, cfg) -> np.ndarray:
        """The whole parameter field of ``cfg`` (f64): the common slots, then the
        components'. The inflow's thickness and switch (IN_H, IN_ON) follow the time and are
        written by the operator at each stage."""
        P = Params
        p = np.zeros(self.end)
        p[P.G_COS], p[P.G_SIN] = cfg.g_cos, cfg.g_sin
        p[P.H_MIN], p[P.H_EPS4], p[P.U_EPS] = cfg.h_min, cfg.h_eps**4, cfg.u_eps
        p[P.THETA], p[P.WENO_EPS] = cfg.theta, cfg.weno_eps
        p[P.PHI_REF], p[P.DX], p[P.DY] = cfg.phi_ref, cfg.dx, cfg.dy
        p[P.COUNT :] = self.values
        p[P.IN_U] = cfg.inflow_u
        p[P.INV_DX], p[P.INV_DY] = 1.0 / cfg.dx, 1.0 / cfg.dy
        p[P.INV_H_REF], p[P.INV_U_REF] = 1.0 / cfg.h_ref, 1.0 / cfg.u_ref
        return p
