"""The state of a simulation as arrays: read it, replace it, sum it.

A mixin of `tiseg.run.simulation.Simulation`: the conserved slots of its Taichi operator
seen as NumPy arrays shaped (ny, nx) (primitive fields) or (nc, nx, ny) (conserved, no ghost
cells), the totals that the mass balance compares and the boundary budget."""

from __future__ import annotations

import numpy as np

from ..errors import InputError


class StateAccess:
    """Reading and replacing the state of a `tiseg.run.simulation.Simulation`."""

    def set_state(self, h, u=None, v=None, phi=None) -> None:
        """Replace the state by primitive fields shaped (ny, nx) as `state` returns them
        (u, v default to 0, phi to the scene's phi0). The time stays; the mass balance starts
        afresh from this state (its mass is the new initial mass, the boundary budget 0), and
        so do the peak fields (tiseg.run.peaks: arrival at the current time where it is wet)."""
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
            phi = arr("phi", phi, self.scene.flow.phi0)
            if np.any((phi < 0) | (phi > 1)):
                raise InputError("set_state: phi must lie in [0, 1]")
            q[lay.HPHI] = (h * phi).T
        self.set_conserved(q)
        self.op.reset_budget()
        self.initial_totals = self.totals()
        self.guard.keep(self.checkpoint_meta())

    def state(self) -> dict[str, np.ndarray]:
        """The primitive fields ``h, u[, v][, phi]`` shaped (ny, nx) (as `fields`)."""
        return self.fields()

    def conserved(self, slot: int = 0) -> np.ndarray:
        """Interior conserved variables (nc, nx, ny)."""
        ix, iy = self.layout.interior()
        return self.op.get(slot)[:, ix, iy]

    def set_conserved(self, q_interior: np.ndarray) -> None:
        """Replace the interior conserved variables (nc, nx, ny); the peak fields start again
        from this state (tiseg.run.peaks)."""
        full = self.op.get(0)
        ix, iy = self.layout.interior()
        full[:, ix, iy] = q_interior
        self.op.set(0, full)
        if self.peaks is not None:
            self.peaks.start(self.t)

    def fields(self, slot: int = 0) -> dict[str, np.ndarray]:
        """Primitive fields ``h, u[, v][, phi]`` shaped (ny, nx) as in the output files.

        Velocities and phi are hu/h etc. where h > 0 and 0 on the empty chute."""
        lay = self.layout
        q = self.conserved(slot)
        h = q[lay.H]
        safe = np.where(h > 0, h, 1.0)
        out = {"h": h.T.copy(), "u": np.where(h > 0, q[lay.HU] / safe, 0.0).T.copy()}
        if not lay.is_1d:
            out["v"] = np.where(h > 0, q[lay.HV] / safe, 0.0).T.copy()
        if lay.segregation:
            out["phi"] = np.clip(np.where(h > 0, q[lay.HPHI] / safe, 0.0), 0.0, 1.0).T.copy()
        return out

    def totals(self, slot: int = 0) -> dict[str, float]:
        """Total mass and small-particle mass [m^3] (per metre of width in 1D), summed in a
        fixed order on the device: deterministic for any thread count."""
        lay = self.layout
        sh, shphi = self.op.sums(slot)
        cell = self.scene.dx * (self.scene.dy if not lay.is_1d else 1.0)
        return {"mass": sh * cell, "small_mass": shphi * cell if lay.segregation else float("nan")}

    def budget(self, slot: int = 0) -> dict[str, float]:
        """Mass and small-particle mass that entered through the boundaries since the start."""
        b = self.op.budget(slot)
        scale = 1.0 if not self.layout.is_1d else 1.0 / self.scene.dy
        return {
            "mass_in": float((b[0] + b[2]) * scale),
            "small_mass_in": float((b[1] + b[3]) * scale),
        }
