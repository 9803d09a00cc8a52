"""The bow shock of a shallow supercritical stream in front of a circular cylinder.

A uniform stream (depth h0, speed u0, Froude number F = u0 / sqrt(g cos(zeta) h0) > 1) meets a
solid cylinder of radius R (solid cells, walls: `tiseg.solver.numerics.walls`). A jump detaches
from the cylinder and stands ahead of it (Gray, Tai & Noelle 2003; Cui & Gray 2013); on the
symmetry line it is a normal jump to h2 = h0 (sqrt(1 + 8 F^2) - 1) / 2, behind which the flow
slows to the stagnation depth of `tiseg.model.exact_oblique_shock.stagnation_depth_ratio`. The
**stand-off distance** is the distance on the symmetry line from the cylinder's upstream face
to the jump, here where h rises through the midpoint (h0 + h2) / 2, linearly interpolated
between the two cells around it; `BowShockCase` reports it over the diameter D = 2R.

`BowShockCase` builds the scene: the stream enters at x = 0 (inflow held at h0, u0) and leaves
through outflow sides; the cylinder's upstream face lies on a cell face and its centre on the
middle row of an odd number of rows, so that the centreline is a row of cell centres and the
face is exactly R from the centre there. Two bases:

* ``friction = "none"`` on a flat plane (zeta = 0): the shallow-water equations, where the
  stand-off over D depends on F alone (the problem has no other length than R);
* ``friction = "coulomb"`` with mu = tan(zeta): gravity and friction balanced, so the oncoming
  flow is uniform at any F (as on the chutes of Gray & Cui 2007 and Cui & Gray 2013). The
  balance holds only where the flow runs straight downslope; where it turns, the friction
  (against the velocity) and gravity (downslope) no longer cancel, and the stand-off then
  depends also on tan(zeta) R / (F^2 h0).

`run_to_steady` advances in chunks of ``chunk`` R / u0 until the stand-off changes by less than
``tol`` diameters over one chunk (or until ``t_max``).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from ...model.exact_oblique_shock import G, jump_depth_ratio, stagnation_depth_ratio
from ...run.simulation import Simulation
from ...setup.reading import scene_from_dict


@dataclass(frozen=True)
class BowShockCase:
    """One run: Froude number, cells per cylinder radius and the base (see the module).

    The domain, in radii: ``upstream`` of inflow ahead of the cylinder's face, the cylinder
    (2), ``downstream`` behind it, and ``half_width`` either side of the centreline (None: 8
    below F = 2.5, where the subcritical region behind the jump is wide, else 5; at F = 2, 8
    and 12 radii give the same stand-off to 1e-4 D, at F = 3, 4 and 8 to 6e-4 D)."""

    froude: float
    cells_per_radius: int
    friction: str = "none"
    zeta_deg: float = 0.0
    h0: float = 0.005
    radius: float = 0.025
    upstream: float | None = None
    downstream: float = 3.0
    half_width: float | None = None

    def __post_init__(self):
        if not self.froude > 1.0:
            raise ValueError(f"a bow shock needs a supercritical stream, got F = {self.froude}")
        if self.friction not in ("none", "coulomb"):
            raise ValueError(f"friction must be 'none' or 'coulomb', got {self.friction!r}")
        if self.friction == "none" and self.zeta_deg != 0.0:
            raise ValueError("friction 'none' is the flat plane: zeta_deg must be 0")
        if self.friction == "coulomb" and not 0.0 < self.zeta_deg < 90.0:
            raise ValueError("friction 'coulomb' balances gravity on a slope: 0 < zeta_deg < 90")

    @property
    def g_normal(self) -> float:
        return G * math.cos(math.radians(self.zeta_deg))

    @property
    def u0(self) -> float:
        return self.froude * math.sqrt(self.g_normal * self.h0)

    @property
    def dx(self) -> float:
        return self.radius / self.cells_per_radius

    @property
    def time_scale(self) -> float:
        """R / u0 [s]."""
        return self.radius / self.u0

    def _upstream(self) -> float:
        if self.upstream is not None:
            return self.upstream
        return 6.0 if self.froude < 2.5 else 4.0

    def _half_width(self) -> float:
        if self.half_width is not None:
            return self.half_width
        return 8.0 if self.froude < 2.5 else 5.0

    @property
    def face_x(self) -> float:
        """x of the cylinder's upstream face [m] (a cell face)."""
        return round(self._upstream() * self.cells_per_radius) * self.dx

    @property
    def centre(self) -> tuple[float, float]:
        n = self.cells_per_radius
        ny = 2 * round(self._half_width() * n) + 1
        return self.face_x + self.radius, 0.5 * ny * self.dx

    def grid(self) -> tuple[int, int]:
        """(nx, ny)."""
        n = self.cells_per_radius
        nx = round(self._upstream() * n) + 2 * n + round(self.downstream * n)
        return nx, 2 * round(self._half_width() * n) + 1

    def scene(self, numerics: dict | None = None):
        """The scene (split MUSCL-Hancock sweeps, WENO slopes, KT fluxes, projected friction:
        the defaults; ``numerics`` overrides them)."""
        nx, ny = self.grid()
        xc, yc = self.centre
        if self.friction == "none":
            effects = {"friction": "none"}
        else:
            effects = {"friction": "coulomb", "coulomb_mu": math.tan(math.radians(self.zeta_deg))}
        num = {"stepper": "hancock", "friction_scheme": "projected", "cfl": 0.9}
        num.update(numerics or {})
        return scene_from_dict(
            {
                "material": {"zeta_deg": self.zeta_deg},
                "flow": {"h0": self.h0, "nu": 0.0, "u0": self.u0},
                "effects": {"segregation": False, "viscosity": False, **effects},
                "domain": {"Lx": nx * self.dx, "Ly": ny * self.dx, "nx": nx, "ny": ny},
                "boundary": {
                    "x_lo": "inflow",
                    "x_hi": "outflow",
                    "y_lo": "outflow",
                    "y_hi": "outflow",
                },
                "inflow": {"h": self.h0, "u": self.u0, "ramp_rate": 0.0, "perturbation": 0.0},
                "terrain": {
                    "shapes": [{"kind": "cylinder", "x": xc, "y": yc, "radius": self.radius}]
                },
                "initial": {"kind": "uniform", "mode": "h", "amplitude": 0.0},
                "numerics": num,
                "time": {"t_end": 1.0},
                "output": {"interval": 1.0, "peak_fields": False},
            },
            name="bow-shock",
        )

    def centreline(self, h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(x [m], h [m]) of the cells on the centreline upstream of the cylinder's face, from
        a field h shaped (ny, nx)."""
        nx, ny = self.grid()
        x = (np.arange(nx) + 0.5) * self.dx
        row = np.asarray(h, dtype=float)[ny // 2]
        up = x < self.face_x
        return x[up], row[up]

    def standoff(self, h: np.ndarray) -> float:
        """The stand-off distance over D, from a field h shaped (ny, nx) (NaN if h nowhere
        reaches the midpoint: no jump stands ahead of the cylinder)."""
        x, row = self.centreline(h)
        mid = 0.5 * self.h0 * (1.0 + jump_depth_ratio(self.froude))
        above = np.nonzero(row > mid)[0]
        if above.size == 0 or above[0] == 0:
            return math.nan
        k = int(above[0])
        xs = x[k - 1] + (mid - row[k - 1]) / (row[k] - row[k - 1]) * (x[k] - x[k - 1])
        return (self.face_x - xs) / (2.0 * self.radius)

    def stagnation_ratio(self, h: np.ndarray) -> float:
        """h / h0 in the fluid cell against the cylinder's face on the centreline (its centre
        is dx / 2 from the face), to set against `stagnation_depth_ratio`."""
        return float(self.centreline(h)[1][-1] / self.h0)


def run_to_steady(case: BowShockCase, chunk=10.0, tol=2.5e-4, t_min=40.0, t_max=200.0,
                  numerics=None) -> dict:  # fmt: skip
    """Run ``case`` from the uniform stream (the cylinder's cells emptied) in chunks of
    ``chunk`` R / u0 until, after ``t_min``, the stand-off changes by less than ``tol``
    diameters over a chunk, or ``t_max`` is reached. Needs `tiseg.init`. Returns a dict:
    standoff_D, last_change_D (its change over the last chunk), t_end (in R / u0), steady
    (bool), stagnation h / h0 and its exact value, steps, cells, wall_s, and the final h
    field (ny, nx)."""
    sim = Simulation(case.scene(numerics))
    T = case.time_scale
    w = time.perf_counter()
    prev, t, change = math.nan, 0.0, math.nan
    while True:
        t += chunk
        sim.advance(t * T)
        h = sim.fields()["h"]
        d = case.standoff(h)
        change = abs(d - prev)
        prev = d
        if (t >= t_min and change < tol) or t >= t_max - 1e-9:
            break
    nx, ny = case.grid()
    return {
        "standoff_D": d,
        "last_change_D": change,
        "t_end": t,
        "steady": bool(change < tol),
        "stagnation": case.stagnation_ratio(h),
        "stagnation_exact": stagnation_depth_ratio(case.froude),
        "steps": int(sim.stats.steps),
        "cells": nx * ny,
        "wall_s": time.perf_counter() - w,
        "h": h,
    }
