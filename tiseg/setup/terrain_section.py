"""The keys of the ``[terrain]`` section: `TerrainConfig` and the ``[[terrain.shapes]]``
tables' `ShapeKeys`, declared as the other sections are (`tiseg.setup.sections`, which lists
it in ``SECTIONS``); read and written by `tiseg.setup.bed`. Its own module, as the sections'
module is long."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

from .schema import key
from .terrain import SHAPE_KINDS, Shape


@dataclass(frozen=True)
class ShapeKeys:
    """The keys of one ``[[terrain.shapes]]`` table; which ones a table takes depends on its
    ``kind`` (`tiseg.setup.terrain.SHAPE_KINDS`, each kind's dataclass fields), which
    `tiseg.setup.terrain.shapes_from_tables` checks. Declared here for the reference page and
    the JSON schema; the shapes themselves are the kinds' frozen dataclasses."""

    kind: str = field(
        metadata=key(
            "the shape (a kind registered by register_shape too)",
            choices=lambda: tuple(SHAPE_KINDS),
        )
    )
    x: float = field(metadata=key("downslope position of the centre (wedge: apex) [m]"))
    y: float = field(metadata=key("cross-slope position of the centre (wedge: apex) [m]"))
    radius: float | None = field(
        default=None, metadata=key("gaussian, cone, cylinder: radius [m]", positive=True)
    )
    height: float | None = field(
        default=None,
        metadata=key("gaussian, cone: height normal to the plane, < 0 for a hollow [m]"),
    )
    half_angle_deg: float | None = field(
        default=None, metadata=key("wedge: half the opening angle, in (0, 90)", units="degree")
    )
    length: float | None = field(
        default=None, metadata=key("wedge: downslope length from the apex [m]", positive=True)
    )


@dataclass(frozen=True)
class RunoutConfig:
    """The keys of ``[terrain.runout]``: the reference surface bends at constant curvature
    from ``material.zeta_deg`` to ``zeta_deg`` between the arc lengths ``x`` and ``x +
    length`` (Savage & Hutter 1991; Gray, Wieland & Hutter 1999): x is the arc length along
    the bed line, the flow feels g sin zeta(x) along it and g cos zeta(x) + kappa u^2 normal
    to it (tiseg.model.bed_line, tiseg.solver.numerics.gravity)."""

    x: float = field(metadata=key("arc length where the bend begins, in [0, Lx) [m]", nonneg=True))
    length: float = field(metadata=key("arc length of the bend [m]", positive=True))
    zeta_deg: float = field(
        metadata=key(
            "inclination past the bend, in (-90, 90); 0 is a horizontal run-out pad",
            lo=-90.0,
            hi=90.0,
            units="degree",
        )
    )

    def line(self, zeta1: float):
        """The `tiseg.model.bed_line.BedLine` from the inclination zeta1 [rad] above it."""
        from ..model.bed_line import BedLine

        return BedLine(zeta1, math.radians(self.zeta_deg), self.x, self.length)

    def curvature(self, zeta1: float) -> float:
        """kappa = (zeta1 - zeta2) / length [1/m], zeta1 [rad]."""
        return (zeta1 - math.radians(self.zeta_deg)) / self.length


def _shapes_doc() -> str:
    kinds = "; ".join(
        f"``{name}`` ({', '.join(f.name for f in dataclasses.fields(cls))})"
        for name, cls in SHAPE_KINDS.items()
    )
    return (
        "[[terrain.shapes]] tables, each with a kind and its keys: " + kinds + "; gaussian "
        "and cone add to the bed b, cylinder and wedge are solid (tiseg.setup.terrain)"
    )


@dataclass(frozen=True)
class TerrainConfig:
    """The bed under the flow: analytic shapes and a raster, b normal to the reference plane.

    b(x, y) [m] is the bed height normal to the inclined reference plane (x down it, y across
    it), the sum of the bed shapes and the raster ``bed``; a cell is solid (a wall: no material,
    no bed) where a solid shape covers its centre or the raster has nodata. A map-view DEM
    (heights along the vertical) is such a bed on a horizontal plane (material.zeta_deg = 0);
    on an inclined one, convert it to heights normal to the plane first. ``runout`` bends the
    reference surface itself. No section: a flat plane. ``Scene.bed_arrays()`` gives (b, solid) on the cells.
    """

    shapes: tuple[Shape, ...] = field(
        default=(), metadata=key(_shapes_doc(), table=ShapeKeys, many=True, compiled="operator")
    )
    bed: str | None = field(
        default=None,
        metadata=key(
            "raster of b normal to the plane [m]: .asc, .nc (variable b on x, y) or GeoTIFF "
            "(extra tiseg[terrain]); nodata = solid; bilinear onto the cell centres; a "
            "relative path is taken from the scene file's folder",
            compiled="operator",
        ),
    )
    runout: RunoutConfig | None = field(
        default=None,
        metadata=key(
            "[terrain.runout]: the reference surface bends from material.zeta_deg to "
            "zeta_deg between the arc lengths x and x + length (a chute levelling out into a "
            "run-out pad); x is then the arc length along the bed",
            table=RunoutConfig,
            compiled="operator",
        ),
    )
    origin_x: float = field(
        default=0.0,
        metadata=key("the raster's x coordinates are shifted by this [m]", compiled="operator"),
    )
    origin_y: float = field(
        default=0.0,
        metadata=key("the raster's y coordinates are shifted by this [m]", compiled="operator"),
    )

    @property
    def has_terrain(self) -> bool:
        """Any shape or a raster: else the flat plane of the paper."""
        return bool(self.shapes) or self.bed is not None
