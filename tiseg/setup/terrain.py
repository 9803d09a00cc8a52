"""Terrain from analytic shapes: a bed height b(x, y) and a solid mask on the cell centres.

Conventions (DESIGN.md, "Terrain"): x runs down the reference plane (0..Lx), y across it
(0..Ly), and b is the bed height *normal to that plane* [m], sampled at the cell centres
x_i = (i + 1/2) dx, y_j = (j + 1/2) dy. With material.zeta_deg = 0 the plane is horizontal
and b an elevation, a map-view DEM's convention (docs/guide.md, "Terrain"). Arrays are indexed [i, j] = (x, y), shape (nx, ny).

Two sorts of shape:

* bed shapes (``gaussian``, ``cone``) add to b; the shallow equations assume |grad b| small,
  so keep them gentle;
* solid shapes (``cylinder``, ``wedge``) mark whole cells solid (walls with faces, not steep
  b): a cell is solid when its centre lies inside the shape. b is 0 in solid cells (a wall has
  no bed), the same fill as `tiseg.setup.rasters.resample` uses for nodata.

Each kind is a frozen dataclass whose fields are its TOML keys (all numbers), checked on
construction; `SHAPE_KINDS` maps ``kind`` to the class, so user code can add a kind
(`register_shape`). `shapes_from_tables` reads the ``[[terrain.shapes]]`` tables and
`bed_on_grid` builds (b, solid), which `tiseg.setup.bed` gives the scene and the solver.
"""

from __future__ import annotations

import difflib
import math
import numbers
from dataclasses import MISSING, dataclass, fields
from typing import ClassVar, Mapping, Sequence

import numpy as np

from ..errors import InputError
from .table import MISSING as REQUIRED
from .table import Table, show, type_name

# A gaussian never reaches zero; beyond this many radii its bump is below e^-16 ~ 1e-7 of its
# height, which is where "outside the domain" and "too coarse" start counting for it.
GAUSSIAN_REACH = 4.0

Box = tuple[float, float, float, float]  # (x_lo, x_hi, y_lo, y_hi) [m]


class ShapeError(InputError):
    """A shape's key breaks its rule; carries ``key``, ``value`` and ``rule`` so that
    `shapes_from_tables` can name the ``[[terrain.shapes]]`` table it came from."""

    def __init__(self, where: str, key: str, value, rule: str):
        self.key, self.value, self.rule = key, value, rule
        super().__init__(f"{where}.{key}={show(value)}: {rule}")


@dataclass(frozen=True)
class Shape:
    """Base of the shape kinds. A subclass sets ``kind`` (its TOML name) and ``solid``, declares
    its keys as float fields, and defines `rules`, `overlaps` and `footprint` (and `bed` for
    a bed shape). Every field must be a finite real number."""

    kind: ClassVar[str] = ""
    solid: ClassVar[bool] = False

    x: float
    y: float

    def __post_init__(self):
        given = {f.name: getattr(self, f.name) for f in fields(self)}
        for name, v in given.items():
            if isinstance(v, bool) or not isinstance(v, numbers.Real):
                raise ShapeError(self.kind, name, v, f"expected a number, got {type_name(v)}")
            if not math.isfinite(v):
                raise ShapeError(self.kind, name, v, "must be a finite number")
            object.__setattr__(self, name, float(v))  # TOML integers become floats
        for key, ok, rule in self.rules():
            if not ok:
                raise ShapeError(self.kind, key, given[key], rule)  # as written, -1 not -1.0

    def rules(self) -> list[tuple[str, bool, str]]:
        """(key, holds, rule) for each range rule of the kind."""
        return []

    def overlaps(self, box: Box) -> bool:
        """Whether the shape reaches into the open rectangle ``box``."""
        raise NotImplementedError

    def footprint(self, X: np.ndarray, Y: np.ndarray) -> np.ndarray:
        """Bool mask of the points (X, Y) the shape covers: the solid cells of a solid shape,
        the support of a bed shape."""
        raise NotImplementedError

    def bed(self, X: np.ndarray, Y: np.ndarray) -> np.ndarray:
        """What a bed shape adds to b at the points (X, Y) [m]."""
        raise NotImplementedError(f"{self.kind} is a solid shape; it adds nothing to b")

    def describe(self) -> str:
        keys = ", ".join(f"{f.name}={getattr(self, f.name):g}" for f in fields(self))
        return f"{self.kind} ({keys})"


def _disc_overlaps(x: float, y: float, r: float, box: Box) -> bool:
    """Whether the open disc of radius r about (x, y) meets the rectangle: its distance from
    the centre is below r (exact at the corners, unlike a bounding-box test)."""
    x_lo, x_hi, y_lo, y_hi = box
    ex = max(x_lo - x, 0.0, x - x_hi)
    ey = max(y_lo - y, 0.0, y - y_hi)
    return math.hypot(ex, ey) < r


def _convex_overlap(p: np.ndarray, q: np.ndarray) -> bool:
    """Whether two convex polygons (vertices in order, (n, 2)) share interior points, by the
    separating-axis test: they are apart when their projections onto some edge normal of
    either do not overlap (touching counts as apart: no area in common)."""
    for poly in (p, q):
        edges = np.roll(poly, -1, axis=0) - poly
        for ex, ey in edges:
            n = np.array([-ey, ex])
            a, b = p @ n, q @ n
            if a.max() <= b.min() or b.max() <= a.min():
                return False
    return True


@dataclass(frozen=True)
class Gaussian(Shape):
    """A smooth bump (height > 0) or hollow (height < 0):
    b += height * exp(-((x - x0)^2 + (y - y0)^2) / radius^2), with (x0, y0) = (x, y).
    Its volume over the plane is pi radius^2 height; slope at most
    sqrt(2/e) |height| / radius. It counts as reaching GAUSSIAN_REACH radii."""

    kind: ClassVar[str] = "gaussian"
    radius: float
    height: float

    def rules(self):
        return [("radius", self.radius > 0, "must be > 0")]

    def overlaps(self, box):
        return _disc_overlaps(self.x, self.y, GAUSSIAN_REACH * self.radius, box)

    def footprint(self, X, Y):
        return (X - self.x) ** 2 + (Y - self.y) ** 2 < (GAUSSIAN_REACH * self.radius) ** 2

    def bed(self, X, Y):
        return self.height * np.exp(-((X - self.x) ** 2 + (Y - self.y) ** 2) / self.radius**2)


@dataclass(frozen=True)
class Disc(Shape):
    """Base of the round kinds: ``radius`` about (x, y), the cells whose centre lies strictly
    inside the circle."""

    radius: float

    def rules(self):
        return [("radius", self.radius > 0, "must be > 0")]

    def overlaps(self, box):
        return _disc_overlaps(self.x, self.y, self.radius, box)

    def footprint(self, X, Y):
        return (X - self.x) ** 2 + (Y - self.y) ** 2 < self.radius**2


@dataclass(frozen=True)
class Cone(Disc):
    """A cone (height > 0) or conical pit (height < 0) with a linear profile:
    b += height * max(0, 1 - r / radius), r the distance from (x, y). Volume
    pi radius^2 height / 3; slope |height| / radius everywhere inside."""

    kind: ClassVar[str] = "cone"
    height: float

    def bed(self, X, Y):
        r = np.hypot(X - self.x, Y - self.y)
        return self.height * np.maximum(0.0, 1.0 - r / self.radius)


@dataclass(frozen=True)
class Cylinder(Disc):
    """A solid upright cylinder (a post): the cells whose centre lies strictly inside the
    circle of ``radius`` about (x, y)."""

    kind: ClassVar[str] = "cylinder"
    solid: ClassVar[bool] = True


@dataclass(frozen=True)
class Wedge(Shape):
    """A solid triangle (a flow splitter), apex upslope at (x, y), symmetric about the line
    through the apex at constant y, opening downslope to x + length where its half-width is
    length tan(half_angle_deg): the points with 0 <= X - x <= length and
    |Y - y| <= (X - x) tan(half_angle). Area length^2 tan(half_angle)."""

    kind: ClassVar[str] = "wedge"
    solid: ClassVar[bool] = True
    half_angle_deg: float
    length: float

    def rules(self):
        return [
            ("half_angle_deg", 0 < self.half_angle_deg < 90, "must lie in (0, 90)"),
            ("length", self.length > 0, "must be > 0"),
        ]

    @property
    def half_width(self) -> float:
        return self.length * math.tan(math.radians(self.half_angle_deg))

    def vertices(self) -> np.ndarray:
        w = self.half_width
        end = self.x + self.length
        return np.array([[self.x, self.y], [end, self.y - w], [end, self.y + w]])

    def overlaps(self, box):
        x_lo, x_hi, y_lo, y_hi = box
        rect = np.array([[x_lo, y_lo], [x_hi, y_lo], [x_hi, y_hi], [x_lo, y_hi]])
        return _convex_overlap(self.vertices(), rect)

    def footprint(self, X, Y):
        s = X - self.x
        tan = math.tan(math.radians(self.half_angle_deg))
        return (s >= 0) & (s <= self.length) & (np.abs(Y - self.y) <= s * tan)


SHAPE_KINDS: dict[str, type[Shape]] = {c.kind: c for c in (Gaussian, Cone, Cylinder, Wedge)}


def register_shape(cls: type[Shape]) -> type[Shape]:
    """Add a shape kind (a frozen `Shape` dataclass with a ``kind``) to `SHAPE_KINDS`; usable
    as a class decorator. A kind registered twice replaces the first."""
    if not (isinstance(cls, type) and issubclass(cls, Shape) and cls.kind):
        raise TypeError(f"{cls!r}: a shape kind is a Shape subclass with a non-empty kind")
    SHAPE_KINDS[cls.kind] = cls
    return cls


def shapes_from_tables(tables, prefix: str = "terrain.shapes") -> list[Shape]:
    """The shapes of the ``[[terrain.shapes]]`` tables (a list of dicts as TOML reads them),
    in order. Every problem is an InputError naming ``terrain.shapes[i]`` and the key: a
    missing or unknown ``kind``, a key the kind lacks, a missing key, a non-number, a value
    out of range."""
    if not isinstance(tables, Sequence) or isinstance(tables, (str, bytes)):
        raise InputError(
            f"{prefix}={show(tables)}: expected an array of tables ([[{prefix}]]), "
            f"got {type_name(tables)}"
        )
    kinds = ", ".join(map(repr, SHAPE_KINDS))
    out = []
    for i, t in enumerate(tables):
        where = f"{prefix}[{i}]"
        if not isinstance(t, Mapping):
            raise InputError(f"{where}={show(t)}: expected a table, got {type_name(t)}")
        if "kind" not in t:
            raise InputError(f"{where}.kind is required: one of {kinds}")
        kind = t["kind"]
        if not isinstance(kind, str) or kind not in SHAPE_KINDS:
            raise InputError(f"{where}.kind={show(kind)}: unknown shape; one of {kinds}")
        cls = SHAPE_KINDS[kind]
        names = [f.name for f in fields(cls)]
        allowed = ", ".join(["kind", *names])
        for k in t:
            if k != "kind" and k not in names:
                close = difflib.get_close_matches(str(k), names, n=1)
                hint = f" (did you mean {close[0]!r}?)" if close else ""
                raise InputError(
                    f"{where}.{k}: unknown key for kind {kind!r}{hint}; its keys: {allowed}"
                )
        required = [f.name for f in fields(cls) if f.default is MISSING]
        missing = [n for n in required if n not in t]
        if missing:
            raise InputError(
                f"{where}: missing key{'s' if len(missing) > 1 else ''} "
                f"{', '.join(missing)} for kind {kind!r}; its keys: {allowed}"
            )
        tab = Table(t, where, ["kind", *names])
        values = {
            f.name: tab.number(f.name, REQUIRED if f.default is MISSING else f.default)
            for f in fields(cls)
        }
        try:
            out.append(cls(**values))
        except ShapeError as e:
            raise ShapeError(where, e.key, t.get(e.key, e.value), e.rule) from None
    return out


def domain_box(xc, yc) -> Box:
    """(x_lo, x_hi, y_lo, y_hi) of the cells centred at ``xc`` and ``yc`` (evenly spaced,
    increasing); an axis of one cell takes its width from its centre, as the cells start at 0
    (x_0 = dx / 2)."""
    out = []
    for name, c in (("x", xc), ("y", yc)):
        c = np.asarray(c, dtype=float)
        if c.ndim != 1 or c.size == 0 or not np.all(np.isfinite(c)):
            raise InputError(f"cell centres {name}: expected a non-empty 1D array of numbers")
        d = float(c[1] - c[0]) if c.size > 1 else 2.0 * float(c[0])
        if not d > 0 or (c.size > 1 and not np.all(np.diff(c) > 0)):
            raise InputError(f"cell centres {name}: must increase")
        lo = float(c[0]) - d / 2
        # a grid that starts at 0 computes its edge as -1e-18 or so; say 0
        out += [0.0 if abs(lo) < 1e-9 * d else lo, float(c[-1]) + d / 2]
    return tuple(out)


def bed_on_grid(shapes: Sequence[Shape], xc, yc) -> tuple[np.ndarray, np.ndarray]:
    """(b, solid) on the cells centred at ``xc`` (nx) and ``yc`` (ny): b float64 (nx, ny),
    the sum of the bed shapes at the cell centres [m] and 0 in solid cells; solid bool
    (nx, ny), the union of the solid shapes' cells.

    A shape that lies entirely outside the domain is an InputError, and so is one that covers
    no cell centre (a post thinner than the cells, a bump between centres): the grid is too
    coarse for it. Messages name the shape by its index, ``terrain.shapes[i]``."""
    xc = np.asarray(xc, dtype=float)
    yc = np.asarray(yc, dtype=float)
    box = domain_box(xc, yc)
    X, Y = np.meshgrid(xc, yc, indexing="ij")
    b = np.zeros(X.shape)
    solid = np.zeros(X.shape, dtype=bool)
    dom = f"[{box[0]:g}, {box[1]:g}] x [{box[2]:g}, {box[3]:g}]"
    for i, s in enumerate(shapes):
        where = f"terrain.shapes[{i}]"
        if not isinstance(s, Shape):
            raise InputError(f"{where}={show(s)}: expected a shape, got {type_name(s)}")
        if not s.overlaps(box):
            raise InputError(f"{where}, {s.describe()}, lies outside the domain {dom}")
        covered = s.footprint(X, Y)
        if not covered.any():
            d = f"dx = {xc[1] - xc[0] if xc.size > 1 else 2 * xc[0]:g} m, "
            d += f"dy = {yc[1] - yc[0] if yc.size > 1 else 2 * yc[0]:g} m"
            raise InputError(
                f"{where}, {s.describe()}, covers no cell centre: the grid ({d}) is too "
                "coarse for it; refine the grid or enlarge the shape"
            )
        if s.solid:
            solid |= covered
        else:
            b += s.bed(X, Y)
    b[solid] = 0.0
    return b, solid


__all__ = [
    "GAUSSIAN_REACH",
    "SHAPE_KINDS",
    "Cone",
    "Cylinder",
    "Gaussian",
    "Shape",
    "ShapeError",
    "Wedge",
    "bed_on_grid",
    "domain_box",
    "register_shape",
    "shapes_from_tables",
]
