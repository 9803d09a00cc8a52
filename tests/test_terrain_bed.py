"""The bed from shapes and rasters (`tiseg.setup.terrain`, `tiseg.setup.rasters`), checked
against truths that do not come from the code: analytic volumes and areas, with bounds that
shrink with the cells; linear fields that bilinear interpolation must reproduce; raster files
written by hand; every bad input an InputError of one line that names its key."""

import math
import sys
import tomllib
import types
from fnmatch import fnmatch
from pathlib import Path

import netCDF4
import numpy as np
import pytest

from tiseg.data import TERRAIN_DIR
from tiseg.errors import InputError
from tiseg.setup.table import toml_float  # TOML's reading of a literal
from tiseg.output.ascii_grid import write_asc
from tiseg.setup.rasters import Raster, read_raster, resample
from tiseg.setup import terrain
from tiseg.setup.terrain import (
    SHAPE_KINDS,
    Cone,
    Cylinder,
    Gaussian,
    Shape,
    Wedge,
    bed_on_grid,
    shapes_from_tables,
)

ROOT = Path(__file__).resolve().parents[1]


def centres(n, L):
    return (np.arange(n) + 0.5) * (L / n)


def one_line_error(match, fn, *args, **kw):
    """``fn`` raises InputError (not another type) whose single-line message matches."""
    with pytest.raises(InputError, match=match) as info:
        fn(*args, **kw)
    assert "\n" not in str(info.value)
    return str(info.value)


# ---- shapes against analytic volumes and areas ----------------------------------------------------
def test_gaussian_volume_is_pi_r2_h_and_its_peak_its_height():
    R, H = 0.08, -0.003  # a hollow; the domain reaches 6 radii past it (e^-36 is nothing)
    xc, yc = centres(200, 1.0), centres(160, 0.96)
    b, solid = bed_on_grid([Gaussian(x=0.5025, y=0.483, radius=R, height=H)], xc, yc)
    assert b.dtype == np.float64 and b.shape == (200, 160) and solid.dtype == bool
    assert not solid.any()
    vol = b.sum() * (xc[1] - xc[0]) * (yc[1] - yc[0])
    assert vol == pytest.approx(math.pi * R**2 * H, rel=1e-10)
    assert b.min() == pytest.approx(H, rel=1e-12)  # the centre is a cell centre
    i, j = np.unravel_index(np.argmin(b), b.shape)
    assert (xc[i], yc[j]) == pytest.approx((0.5025, 0.483))


def test_cone_volume_converges_to_a_third_of_its_cylinder():
    R, H = 0.1, 0.004
    errors = []
    for n in (50, 100, 200, 400):
        xc = yc = centres(n, 1.0)
        b, _ = bed_on_grid([Cone(x=0.43, y=0.51, radius=R, height=H)], xc, yc)
        errors.append(abs(b.sum() / n**2 - math.pi * R**2 * H / 3) / (math.pi * R**2 * H / 3))
    assert errors[-1] < 1e-3 and errors[-1] < errors[0] / 4, errors
    assert b.max() <= H and b.min() == 0.0


@pytest.mark.parametrize("n", [(24, 20), (50, 37), (100, 81), (400, 330)])
def test_cylinder_cells_cover_pi_r2_within_a_bound_shrinking_with_the_cells(n):
    # the cells whose centre is inside lie within R + h and cover everything within R - h,
    # h the half-diagonal of a cell: pi (R - h)^2 <= N dA <= pi (R + h)^2
    nx, ny = n
    xc, yc = centres(nx, 1.0), centres(ny, 0.8)
    dx, dy = 1.0 / nx, 0.8 / ny
    R = 0.13
    b, solid = bed_on_grid([Cylinder(x=0.4871, y=0.3923, radius=R)], xc, yc)
    h = 0.5 * math.hypot(dx, dy)
    area = solid.sum() * dx * dy
    assert abs(area - math.pi * R**2) <= math.pi * (2 * R * h + h**2)
    assert not b.any()
    if nx == 400:
        assert abs(area / (math.pi * R**2) - 1) < 5e-3


@pytest.mark.parametrize("nx, ny", [(30, 26), (90, 70), (300, 250)])
@pytest.mark.parametrize("half_angle", [10.0, 35.0, 60.0])
def test_wedge_area_is_length2_tan_half_angle_within_a_steiner_bound(nx, ny, half_angle):
    # the union of cells whose centre lies in the triangle T is within h of T and holds all
    # of T further than h from its edge: |N dA - A| <= P h + pi h^2 (P the perimeter)
    L, t = 0.3, math.tan(math.radians(half_angle))
    xc, yc = centres(nx, 1.0), centres(ny, 1.0)
    dx, dy = 1.0 / nx, 1.0 / ny
    _, solid = bed_on_grid([Wedge(x=0.2113, y=0.5071, half_angle_deg=half_angle, length=L)], xc, yc)
    h = 0.5 * math.hypot(dx, dy)
    P = 2 * L / math.cos(math.radians(half_angle)) + 2 * L * t
    assert abs(solid.sum() * dx * dy - L**2 * t) <= P * h + math.pi * h**2
    # the apex is upslope: no solid cell before x, and the widest column is the last one
    xs = xc[np.any(solid, axis=1)]
    assert xs.min() >= 0.2113 and xs.max() <= 0.2113 + L
    assert solid[np.searchsorted(xc, xs.max())].sum() == solid.sum(axis=1).max()


def test_solid_cells_have_no_bed_and_bed_shapes_add_up():
    xc, yc = centres(60, 0.6), centres(40, 0.4)
    g = Gaussian(x=0.3, y=0.2, radius=0.05, height=0.002)
    c = Cone(x=0.3, y=0.2, radius=0.1, height=-0.001)
    post = Cylinder(x=0.3, y=0.2, radius=0.02)
    b1, _ = bed_on_grid([g], xc, yc)
    b2, _ = bed_on_grid([c], xc, yc)
    b, solid = bed_on_grid([g, post, c], xc, yc)
    assert solid.sum() > 0 and np.all(b[solid] == 0.0)
    np.testing.assert_allclose(b[~solid], (b1 + b2)[~solid], rtol=0, atol=1e-18)


# ---- reading [[terrain.shapes]] -------------------------------------------------------------------
def test_shapes_from_toml_tables():
    text = """
    [[terrain.shapes]]
    kind = "gaussian"
    x = 0.2
    y = 0.1
    radius = 0.03
    height = -0.002
    [[terrain.shapes]]
    kind = "wedge"
    x = 1
    y = 0.15
    half_angle_deg = 20
    length = 0.1
    """
    shapes = shapes_from_tables(tomllib.loads(text)["terrain"]["shapes"])
    assert shapes == [
        Gaussian(x=0.2, y=0.1, radius=0.03, height=-0.002),
        Wedge(x=1.0, y=0.15, half_angle_deg=20.0, length=0.1),
    ]
    assert isinstance(shapes[1].x, float)
    with pytest.raises(AttributeError):  # frozen
        shapes[0].radius = 1.0


GOOD = {"kind": "gaussian", "x": 0.1, "y": 0.1, "radius": 0.02, "height": 0.001}


@pytest.mark.parametrize(
    "table, match",
    [
        ({**GOOD, "radius": -1}, r"^terrain\.shapes\[2\]\.radius=-1: must be > 0$"),
        ({**GOOD, "radius": 0.0}, r"terrain\.shapes\[2\]\.radius=0\.0: must be > 0"),
        ({**GOOD, "x": "a"}, r"terrain\.shapes\[2\]\.x='a': expected a number"),
        ({**GOOD, "y": True}, r"terrain\.shapes\[2\]\.y=True: expected a number"),
        (
            {**GOOD, "height": float("nan")},
            r"terrain\.shapes\[2\]\.height=nan: must be a finite number",
        ),
        ({**GOOD, "radus": 1}, r"terrain\.shapes\[2\]\.radus: unknown key .*'radius'"),
        (
            {"kind": "gaussian", "x": 0, "y": 0},
            r"terrain\.shapes\[2\]: missing keys radius, height",
        ),
        ({"x": 0, "y": 0}, r"terrain\.shapes\[2\]\.kind is required"),
        ({"kind": "blob"}, r"terrain\.shapes\[2\]\.kind='blob': unknown shape; one of 'gaussian'"),
        ({"kind": 3}, r"terrain\.shapes\[2\]\.kind=3: unknown shape"),
        ("gaussian", r"terrain\.shapes\[2\]='gaussian': expected a table"),
        ({"kind": "cylinder", "x": 0, "y": 0, "radius": -0.5}, r"\[2\]\.radius=-0\.5: must be > 0"),
        ({"kind": "cone", "x": 0, "y": 0, "radius": 0, "height": 1}, r"\[2\]\.radius=0: must be"),
        (
            {"kind": "wedge", "x": 0, "y": 0, "half_angle_deg": 90, "length": 1},
            r"terrain\.shapes\[2\]\.half_angle_deg=90: must lie in \(0, 90\)",
        ),
        (
            {"kind": "wedge", "x": 0, "y": 0, "half_angle_deg": 0, "length": 1},
            r"\[2\]\.half_angle_deg=0: must lie in \(0, 90\)",
        ),
        (
            {"kind": "wedge", "x": 0, "y": 0, "half_angle_deg": 30, "length": -2},
            r"terrain\.shapes\[2\]\.length=-2: must be > 0",
        ),
        ({**GOOD, "radius": toml_float("1e-400")}, r"\[2\]\.radius=1e-400: smaller than"),
    ],
)
def test_bad_shape_tables_name_table_and_key(table, match):
    one_line_error(match, shapes_from_tables, [GOOD, GOOD, table])


def test_shapes_must_be_an_array_and_constructors_check_too():
    one_line_error(r"terrain\.shapes=.*expected an array of tables", shapes_from_tables, {})
    one_line_error(r"^gaussian\.radius=-1: must be > 0$", Gaussian, x=0, y=0, radius=-1, height=1)
    one_line_error(r"^cylinder\.x='1': expected a number", Cylinder, x="1", y=0, radius=1)


def test_a_registered_kind_is_read_and_built(monkeypatch):
    from dataclasses import dataclass
    from typing import ClassVar

    @dataclass(frozen=True)
    class Ridge(Shape):  # a bump constant along x
        kind: ClassVar[str] = "ridge"
        width: float
        height: float = 0.001

        def rules(self):
            return [("width", self.width > 0, "must be > 0")]

        def overlaps(self, box):
            return box[2] < self.y + self.width and self.y - self.width < box[3]

        def footprint(self, X, Y):
            return np.abs(Y - self.y) < self.width

        def bed(self, X, Y):
            return self.height * np.maximum(0.0, 1 - np.abs(Y - self.y) / self.width)

    monkeypatch.setattr(terrain, "SHAPE_KINDS", dict(SHAPE_KINDS))  # undone after the test
    assert terrain.register_shape(Ridge) is Ridge and terrain.SHAPE_KINDS["ridge"] is Ridge
    with pytest.raises(TypeError):
        terrain.register_shape(dict)
    (s,) = shapes_from_tables([{"kind": "ridge", "x": 0, "y": 0.2, "width": 0.1}])
    assert s.height == 0.001  # the default of a key not given
    b, _ = bed_on_grid([s], centres(10, 1.0), centres(40, 0.4))
    assert b.max() == pytest.approx(0.001 * (1 - 0.005 / 0.1)) and np.all(b[:, 0] == b[0, 0])
    one_line_error(
        r"terrain\.shapes\[0\]\.width=0: must be > 0",
        shapes_from_tables,
        [{"kind": "ridge", "x": 0, "y": 0, "width": 0}],
    )


@pytest.mark.parametrize(
    "shape",
    [
        Cylinder(x=1.2, y=0.2, radius=0.1),
        Cylinder(x=1.08, y=0.58, radius=0.1),  # its bounding box overlaps the corner, not it
        Wedge(x=-0.5, y=0.2, half_angle_deg=30, length=0.5),  # ends at the edge x = 0
        Wedge(x=0.5, y=0.9, half_angle_deg=10, length=0.3),
        Gaussian(x=-0.21, y=0.2, radius=0.05, height=0.01),  # over 4 radii away
        Cone(x=0.5, y=-0.1, radius=0.1, height=0.01),  # touches y = 0
    ],
)
def test_a_shape_outside_the_domain_is_refused(shape):
    xc, yc = centres(40, 1.0), centres(20, 0.5)
    one_line_error(
        r"^terrain\.shapes\[1\], .*lies outside the domain \[0, 1\] x \[0, 0\.5\]$",
        bed_on_grid,
        [Cone(x=0.5, y=0.25, radius=0.1, height=0.001), shape],
        xc,
        yc,
    )


def test_shapes_partly_inside_are_taken():
    xc, yc = centres(40, 1.0), centres(20, 0.5)
    _, solid = bed_on_grid([Wedge(x=-0.2, y=0.25, half_angle_deg=30, length=0.3)], xc, yc)
    assert solid[0].any() and not solid[5:].any()
    b, _ = bed_on_grid([Gaussian(x=-0.15, y=0.2, radius=0.05, height=0.01)], xc, yc)
    assert 0 < b.max() < 0.01 * math.exp(-9)


@pytest.mark.parametrize(
    "shape",
    [
        Cylinder(x=0.5, y=0.25, radius=0.005),  # between four centres, 0.0177 away
        Wedge(x=0.501, y=0.25, half_angle_deg=5, length=0.02),  # between two rows
        Cone(x=0.5, y=0.25, radius=0.01, height=0.001),
    ],
)
def test_a_shape_between_cell_centres_says_the_grid_is_too_coarse(shape):
    msg = one_line_error(
        r"^terrain\.shapes\[0\], .*covers no cell centre: the grid \(dx = 0\.025 m, "
        r"dy = 0\.025 m\) is too coarse",
        bed_on_grid,
        [shape],
        centres(40, 1.0),
        centres(20, 0.5),
    )
    assert shape.kind in msg


# ---- rasters: files -------------------------------------------------------------------------------
def test_asc_round_trip_keeps_every_bit_and_the_nodata(tmp_path):
    rng = np.random.default_rng(3)
    v = rng.normal(size=(7, 4)) * 1e-3
    v[2, 3] = v[0, 0] = np.nan
    # values (ny, nx) for the writer, [x, y] in the Raster
    write_asc(tmp_path / "r.asc", v.T, corner=(12.5, -3.25), dx=0.04, nodata=-1)
    r = read_raster(tmp_path / "r.asc")
    assert (r.x0, r.y0, r.dx, r.dy) == (12.5, -3.25, 0.04, 0.04)
    np.testing.assert_array_equal(r.values, v)  # NaN where v is NaN
    np.testing.assert_array_equal(r.nodata, np.isnan(v))
    assert "NODATA_value  -1" in (tmp_path / "r.asc").read_text()
    one_line_error(
        "equals NODATA_value -1",
        write_asc,
        tmp_path / "s.asc",
        -np.ones((2, 2)),
        corner=(0, 0),
        dx=1,
        nodata=-1,
    )


def test_asc_rows_run_north_to_south(tmp_path):
    # written by hand: the first data row is the top (largest y); 5 is the north-east corner
    (tmp_path / "ne.asc").write_text(
        "NCOLS 3\nNROWS 2\nXLLCENTER 0.05\nYLLCENTER 0.05\nCELLSIZE 0.1\nNODATA_VALUE -9999\n"
        "0 0 5\n-9999 0 0\n"
    )
    r = read_raster(tmp_path / "ne.asc")
    assert r.shape == (3, 2) and r.values[2, 1] == 5.0 and (r.x0, r.y0) == (0.0, 0.0)
    assert r.nodata[0, 0] and r.nodata.sum() == 1  # the south-west corner
    x, y = r.centres()
    np.testing.assert_allclose(x, [0.05, 0.15, 0.25]) and np.testing.assert_allclose(
        y, [0.05, 0.15]
    )
    # on a domain of 0.3 x 0.2 the 5 lands at large x, large y, the nodata at small x, small y
    b, solid = resample(r, centres(6, 0.3), centres(4, 0.2))
    i, j = np.unravel_index(np.argmax(b), b.shape)
    assert (i, j) == (5, 3) and b[5, 3] == 5.0
    assert solid[0, 0] and not solid[-1, -1]


def test_asc_reads_the_peak_grids_tiseg_writes(tmp_path):
    m = np.arange(6.0).reshape(2, 3)  # (ny, nx), non-square cells: GDAL's dx and dy lines
    write_asc(tmp_path / "h_max.asc", m, [0.01, 0.03, 0.05], [0.015, 0.045])
    r = read_raster(tmp_path / "h_max.asc")
    assert (r.dx, r.dy) == pytest.approx((0.02, 0.03)) and (r.x0, r.y0) == (0.0, 0.0)
    np.testing.assert_array_equal(r.values, m.T)


HEAD = "ncols 2\nnrows 2\nxllcorner 0\nyllcorner 0\ncellsize 1\n"


@pytest.mark.parametrize(
    "text, match",
    [
        (HEAD + "1 2 3\n", r"3 values, expected nrows x ncols = 2 x 2 = 4"),
        (HEAD + "1 2\n3 4 5\n", r"5 values, expected"),
        (HEAD + "1 2\n3 x\n", r"value 'x' \(data row 2, column 2\) is not a number"),
        (HEAD.replace("cellsize 1", "cellsize one") + "1 2\n3 4\n", r"line 5: cellsize 'one'"),
        (HEAD.replace("cellsize 1", "cellsize -1") + "1 2\n3 4\n", r"cell size -1 x -1"),
        (HEAD.replace("cellsize 1\n", "") + "1 2\n3 4\n", r"header needs cellsize"),
        (HEAD.replace("ncols 2\n", "") + "1 2\n3 4\n", r"header needs ncols"),
        (HEAD.replace("ncols 2", "ncols 2.5") + "1 2\n3 4\n", r"ncols '2\.5' is not an integer"),
        (HEAD + "xllcenter 0\n1 2\n3 4\n", r"one of xllcorner, xllcenter"),
        (HEAD + "cellsise 1\n1 2\n3 4\n", r"line 6: unknown header keyword 'cellsise'"),
        (HEAD + "1 2\n3 inf\n", r"an infinite value"),
        ("", r"header needs ncols"),
    ],
)
def test_malformed_asc_is_one_line_naming_the_file(tmp_path, text, match):
    (tmp_path / "bad.asc").write_text(text)
    msg = one_line_error(match, read_raster, tmp_path / "bad.asc")
    assert msg.startswith(str(tmp_path / "bad.asc"))


def test_unknown_suffix_missing_file_and_binary_junk(tmp_path):
    one_line_error(r"unknown raster format '\.xyz'; known: \.asc", read_raster, tmp_path / "a.xyz")
    one_line_error(r"no such file", read_raster, tmp_path / "none.asc")
    (tmp_path / "junk.asc").write_bytes(b"\x89PNG\xff\x00")
    one_line_error(r"not an ESRI ASCII grid", read_raster, tmp_path / "junk.asc")
    (tmp_path / "junk.nc").write_text("not netcdf")
    one_line_error(r"junk\.nc: not a readable NetCDF file", read_raster, tmp_path / "junk.nc")


def _nc(path, b, x, y, dims=("y", "x"), units="m"):
    with netCDF4.Dataset(path, "w") as ds:
        ds.createDimension("x", len(x))
        ds.createDimension("y", len(y))
        for name, c in (("x", x), ("y", y)):
            v = ds.createVariable(name, "f8", (name,))
            v[:] = c
            v.units = units
        v = ds.createVariable("b", "f8", dims, fill_value=-1e30)
        v.units = "m"
        v[:] = b


def test_netcdf_reader_orients_by_dimension_names_and_masks_fill(tmp_path):
    x = 10.0 + 0.02 * np.arange(5)  # centres
    y = (0.03 * np.arange(3))[::-1]  # decreasing, as a north-up image
    X, Y = np.meshgrid(x, y, indexing="xy")  # (ny, nx)
    b = np.ma.masked_array(X + 100 * Y, mask=np.zeros_like(X, dtype=bool))
    b.mask[0, 4] = True  # y largest, x largest
    _nc(tmp_path / "b.nc", b, x, y)
    r = read_raster(tmp_path / "b.nc")
    assert r.shape == (5, 3) and (r.dx, r.dy) == pytest.approx((0.02, 0.03))
    assert (r.x0, r.y0) == pytest.approx((9.99, -0.015))
    xc, yc = r.centres()
    Xc, Yc = np.meshgrid(xc, yc, indexing="ij")
    ok = ~r.nodata
    np.testing.assert_allclose(r.values[ok], (Xc + 100 * Yc)[ok], rtol=1e-14)
    assert r.nodata[4, 2] and r.nodata.sum() == 1
    # (x, y) order, x decreasing: the same raster
    _nc(tmp_path / "t.nc", (X + 100 * Y).T[::-1], x[::-1], y, dims=("x", "y"))
    t = read_raster(tmp_path / "t.nc")
    assert (t.x0, t.y0) == pytest.approx((9.99, -0.015))
    np.testing.assert_allclose(t.values, Xc + 100 * Yc, rtol=1e-14)


def test_netcdf_errors(tmp_path):
    x, y = np.arange(3.0), np.arange(2.0)
    _nc(tmp_path / "km.nc", np.zeros((2, 3)), x, y, units="km")
    one_line_error(
        r"coordinate x is in 'km'; terrain rasters are in metres", read_raster, tmp_path / "km.nc"
    )
    _nc(tmp_path / "uneven.nc", np.zeros((2, 3)), np.array([0.0, 1.0, 3.0]), y)
    one_line_error(r"coordinate x is not evenly spaced", read_raster, tmp_path / "uneven.nc")
    with netCDF4.Dataset(tmp_path / "nob.nc", "w") as ds:
        ds.createDimension("x", 3)
        ds.createVariable("h", "f8", ("x",))
    one_line_error(
        r"no variable 'b' \(the bed height\); variables: h", read_raster, tmp_path / "nob.nc"
    )


class _FakeDataset:
    """What read_geotiff uses of a rasterio dataset: a north-up 3 x 2 image."""

    transform = types.SimpleNamespace(a=0.5, b=0.0, c=100.0, d=0.0, e=-0.25, f=20.0)
    crs = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False

    def read(self, band, masked=False):
        a = np.ma.masked_array([[1.0, 2.0, 7.0], [4.0, 5.0, 6.0]])  # rows top first
        a[1, 0] = np.ma.masked  # the bottom-left (south-west) cell
        return a


def test_geotiff_without_rasterio_says_how_to_get_it(tmp_path, monkeypatch):
    (tmp_path / "dem.tif").write_bytes(b"II*\x00")
    monkeypatch.setitem(sys.modules, "rasterio", None)  # `import rasterio` raises ImportError
    one_line_error(
        r'needs rasterio: pip install "tiseg\[terrain\]"', read_raster, tmp_path / "dem.tif"
    )


def test_geotiff_north_up_lands_with_north_at_large_y(tmp_path, monkeypatch):
    fake = types.ModuleType("rasterio")
    fake.open = lambda path: _FakeDataset()
    monkeypatch.setitem(sys.modules, "rasterio", fake)
    (tmp_path / "dem.tif").write_bytes(b"II*\x00")
    r = read_raster(tmp_path / "dem.tif")
    assert (r.x0, r.y0, r.dx, r.dy) == (100.0, 19.5, 0.5, 0.25)
    assert r.values[2, 1] == 7.0 and r.values[0, 1] == 1.0  # the top row is y index 1
    assert r.nodata[0, 0] and r.nodata.sum() == 1


# ---- rasters onto the grid ------------------------------------------------------------------------
@pytest.mark.parametrize(
    "grid, raster, origin",
    [
        ((37, 23, 0.74, 0.46), (11, 7, 0.07, 0.07, 0.0, 0.0), (0.0, 0.0)),  # coarser
        ((20, 12, 0.5, 0.3), (123, 77, 0.0041, 0.0039, -0.003, -0.0012), (0.0, 0.0)),  # finer
        ((16, 9, 1.6, 0.9), (9, 6, 0.2, 0.16, 503.0, 1004.0), (-503.0, -1004.0)),  # map origin
        ((1, 40, 0.01, 0.4), (2, 9, 0.01, 0.05, 0.0, -0.01), (0.0, 0.01)),  # one cell in x
    ],
)
def test_bilinear_reproduces_a_linear_field_to_round_off_and_holds_it_at_the_edge(
    grid, raster, origin
):
    nx, ny, Lx, Ly = grid
    mx, my, dx, dy, x0, y0 = raster
    a, c, d = 0.3, -0.7, 1.9
    xr = x0 + origin[0] + (np.arange(mx) + 0.5) * dx  # raster centres in the domain's frame
    yr = y0 + origin[1] + (np.arange(my) + 0.5) * dy
    r = Raster(a + c * xr[:, None] + d * yr[None, :], x0, y0, dx, dy)
    xc, yc = centres(nx, Lx), centres(ny, Ly)
    b, solid = resample(r, xc, yc, origin=origin)
    assert b.shape == (nx, ny) and b.dtype == np.float64 and not solid.any()
    exact = a + c * xc[:, None] + d * yc[None, :]
    inside = (xc >= xr[0]) & (xc <= xr[-1]), (yc >= yr[0]) & (yc <= yr[-1])
    np.testing.assert_allclose(b[np.ix_(*inside)], exact[np.ix_(*inside)], rtol=0, atol=1e-13)
    # beyond the outer centres (the raster's outer half-cell) the edge value holds
    xe, ye = np.clip(xc, xr[0], xr[-1]), np.clip(yc, yr[0], yr[-1])
    np.testing.assert_allclose(b, a + c * xe[:, None] + d * ye[None, :], rtol=0, atol=1e-13)


def test_nodata_is_solid_where_a_stencil_weight_reaches_it():
    dx = dy = 0.1
    v = np.ones((8, 6))
    v[3, 2] = np.nan
    r = Raster(v, 0.0, 0.0, dx, dy)
    # on the raster's own cells the stencil weights of neighbours are 0: only that cell
    b, solid = resample(r, centres(8, 0.8), centres(6, 0.6))
    np.testing.assert_array_equal(solid, np.isnan(v))
    assert b[3, 2] == 0.0 and np.all(b[~solid] == 1.0)
    # on a finer grid: solid exactly where the node's bilinear hat is non-zero
    xc, yc = centres(32, 0.8), centres(30, 0.6)
    b, solid = resample(r, xc, yc)
    hat = (np.abs(xc - 0.35)[:, None] < dx) & (np.abs(yc - 0.25)[None, :] < dy)
    np.testing.assert_array_equal(solid, hat)
    assert np.all(b[solid] == 0.0) and np.allclose(b[~solid], 1.0, rtol=0, atol=1e-15)


@pytest.mark.parametrize(
    "origin, match",
    [
        ((0.012, 0.0), r"falls short on the upslope side x_lo by 0\.0095 m"),
        ((-0.02, 0.0), r"falls short on the downslope side x_hi by 0\.0175 m"),
        ((0.0, -0.05), r"falls short on the cross-slope side y_hi by 0\.0475 m"),
        ((0.01, 0.01), r"x_lo by 0\.0075 m; cross-slope side y_lo by 0\.0075 m"),
    ],
)
def test_a_raster_short_of_the_domain_says_which_side_and_how_much(origin, match):
    r = Raster(np.zeros((10, 6)), 0.0, 0.0, 0.05, 0.05)  # 0.5 x 0.3
    one_line_error(match, resample, r, centres(100, 0.5), centres(60, 0.3), origin=origin)


def test_a_raster_exactly_the_domain_covers_it_at_any_resolution():
    r = Raster(np.zeros((10, 6)), 0.0, 0.0, 0.05, 0.05)
    for n in (7, 10, 100, 333):
        b, solid = resample(r, centres(n, 0.5), centres(n, 0.3))
        assert not solid.any() and not b.any()


# ---- the example DEM --------------------------------------------------------------------------------
def example_dem() -> np.ndarray:
    """The shipped example: 0.5 m x 0.3 m at 5 mm cells, a channel 2 mm deep along y = 0.15
    and a hollow 3 mm deeper at x = 0.3 (slopes below 0.07), to 0.01 mm."""
    d = 0.005
    X, Y = np.meshgrid((np.arange(100) + 0.5) * d, (np.arange(60) + 0.5) * d, indexing="ij")
    b = -0.002 * np.exp(-(((Y - 0.15) / 0.03) ** 2))
    b -= 0.003 * np.exp(-((X - 0.3) ** 2 + (Y - 0.15) ** 2) / 0.04**2)
    return np.round(b, 5) + 0.0  # + 0.0: no "-0"


def test_the_example_dem_is_shipped_small_and_as_documented(tmp_path):
    path = TERRAIN_DIR / "channel-hollow.asc"
    assert path.stat().st_size < 50_000
    again = tmp_path / "again.asc"  # the one writer, values (ny, nx), 10 digits, -9999 as is
    write_asc(again, example_dem().T, corner=(0.0, 0.0), dx=0.005, nodata=-9999, fmt="%.10g")
    assert again.read_bytes() == path.read_bytes()
    r = read_raster(path)
    assert r.shape == (100, 60) and r.x0 + 100 * r.dx == pytest.approx(0.5)
    b, solid = resample(r, centres(200, 0.5), centres(120, 0.3))
    assert not solid.any() and b.min() == pytest.approx(-0.005, abs=2e-4)
    # package data: pyproject's globs for tiseg.data take it into the wheel
    globs = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"][
        "package-data"
    ]["tiseg.data"]
    rel = path.relative_to(Path(TERRAIN_DIR).parent).as_posix()
    assert any(fnmatch(rel, g) for g in globs), (rel, globs)
