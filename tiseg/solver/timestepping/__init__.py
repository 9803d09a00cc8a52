"""Time steppers that know only the operator: a registry by name.

Every stepper advances slot 0 of an operator offering

* ``rhs(src, dst, t)``: slot dst := L(slot src, t),
* ``combine(dst, [(c, slot), ...], limit)``: slot dst := sum c * slot (element-wise, dst may be
  a source), followed with ``limit=True`` by the stage limiter (h >= 0, phi in [0, 1]) in the
  same pass over memory,
* ``stage(dst, terms, src, t)``: the same combination with one term ``(c, RATE)`` standing for
  L(slot src, t), computed in the same launch and never stored (``base.RATE``),

(a split stepper, ``split = True``, calls ``sweep(d, t, dt)`` instead: one dimensionally
split update of slot 0 along direction d, tiseg.solver.numerics.split), and chooses its step from two
numbers the caller measures on the current state: the convective
step ``dt_cfl`` and the spectral radius ``rho`` of the operator's Jacobian on the negative real
axis (viscous + friction + KT dissipation 2 a / dx: without the dissipation the SSP steps are too
long for their stability interval).
"""

from .base import STEPPERS, Stepper, make_stepper, stepper_for
from .rkc import RKC
from .split import Hancock
from .ssprk import SSPRK2, SSPRK3, SSPRK42, SSPRK93, SSPRK102, SSPRK104, SSPRK163, Euler

__all__ = [
    "Stepper",
    "STEPPERS",
    "make_stepper",
    "stepper_for",
    "RKC",
    "Hancock",
    "SSPRK2",
    "SSPRK3",
    "SSPRK42",
    "SSPRK102",
    "SSPRK104",
    "SSPRK93",
    "SSPRK163",
    "Euler",
]
