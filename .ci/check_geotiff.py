"""The GeoTIFF bed reader (`tiseg.setup.rasters.read_raster`) against real rasterio (the
`tiseg[terrain]` extra): a small north-up raster with known values and a nodata cell, written by
rasterio, must come back indexed [x, y] from the south-west corner, with its origin, cell size
and nodata cell. The test suite checks the reader against a stand-in module only (rasterio is
not a test dependency); CI runs this in the venv that has rasterio for the CF readers.

    python .ci/check_geotiff.py        (with tiseg importable, e.g. PYTHONPATH=.)
"""

import math
import sys
import tempfile
from pathlib import Path

import numpy as np
import rasterio
from rasterio.transform import from_origin

from tiseg.setup.rasters import read_raster

COLS, ROWS, D = 4, 3, 0.1  # a 4 x 3 raster of 0.1 m cells, lower-left corner (1, 2)
X0, Y0 = 1.0, 2.0

# value 10 col + row counted from the south; rows are written north first, as GeoTIFF stores them
north_first = np.array([[10.0 * c + (ROWS - 1 - r) for c in range(COLS)] for r in range(ROWS)])
north_first[0, COLS - 1] = -9999.0  # nodata in the north-east corner
with tempfile.TemporaryDirectory() as tmp:
    path = Path(tmp) / "bed.tif"
    profile = dict(driver="GTiff", height=ROWS, width=COLS, count=1, dtype="float64")
    with rasterio.open(
        path, "w", transform=from_origin(X0, Y0 + ROWS * D, D, D), nodata=-9999.0, **profile
    ) as ds:
        ds.write(north_first, 1)
    r = read_raster(path)

problems = []
expect = np.array([[10.0 * c + j for j in range(ROWS)] for c in range(COLS)])
got = np.asarray(r.values, dtype=float)
if got.shape != (COLS, ROWS):
    problems.append(f"values of shape {got.shape}, expected (x, y) = {(COLS, ROWS)}")
else:
    nodata = np.isnan(got) | (np.asarray(r.nodata) if r.nodata is not None else False)
    if not nodata[COLS - 1, ROWS - 1] or nodata.sum() != 1:
        problems.append(f"nodata cells {np.argwhere(nodata).tolist()}, expected [[3, 2]]")
    ok = ~nodata
    if not np.array_equal(got[ok], expect[ok]):
        problems.append(f"values\n{got}\nexpected\n{expect}")
for name, value, want in (("x0", r.x0, X0), ("y0", r.y0, Y0), ("dx", r.dx, D), ("dy", r.dy, D)):
    if not math.isclose(value, want, rel_tol=1e-12, abs_tol=1e-12):
        problems.append(f"{name} = {value!r}, expected {want}")
if problems:
    sys.exit("GeoTIFF check failed: " + "; ".join(problems))
print(f"GeoTIFF ok: rasterio {rasterio.__version__}, a {COLS} x {ROWS} raster read back as written")
