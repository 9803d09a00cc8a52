"""Initial states of a scene as conserved arrays (nc, NX, NY) with ghost cells.

* empty slope (6.7);
* the steady uniform flow of section 4 with an optional small perturbation: the most unstable
  linear mode of (5.20)-(5.21) (or its 2D analogue, appendix B), a single field, or noise; the
  perturbation is set as exact cell averages (the sinc factor of a cell average of e^{ikx});
* dam break (h_left | h_right, at rest), e.g. the Ritter problem;
* release of a finite block of material at rest;
* a straight channel between levees, at rest (the sharp-contact verification case);
* a uniform static layer at rest, the erodible bed of erosion-deposition waves (Edwards &
  Gray 2015);
* a parabolic cap sliding downslope (Savage & Hutter 1991);
* a lake at rest over the bed of ``[terrain]``, h = max(level - b, 0) (b normal to the plane);
* a thickness read from a raster file, at rest.

Solid cells of the terrain (`Scene.bed_arrays`) hold no material whatever the kind.

Each kind is an `InitialKind` in the registry `INITIAL_KINDS` (read when asked): its name, the
``initial.*`` keys it reads beyond the built-ins' own (declared on the scene's fields, `kinds`),
its checks against the domain, and the function that builds h, u, v, phi from the scene and the
cell centres. A kind registered by user code (`register_initial`) is accepted by the scene and
built by the simulation without touching the package.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..errors import InputError
from ..solver.numerics.config import Layout


def _cell_avg_wave(k: float, d: float, centres: np.ndarray) -> np.ndarray:
    """Cell averages of exp(i k x) over cells of width d centred at ``centres``."""
    return np.exp(1j * k * centres) * np.sinc(k * d / (2 * np.pi))  # np.sinc(x) = sin(pi x)/(pi x)


def eigenmode(scene) -> tuple[complex, np.ndarray]:
    """Most unstable eigenvalue (dimensionless) and eigenvector (H, U[, V], Phi) normalised to
    H = 1 for the scene's perturbation wavenumbers (k, ky) in the scalings (5.1).

    Without segregation phi stays flow.phi0, so the modes are those of the mass and momentum
    balances alone: the matrix without its Phi row and column (the monodisperse roll-wave
    problem, `tiseg.model.stability.monodisperse`), and Phi = 0. The least damped of them is
    taken where none grows (a wavenumber above the viscous cut-off)."""
    from ..model.stability.base import base_state

    ini, fl = scene.initial, scene.flow
    bs = base_state(fl.h0, fl.phi0, scene.acting_nu, scene.material)
    if scene.is_1d or not ini.ky:
        from ..model.stability.dispersion1d import matrix

        A = matrix(bs, np.array([ini.k]))[0]
    else:
        from ..model.stability.dispersion2d import matrix

        A = matrix(bs, np.array([ini.k]), np.array([ini.ky]))[0]
    if not scene.segregation:
        A = A[:-1, :-1]  # phi is fixed: no Phi unknown
    lam, vec = np.linalg.eig(A)
    i = int(np.argmax(lam.real))
    v = vec[:, i]
    if not scene.segregation:
        v = np.append(v, 0.0)
    if abs(v[0]) == 0:
        raise InputError(
            "the most unstable mode has no thickness component; use initial.mode='phi'"
        )
    return complex(lam[i]), v / v[0]


def thickness_noise(x: np.ndarray, dx: float, Lx: float, seed: int) -> np.ndarray:
    """Unit-RMS random downslope profile r(x) of ``initial.mode = "h-noise"`` (cell averages).

    r = sqrt(2 / N) sum_n cos(2 pi n x / Lx + theta_n), n = 1..N with N = nx // 8 (every
    wavelength resolved by 8 cells or more), the phases theta_n uniform random from ``seed``
    and drawn in order of n: on a finer grid the same long waves come first, with the same
    phases, so runs at different resolutions start from the same long-wave perturbation."""
    nx = len(x)
    n_modes = max(1, nx // 8)
    theta = np.random.default_rng(seed).uniform(0.0, 2.0 * np.pi, n_modes)
    r = np.zeros(nx)
    for n in range(1, n_modes + 1):
        k = 2.0 * np.pi * n / Lx
        r += np.real(np.exp(1j * theta[n - 1]) * _cell_avg_wave(k, dx, x))
    return r * np.sqrt(2.0 / n_modes)


def channel_fraction(y, dy: float, Ly: float, width: float) -> np.ndarray:
    """Fraction of each cell [y - dy/2, y + dy/2] inside the channel |y - Ly/2| <= width/2:
    1 inside, 0 outside, the covered fraction in a cell the contact cuts (exact cell
    averages)."""
    lo = np.maximum(y - 0.5 * dy, 0.5 * (Ly - width))
    hi = np.minimum(y + 0.5 * dy, 0.5 * (Ly + width))
    return np.clip((hi - lo) / dy, 0.0, 1.0)


@dataclass(frozen=True)
class InitialKind:
    """One initial state. ``build(scene, X, Y)`` returns the interior (h, u, v, phi) on the
    cell centres X, Y (each (nx, ny)); phi is clipped to [0, 1] afterwards and ignored without
    segregation, v in 1D. ``keys``: the ``initial.*`` keys a kind registered by user code reads
    (the built-ins declare theirs on the scene's fields); ``check(values, domain)``: raises
    `InputError` for values that do not fit the domain (the built-ins' rules are in
    `tiseg.setup.validators.read_initial`)."""

    name: str
    build: Callable
    keys: tuple[str, ...] = ()
    check: Callable | None = None


INITIAL_KINDS: dict[str, InitialKind] = {}


def register_initial(kind: InitialKind) -> InitialKind:
    """Add an initial state to the registry (the last one of a name wins)."""
    INITIAL_KINDS[kind.name] = kind
    return kind


def _zeros(X):
    return np.zeros_like(X), np.zeros_like(X), np.zeros_like(X), np.zeros_like(X)


def _phi_or_phi0(scene) -> float:
    return scene.initial.phi if scene.initial.phi is not None else scene.flow.phi0


def _empty(scene, X, Y):
    return _zeros(X)


def _uniform(scene, X, Y):
    ini, fl = scene.initial, scene.flow
    if fl.u0 is None:
        raise InputError(
            "initial.kind='uniform' needs a steady velocity: give flow.u0 or use "
            "the pouliquen-mixture friction"
        )
    h, u, v, phi = _zeros(X)
    h[:], u[:], phi[:] = fl.h0, fl.u0, fl.phi0
    eps = ini.amplitude or 0.0
    if eps:
        kx, ky = scene.perturbation_wavenumbers  # SI [1/m]
        wave = _cell_avg_wave(kx, scene.dx, X) * (
            1.0 if scene.is_1d else _cell_avg_wave(ky, scene.dy, Y)
        )
        if ini.mode == "eigen":
            _, W = eigenmode(scene)
            H, U = W[0], W[1]
            V = W[2] if len(W) == 4 else 0.0
            P = W[-1]
            h = fl.h0 * (1 + eps * np.real(H * wave))
            u = fl.u0 * (1 + eps * np.real(U * wave))
            v = fl.u0 * eps * np.real(V * wave)
            phi = fl.phi0 + eps * np.real(P * wave)
        elif ini.mode == "h":
            h = fl.h0 * (1 + eps * np.real(wave))
        elif ini.mode == "phi":
            phi = fl.phi0 + eps * np.real(wave)
        elif ini.mode == "h-noise":
            x = X[:, 0]
            r = thickness_noise(x, scene.dx, scene.domain.Lx, ini.seed or 0)
            h = fl.h0 * (1 + eps * r[:, None])
        elif ini.mode == "noise":
            rng = np.random.default_rng(ini.seed or 0)
            phi = fl.phi0 + eps * (rng.random(X.shape) - 0.5)
    return h, u, v, phi


def _dam_break(scene, X, Y):
    ini = scene.initial
    h, u, v, phi = _zeros(X)
    h[:] = np.where(X < ini.x0, ini.h_left, ini.h_right or 0.0)
    phi[:] = _phi_or_phi0(scene)
    return h, u, v, phi


def _release(scene, X, Y):
    ini = scene.initial
    h, u, v, phi = _zeros(X)
    inside = (X >= ini.x0) & (X <= ini.x1)
    if not scene.is_1d:
        inside &= (Y >= ini.y0) & (Y <= ini.y1)
    h[:] = np.where(inside, ini.h, 0.0)
    phi[:] = _phi_or_phi0(scene)
    return h, u, v, phi


def _channel(scene, X, Y):
    ini = scene.initial
    h, u, v, phi = _zeros(X)
    h[:] = ini.h
    phi[:] = ini.phi_levee + (ini.phi_channel - ini.phi_levee) * channel_fraction(
        Y, scene.dy, scene.domain.Ly, ini.width
    )
    return h, u, v, phi


def _layer(scene, X, Y):
    # uniform normal to the plane whatever b: the layer follows the bed (its surface is b +
    # layer_h); walls hold none
    h, u, v, phi = _zeros(X)
    _, solid = scene.bed_arrays()
    h[:] = np.where(solid, 0.0, scene.initial.layer_h)
    phi[:] = _phi_or_phi0(scene)
    return h, u, v, phi


def _lake(scene, X, Y):
    # at rest with a flat free surface eta = h + b = level: the state the well-balanced
    # schemes must keep exactly (DESIGN.md, "Terrain")
    h, u, v, phi = _zeros(X)
    b, solid = scene.bed_arrays()
    h[:] = np.where(solid, 0.0, np.maximum(scene.initial.level - b, 0.0))
    phi[:] = _phi_or_phi0(scene)
    return h, u, v, phi


def _file(scene, X, Y):
    h, u, v, phi = _zeros(X)
    _, solid = scene.bed_arrays()
    h[:] = np.where(solid, 0.0, scene.initial_thickness())
    phi[:] = _phi_or_phi0(scene)
    return h, u, v, phi


def _cap(scene, X, Y):
    # exact cell averages of the parabola: h (1 - s^2) integrated over each cell's part inside
    # |s| < 1, s = (x - x0) / half_width
    ini = scene.initial
    h, u, v, phi = _zeros(X)
    a = ini.half_width
    lo = np.clip((X - 0.5 * scene.dx - ini.x0) / a, -1.0, 1.0)
    hi = np.clip((X + 0.5 * scene.dx - ini.x0) / a, -1.0, 1.0)
    h[:] = ini.h * a * ((hi - hi**3 / 3) - (lo - lo**3 / 3)) / scene.dx
    u[:] = np.where(h > 0, ini.u, 0.0)
    phi[:] = _phi_or_phi0(scene)
    return h, u, v, phi


for _name, _build in (
    ("empty", _empty),
    ("uniform", _uniform),
    ("dam-break", _dam_break),
    ("release", _release),
    ("channel", _channel),
    ("layer", _layer),
    ("cap", _cap),
    ("lake", _lake),
    ("file", _file),
):
    register_initial(InitialKind(_name, _build))

# the built-ins, in the order the scene reference lists them
BUILTIN_KINDS = tuple(INITIAL_KINDS)


def initial_state(scene, lay: Layout) -> np.ndarray:
    """The conserved state (nc, NX, NY) with ghost cells of the scene's initial kind."""
    kind = INITIAL_KINDS.get(scene.initial.kind)
    if kind is None:
        raise InputError(
            f"initial.kind={scene.initial.kind!r} is not registered; "
            f"the registered kinds: {', '.join(INITIAL_KINDS)}"
        )
    q = np.zeros((lay.nc, lay.NX, lay.NY))
    ix, iy = lay.interior()
    x, y = scene.domain.cell_centres()
    X, Y = np.meshgrid(x, y, indexing="ij")  # (nx, ny)
    h, u, v, phi = kind.build(scene, X, Y)
    if scene.has_terrain:  # solid cells (walls) hold no material, whatever the kind
        _, solid = scene.bed_arrays()
        h = np.where(solid, 0.0, h)
    if scene.terrain.runout is not None and h.size:  # the bend's h kappa, on this thickness
        from .bed import check_bend  # (bed imports the sections, which import this module)

        check_bend(scene.terrain.runout, scene.material.zeta, scene.domain.Lx, float(h.max()))
    phi = np.clip(phi, 0.0, 1.0)
    q[lay.H][ix, iy] = h
    q[lay.HU][ix, iy] = h * u
    if not lay.is_1d:
        q[lay.HV][ix, iy] = h * v
    if lay.segregation:
        q[lay.HPHI][ix, iy] = h * phi
    return q
