"""The ``[terrain]`` section of a scene and the bed it gives on the cells.

Conventions (DESIGN.md, "Terrain"): b(x, y) is the bed height *normal to the reference plane*
[m], x down the plane and y across it, sampled at the cell centres; arrays are indexed
[i, j] = (x, y), shape (nx, ny). A cell is solid (a wall: no material and b = 0) where a solid
shape covers its centre or where the raster's bilinear stencil reaches nodata. A map-view DEM
(heights along the vertical) is such a bed on a horizontal plane (material.zeta_deg = 0). A
run-out's bend (``[terrain.runout]``) bends the reference surface itself: `check_bend`.

* `read_terrain`: the section, read and checked: the shapes through
  `tiseg.setup.terrain.shapes_from_tables`, the raster path made absolute (a relative path is
  taken from the scene file's folder, or the current directory for a scene that comes from
  no file), so that the scene a run writes into its folder loads from anywhere;
* `terrain_to_dict`: the section as TOML writes it (absent for a flat plane);
* `bed_arrays`: (b, solid) of the shapes plus the raster, cached per terrain and grid (and
  the raster file's size and modification time: an edited file is read again);
* `initial_thickness`: the thickness raster of ``initial.kind = "file"``, cached alike;
* `check_initial`: what the kinds that read the bed need (``lake``, ``file``).

Every bad input is a one-line `tiseg.errors.InputError` naming its key.
"""

from __future__ import annotations

import dataclasses
import functools
import os
from pathlib import Path

import numpy as np

from ..errors import InputError
from .rasters import read_raster, resample
from .schema import field_named, key_names, read_key, read_section
from .sections import DomainConfig, InitialConfig, TerrainConfig
from .terrain_section import RunoutConfig
from .table import Table, show
from .terrain import bed_on_grid, shapes_from_tables


# ---- paths --------------------------------------------------------------------------------------
def base_folder(source: str | None) -> Path:
    """The folder relative paths of a scene are taken from: the scene file's, else the
    current directory."""
    return Path(source).expanduser().parent if source else Path.cwd()


def absolute_path(text: str, base: Path, key: str) -> str:
    """``text`` as an absolute, normalised path (a relative one taken from ``base``)."""
    if not text.strip():
        raise InputError(f"{key}={text!r}: expected the path of a raster file")
    p = Path(text).expanduser()
    return os.path.normpath(p if p.is_absolute() else Path(base).absolute() / p)


def _stamp(path: str | None, key: str, given: str | None = None) -> tuple:
    """(size, mtime_ns) of a raster file, part of the cache keys; a missing file is an
    InputError naming ``key``."""
    if path is None:
        return ()
    try:
        st = os.stat(path)
    except OSError:
        raise InputError(f"{key}={show(given or path)}: no such file ({path})") from None
    if not Path(path).is_file():
        raise InputError(f"{key}={show(given or path)}: not a regular file ({path})")
    return (st.st_size, st.st_mtime_ns)


# ---- the section --------------------------------------------------------------------------------
def read_terrain(
    t: Table, domain: DomainConfig, source: str | None, zeta: float = 0.0, h_scale: float = 0.0
) -> TerrainConfig:
    """The ``[terrain]`` section; its bed is built once here, so that a shape outside the
    domain, a raster that falls short of it or a missing file is refused when the scene is
    read. ``zeta`` [rad]: the inclination above a run-out's bend; ``h_scale`` [m]: the
    scene's thickness scale, which the bend's curvature must keep small (`check_bend`)."""
    runout = None
    if t.has("runout"):
        sub = t.table("runout", key_names(RunoutConfig))
        runout = RunoutConfig(**read_section(RunoutConfig, sub))
        check_bend(runout, zeta, domain.Lx, h_scale)
    shapes = tuple(shapes_from_tables(t.get("shapes", []), prefix=t.full("shapes")))
    bed = read_key(t, field_named(TerrainConfig, "bed"))
    origin = {n: read_key(t, field_named(TerrainConfig, n)) for n in ("origin_x", "origin_y")}
    if bed is None:
        for n in origin:
            if t.has(n):
                raise InputError(
                    f"terrain.{n}={show(t.get(n))}: places the raster terrain.bed, which is "
                    "not given; give terrain.bed or remove the key"
                )
    else:
        given, bed = bed, absolute_path(bed, base_folder(source), "terrain.bed")
        _stamp(bed, "terrain.bed", given)
    terrain = TerrainConfig(shapes=shapes, bed=bed, runout=runout, **origin)
    if terrain.has_terrain:
        bed_arrays(terrain, domain)  # the checks
    return terrain


# the largest h kappa a run-out's bend takes: the model drops terms of higher order in the
# thickness over the radius of curvature (Gray, Wieland & Hutter 1999)
MAX_H_KAPPA = 0.1


def check_bend(runout: RunoutConfig, zeta: float, Lx: float, h: float) -> None:
    """A bend that stays short of vertical, starts inside the domain, and whose curvature is
    small against the thickness h [m]: h |kappa| <= MAX_H_KAPPA (one-line InputErrors)."""
    if not abs(runout.zeta_deg) < 90.0:
        raise InputError(
            f"terrain.runout.zeta_deg={runout.zeta_deg!r}: the bed would turn to or past "
            "vertical; give an inclination in (-90, 90) degrees"
        )
    if not runout.x < Lx:
        raise InputError(
            f"terrain.runout.x={runout.x!r}: the bend begins at or beyond the domain's end "
            f"(Lx = {Lx!r} m): nothing would bend"
        )
    kappa = abs(runout.curvature(zeta))
    if h * kappa > MAX_H_KAPPA:
        raise InputError(
            f"terrain.runout.length={runout.length!r}: the bend's curvature {kappa:.4g} 1/m "
            f"times the thickness {h:.4g} m is {h * kappa:.3g} > {MAX_H_KAPPA} (the model "
            "needs thin layers on gentle bends); make the bend longer"
        )


def terrain_to_dict(terrain: TerrainConfig) -> dict | None:
    """The section as TOML writes it: each shape a table with its kind first; the raster with
    its origin; the run-out's bend. None for a flat plane (no section is written)."""
    out: dict = {}
    if terrain.runout is not None:
        r = terrain.runout
        out["runout"] = {"x": r.x, "length": r.length, "zeta_deg": r.zeta_deg}
    if not terrain.has_terrain:
        return out or None
    if terrain.bed is not None:
        out.update(bed=terrain.bed, origin_x=terrain.origin_x, origin_y=terrain.origin_y)
    if terrain.shapes:
        out["shapes"] = [
            {"kind": s.kind, **{f.name: getattr(s, f.name) for f in dataclasses.fields(s)}}
            for s in terrain.shapes
        ]
    return out


# ---- the bed on the cells -----------------------------------------------------------------------
def _grid(domain: DomainConfig) -> tuple:
    return (domain.Lx, domain.Ly, domain.nx, domain.ny)


def bed_arrays(terrain: TerrainConfig, domain: DomainConfig) -> tuple[np.ndarray, np.ndarray]:
    """(b, solid) on the cell centres: b float64 (nx, ny) [m] normal to the reference plane,
    the bed shapes plus the raster, 0 in solid cells; solid bool (nx, ny), the solid shapes'
    cells and the raster's nodata. Zeros and no solid cell for a flat plane. The arrays are
    cached and read-only (copy to change them)."""
    stamp = _stamp(terrain.bed, "terrain.bed")
    return _bed_cached(terrain, _grid(domain), stamp)


@functools.lru_cache(maxsize=8)
def _bed_cached(terrain: TerrainConfig, grid: tuple, stamp: tuple):
    Lx, Ly, nx, ny = grid
    dom = DomainConfig(Lx=Lx, Ly=Ly, nx=nx, ny=ny)
    xc, yc = dom.cell_centres()
    b, solid = bed_on_grid(terrain.shapes, xc, yc)
    if terrain.bed is not None:
        where = f"terrain.bed={terrain.bed!r}"  # the whole path: show() would cut it
        try:
            rb, rsolid = resample(
                read_raster(terrain.bed), xc, yc, (terrain.origin_x, terrain.origin_y)
            )
        except InputError as exc:
            hint = (
                "; move it with terrain.origin_x, terrain.origin_y" if "cover" in str(exc) else ""
            )
            raise InputError(f"{where}: {exc}{hint}") from None
        b = b + rb
        solid = solid | rsolid
    b[solid] = 0.0  # a wall has no bed
    b.flags.writeable = False
    solid.flags.writeable = False
    return b, solid


def initial_thickness(initial: InitialConfig, domain: DomainConfig) -> np.ndarray:
    """The thickness of ``initial.kind = "file"`` on the cell centres, (nx, ny) [m]: the raster
    ``initial.path`` placed at (origin_x, origin_y), bilinear, 0 where it reaches nodata.
    Cached and read-only."""
    stamp = _stamp(initial.path, "initial.path")
    return _thickness_cached(
        initial.path, (initial.origin_x, initial.origin_y), _grid(domain), stamp
    )


@functools.lru_cache(maxsize=4)
def _thickness_cached(path: str, origin: tuple, grid: tuple, stamp: tuple) -> np.ndarray:
    Lx, Ly, nx, ny = grid
    xc, yc = DomainConfig(Lx=Lx, Ly=Ly, nx=nx, ny=ny).cell_centres()
    where = f"initial.path={path!r}"
    try:
        h, missing = resample(read_raster(path), xc, yc, origin)
    except InputError as exc:
        hint = "; move it with initial.origin_x, initial.origin_y" if "cover" in str(exc) else ""
        text = str(exc).replace("the terrain raster", "the raster")
        raise InputError(f"{where}: {text}{hint}") from None
    if np.any(h < 0):
        i, j = np.unravel_index(np.argmin(h), h.shape)
        raise InputError(
            f"{where}: a negative thickness {h[i, j]:.6g} m at x={xc[i]:.6g}, y={yc[j]:.6g} m; "
            "a thickness raster holds h >= 0 (nodata for none)"
        )
    h = np.where(missing, 0.0, h)
    h.flags.writeable = False
    return h


# ---- the initial kinds that read the bed --------------------------------------------------------
def check_initial(
    initial: InitialConfig, terrain: TerrainConfig, domain: DomainConfig, source: str | None
) -> InitialConfig:
    """The initial state with ``initial.path`` made absolute; a lake must hold material
    somewhere, a thickness file must cover the domain and hold h >= 0."""
    if initial.kind == "file":
        path = absolute_path(initial.path, base_folder(source), "initial.path")
        _stamp(path, "initial.path", initial.path)
        initial = dataclasses.replace(initial, path=path)
        if not np.any(initial_thickness(initial, domain) > 0):
            raise InputError(
                f"initial.path={initial.path!r}: the thickness is 0 on every cell "
                "(nothing to start from); check the raster and its origin"
            )
    elif initial.kind == "lake":
        b, solid = bed_arrays(terrain, domain)
        if not np.any((initial.level > b) & ~solid):
            low = float(b[~solid].min()) if (~solid).any() else float("nan")
            raise InputError(
                f"initial.level={initial.level!r}: the free surface lies at or below the bed "
                f"everywhere (the lowest bed is {low:.6g} m): the lake holds no material"
            )
    return initial


__all__ = [
    "absolute_path",
    "base_folder",
    "bed_arrays",
    "check_bend",
    "check_initial",
    "initial_thickness",
    "read_terrain",
    "terrain_to_dict",
]
