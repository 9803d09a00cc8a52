"""Source terms beyond (6.4), and auxiliary per-cell fields, as components.

The momentum sources of the paper (gravity along the slope and the basal friction of (6.4)) are
pointwise and built into `tiseg.model.physics.pointwise.Physics`. A scene may add further
terms by name (``effects.sources = ["name", ...]``), each a `SourceTerm` found through
`SOURCES`; a term may read its cell's neighbours (a gradient) and static per-cell data, the
`AuxField` components of `AUX_FIELDS` (a bed height, a solid mask), that the operator
allocates and fills once for the terms that name them. A component holds everything the
solver needs of it, in one place, as a friction law does:

* ``constants``: its numbers as scene keys (`tiseg.model.physics.constants.Constant`, in the
  effects section unless it says otherwise), written to and read from the scene only while the
  component is on; they are also its run-time parameters, stored in the operator's parameter
  field in this order (`tiseg.model.physics.param_layout`), so changing one needs no new
  kernels;
* ``taichi``: its Taichi function built for one operator (`TaichiContext`: the parameter
  field and its first slot, the primitives, the auxiliary fields, the layout's constants);
* ``rate_np`` (``values_np`` for a field): its NumPy twin, written independently, which the
  reference operator (`tiseg.solver.reference.operator`) calls and the kernels are tested
  against;
* optionally ``stiffness``: a bound on the rate's Jacobian [1/s] per cell, which the
  steppers plan with (RKC's stage count; the split scheme's step).

The operator composes the chosen terms with ``ti.static``: a scene without ``effects.sources``
compiles exactly the kernels it had before, with no auxiliary field allocated.

How the schemes take a term (`tiseg.solver.numerics.finite_volume`, `.split`): the unsplit
scheme adds its rate to L(q) at every stage, like (6.4); the split sweeps add it in the x sweep
(the sweep that carries the gravity), with Hancock's half step in the predicted edges and the
whole step in the update, both from the primitives at the sweep's start. The rate of a cell
that is empty should be zero (the stage limiter then keeps h >= 0).

Registering a term from user code is one line, ``SOURCES[term.name] = term``; the scene, the
kernels, the twin and the written scene take it from there (tests/test_components.py defines
one in the test file).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

from .constants import Constant

# how far a term's rate may read from its cell along x and y: the split predictor evaluates it
# on the ghost cells next to the interior too, and the ghost layers are two cells deep
MAX_STENCIL = 1


@dataclass(frozen=True)
class TaichiContext:
    """What a component's Taichi function may read, for one operator: ``par`` the parameter
    field (member e's numbers from ``par[e, base]`` on, in the order of its ``constants``),
    ``w`` the primitives (h, u[, v][, phi]) of every cell of every member (``w[i, j, e]``),
    ``aux`` the auxiliary fields (a vector per cell, ``aux[i, j, e]``; component
    ``aux_index[name]``) or None, and the layout's compile-time constants
    (``nc``, ``is_1d``, ``seg``, the component indices ``H, HU, HV, HPHI``, ``fp``).
    Grid spacings and the slope are in ``par`` at `tiseg.model.physics.params.Params`."""

    par: Any
    base: int
    w: Any
    aux: Any
    aux_index: Mapping[str, int]
    nc: int
    is_1d: bool
    seg: bool
    H: int
    HU: int
    HV: int
    HPHI: int
    fp: Any


@dataclass(frozen=True)
class NumpyContext:
    """What a component's NumPy twin may read: ``w`` the primitives (nc, NX, NY) with ghost
    cells filled, ``aux`` {name: (NX, NY) array}, ``values`` {constant name: value}, ``cfg``
    the operator's configuration (g_cos, g_sin, dx, dy, layout)."""

    w: np.ndarray
    aux: Mapping[str, np.ndarray]
    values: Mapping[str, float]
    cfg: Any


class SourceTerm:
    """A source term of the momentum or mass balances; subclass it and register it in
    `SOURCES`. The base class is the interface and adds nothing."""

    name = ""
    doc = ""  # one line for the scenes reference
    constants: tuple[Constant, ...] = ()
    aux: tuple[str, ...] = ()  # the auxiliary fields it reads (names in AUX_FIELDS)
    stencil = 0  # how many cells along x and y its rate reads from its own (<= MAX_STENCIL)

    def taichi(self, ti, ctx: TaichiContext):
        """Its Taichi function ``rate(e, i, j)``: the rate vector of the conserved variables
        (nc components) at cell (i, j) of ensemble member e, from ``ctx``'s fields."""
        raise NotImplementedError

    def stiffness_taichi(self, ti, ctx: TaichiContext):
        """A Taichi function ``stiffness(e, i, j)`` [1/s] bounding its rate's Jacobian at
        cell (i, j) of member e, or None for a term that is not stiff."""
        return None

    def rate_np(self, ctx: NumpyContext) -> np.ndarray:
        """NumPy twin of ``rate``: (nc, NX, NY), read on the interior cells."""
        raise NotImplementedError


class AuxField:
    """Static data per cell that source terms read (a bed height, a solid mask); subclass it
    and register it in `AUX_FIELDS`. The operator fills it on every cell, ghost cells
    included, from ``values_np`` whenever its run-time numbers are set."""

    name = ""
    doc = ""
    constants: tuple[Constant, ...] = ()

    def values_np(self, x: np.ndarray, y: np.ndarray, values: Mapping[str, float]):
        """The field at the cell centres (x, y) [m] (arrays of one shape: every cell of the
        operator's grid, ghost cells at their own centres beyond the domain), from the
        constants' ``values`` by name."""
        raise NotImplementedError


SOURCES: dict[str, SourceTerm] = {}
AUX_FIELDS: dict[str, AuxField] = {}


def chosen_aux(sources) -> tuple[str, ...]:
    """The auxiliary fields the terms ``sources`` (names) read, once each, in order."""
    return tuple(dict.fromkeys(a for s in sources for a in SOURCES[s].aux))


def components(sources) -> list:
    """The components whose constants a scene with ``sources`` on has: the terms and the
    auxiliary fields they read, in that order."""
    return [SOURCES[s] for s in sources] + [AUX_FIELDS[a] for a in chosen_aux(sources)]


def declared_constants(section: str | None = None) -> dict[str, Constant]:
    """{name: Constant} that the registered terms and fields declare (for ``section``; all
    sections when None), the first declaration of a name winning."""
    out: dict[str, Constant] = {}
    for comp in (*SOURCES.values(), *AUX_FIELDS.values()):
        for c in comp.constants:
            if (section is None or c.section == section) and c.name not in out:
                out[c.name] = c
    return out


def cell_centres(cfg) -> tuple[np.ndarray, np.ndarray]:
    """(x, y) [m] of every cell of ``cfg``'s grid, ghost cells included, as (NX, NY) arrays:
    x_i = (i - gx + 1/2) dx, likewise y; a 1D run's single row sits at y = Ly / 2."""
    lay = cfg.layout
    x = (np.arange(lay.NX) - lay.gx + 0.5) * cfg.dx
    y = (np.arange(lay.NY) - lay.gy + 0.5) * cfg.dy if not lay.is_1d else np.array([cfg.Ly / 2])
    return np.meshgrid(x, y, indexing="ij")


def aux_arrays(cfg) -> dict[str, np.ndarray]:
    """{name: (NX, NY) float64} of the auxiliary fields the terms of ``cfg.sources`` read, on
    every cell: what the operator stores and what the twin reads."""
    x, y = cell_centres(cfg)
    values = dict(cfg.constants)
    out = {}
    for name in chosen_aux(cfg.sources):
        a = np.asarray(AUX_FIELDS[name].values_np(x, y, values), dtype=float)
        out[name] = np.broadcast_to(a, x.shape).copy()
    return out
