"""The state of a simulation as arrays: read it, replace it, sum it.

A collaborator of `tiseg.run.simulation.Simulation` (issue 49; a mixin before) that receives
the operator's state (`tiseg.solver.numerics.state.OperatorState`: its slots, budgets and
layout) and the operator's deterministic totals and boundary budgets (`TaichiOperator.sums`
and ``budget``, or a batch member's, `tiseg.run.member_view.MemberOperator`): the conserved
slots seen as NumPy arrays shaped (ny, nx) (primitive fields) or (nc, nx, ny) (conserved, no
ghost cells), the totals that the mass balance compares and the boundary budget. What a new state means for the run (the mass balance, the peak
fields) is the simulation's."""

from __future__ import annotations

import numpy as np

from ..errors import InputError


def output_velocity(h: np.ndarray, m: np.ndarray, h_eps: float) -> np.ndarray:
    """The velocity of momentum ``m`` in thickness ``h`` as the output writes it: m/h where
    h >= h_eps, below it the solver's desingularised sqrt(2) h m / sqrt(h^4 + h_eps^4)
    (`FiniteVolume.primitive`; Kurganov & Petrova 2007), 0 where h <= 0. (A film of 1e-19 m
    with a round-off momentum would otherwise report 1e7 m/s or more.) In the arrays' own
    precision; the cells at or above h_eps keep m/h's bits."""
    safe = np.where(h > 0, h, 1.0)
    out = np.where(h > 0, m / safe, 0.0)
    thin = h < h_eps
    film = h[thin]
    out[thin] = np.sqrt(2.0) * film * m[thin] / np.sqrt(film**4 + h_eps**4)
    return out


class StateArrays:
    """Reading and replacing the state of a `tiseg.run.simulation.Simulation`'s operator."""

    def __init__(self, state, sums, budget, dx: float, dy: float, member: int = 0):
        """``state``: the operator's `OperatorState`; ``sums``: ``sums(slot)``, the
        member's (sum of h, sum of h phi) over the interior cells of a slot (the operator's
        `sums`); ``budget``: ``budget(slot)``, the member's boundary budget (the operator's
        `budget`); ``dx``, ``dy``: the cell size [m] (fixed for the kernels' life);
        ``member``: the ensemble member whose state these are."""
        self.state = state
        self.sums = sums
        self._budget = budget
        self.member = int(member)
        self.layout = state.lay
        # a cell's area (per metre of width in 1D)
        self.cell = dx * (dy if not self.layout.is_1d else 1.0)
        self._per_width = 1.0 if not self.layout.is_1d else 1.0 / dy

    def from_primitives(self, h, u, v, phi, phi0: float) -> np.ndarray:
        """Interior conserved variables (nc, nx, ny) of primitive fields shaped (ny, nx) as
        `fields` returns them (u, v default to 0, phi to ``phi0``), checked."""
        lay = self.layout
        shape = (lay.ny, lay.nx)

        def arr(name, a, default):
            if a is None:
                return np.full(shape, float(default))
            a = np.asarray(a, dtype=float)
            if a.shape != shape:
                raise InputError(
                    f"set_state: {name} has shape {a.shape}, expected {shape} (ny, nx)"
                )
            if not np.all(np.isfinite(a)):
                raise InputError(f"set_state: {name} holds NaN or Inf")
            return a

        h = arr("h", h, 0.0)
        if np.any(h < 0):
            raise InputError(f"set_state: h must be >= 0 (min {h.min():.3g})")
        if v is not None and lay.is_1d:
            raise InputError("set_state: a 1D simulation has no v")
        if phi is not None and not lay.segregation:
            raise InputError("set_state: this scene has no segregation, so no phi")
        u = arr("u", u, 0.0)
        q = np.zeros((lay.nc, lay.nx, lay.ny))
        q[lay.H], q[lay.HU] = h.T, (h * u).T
        if not lay.is_1d:
            q[lay.HV] = (h * arr("v", v, 0.0)).T
        if lay.segregation:
            phi = arr("phi", phi, phi0)
            if np.any((phi < 0) | (phi > 1)):
                raise InputError("set_state: phi must lie in [0, 1]")
            q[lay.HPHI] = (h * phi).T
        return q

    def conserved(self, slot: int = 0) -> np.ndarray:
        """Interior conserved variables (nc, nx, ny)."""
        ix, iy = self.layout.interior()
        return self.state.get(slot, self.member)[:, ix, iy]

    def set_conserved(self, q_interior: np.ndarray) -> None:
        """Replace the interior conserved variables (nc, nx, ny) of slot 0."""
        full = self.state.get(0, self.member)
        ix, iy = self.layout.interior()
        full[:, ix, iy] = q_interior
        self.state.set(0, full, self.member)

    def fields(self, slot: int = 0) -> dict[str, np.ndarray]:
        """Primitive fields ``h, u[, v][, phi]`` shaped (ny, nx) as in the output files.

        Velocities are hu/h where h >= h_eps, and below it the solver's desingularised
        velocity sqrt(2) h (hu) / sqrt(h^4 + h_eps^4) (`FiniteVolume`; Kurganov & Petrova
        2007): a film of 1e-19 m with a round-off momentum would otherwise report 1e11 m/s.
        phi is h phi / h clipped to [0, 1] where h > 0; all are 0 on the empty chute."""
        lay = self.layout
        q = self.conserved(slot)
        h = q[lay.H]
        safe = np.where(h > 0, h, 1.0)
        h_eps = self.state.cfgs[self.member].h_eps
        out = {"h": h.T.copy(), "u": output_velocity(h, q[lay.HU], h_eps).T.copy()}
        if not lay.is_1d:
            out["v"] = output_velocity(h, q[lay.HV], h_eps).T.copy()
        if lay.segregation:
            out["phi"] = np.clip(np.where(h > 0, q[lay.HPHI] / safe, 0.0), 0.0, 1.0).T.copy()
        return out

    def totals(self, slot: int = 0) -> dict[str, float]:
        """Total mass and small-particle mass [m^3] (per metre of width in 1D), summed in a
        fixed order on the device: deterministic for any thread count."""
        sh, shphi = self.sums(slot)
        seg = self.layout.segregation
        return {"mass": sh * self.cell, "small_mass": shphi * self.cell if seg else float("nan")}

    def budget(self, slot: int = 0) -> dict[str, float]:
        """Mass and small-particle mass that entered through the boundaries since the start."""
        b = self._budget(slot)
        return {
            "mass_in": float((b[0] + b[2]) * self._per_width),
            "small_mass_in": float((b[1] + b[3]) * self._per_width),
        }
