"""Basal friction laws mu_b as components: one class per law, one registry line each.

A law holds everything the solver needs of it:

* ``constants``: the numbers of its own that a scene sets (`Constant`: the scene key,
  its default, its doc text and its checks); the scene reads them through the law, so a law
  registered by user code brings its keys with it;
* ``slots``: the names of its run-time numbers, stored in the operator's parameter field after
  `tiseg.model.physics.params.Params.COUNT` (a law without numbers has no slots), and
  ``values``, which reads them from `FrictionParams`;
* ``taichi``: its Taichi functions ``mu(e, h, |u|, phi)`` and ``mu_start(e, h, phi)``, built
  for one operator's parameter field, whose row e holds ensemble member e's numbers (so a law
  that is not chosen leaves no code in the kernels);
* ``mu_np`` / ``mu_start_np``: their NumPy twins, written independently, for the reference
  operator (`tiseg.solver.reference.operator`), which the Taichi kernels are tested against;
* ``least_mu``: the smallest coefficient it can give, which bounds the acceleration in the run
  estimate; the friction stiffness g cos(zeta) mu_b / max(|u|, u_eps) of the regularised
  scheme is computed from ``mu`` itself (``Physics.friction_rate``);
* flags the scene reads: ``weighted`` (a concentration-weighted mixture (3.4), so mobility
  feedback applies), ``steady`` (the steady uniform flow (4.3), (4.9) of section 4 is that of
  this law, and u0 is derived from it) and ``hysteresis`` (a static coefficient mu_start above
  the dynamic one, which the projected friction uses to decide whether a cell at rest starts).

The scene's allowed ``effects.friction`` values are the keys of `FRICTION_LAWS`, read
when a scene is read. Adding a law is one class with its ``constants`` plus its registry line
(``FRICTION_LAWS[law.name] = law`` from user code works the same). This module imports no Taichi: the Taichi functions are built from the ``ti`` module
the operator passes in, so the scene can read the registry without starting Taichi.

``phi`` is the concentration the law weights with; ``Physics`` passes the local phi with
mobility feedback and ``flow.phi0`` without. Every ``h`` reaching a law is >= h_min > 0.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..material import DEFAULT_BETA_STAR, DEFAULT_KAPPA
from ..material import pouliquen as _pouliquen_np  # (3.7), the NumPy closures' own
from .constants import Constant, ConstantsByName  # declared for every component
from .params import Params

DEFAULT_COULOMB_MU = math.tan(math.radians(20.0))


@dataclass(frozen=True)
class FrictionParams(ConstantsByName):
    """The numbers the laws read: (3.7)'s constants of each species (Table 1; ``mu3`` the
    start coefficient of the extended law) and every registered law's `Constant` by
    name (``fric.coulomb_mu``). Build it with `of`."""

    mu1_s: float
    mu2_s: float
    beta_s: float
    L_s: float
    mu3_s: float
    mu1_l: float
    mu2_l: float
    beta_l: float
    L_l: float
    mu3_l: float
    constants: tuple[tuple[str, float], ...] = field(default=())

    @classmethod
    def of(cls, material, **given: float) -> "FrictionParams":
        """The parameters of ``material``'s species and of every registered law's constants:
        ``given`` by name, else the Material field of a "material" constant, else the
        declared default."""
        known = {c.name: c for law in FRICTION_LAWS.values() for c in law.constants}
        unknown = sorted(set(given) - set(known))
        if unknown:
            raise TypeError(f"no registered friction law declares {unknown}")
        consts = []
        for name, c in known.items():
            if name in given:
                v = given[name]
            elif c.section == "material":
                v = getattr(material, name)
            else:
                v = c.default
            consts.append((name, float(v)))
        s, l = material.small, material.large
        return cls(
            mu1_s=s.mu1,
            mu2_s=s.mu2,
            beta_s=s.beta,
            L_s=s.L,
            mu3_s=s.mu3,
            mu1_l=l.mu1,
            mu2_l=l.mu2,
            beta_l=l.beta,
            L_l=l.L,
            mu3_l=l.mu3,
            constants=tuple(consts),
        )


class FrictionLaw:
    """No basal friction (``effects.friction = "none"``)."""

    name = "none"
    constants: tuple[Constant, ...] = ()
    slots: tuple[str, ...] = ()
    weighted = False
    steady = False
    hysteresis = False

    def values(self, fric) -> list[float]:
        """The law's run-time numbers, in the order of ``slots``."""
        return []

    def least_mu(self, fric) -> float:
        """The smallest friction coefficient the law can give at any h and speed."""
        return 0.0

    def mu_np(self, c, h, speed, phi):
        """NumPy twin of ``mu``: the coefficient at thickness h and speed |u| (c: the
        OperatorConfig)."""
        return np.zeros_like(h)

    def mu_start_np(self, c, h, phi):
        """NumPy twin of ``mu_start``: the largest coefficient at rest."""
        return self.mu_np(c, h, np.zeros_like(h), phi)

    def taichi(self, ti, par, base: int, f32_pow: bool = False):
        """(mu(h, spd, phi), mu_start(h, phi)) as Taichi functions reading ``par[e, base + k]``
        for slot k of member e. ``f32_pow``: take powers in 32 bits (Vulkan has no 64-bit pow)."""

        @ti.func
        def mu(e, h, spd, phi):
            return 0.0 * h

        @ti.func
        def mu_start(e, h, phi):
            return mu(e, h, 0.0 * h, phi)

        return mu, mu_start


class Coulomb(FrictionLaw):
    """A constant coefficient ``effects.coulomb_mu``, at any speed and thickness."""

    name = "coulomb"
    constants = (
        Constant(
            "coulomb_mu",
            DEFAULT_COULOMB_MU,
            'constant friction coefficient for "coulomb"',
            nonneg=True,
        ),
    )
    slots = ("mu",)

    def values(self, fric):
        return [fric.coulomb_mu]

    def least_mu(self, fric):
        return fric.coulomb_mu

    def mu_np(self, c, h, speed, phi):
        return np.full_like(h, c.fric.coulomb_mu)

    def taichi(self, ti, par, base, f32_pow=False):
        @ti.func
        def mu(e, h, spd, phi):
            return par[e, base] + 0.0 * h

        @ti.func
        def mu_start(e, h, phi):
            return mu(e, h, 0.0 * h, phi)

        return mu, mu_start


# ---- Pouliquen-Forterre (3.7) ------------------------------------------------------------------
def _froude_np(c, h, speed):
    return speed / np.sqrt(c.g_cos * h)  # (6.5)


def _species(fric, s: str) -> list[float]:
    return [getattr(fric, f"{k}_{s}") for k in ("mu1", "mu2", "beta", "L")]


class PouliquenSpecies(FrictionLaw):
    """(3.7) of one species: the small (``species = "s"``) or the large grains alone."""

    slots = ("mu1", "mu2", "beta", "L")

    def __init__(self, name: str, species: str):
        self.name, self.species = name, species

    def values(self, fric):
        return _species(fric, self.species)

    def least_mu(self, fric):
        return getattr(fric, f"mu1_{self.species}")

    def mu_np(self, c, h, speed, phi):
        return _pouliquen_np(h, _froude_np(c, h, speed), *_species(c.fric, self.species))

    def taichi(self, ti, par, base, f32_pow=False):
        one = _pouliquen_ti(ti, par, base)

        @ti.func
        def mu(e, h, spd, phi):
            return one(e, h, spd / ti.sqrt(par[e, Params.G_COS] * h))

        @ti.func
        def mu_start(e, h, phi):
            return mu(e, h, 0.0 * h, phi)

        return mu, mu_start


def _pouliquen_ti(ti, par, b: int):
    """(3.7) at (h, Fr) with the species' (mu1, mu2, beta, L) in member e's par[e, b:b + 4]."""

    @ti.func
    def one(e, h, fr):
        x = par[e, b + 3] * fr
        return par[e, b] + (par[e, b + 1] - par[e, b]) * x / (par[e, b + 2] * h + x)

    return one


def _mixture_ti(ti, par, small, large):
    """(3.4) of two species' laws one(h, Fr): mu(h, |u|, phi) = phi mu^S + (1 - phi) mu^L."""

    @ti.func
    def mu(e, h, spd, phi):
        fr = spd / ti.sqrt(par[e, Params.G_COS] * h)
        mus = small(e, h, fr)
        mul = large(e, h, fr)
        return phi * mus + (1.0 - phi) * mul

    return mu


class PouliquenMixture(FrictionLaw):
    """(3.4): phi mu^S + (1 - phi) mu^L, each species by (3.7): the paper's law."""

    name = "pouliquen-mixture"
    slots = tuple(f"{k}_{s}" for s in "sl" for k in ("mu1", "mu2", "beta", "L"))
    weighted = True
    steady = True

    def values(self, fric):
        return _species(fric, "s") + _species(fric, "l")

    def least_mu(self, fric):
        return min(fric.mu1_s, fric.mu1_l)

    def mu_np(self, c, h, speed, phi):
        fr = _froude_np(c, h, speed)
        mus = _pouliquen_np(h, fr, *_species(c.fric, "s"))
        mul = _pouliquen_np(h, fr, *_species(c.fric, "l"))
        return phi * mus + (1.0 - phi) * mul

    def taichi(self, ti, par, base, f32_pow=False):
        small = _pouliquen_ti(ti, par, base)
        large = _pouliquen_ti(ti, par, base + 4)

        mu = _mixture_ti(ti, par, small, large)

        @ti.func
        def mu_start(e, h, phi):
            return mu(e, h, 0.0 * h, phi)

        return mu, mu_start


# ---- the extended law with hysteresis ----------------------------------------------------------
EXTENDED_SPECIES = ("mu1", "mu2", "beta", "L", "mu3")


def _extended_np(h, fr, mu1, mu2, beta, L, mu3, beta_star, kappa):
    """One species of the extended law (see `PouliquenExtended`)."""
    md = _pouliquen_np(h, np.maximum(fr, beta_star), mu1, mu2, beta, L)
    ms = mu3 + (mu2 - mu1) * L / (L + h)
    mi = (np.minimum(fr, beta_star) / beta_star) ** kappa * (md - ms) + ms
    return np.where(fr < beta_star, mi, md)


def _start_np(h, mu1, mu2, beta, L, mu3):
    return mu3 + (mu2 - mu1) * L / (L + h)


class PouliquenExtended(FrictionLaw):
    """The extended Pouliquen-Forterre law with hysteresis, per species, weighted by the
    concentration like (3.4): mu_b = phi mu^S + (1 - phi) mu^L.

    Pouliquen & Forterre (2002, J. Fluid Mech. 453, 133-151) add a static and an intermediate
    regime to (3.7); this is the form Edwards & Gray (2015, J. Fluid Mech. 762, 35-67) and
    Edwards et al. (2017, J. Fluid Mech. 823, 278-315) use together with the depth-averaged
    mu(I) viscosity. For each species, with mu_i = tan(zeta_i) and Fr = |u| / sqrt(g h cos
    zeta):

    * dynamic, Fr >= beta*:  mu = mu_D(h, Fr) = mu1 + (mu2 - mu1) / (beta h / (L Fr) + 1),
      which is (3.7) itself (Edwards & Gray's Gamma = 0);
    * intermediate, 0 < Fr < beta*:  mu = (Fr / beta*)^kappa (mu_D(h, beta*) - mu_S(h)) +
      mu_S(h), continuous with the dynamic regime at Fr = beta*; friction grows as the flow
      slows, which is what brings it to rest;
    * static, Fr = 0: any coefficient up to mu_S(h) = mu3 + (mu2 - mu1) / (1 + h / L), the
      start curve: a layer at rest starts only where tan(zeta) > mu_S(h), i.e. where it is
      thicker than h_start(zeta).

    A steady uniform flow in the dynamic regime (F >= beta*) is the same as with (3.7), so the
    steady states, the Froude number and the linear stability of sections 4-5 are unchanged
    there; slower steady flows (0 < F < beta*) are not those of section 4 and the scene
    derives no u0 for them. The deposit a steady flow leaves when its supply stops has the
    thickness h_stop where tan(zeta) = mu_D(h_stop, beta*):
    h_stop = (L beta* / beta) (mu2 - tan zeta) / (tan zeta - mu1) (`h_stop`).

    Slots: (mu1, mu2, beta, L, mu3) of the small, then of the large grains, then beta*, kappa.
    """

    name = "pouliquen-extended"
    constants = (
        Constant(
            "beta_star",
            DEFAULT_BETA_STAR,
            'Froude number below which the extended law ("pouliquen-extended") leaves the '
            "dynamic regime (3.7) for the intermediate one; 0.136 of Pouliquen & Forterre "
            "(2002), as in Edwards & Gray (2015)",
            section="material",
            positive=True,
        ),
        Constant(
            "kappa",
            DEFAULT_KAPPA,
            "exponent of the extended law's intermediate regime (Fr / beta*)^kappa, 1e-3 as "
            "in Pouliquen & Forterre (2002)",
            section="material",
            positive=True,
        ),
    )
    slots = tuple(f"{k}_{s}" for s in "sl" for k in EXTENDED_SPECIES) + ("beta_star", "kappa")
    weighted = True
    steady = True  # in the dynamic regime: checked where u0 is derived (Fr >= beta*)
    hysteresis = True

    def values(self, fric):
        missing = [
            k for k in ("mu3_s", "mu3_l", "beta_star", "kappa") if getattr(fric, k, None) is None
        ]
        if missing:
            raise ValueError(f"friction 'pouliquen-extended' needs FrictionParams {missing}")
        return (
            _species(fric, "s")
            + [fric.mu3_s]
            + _species(fric, "l")
            + [fric.mu3_l, fric.beta_star, fric.kappa]
        )

    def least_mu(self, fric):
        return min(fric.mu1_s, fric.mu1_l)  # mu_D >= mu1, and mu_I, mu_S lie above mu_D

    def _np_species(self, fric, s):
        return _species(fric, s) + [getattr(fric, f"mu3_{s}")]

    def mu_np(self, c, h, speed, phi):
        f = c.fric
        fr = _froude_np(c, h, speed)
        mus = _extended_np(h, fr, *self._np_species(f, "s"), f.beta_star, f.kappa)
        mul = _extended_np(h, fr, *self._np_species(f, "l"), f.beta_star, f.kappa)
        return phi * mus + (1.0 - phi) * mul

    def mu_start_np(self, c, h, phi):
        f = c.fric
        return phi * _start_np(h, *self._np_species(f, "s")) + (1.0 - phi) * _start_np(
            h, *self._np_species(f, "l")
        )

    def taichi(self, ti, par, base, f32_pow=False):
        n = len(EXTENDED_SPECIES)
        bs, kp = base + 2 * n, base + 2 * n + 1  # beta*, kappa

        @ti.func
        def power(x, k):
            r = x
            if ti.static(f32_pow):  # SPIR-V has no 64-bit pow: 1e-7 relative error
                r = ti.cast(ti.pow(ti.cast(x, ti.f32), ti.cast(k, ti.f32)), ti.f64)
            else:
                r = ti.pow(x, k)
            return r

        def species(b):
            dyn = _pouliquen_ti(ti, par, b)

            @ti.func
            def start(e, h):
                L = par[e, b + 3]
                return par[e, b + 4] + (par[e, b + 1] - par[e, b]) * L / (L + h)

            @ti.func
            def one(e, h, fr):
                bstar = par[e, bs]
                m = dyn(e, h, ti.max(fr, bstar))  # mu_D(h, max(Fr, beta*))
                if fr < bstar:
                    ms = start(e, h)
                    m = power(fr / bstar, par[e, kp]) * (m - ms) + ms
                return m

            return one, start

        small, small_start = species(base)
        large, large_start = species(base + n)

        mu = _mixture_ti(ti, par, small, large)

        @ti.func
        def mu_start(e, h, phi):
            return phi * small_start(e, h) + (1.0 - phi) * large_start(e, h)

        return mu, mu_start


def h_stop(zeta: float, mu1: float, mu2: float, beta: float, L: float, beta_star: float):
    """Deposit thickness [m] of one species under the extended law: tan(zeta) = mu_D(h, beta*),
    h = (L beta* / beta) (mu2 - tan zeta) / (tan zeta - mu1), for mu1 < tan(zeta) < mu2."""
    t = np.tan(zeta)
    return L * beta_star / beta * (mu2 - t) / (t - mu1)


def layer_thresholds(material, phi: float) -> tuple[float, float]:
    """(h_stop, h_start) [m] of a layer of concentration ``phi`` at the material's slope under
    the extended law, each weighted by (3.4) as the law is: h_stop where tan(zeta) equals the
    mixture's mu_D(h, beta*), h_start where it equals the mixture's start coefficient mu_S(h)
    (see `PouliquenExtended`). Both coefficients fall as h grows, so each threshold is one root
    (found by bisection in log h); 0 where the slope is steeper than the coefficient at any
    thickness (nothing is held), inf where it is gentler (everything is held)."""
    t = material.tan_zeta
    sp = (material.small, material.large)
    w = (phi, 1.0 - phi)

    def mu_d(h):
        return sum(
            wi * (s.mu1 + (s.mu2 - s.mu1) / (s.beta * h / (s.L * material.beta_star) + 1.0))
            for wi, s in zip(w, sp)
        )

    def mu_s(h):
        return sum(wi * (s.mu3 + (s.mu2 - s.mu1) * s.L / (s.L + h)) for wi, s in zip(w, sp))

    def root(mu):
        lo, hi = 1e-9, 1e2  # [m]
        if mu(lo) <= t:
            return 0.0
        if mu(hi) >= t:
            return math.inf
        for _ in range(200):
            mid = math.sqrt(lo * hi)
            lo, hi = (mid, hi) if mu(mid) > t else (lo, mid)
        return math.sqrt(lo * hi)

    return root(mu_d), root(mu_s)


FRICTION_LAWS: dict[str, FrictionLaw] = {
    law.name: law
    for law in (
        PouliquenMixture(),
        PouliquenSpecies("pouliquen-small", "s"),
        PouliquenSpecies("pouliquen-large", "l"),
        PouliquenExtended(),
        Coulomb(),
        FrictionLaw(),
    )
}
