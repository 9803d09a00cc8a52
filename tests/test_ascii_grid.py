"""ESRI ASCII grids of the peak fields (`tiseg.output.ascii_grid`, `tiseg render --raster`):
the header places the cells where fields.nc has them, the rows run from the largest y down, and
the values read back bit for bit, NaN as NODATA."""

import numpy as np
import pytest

from tiseg.apps.cli import main
from tiseg.errors import InputError
from tiseg.output.ascii_grid import NODATA, read_asc, write_asc
from tiseg.output.netcdf import FieldsWriter

NX, NY, DX, DY = 5, 3, 0.02, 0.03
X = (np.arange(NX) + 0.5) * DX
Y = (np.arange(NY) + 0.5) * DY


def _map(seed=0):
    a = np.random.default_rng(seed).random((NY, NX)) * 1e-3
    a[0, 0] = np.nan  # a cell the flow never reached
    return a


def test_header_rows_and_values(tmp_path):
    a = _map()
    write_asc(tmp_path / "m.asc", a, X, Y)
    lines = (tmp_path / "m.asc").read_text().splitlines()
    head = dict(line.split() for line in lines[:7])
    assert int(head["ncols"]) == NX and int(head["nrows"]) == NY
    # the lower-left corner of the lower-left cell; non-square cells: GDAL's dx / dy lines
    assert float(head["xllcorner"]) == 0.0 and float(head["yllcorner"]) == 0.0
    assert float(head["dx"]) == pytest.approx(DX) and float(head["dy"]) == pytest.approx(DY)
    assert "cellsize" not in head and float(head["NODATA_value"]) == NODATA
    # the first row of values is the one at the largest y; the missing cell is NODATA
    first = np.array(lines[7].split(), dtype=float)
    np.testing.assert_array_equal(first, a[-1])
    last = np.array(lines[-1].split(), dtype=float)
    assert last[0] == NODATA
    np.testing.assert_array_equal(last[1:], a[0, 1:])
    head2, back = read_asc(tmp_path / "m.asc")
    np.testing.assert_array_equal(back, a)  # 17 digits: the same float64 bits, NaN kept


def test_square_cells_use_cellsize_and_a_value_equal_to_nodata_is_refused(tmp_path):
    write_asc(tmp_path / "s.asc", np.ones((2, 3)), [0.5, 1.5, 2.5], [10.5, 11.5])
    head, _ = read_asc(tmp_path / "s.asc")
    assert head["cellsize"] == 1.0 and head["xllcorner"] == 0.0 and head["yllcorner"] == 10.0
    with pytest.raises(ValueError, match="NODATA"):
        write_asc(tmp_path / "bad.asc", np.full((2, 3), NODATA), [0.5, 1.5, 2.5], [0, 1])
    assert not (tmp_path / "bad.asc").exists()


def test_a_grid_from_another_tool_reads_with_its_corner_and_a_bad_one_is_one_line(tmp_path):
    # written by hand: keywords in capitals, the lower-left cell's centre, values wrapped
    (tmp_path / "g.asc").write_text(
        "NCOLS 3\nNROWS 2\nXLLCENTER 1.25\nYLLCENTER -0.25\nCELLSIZE 0.5\n"
        "NODATA_VALUE -1\n1 2\n3 4 -1\n6\n"
    )
    head, a = read_asc(tmp_path / "g.asc")
    assert (head["xllcorner"], head["yllcorner"], head["dx"], head["dy"]) == (1.0, -0.5, 0.5, 0.5)
    np.testing.assert_array_equal(a, [[4, np.nan, 6], [1, 2, 3]])  # first row: smallest y
    # written back from its corner, it reads the same
    write_asc(tmp_path / "h.asc", a, corner=(1.0, -0.5), dx=0.5)
    head2, b = read_asc(tmp_path / "h.asc")
    np.testing.assert_array_equal(b, a)
    assert (head2["xllcorner"], head2["yllcorner"], head2["cellsize"]) == (1.0, -0.5, 0.5)
    (tmp_path / "bad.asc").write_text("ncols 2\nnrows 1\nxllcorner 0\nyllcorner 0\n1 2\n")
    with pytest.raises(InputError, match="bad.asc: header needs cellsize") as info:
        read_asc(tmp_path / "bad.asc")
    assert "\n" not in str(info.value)


def _fields(path, peaks: bool):
    static = ("h_max", "speed_max", "arrival_time", "deposit_h") if peaks else ()
    with FieldsWriter(path, X, Y, fields=("h", "u", "v"), static=static) as w:
        w.write(0.0, h=_map(1), u=_map(2), v=_map(3))
        if peaks:
            w.write_static(0.75, **{n: _map(i + 4) for i, n in enumerate(static)})


def test_render_raster_writes_the_peak_fields(tmp_path, capsys):
    import netCDF4

    run = tmp_path / "run"
    _fields(run / "fields.nc", peaks=True)
    assert main(["render", str(run), "--raster"]) == 0
    out = capsys.readouterr().out
    names = ("h_max", "speed_max", "arrival_time", "deposit_h")
    with netCDF4.Dataset(run / "fields.nc") as ds:
        for name in names:
            assert f"wrote {run / (name + '.asc')}" in out
            head, a = read_asc(run / f"{name}.asc")
            want = np.ma.filled(ds[name][:].astype(float), np.nan)
            np.testing.assert_array_equal(a, want)
            assert head["xllcorner"] == 0.0 and head["dx"] == pytest.approx(DX)
    assert not list(run.glob("*.mp4"))  # --raster alone writes no movie


def test_render_raster_without_peak_fields_is_one_line(tmp_path, capsys):
    run = tmp_path / "run"
    _fields(run / "fields.nc", peaks=False)
    assert main(["render", str(run), "--raster"]) == 2
    err = capsys.readouterr().err
    assert "no peak fields" in err and err.count("\n") == 1 and "Traceback" not in err
