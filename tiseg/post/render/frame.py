"""The frame kernel: (h, phi, u, v) on the grid -> an RGB picture, in Taichi.

Everything tiseg draws goes through `_Painter.paint`: off-screen frames of NumPy fields
(`render_fields`), frames straight from a running simulation's Taichi state
(`FrameRenderer`) and the GGUI viewer (which paints into its window image); the matplotlib
panels use its NumPy twin (`tiseg.post.render.raster`, no Taichi). Only plain ``ti.field`` s and kernels are used, so it
runs on every Taichi backend and needs no Vulkan; the picture comes back with ``to_numpy``.

Orientation (as in figure 12): x (downslope) runs from left to right, y (cross-slope) from bottom
to top, so the inflow is on the left edge and the fingers grow to the right. The image field is
indexed ``img[px, py]`` with ``py = 0`` at the bottom, which is GGUI's convention; NumPy images
are returned the usual way, ``(rows, columns, 3)`` with row 0 at the top.

Colouring (see `tiseg.post.render.colours`): phi = 1 white fines, phi = 0 brown coarse grains,
a linear blend in between, turquoise where the chute is empty (h < h_min). The fields h, |u|, u, v
use the viridis table. Optional relief shading lights the thickness from the upper left of the
picture so levees and the bulbous front read as relief::

    f = 1 - S tanh(R grad(h) . l),   l = (-1, 1) / sqrt(2)  (towards the light, picture axes)

i.e. a flank whose surface normal (-grad h, 1) leans towards the light is brightened and a flank
leaning away is darkened, as in a hill-shaded map (Lambert's law to first order in the slope),
with strength S (default 0.35) and vertical exaggeration R (default 10, i.e. a slope dh/dx = 0.1
gives tanh(1)). Flat flow keeps f = 1 exactly, so shading changes brightness only where h varies;
the saturating tanh keeps the steep front (dh/dx ~ 1) from turning black. f < 1 darkens (c f),
f > 1 brightens towards white (c + (1 - c)(f - 1)). The empty chute is never shaded.

A scene with terrain has its bed shaded the same way under the colours, flow and empty chute
alike, and its solid cells drawn as walls (`tiseg.post.render.relief`): `render_fields` blends
the relief into its finished picture, `FrameRenderer` uploads the relief's factors once into
the kernel (`_Painter.set_bed`), which applies them per cell. A flat scene allocates nothing
for it and compiles the kernel of before.

Captions are burned in with `annotate` (time stamp and scale bar) and `add_colourbar`,
using glyphs rasterised once by matplotlib's FreeType wrapper (no figure, sub-millisecond).
"""
# (no "from __future__ import annotations": Taichi reads kernel annotations as objects)

import math
from functools import lru_cache

import numpy as np
import taichi as ti

from ...taichi_classes import data_oriented

from ... import backend
from ...solver import field_tree
from . import colours as C
from .relief import SOLID_RGB, bed_cells, bed_of, with_relief
from .lengths import format_length, nice_length  # noqa: F401  (also used from here)
from .raster import (  # noqa: F401  (image_size and the constants are also used from here)
    DEFAULT_RELIEF,
    DEFAULT_SHADE,
    MAX_SIDE,
    MIN_1D_HEIGHT,
    PAPER_DX,
    _shade_strength,
    _spacing,
    checked_fields,
    image_size,
)

# Indices in the painter's run-time parameter field (changing them recompiles nothing).
P_HMIN, P_VMIN, P_VMAX, P_MODE, P_SHADE, P_RELIEF, P_LX, P_LY, P_DX, P_DY, P_PHI = range(11)
P_COUNT = 11

_BIG = 3.0e38


# =================================================================================================
# Sources: where the kernel reads (h, phi, u, v) of cell (i, j)
# =================================================================================================
@data_oriented
class _ArraySource:
    """Fields handed over as NumPy arrays, uploaded into one (nx, ny) vector field."""

    has_phi = True  # a missing phi array is refused by render_fields for field="phi"

    def __init__(self, nx: int, ny: int):
        self.nx, self.ny = nx, ny
        self.f = ti.Vector.field(4, float, shape=(nx, ny))  # (h, phi, u, v) per cell
        field_tree.track(self)

    def upload(self, h, phi=None, u=None, v=None) -> None:
        """Arrays shaped (ny, nx) like the output files; missing ones are zero."""
        a = np.zeros((self.nx, self.ny, 4), dtype=np.float64)
        for k, arr in enumerate((h, phi, u, v)):
            if arr is not None:
                a[:, :, k] = np.nan_to_num(
                    np.asarray(arr, dtype=np.float64).reshape(self.ny, self.nx)
                ).T
        dt = np.float64 if backend.state().precision == "f64" else np.float32
        self.f.from_numpy(a.astype(dt))

    @ti.func
    def thickness(self, i, j):
        return self.f[i, j][0]

    @ti.func
    def sample(self, i, j):
        return self.f[i, j]


@data_oriented
class _StateSource:
    """A simulation's conserved state, a slot of ``op.q`` (ghost cells skipped), read in place:
    rendering a frame moves no state through NumPy. The slot is 0 (the step state) unless a
    snapshot in another slot is drawn (`use_slot`); the member is ``member`` of an ensemble
    (compiled in)."""

    def __init__(self, op, member: int = 0):
        lay = op.lay
        self.op = op  # keeps the operator, and so its field tree (tiseg.solver.field_tree), alive
        self.q = op.q
        self.member = int(member)
        self.slot = ti.field(ti.i32, shape=())
        field_tree.track(self)
        self.slot[None] = 0  # written, not trusted to start at 0 (Vulkan does not)
        self._slot = 0
        self.nx, self.ny = lay.nx, lay.ny
        self.gx, self.gy = lay.gx, lay.gy
        self.HU, self.HV, self.HPHI = lay.HU, lay.HV, lay.HPHI
        self.has_v, self.has_phi = not lay.is_1d, lay.segregation

    def use_slot(self, slot: int) -> None:
        if slot != self._slot:  # a field write from Python is a kernel launch
            self.slot[None] = int(slot)
            self._slot = int(slot)

    @ti.func
    def thickness(self, i, j):
        return self.q[self.slot[None], i + self.gx, j + self.gy, self.member][0]

    @ti.func
    def sample(self, i, j):
        q = self.q[self.slot[None], i + self.gx, j + self.gy, self.member]
        h = q[0]
        inv = 0.0
        if h > 0:  # as Simulation.fields(): hu/h where h > 0, else 0
            inv = 1.0 / h
        out = ti.Vector([h, 0.0, q[self.HU] * inv, 0.0])
        if ti.static(self.has_phi):
            out[1] = ti.min(ti.max(q[self.HPHI] * inv, 0.0), 1.0)
        if ti.static(self.has_v):
            out[3] = q[self.HV] * inv
        return out


# =================================================================================================
# The painter: one kernel for every picture
# =================================================================================================
@data_oriented
class _Painter:
    """Colour kernels over one source of nx x ny cells.

    Run-time numbers (field, range, h_min, shading, cell size) live in ``par``; the colour table
    in ``lut``. Each distinct image field passed to `paint` compiles once (template).
    ``has_bed``: the source has terrain, whose relief factor and walls per cell `set_bed`
    uploads into ``bed`` (allocated only then; without it the kernel has no bed code)."""

    def __init__(self, source, has_bed: bool = False):
        self.src = source
        self.nx, self.ny = source.nx, source.ny
        self.has_bed = bool(has_bed)
        # parameters in the simulation's float type, so h >= h_min decides exactly as the solver
        self.par = ti.field(float, shape=P_COUNT)
        field_tree.track(self)
        self._np_fp = np.float64 if backend.state().precision == "f64" else np.float32
        self.lut = ti.Vector.field(3, ti.f32, shape=C.LUT_SIZE)
        self.lut.from_numpy(np.asarray(C.viridis_table(C.LUT_SIZE), dtype=np.float32))
        self.red = ti.field(ti.f32, shape=2)
        if self.has_bed:  # (f, wall) per cell: relief factor, 1 for a solid cell
            self.bed = ti.Vector.field(2, ti.f32, shape=(self.nx, self.ny))
        self._images: dict[tuple[int, int], object] = {}
        self.generation = backend.state().generation
        self._par = None

    def image(self, w: int, h: int):
        """A cached (w, h) RGB image field (one per size, so kernels compile once per size)."""
        key = (int(w), int(h))
        if key not in self._images:
            self._images[key] = ti.Vector.field(3, ti.f32, shape=key)
        return self._images[key]

    def set_params(
        self,
        *,
        h_min,
        field="phi",
        vrange=(0.0, 1.0),
        shade=DEFAULT_SHADE,
        relief=DEFAULT_RELIEF,
        dx=1.0,
        dy=1.0,
        phi_const=1.0,
    ) -> None:
        p = np.zeros(P_COUNT, dtype=self._np_fp)
        lo, hi = vrange if vrange is not None else (0.0, 1.0)
        p[P_HMIN], p[P_VMIN], p[P_VMAX] = h_min, lo, hi
        p[P_MODE] = C.FIELD_CODES[C.canonical_field(field)]
        p[P_SHADE], p[P_RELIEF] = shade, relief
        # unit vector towards the light in picture axes (x right, y up): the upper left
        p[P_LX], p[P_LY] = -math.sqrt(0.5), math.sqrt(0.5)
        p[P_DX], p[P_DY], p[P_PHI] = dx, dy, phi_const
        if self._par is None or not np.array_equal(p, self._par):  # upload only changes
            self.par.from_numpy(p)
            self._par = p

    def set_bed(self, f: np.ndarray, wall: np.ndarray) -> None:
        """Upload the relief factor ``f`` and the walls ``wall`` of each cell, (ny, nx) as
        `tiseg.post.render.relief.bed_cells` gives them."""
        a = np.stack([np.asarray(f, np.float32), np.asarray(wall, np.float32)], axis=-1)
        self.bed.from_numpy(np.ascontiguousarray(a.transpose(1, 0, 2)))

    # --------------------------------------------------------------------- device functions
    @ti.func
    def _value(self, s, mode):
        """The colour-mapped quantity of sample s = (h, phi, u, v) for field code mode."""
        val = s[0]
        if mode == 2:
            val = ti.sqrt(s[2] * s[2] + s[3] * s[3])
        elif mode == 3:
            val = s[2]
        elif mode == 4:
            val = s[3]
        return val

    @ti.func
    def _lut(self, t):
        x = ti.cast(ti.min(ti.max(t, 0.0), 1.0) * (C.LUT_SIZE - 1), ti.f32)
        i0 = ti.min(ti.cast(ti.floor(x), ti.i32), C.LUT_SIZE - 2)
        w = x - ti.cast(i0, ti.f32)
        return (1.0 - w) * self.lut[i0] + w * self.lut[i0 + 1]

    @ti.func
    def _shade_factor(self, i, j):
        """1 - S tanh(R grad(h) . l), central differences (one-sided at the edges)."""
        nx, ny = ti.static(self.nx, self.ny)
        im, ip = ti.max(i - 1, 0), ti.min(i + 1, nx - 1)
        jm, jp = ti.max(j - 1, 0), ti.min(j + 1, ny - 1)
        gx = 0.0
        gy = 0.0
        if ip > im:
            gx = (self.src.thickness(ip, j) - self.src.thickness(im, j)) / (
                (ip - im) * self.par[P_DX]
            )
        if jp > jm:
            gy = (self.src.thickness(i, jp) - self.src.thickness(i, jm)) / (
                (jp - jm) * self.par[P_DY]
            )
        d = gx * self.par[P_LX] + gy * self.par[P_LY]
        # tanh in f32: SPIR-V (Vulkan) has no 64-bit tanh, and a colour needs no more
        return 1.0 - self.par[P_SHADE] * ti.tanh(ti.cast(self.par[P_RELIEF] * d, ti.f32))

    @ti.func
    def _lit(self, c, f):
        """The colour c under the shading factor f: c f below 1, towards white above."""
        out = c
        if f < 1.0:
            out = c * f
        else:
            out = c + (1.0 - c) * ti.min(f - 1.0, 1.0)
        return out

    @ti.func
    def colour(self, i, j):
        """RGB (f32) of cell (i, j) under the current parameters."""
        s = self.src.sample(i, j)
        mode = ti.cast(self.par[P_MODE], ti.i32)
        # colour arithmetic in the default float type; the image stores f32
        c = ti.Vector([C.CHUTE_RGB[0], C.CHUTE_RGB[1], C.CHUTE_RGB[2]], float)
        if mode != 0:
            c = ti.Vector([C.EMPTY_MAP_RGB[0], C.EMPTY_MAP_RGB[1], C.EMPTY_MAP_RGB[2]], float)
        if s[0] >= self.par[P_HMIN]:
            if mode == 0:
                phi = s[1]
                if ti.static(not self.src.has_phi):  # no segregation: a constant mixture
                    phi = self.par[P_PHI]
                phi = ti.min(ti.max(phi, 0.0), 1.0)
                coarse = ti.Vector([C.COARSE_RGB[0], C.COARSE_RGB[1], C.COARSE_RGB[2]], float)
                fines = ti.Vector([C.FINES_RGB[0], C.FINES_RGB[1], C.FINES_RGB[2]], float)
                c = (1.0 - phi) * coarse + phi * fines
            else:
                lo, hi = self.par[P_VMIN], self.par[P_VMAX]
                t = (self._value(s, mode) - lo) / ti.max(hi - lo, 1e-30)
                c = ti.cast(self._lut(t), float)
            if self.par[P_SHADE] > 0.0:
                c = self._lit(c, self._shade_factor(i, j))
        if ti.static(self.has_bed):  # the terrain under the colours, its walls over them
            g = self.bed[i, j]
            c = self._lit(c, ti.cast(g[0], float))
            if g[1] > 0.5:
                c = ti.Vector([SOLID_RGB[0], SOLID_RGB[1], SOLID_RGB[2]], float)
        return c

    # --------------------------------------------------------------------- kernels
    @ti.kernel
    def paint(self, img: ti.template(), x0: ti.i32, y0: ti.i32, w: ti.i32, h: ti.i32):
        """Fill the rectangle [x0, x0 + w) x [y0, y0 + h) of img with the grid, nearest cell per
        pixel (so any scale, up or down, works; an integer scale gives square blocks)."""
        nx, ny = ti.static(self.nx, self.ny)
        for p, q in ti.ndrange(w, h):
            i = ti.min(ti.cast((p + 0.5) * nx / w, ti.i32), nx - 1)
            j = ti.min(ti.cast((q + 0.5) * ny / h, ti.i32), ny - 1)
            img[x0 + p, y0 + q] = ti.cast(self.colour(i, j), ti.f32)

    @ti.kernel
    def value_range(self):
        """Min and max of the colour-mapped quantity over cells with h >= h_min into red[0:2].

        Columns in parallel, each scanned serially, then one atomic min/max per column: far less
        contention than one atomic per cell, and deterministic (min/max do not depend on order)."""
        self.red[0] = ti.cast(_BIG, ti.f32)
        self.red[1] = ti.cast(-_BIG, ti.f32)
        mode = ti.cast(self.par[P_MODE], ti.i32)
        for i in range(self.nx):
            lo = ti.cast(_BIG, ti.f32)
            hi = ti.cast(-_BIG, ti.f32)
            for j in range(self.ny):
                s = self.src.sample(i, j)
                if s[0] >= self.par[P_HMIN]:
                    v = ti.cast(self._value(s, mode), ti.f32)
                    lo = ti.min(lo, v)
                    hi = ti.max(hi, v)
            ti.atomic_min(self.red[0], lo)
            ti.atomic_max(self.red[1], hi)

    @ti.kernel
    def fill(
        self,
        img: ti.template(),
        x0: ti.i32,
        y0: ti.i32,
        w: ti.i32,
        h: ti.i32,
        r: ti.f32,
        g: ti.f32,
        b: ti.f32,
    ):
        for p, q in ti.ndrange(w, h):
            img[x0 + p, y0 + q] = ti.Vector([r, g, b])

    @ti.kernel
    def colourbar(self, img: ti.template(), x0: ti.i32, y0: ti.i32, w: ti.i32, h: ti.i32):
        """A vertical colour bar of the current field, low values at the bottom."""
        mode = ti.cast(self.par[P_MODE], ti.i32)
        coarse = ti.Vector([C.COARSE_RGB[0], C.COARSE_RGB[1], C.COARSE_RGB[2]], float)
        fines = ti.Vector([C.FINES_RGB[0], C.FINES_RGB[1], C.FINES_RGB[2]], float)
        for p, q in ti.ndrange(w, h):
            t = (q + 0.5) / h
            c = (1.0 - t) * coarse + t * fines
            if mode != 0:
                c = ti.cast(self._lut(t), float)
            img[x0 + p, y0 + q] = ti.cast(c, ti.f32)


def _image_to_numpy(
    img, w: int | None = None, h: int | None = None, x0: int = 0, y0: int = 0
) -> np.ndarray:
    """An image field (x right, y up) as uint8 (rows, columns, 3) with row 0 at the top."""
    a = img.to_numpy()
    if w is not None:
        a = a[x0 : x0 + w, y0 : y0 + h]
    return C.to_uint8(np.transpose(a, (1, 0, 2))[::-1])


# =================================================================================================
# Off-screen rendering of NumPy fields
# =================================================================================================
_painters: dict = {}


def _array_painter(nx: int, ny: int) -> _Painter:
    """A cached painter over (nx, ny) arrays (one compile per grid size and Taichi runtime)."""
    gen = backend.state().generation  # initialises Taichi (cpu, f64) if nobody has
    key = (nx, ny, gen)
    if key not in _painters:
        for k in [k for k in _painters if k[2] != gen]:
            del _painters[k]  # fields of an old runtime are gone
        painter = _Painter(_ArraySource(nx, ny))
        # a cache, rebuilt above for a new runtime: it must not keep Taichi from being reset
        # (tiseg.apps.cli renews an idle runtime so that kernels load from the offline cache)
        field_tree.untrack(painter)
        field_tree.untrack(painter.src)
        _painters[key] = painter
    return _painters[key]


def render_fields(
    fields: dict,
    h_min: float,
    field: str = "phi",
    shade=True,
    scale: float = 1,
    vrange=None,
    colourbar: bool | None = None,
    relief: float = DEFAULT_RELIEF,
    aspect: float = 1.0,
    dx: float | None = None,
    dy: float | None = None,
) -> np.ndarray:
    """Render a snapshot of (ny, nx) arrays to an RGB image, uint8 (H, W, 3), row 0 at the top.

    Parameters
    ----------
    fields
        "h" and, as needed, "phi", "u", "v" (a dict as from ``Simulation.fields()`` or one
        time of ``read_fields``); with "b" (and "solid"), the terrain's bed (ny, nx) [m],
        its relief is shaded under the colours and its walls drawn
        (`tiseg.post.render.relief`).
    h_min
        Thinner cells are drawn as the empty chute [m].
    field
        "phi" (experiment colours), "h", "speed" (alias "|u|"), "u" or "v" (viridis).
    shade
        True, False or a strength S in [0, 1] of the relief shading.
    scale
        Pixels per cell.
    vrange
        (vmin, vmax) of a colour-mapped field; default the data range of the flowing cells.
    colourbar
        Add a colour bar at the right; default for the mapped fields only.
    relief
        Vertical exaggeration of the slopes of h in the relief shading.
    aspect
        dy / dx: the picture keeps cells of other shapes true to size.
    dx, dy
        Cell sizes [m], which set the slopes of the relief shading; by default the spacing of
        ``fields["x"]`` / ``fields["y"]`` when given, else the paper's 1/750 m.

    Returns
    -------
    numpy.ndarray
        The picture, uint8 (H, W, 3).
    """
    field, h, vrange = checked_fields(fields, field, vrange, h_min)
    ny, nx = h.shape
    painter = _array_painter(nx, ny)
    painter.src.upload(h, fields.get("phi"), fields.get("u"), fields.get("v"))
    strength = _shade_strength(shade)
    dx = _spacing(fields.get("x"), dx, PAPER_DX)
    dy = _spacing(fields.get("y"), dy, dx)
    painter.set_params(
        h_min=h_min, field=field, vrange=vrange, shade=strength, relief=relief, dx=dx, dy=dy
    )
    w, hh = image_size(nx, ny, scale, aspect)
    img = painter.image(w, hh)
    painter.paint(img, 0, 0, w, hh)
    out = _image_to_numpy(img)
    b, solid = bed_of(fields, ny, nx)
    if b is not None:  # a run with terrain: its relief under the colours (flat: untouched)
        out = with_relief(out, b, solid, dx, dy, strength)
    if colourbar is None:
        colourbar = field != "phi"
    if colourbar:
        out = add_colourbar(out, field, *(vrange or (0.0, 1.0)))
    return out


# =================================================================================================
# Frames straight from a simulation
# =================================================================================================
class FrameRenderer:
    """Render a `tiseg.run.simulation.Simulation` 's current state, or one of its snapshots
    (``state=snap``, `tiseg.run.callbacks.Snapshot`), without copying it to NumPy.

    The kernel reads the state's slot of ``sim.op.q`` in place; only the finished picture comes back (or
    nothing, when the viewer shows the image field directly). ``vrange`` for the mapped fields:
    None starts from a range suited to the scene's reference flow and widens it whenever the data
    leave it (colours stay comparable across a movie); "auto" fits every frame to its data; a
    tuple fixes it. ``phi_const``: the concentration drawn when the scene has no segregation.
    A scene with terrain has its relief shaded under the colours and its solid cells drawn as
    walls, as `render_fields` draws them from fields.nc (`tiseg.post.render.relief`).
    """

    def __init__(
        self,
        sim,
        field: str = "phi",
        shade=True,
        scale: float = 1.0,
        vrange=None,
        colourbar: bool | None = None,
        relief: float = DEFAULT_RELIEF,
    ):
        self.sim = sim
        sc = sim.scene
        self.source = _StateSource(sim.op)
        # the terrain's bed and walls (ny, nx), static: uploaded when the shading changes
        self._bed = None
        if sc.has_terrain:
            b, solid = sc.bed_arrays()
            self._bed = (b.T, solid.T)
        self._bed_shade = None  # the strength the uploaded relief factors were made with
        self.painter = _Painter(self.source, has_bed=self._bed is not None)
        self.nx, self.ny = self.painter.nx, self.painter.ny
        self.h_min = float(sc.numerics.h_min)
        self.dx, self.dy = float(sc.dx), float(sc.dy)
        self.shade = _shade_strength(shade)
        self.relief = float(relief)
        self.colourbar = colourbar
        self._vrange_mode = vrange
        aspect = 1.0 if sim.layout.is_1d else self.dy / self.dx
        self.width, self.height = image_size(self.nx, self.ny, scale, aspect)
        self.scale = self.width / self.nx
        self.image = self.painter.image(self.width, self.height)
        self.field = "phi"
        self.vrange = (0.0, 1.0)
        self.set_field(field)

    @property
    def has_phi(self) -> bool:
        return bool(self.sim.layout.segregation)

    @property
    def pixel_size(self) -> float:
        """Metres per pixel along x."""
        return self.dx / self.scale

    def set_field(self, field: str) -> None:
        field = C.canonical_field(field)
        if field == "v" and self.sim.layout.is_1d:
            raise ValueError("field='v' does not exist in a 1D run")
        self.field = field
        mode = self._vrange_mode
        if field == "phi":
            self.vrange = (0.0, 1.0)
        elif isinstance(mode, (tuple, list)):
            self.vrange = (float(mode[0]), float(mode[1]))
        else:
            self.vrange = C.default_range(field, scene=self.sim.scene) or (0.0, 0.0)

    def _update_params(self) -> None:
        self.h_min = float(self.sim.scene.numerics.h_min)  # set_parameters may change it
        self.painter.set_params(
            h_min=self.h_min,
            field=self.field,
            vrange=self.vrange,
            shade=self.shade,
            relief=self.relief,
            dx=self.dx,
            dy=self.dy,
            phi_const=float(self.sim.scene.flow.phi0),
        )
        if self._bed is not None and self.shade != self._bed_shade:
            self.painter.set_bed(*bed_cells(*self._bed, self.dx, self.dy, self.shade))
            self._bed_shade = self.shade

    def _update_range(self) -> None:
        """Refit (auto) or widen (default) the colour range to the current data."""
        mode = self._vrange_mode
        if self.field == "phi" or isinstance(mode, (tuple, list)):
            return
        self._update_params()
        self.painter.value_range()
        lo, hi = (float(x) for x in self.painter.red.to_numpy())
        if lo > hi:  # no flowing cell
            lo = hi = 0.0
        if self.field == "v":
            m = max(abs(lo), abs(hi))
            lo, hi = -m, m
        elif self.field != "u":
            lo = 0.0
        else:
            lo = min(lo, 0.0)
        if mode == "auto":
            self.vrange = C._nondegenerate(lo, hi, self.field)
        else:
            cur = self.vrange
            self.vrange = C._nondegenerate(min(cur[0], lo), max(cur[1], hi), self.field)

    def render(self, state=None):
        """Paint the current state (or ``state``, a snapshot) into `image` (a Taichi
        field) and return it."""
        self.paint_into(self.image, 0, 0, self.width, self.height, state)
        return self.image

    def paint_into(self, img, x0: int, y0: int, w: int, h: int, state=None) -> None:
        """Paint the current state (or ``state``) into a rectangle of another image field (the
        viewer's)."""
        self.sim.op.check_alive()
        self.source.use_slot(0 if state is None else state.slot)
        self._update_range()
        self._update_params()
        self.painter.paint(img, x0, y0, w, h)

    def to_numpy(
        self, annotate_frame: bool = False, colourbar: bool | None = None, state=None
    ) -> np.ndarray:
        """Render and return uint8 (H, W, 3); optionally with colour bar, time and scale bar.
        ``state``: a `tiseg.run.callbacks.Snapshot` to draw instead of the current state."""
        self.render(state)
        out = _image_to_numpy(self.image)
        cb = self.colourbar if colourbar is None else colourbar
        if cb is None:
            cb = self.field != "phi"
        map_width = out.shape[1]
        if cb:
            out = add_colourbar(out, self.field, *self.vrange)
        if annotate_frame:
            t = self.sim.t if state is None else state.t
            out = annotate(out, t, self.pixel_size, map_width=map_width)
        return out


# =================================================================================================
# Captions: text, time stamp, scale bar, colour bar
# =================================================================================================
@lru_cache(maxsize=1)
def _font_path() -> str:
    from matplotlib import font_manager

    return font_manager.findfont(font_manager.FontProperties(family="DejaVu Sans"))


@lru_cache(maxsize=8)
def _font(size: int):
    """DejaVu Sans (shipped with matplotlib) at ``size`` pixels, through Pillow's FreeType."""
    from PIL import ImageFont

    return ImageFont.truetype(_font_path(), size)


def text_width(s: str, size: int = 12) -> int:
    """Width in pixels of a string drawn by `draw_text`."""
    return int(round(_font(size).getlength(s)))


def draw_text(
    img: np.ndarray, s: str, x: int, baseline: int, colour=C.TEXT_RGB, size: int = 12
) -> int:
    """Draw s into a uint8 (H, W, 3) image in place, left end at column x, on the given baseline
    row (Pillow's ``ls`` anchor), antialiased; clipped at the borders. Returns the x after the
    text."""
    from PIL import Image, ImageDraw

    pil = Image.fromarray(np.ascontiguousarray(img))
    fill = tuple(int(round(float(c) * 255.0)) for c in colour)
    ImageDraw.Draw(pil).text((x, baseline), s, font=_font(size), fill=fill, anchor="ls")
    img[...] = np.asarray(pil)
    return x + text_width(s, size)


def annotate(
    img: np.ndarray,
    t: float | None,
    dx: float,
    label: str | None = None,
    map_width: int | None = None,
    strip: int = 20,
    size: int = 12,
) -> np.ndarray:
    """A copy of img with a caption strip below: time stamp "t = 1.90 s" (and an optional label)
    on the left, a scale bar on the right.

    ``dx``: metres per pixel of the map; ``map_width``: pixel width of the map part of img (the
    scale bar sits under the map, not under a colour bar; default the whole width). The strip is
    added below rather than drawn over the flow so that no data is hidden."""
    H, W = img.shape[:2]
    mw = W if map_width is None else int(map_width)
    bg = C.to_uint8(C.BACKGROUND_RGB)
    out = np.empty((H + strip, W, 3), dtype=np.uint8)
    out[:H] = img
    out[H:] = bg
    baseline = H + strip // 2 + size // 3 + 1
    x = 6
    if t is not None:
        x = draw_text(out, f"t = {t:.2f} s", x, baseline, size=size) + 12
    if label:
        draw_text(out, label, x, baseline, size=size)
    if dx > 0:
        length = nice_length(0.2 * mw * dx)  # about a fifth of the map width
        npx = int(round(length / dx))
        text = format_length(length)
        tw = text_width(text, size)
        x1 = mw - 6
        x0 = x1 - npx
        if npx >= 2 and x0 - tw - 6 > x:  # room for bar and label without overlap
            bar_row = H + strip // 2
            out[bar_row - 1 : bar_row + 2, x0:x1] = C.to_uint8(C.TEXT_RGB)
            out[bar_row - 4 : bar_row + 5, x0 : x0 + 1] = C.to_uint8(C.TEXT_RGB)
            out[bar_row - 4 : bar_row + 5, x1 - 1 : x1] = C.to_uint8(C.TEXT_RGB)
            draw_text(out, text, x0 - tw - 6, baseline, size=size)
    return out


def _tick_text(v: float) -> str:
    s = f"{v:.3g}"
    return "0" if s in ("-0", "0") else s


def add_colourbar(
    img: np.ndarray, field: str, vmin: float, vmax: float, width: int = 70, size: int = 11
) -> np.ndarray:
    """A copy of img with a vertical colour bar for ``field`` at the right: the same colour table
    as the frame kernel, ticks at the ends and the middle in display units (h in mm), the unit on
    top. phi gets the coarse-to-fines ramp."""
    field = C.canonical_field(field)
    H, W = img.shape[:2]
    out = np.empty((H, W + width, 3), dtype=np.uint8)
    out[:, :W] = img
    out[:, W:] = C.to_uint8(C.BACKGROUND_RGB)
    _, factor, unit = C.FIELD_LABELS[field]
    top = min(size + 6, H // 3) if H >= 3 * size else 0  # room for the unit above the bar
    bot = max(H - 4, top + 1) if H > 8 else H
    bx0, bx1 = W + 6, W + 18
    n = bot - top
    t = (np.arange(n)[::-1] + 0.5) / n  # top row = high values
    out[top:bot, bx0:bx1] = C.to_uint8(C.colours_for(field, t))[:, None, :]
    if H >= 2 * size:
        title = unit or ("φ" if field == "phi" else "")
        draw_text(out, title, bx0, top - 4 if top else size, size=size)
        for frac in (0.0, 0.5, 1.0):
            v = (vmin + frac * (vmax - vmin)) * factor
            row = int(round(bot - 1 - frac * (n - 1)))
            out[row, bx1 : bx1 + 3] = C.to_uint8(C.TEXT_RGB)
            base = min(max(row + size // 3, top + size - 2), H - 2)
            draw_text(out, _tick_text(v), bx1 + 5, base, size=size)
    return out
