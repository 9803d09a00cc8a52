"""The ``[terrain]`` section of a scene (`tiseg.setup.bed`): each key read, checked, written back
and read equal; the bed on the cells against `tiseg.setup.terrain.bed_on_grid` and the raster
resampling; the initial kinds that read it (lake, file, a layer that follows the bed); the
static b and solid of fields.nc; the relief under the pictures' colours.

The solver does not use b yet: a terrain scene runs here with the flat solver, which is enough
for what the run folder writes."""

import json
import os
import tomllib

import netCDF4
import numpy as np
import pytest

from tiseg.errors import InputError
from tiseg.output.ascii_grid import write_asc
from tiseg.output.fields import OUTPUT_FIELDS, static_fields
from tiseg.output.netcdf import FieldsWriter
from tiseg.setup.initial import initial_state
from tiseg.setup.json_schema import scene_schema
from tiseg.setup.rasters import read_raster, resample
from tiseg.setup.reading import load_scene, scene_from_dict, scene_from_text
from tiseg.setup.reference import markdown
from tiseg.setup.terrain import Cone, Cylinder, Gaussian, Wedge, bed_on_grid
from tiseg.solver.numerics.config import Layout

# a small 2D chute at rest: 60 x 20 cells of 5 mm, flat, frictionless, no inflow
BASE = {
    "material": {"zeta_deg": 0.0},
    "flow": {"h0": 0.002, "nu": 0.0},
    "effects": {"segregation": False, "viscosity": False, "friction": "none"},
    "domain": {"Lx": 0.3, "Ly": 0.1, "nx": 60, "ny": 20},
    "boundary": {"x_lo": "outflow", "x_hi": "outflow", "y_lo": "wall", "y_hi": "wall"},
    "initial": {"kind": "layer", "layer_h": 0.001},
    "time": {"t_end": 0.01},
    "output": {"interval": 0.005, "peak_fields": False},
}
SHAPES = [
    {"kind": "gaussian", "x": 0.1, "y": 0.05, "radius": 0.02, "height": 0.003},
    {"kind": "cone", "x": 0.2, "y": 0.03, "radius": 0.015, "height": -0.002},
    {"kind": "cylinder", "x": 0.15, "y": 0.07, "radius": 0.012},
    {"kind": "wedge", "x": 0.22, "y": 0.07, "half_angle_deg": 30, "length": 0.04},
]


def scene(terrain=None, initial=None, source=None, **sections):
    data = json.loads(json.dumps(BASE))  # a deep copy
    if terrain is not None:
        data["terrain"] = terrain
    if initial is not None:
        data["initial"] = initial
    data.update(sections)
    return scene_from_dict(data, name="t", source=source)


def one_line(match, fn, *args, **kw):
    with pytest.raises(InputError, match=match) as info:
        fn(*args, **kw)
    assert "\n" not in str(info.value)
    return str(info.value)


def ramp_asc(path, x0=0.0, y0=0.0, nx=40, ny=14, d=0.01, slope=0.01, nodata=None):
    """A raster b = slope * x (x of the raster's own cell centres), (ny, nx) as written."""
    xc = x0 + (np.arange(nx) + 0.5) * d
    values = np.tile(slope * (xc - x0), (ny, 1))
    if nodata is not None:
        values[nodata] = np.nan
    return write_asc(path, values, corner=(x0, y0), dx=d)


# ---- the section: read, written back, read equal ---------------------------------------------
def test_no_section_is_the_flat_plane_and_writes_nothing():
    sc = scene()
    assert not sc.has_terrain and not sc.terrain.shapes and sc.terrain.bed is None
    assert "terrain" not in sc.to_dict()
    b, solid = sc.bed_arrays()
    assert b.shape == solid.shape == (60, 20) and not b.any() and not solid.any()
    assert static_fields(sc) == {}


def test_shapes_are_read_as_the_kinds_dataclasses_and_written_back_equal():
    sc = scene({"shapes": SHAPES})
    assert sc.has_terrain
    assert sc.terrain.shapes == (
        Gaussian(x=0.1, y=0.05, radius=0.02, height=0.003),
        Cone(x=0.2, y=0.03, radius=0.015, height=-0.002),
        Cylinder(x=0.15, y=0.07, radius=0.012),
        Wedge(x=0.22, y=0.07, half_angle_deg=30.0, length=0.04),
    )
    hash(sc)  # the scene stays hashable
    written = sc.to_dict()["terrain"]
    assert written == {
        "shapes": [{k: float(v) if k != "kind" else v for k, v in t.items()} for t in SHAPES]
    }
    again = scene_from_text(sc.to_toml())
    assert again == sc and again.terrain == sc.terrain


def test_bed_arrays_are_those_of_bed_on_grid_and_cached_read_only():
    sc = scene({"shapes": SHAPES})
    xc, yc = sc.domain.cell_centres()
    b0, s0 = bed_on_grid(sc.terrain.shapes, xc, yc)
    b, solid = sc.bed_arrays()
    assert b.dtype == np.float64 and solid.dtype == bool and b.shape == (60, 20)
    np.testing.assert_array_equal(b, b0)
    np.testing.assert_array_equal(solid, s0)
    assert solid.any() and b.max() > 0 and b.min() < 0 and not b[solid].any()
    assert sc.bed_arrays()[0] is b  # cached
    with pytest.raises(ValueError):
        b[0, 0] = 1.0


def test_a_raster_bed_adds_to_the_shapes_with_its_origin_and_nodata_is_solid(tmp_path):
    nodata = (slice(0, 2), slice(30, 34))  # rows at the largest y (north first), near x 0.3
    ramp_asc(tmp_path / "bed.asc", x0=-0.05, y0=-0.02, nodata=nodata)
    terrain = {"bed": "bed.asc", "origin_x": 0.01, "origin_y": 0.0, "shapes": SHAPES[:1]}
    sc = scene(terrain, source=str(tmp_path / "scene.toml"))
    assert sc.terrain.bed == str(tmp_path / "bed.asc")  # made absolute, from the scene's folder
    xc, yc = sc.domain.cell_centres()
    rb, rsolid = resample(read_raster(tmp_path / "bed.asc"), xc, yc, (0.01, 0.0))
    sb, _ = bed_on_grid(sc.terrain.shapes, xc, yc)
    b, solid = sc.bed_arrays()
    np.testing.assert_array_equal(solid, rsolid)
    assert solid.any()
    np.testing.assert_array_equal(b, np.where(solid, 0.0, sb + rb))
    # the written scene loads from anywhere: the path it writes is absolute
    written = sc.to_dict()["terrain"]
    assert written["bed"] == str(tmp_path / "bed.asc") and written["origin_x"] == 0.01
    (tmp_path / "elsewhere").mkdir()
    (tmp_path / "elsewhere" / "scene.toml").write_text(sc.to_toml(), encoding="utf-8")
    assert load_scene(tmp_path / "elsewhere" / "scene.toml") == sc


def test_a_relative_bed_of_a_scene_from_no_file_is_taken_from_the_current_folder(
    tmp_path, monkeypatch
):
    ramp_asc(tmp_path / "bed.asc", x0=-0.05, y0=-0.02)
    monkeypatch.chdir(tmp_path)
    sc = scene({"bed": "bed.asc"})
    assert sc.terrain.bed == os.path.join(str(tmp_path), "bed.asc")
    # an override on the resolved scene keeps it
    assert sc.with_overrides({"time.t_end": 0.02}).terrain == sc.terrain


@pytest.mark.parametrize(
    "terrain, match",
    [
        (
            {"shapes": [{"kind": "gaussian", "x": 0.1, "y": 0.05, "radius": 0}]},
            r"terrain\.shapes\[0\]: missing key height",
        ),
        (
            {"shapes": [SHAPES[0], {**SHAPES[2], "radius": -1}]},
            r"terrain\.shapes\[1\]\.radius=-1: must be > 0",
        ),
        (
            {"shapes": [{**SHAPES[3], "half_angle_deg": 95}]},
            r"terrain\.shapes\[0\]\.half_angle_deg=95",
        ),
        (
            {"shapes": [{**SHAPES[0], "hieght": 1}]},
            r"terrain\.shapes\[0\]\.hieght: unknown key.*did you mean 'height'",
        ),
        (
            {"shapes": [{**SHAPES[0], "kind": "dome"}]},
            r"terrain\.shapes\[0\]\.kind='dome': unknown shape",
        ),
        ({"shapes": [{**SHAPES[0], "x": "a"}]}, r"terrain\.shapes\[0\]\.x='a': expected a number"),
        (
            {"shapes": [{**SHAPES[0], "x": 2.0}]},
            r"terrain\.shapes\[0\], gaussian .* lies outside the domain",
        ),
        (
            {"shapes": [{**SHAPES[2], "radius": 0.001}]},
            r"terrain\.shapes\[0\], cylinder .* covers no cell centre",
        ),
        ({"shapes": 3}, r"terrain\.shapes=3: expected an array of tables"),
        ({"bed": 3}, r"terrain\.bed=3: expected a string"),
        ({"bed": "nowhere.asc"}, r"terrain\.bed='nowhere\.asc': no such file"),
        (
            {"origin_x": 0.1},
            r"terrain\.origin_x=0\.1: places the raster terrain\.bed, which is not given",
        ),
        ({"origin": 0.1}, r"unknown key 'terrain\.origin'"),
    ],
)
def test_bad_terrain_is_one_line_naming_the_key(terrain, match):
    one_line(match, scene, terrain)


def test_a_raster_short_of_the_domain_names_the_key_and_the_side(tmp_path):
    ramp_asc(tmp_path / "bed.asc", x0=0.0, y0=0.0, nx=20)  # 0.2 m of the 0.3 m chute
    msg = one_line(
        r"terrain\.bed='.*bed\.asc': .*falls short on the downslope side x_hi",
        scene,
        {"bed": "bed.asc"},
        source=str(tmp_path / "s.toml"),
    )
    assert "terrain.origin_x" in msg
    one_line(
        r"terrain\.origin_y=.*expected a number",
        scene,
        {"bed": "bed.asc", "origin_y": "1"},
        source=str(tmp_path / "s.toml"),
    )


def test_the_reference_page_and_the_json_schema_show_the_section():
    page = markdown()
    assert "## `[terrain]`" in page
    for k in ("shapes", "bed", "runout", "origin_x", "origin_y"):
        assert f"| `{k}` |" in page
    for k in ("level", "path"):
        assert f"| `{k}` |" in page
    schema = scene_schema()["properties"]["terrain"]
    assert list(schema["properties"]) == ["shapes", "bed", "runout", "origin_x", "origin_y"]
    runout = schema["properties"]["runout"]
    assert set(runout["properties"]) == {"x", "length", "zeta_deg"}
    item = schema["properties"]["shapes"]["items"]
    assert item["properties"]["kind"]["enum"][:4] == ["gaussian", "cone", "cylinder", "wedge"]
    assert {"radius", "height", "half_angle_deg", "length"} <= set(item["properties"])
    assert scene_schema()["properties"]["initial"]["properties"]["kind"]["enum"][-2:] == [
        "lake",
        "file",
    ]


# ---- the initial kinds ------------------------------------------------------------------------
def interior_h(sc):
    lay = Layout(sc.domain.nx, sc.domain.ny, bool(sc.segregation))
    q = initial_state(sc, lay)
    ix, iy = lay.interior()
    return q[lay.H][ix, iy], q, lay


def test_lake_is_level_minus_bed_exactly_and_empty_in_solid_cells():
    level = 0.0015
    sc = scene({"shapes": SHAPES}, {"kind": "lake", "level": level})
    b, solid = sc.bed_arrays()
    h, q, lay = interior_h(sc)
    expected = np.where(solid, 0.0, np.maximum(level - b, 0.0))
    np.testing.assert_array_equal(h, expected)  # bit for bit
    assert (h == 0).any() and (h > 0).any() and not h[solid].any()
    assert not q[lay.HU].any() and not q[lay.HV].any()  # at rest
    # the free surface is flat wherever there is material
    wet = h > 0
    np.testing.assert_allclose((h + b)[wet], level, rtol=1e-15)
    assert sc.to_dict()["initial"] == {"kind": "lake", "level": level, "phi": sc.flow.phi0}
    assert scene_from_text(sc.to_toml()) == sc


def test_lake_needs_a_level_and_material():
    one_line(r"initial\.level is required", scene, {"shapes": SHAPES}, {"kind": "lake"})
    one_line(
        r"initial\.level=-0\.01: the free surface lies at or below the bed everywhere",
        scene,
        {"shapes": SHAPES},
        {"kind": "lake", "level": -0.01},
    )
    one_line(r"initial\.level='a'", scene, None, {"kind": "lake", "level": "a"})
    one_line(
        r"initial\.path is not used by initial\.kind='lake'",
        scene,
        None,
        {"kind": "lake", "level": 1e-3, "path": "x"},
    )


def test_a_layer_follows_the_bed_and_leaves_the_walls_empty():
    sc = scene({"shapes": SHAPES}, {"kind": "layer", "layer_h": 0.001})
    _, solid = sc.bed_arrays()
    h, _, _ = interior_h(sc)
    np.testing.assert_array_equal(h, np.where(solid, 0.0, 0.001))
    flat, _, _ = interior_h(scene(None, {"kind": "layer", "layer_h": 0.001}))
    assert (flat == 0.001).all()


def test_any_kind_leaves_the_walls_empty():
    sc = scene({"shapes": SHAPES}, {"kind": "dam-break", "x0": 0.2, "h_left": 0.002})
    _, solid = sc.bed_arrays()
    h, _, _ = interior_h(sc)
    assert solid[:40].any() and not h[solid].any() and (h[:40][~solid[:40]] == 0.002).all()


def test_file_kind_reads_a_thickness_raster_at_rest(tmp_path):
    d = 0.005
    values = np.zeros((20, 60))  # (ny, nx) as written: the domain's own cells
    values[5:15, 10:30] = 0.002
    values[0, :] = np.nan  # nodata: no material
    values[19, :] = 0.001
    write_asc(tmp_path / "h0.asc", values, corner=(0.0, 0.0), dx=d)
    sc = scene(None, {"kind": "file", "path": "h0.asc"}, source=str(tmp_path / "s.toml"))
    assert sc.initial.path == str(tmp_path / "h0.asc")
    assert sc.initial.phi == sc.flow.phi0 and sc.initial.origin_x == 0.0
    h, q, lay = interior_h(sc)
    expected = np.nan_to_num(values).T  # (ny, nx), row 0 at y = dy/2, as write_asc takes it
    np.testing.assert_allclose(h, expected, rtol=0, atol=1e-15)
    assert not q[lay.HU].any()
    assert scene_from_text(sc.to_toml()) == sc
    # shifted by an origin: a raster that then falls short says so, naming the key
    one_line(
        r"initial\.path='.*h0\.asc': .*falls short.*initial\.origin_x",
        scene,
        None,
        {"kind": "file", "path": "h0.asc", "origin_x": 0.01},
        source=str(tmp_path / "s.toml"),
    )


def test_file_kind_refuses_negative_or_empty_or_missing(tmp_path):
    src = str(tmp_path / "s.toml")
    bad = np.full((20, 60), 0.001)
    bad[3, 4] = -0.5
    write_asc(tmp_path / "neg.asc", bad, corner=(0.0, 0.0), dx=0.005)
    one_line(
        r"initial\.path='.*neg\.asc': a negative thickness -0\.5",
        scene,
        None,
        {"kind": "file", "path": "neg.asc"},
        source=src,
    )
    write_asc(tmp_path / "zero.asc", np.zeros((20, 60)), corner=(0.0, 0.0), dx=0.005)
    one_line(
        r"initial\.path='.*zero\.asc': the thickness is 0 on every cell",
        scene,
        None,
        {"kind": "file", "path": "zero.asc"},
        source=src,
    )
    one_line(
        r"initial\.path='gone\.asc': no such file",
        scene,
        None,
        {"kind": "file", "path": "gone.asc"},
        source=src,
    )
    one_line(r"initial\.path is required", scene, None, {"kind": "file"}, source=src)


# ---- fields.nc -------------------------------------------------------------------------------
def test_static_specs_and_their_attributes():
    for name in ("b", "solid"):
        assert OUTPUT_FIELDS[name].kind == "static"
    assert OUTPUT_FIELDS["b"].attrs["units"] == "m"
    assert OUTPUT_FIELDS["b"].attrs["long_name"] == "bed height normal to the reference plane"
    sc = scene({"shapes": SHAPES})
    got = static_fields(sc)
    b, solid = sc.bed_arrays()
    np.testing.assert_array_equal(got["b"], b.T)
    np.testing.assert_array_equal(got["solid"], solid.T.astype("i1"))


def test_a_truncated_file_keeps_its_static_fields(tmp_path):
    sc = scene({"shapes": SHAPES})
    x, y = sc.domain.cell_centres()
    path = tmp_path / "fields.nc"
    with FieldsWriter(path, x, y, fields=("h", "u", "v")) as w:
        w.write_fixed(**static_fields(sc))
        for t in (0.0, 1.0, 2.0):
            w.write(t, **{n: np.full((20, 60), t) for n in ("h", "u", "v")})
    w = FieldsWriter.append(path, keep=2)
    w.close()
    with netCDF4.Dataset(path) as ds:
        assert ds.dimensions["time"].size == 2
        np.testing.assert_array_equal(ds["b"][...], sc.bed_arrays()[0].T)
        np.testing.assert_array_equal(ds["solid"][...], sc.bed_arrays()[1].T.astype("i1"))
        assert ds["b"].long_name == "bed height normal to the reference plane"


def test_a_terrain_run_writes_b_and_solid_once_and_a_flat_run_neither(ti_cpu, tmp_path):
    from tiseg.run.simulation import Simulation

    sc = scene({"shapes": SHAPES}, {"kind": "lake", "level": 0.0015})
    sim = Simulation.from_scene(sc)  # the flat solver for now: b is not in the kernels yet
    sim.run(out_dir=tmp_path / "terrain", progress=False)
    b, solid = sc.bed_arrays()
    with netCDF4.Dataset(tmp_path / "terrain" / "fields.nc") as ds:
        assert ds["b"].dimensions == ("y", "x") and ds["solid"].dimensions == ("y", "x")
        assert ds["b"].units == "m" and ds["b"].dtype == np.float64
        assert ds["b"].long_name == "bed height normal to the reference plane"
        assert ds["solid"].dtype == np.int8 and list(ds["solid"].flag_values) == [0, 1]
        assert ds["solid"].flag_meanings == "open solid"
        np.testing.assert_array_equal(ds["b"][...], b.T)
        np.testing.assert_array_equal(ds["solid"][...], solid.T)
        np.testing.assert_array_equal(ds["h"][0], np.where(solid, 0, np.maximum(0.0015 - b, 0)).T)
        scene_text = ds.scene
    assert tomllib.loads(scene_text)["terrain"]["shapes"][0]["kind"] == "gaussian"
    assert load_scene(tmp_path / "terrain" / "scene.toml") == sc

    flat = scene()
    Simulation.from_scene(flat).run(out_dir=tmp_path / "flat", progress=False)
    with netCDF4.Dataset(tmp_path / "flat" / "fields.nc") as ds:
        assert "b" not in ds.variables and "solid" not in ds.variables
        assert "terrain" not in ds.scene


# ---- the relief in the pictures --------------------------------------------------------------
def snapshot(sc):
    h, _, _ = interior_h(sc)
    x, y = sc.domain.cell_centres()
    return {"h": h.T, "u": np.zeros_like(h.T), "v": np.zeros_like(h.T), "x": x, "y": y}


def test_the_relief_shades_the_pictures_where_the_bed_varies(ti_cpu):
    from tiseg.post.render import render_fields
    from tiseg.post.render.raster import render_fields_numpy
    from tiseg.post.render.relief import SOLID_RGB

    sc = scene({"shapes": SHAPES}, {"kind": "lake", "level": 0.0015})
    b, solid = sc.bed_arrays()
    plain = snapshot(sc)
    with_bed = {**plain, "b": b.T, "solid": solid.T.astype("i1")}
    flat_bed = {**plain, "b": np.zeros_like(b.T)}
    for render in (render_fields, render_fields_numpy):
        kw = {"colourbar": False} if render is render_fields else {}
        a = render(plain, 1e-4, field="h", vrange=(0.0, 0.002), scale=2, **kw)
        # a bed without relief changes no pixel: flat runs' pictures are as before
        np.testing.assert_array_equal(
            render(flat_bed, 1e-4, field="h", vrange=(0.0, 0.002), scale=2, **kw), a
        )
        c = render(with_bed, 1e-4, field="h", vrange=(0.0, 0.002), scale=2, **kw)
        assert c.shape == a.shape
        diff = np.any(c != a, axis=2)[::-1].T[::2, ::2]  # per cell, (nx, ny)
        slope = np.hypot(*np.gradient(b))  # per cell
        assert diff[(slope > 1e-5) & ~solid].mean() > 0.5  # shaded where the bed slopes
        assert not diff[(slope < 1e-9) & ~solid].any()  # and nowhere else
        walls = c[::-1].transpose(1, 0, 2)[::2, ::2][solid]
        assert (walls == np.round(np.asarray(SOLID_RGB) * 255)).all()
    # the Taichi painter and its NumPy twin agree to one 8-bit level
    kw = {"field": "h", "vrange": (0.0, 0.002), "scale": 2}
    t = render_fields(with_bed, 1e-4, colourbar=False, **kw)
    n = render_fields_numpy(with_bed, 1e-4, **kw)
    assert np.abs(t.astype(int) - n.astype(int)).max() <= 1


def test_render_run_reads_the_bed_from_fields_nc(ti_cpu, tmp_path):
    from tiseg.post.render.movie import _snapshot
    from tiseg.output.netcdf import read_fields
    from tiseg.run.simulation import Simulation

    sc = scene({"shapes": SHAPES}, {"kind": "lake", "level": 0.0015})
    Simulation.from_scene(sc).run(out_dir=tmp_path / "run", progress=False)
    with read_fields(tmp_path / "run" / "fields.nc") as ds:
        snap = _snapshot(ds, 0)
        np.testing.assert_array_equal(snap["b"], sc.bed_arrays()[0].T)
        assert snap["solid"].astype(bool).sum() == sc.bed_arrays()[1].sum()


def test_peak_and_probability_maps_are_drawn_over_the_relief(ti_cpu, tmp_path, capsys):
    """The maps of the peak fields and of a sweep's probabilities (tiseg.post.render.maps):
    a map's colours are shaded where the bed slopes, unchanged where it is flat, the walls in
    their colour; `tiseg render RUN --peaks` draws them from fields.nc."""
    import matplotlib.colors as mcolors

    from tiseg.apps.cli import main
    from tiseg.output.netcdf import read_fields
    from tiseg.post.render import colours as C
    from tiseg.post.render.maps import bed_of_dataset, relief_picture
    from tiseg.post.render.peak_maps import plot_peak_fields
    from tiseg.post.render.relief import SOLID_RGB
    from tiseg.run.simulation import Simulation

    sc = scene(
        {"shapes": SHAPES},
        {"kind": "lake", "level": 0.0015},
        output={"interval": 0.005, "peak_fields": True},
    )
    b, solid = sc.bed_arrays()
    values = np.full(b.T.shape, 0.5)
    values[:2] = np.nan  # cells without a value: the grey, shaded too
    cmap = C.matplotlib_cmap("h").with_extremes(bad=C.EMPTY_MAP_RGB)
    norm = mcolors.Normalize(0.0, 1.0)
    plain = relief_picture(values, cmap, norm, (np.zeros_like(b.T), None), sc.dx, sc.dy, 0.35)
    shaded = relief_picture(values, cmap, norm, (b.T, solid.T), sc.dx, sc.dy, 0.35)
    assert plain.shape == shaded.shape == (sc.domain.ny, sc.domain.nx, 3)
    diff = np.any(shaded != plain, axis=2)[::-1].T  # per cell, (nx, ny)
    slope = np.hypot(*np.gradient(b))
    assert diff[(slope > 1e-5) & ~solid].mean() > 0.5 and not diff[(slope < 1e-9) & ~solid].any()
    assert (shaded[::-1].transpose(1, 0, 2)[solid] == C.to_uint8(SOLID_RGB)).all()
    # without shading only the walls differ
    walls_only = relief_picture(values, cmap, norm, (b.T, solid.T), sc.dx, sc.dy, 0.0)
    assert np.array_equal(np.any(walls_only != plain, axis=2)[::-1].T, solid)

    Simulation.from_scene(sc).run(out_dir=tmp_path / "run", progress=False)
    assert main(["render", str(tmp_path / "run"), "--peaks"]) == 0
    assert f"wrote {tmp_path / 'run' / 'peaks.png'}" in capsys.readouterr().out
    assert (tmp_path / "run" / "peaks.png").read_bytes()[:4] == b"\x89PNG"
    assert not list((tmp_path / "run").glob("*.mp4"))  # --peaks alone writes no movie
    with read_fields(tmp_path / "run" / "fields.nc") as ds:
        bed = bed_of_dataset(ds)
        np.testing.assert_array_equal(bed[0], b.T)
        np.testing.assert_array_equal(bed[1], solid.T)
        fig = plot_peak_fields(ds, fields=["h_max", "arrival_time"])
    titles = [ax.get_title() for ax in fig.axes if ax.get_title()]
    assert titles == ["h_max", "arrival_time"]
    labels = [ax.get_ylabel() for ax in fig.axes if ax.get_ylabel() not in ("", "y [m]")]
    assert labels == ["peak thickness h_max [mm]", "arrival time [s]"]  # the colour bars
    with pytest.raises(InputError, match="this run's peak fields are h_max, speed_max"):
        plot_peak_fields(tmp_path / "run", fields=["h"])
