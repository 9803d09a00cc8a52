"""The keys of the ``[terrain]`` section: `TerrainConfig` and the ``[[terrain.shapes]]``
tables' `ShapeKeys`, declared as the other sections are (`tiseg.setup.sections`, which lists
it in ``SECTIONS``); read and written by `tiseg.setup.bed`. Its own module, as the sections'
module is long."""

from __future__ import annotations

import dataclasses
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
    (heights along the vertical) is not handled: convert it to heights normal to the plane
    first. No section: a flat plane. ``Scene.bed_arrays()`` gives (b, solid) on the cells.
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
