"""fields.nc through VTK's vtkNetCDFCFReader, the reader ParaView opens NetCDF-CF files with:
it must see the snapshot times in seconds, the grid of cell centres, the four fields, and phi
missing (NaN with "replace fill value with NaN", as ParaView offers) exactly where h < h_min.

Then through GDAL's netCDF driver (QGIS's reader; pip's rasterio wheel bundles GDAL): a peak
field must come with a geotransform in metres, cells of dx by dy whose corner is the grid's,
not one of pixels (which GDAL gives when x and y carry no axis attribute)."""

import sys

import netCDF4
import numpy as np
import vtk
from vtk.util.numpy_support import vtk_to_numpy

path = sys.argv[1]
with netCDF4.Dataset(path) as nc:
    times = np.asarray(nc["time"][:], dtype=float)
    nx, ny = nc.dimensions["x"].size, nc.dimensions["y"].size
    h_last = np.asarray(nc["h"][-1], dtype=float)
    xc, yc = np.asarray(nc["x"][:], dtype=float), np.asarray(nc["y"][:], dtype=float)
r = vtk.vtkNetCDFCFReader()
r.SetFileName(path)
r.ReplaceFillValueWithNanOn()
r.UpdateInformation()
info = r.GetOutputInformation(0)
steps = info.Get(vtk.vtkStreamingDemandDrivenPipeline.TIME_STEPS())
problems = []
if steps is None or not np.allclose(steps, times):
    problems.append(f"time steps {steps} != {times.tolist()}")
r.UpdateTimeStep(float(times[-1]))
out = r.GetOutput()
data = out.GetPointData() if out.GetPointData().GetNumberOfArrays() else out.GetCellData()
names = {data.GetArrayName(i) for i in range(data.GetNumberOfArrays())}
if not {"h", "u", "v", "phi"} <= names:
    problems.append(f"arrays {sorted(names)}")
else:
    phi = vtk_to_numpy(data.GetArray("phi"))
    h = vtk_to_numpy(data.GetArray("h"))
    if phi.size != nx * ny:
        problems.append(f"{phi.size} values, expected {nx} x {ny}")
    elif (
        not np.array_equal(np.isnan(phi), h < 1e-4) or np.isnan(phi).sum() != (h_last < 1e-4).sum()
    ):
        problems.append("phi is not missing exactly where h < h_min")
if problems:
    sys.exit("VTK CF reader check failed: " + "; ".join(problems))
print(f"VTK CF reader: {len(steps)} time steps, {nx} x {ny} cells, phi missing where dry")

import rasterio  # noqa: E402  (after VTK's check: each reader's failure is reported on its own)

dx, dy = xc[1] - xc[0], yc[1] - yc[0]
# GDAL's rows run north to south: the top edge is the largest y, the row step -dy
want = tuple(float(v) for v in (dx, 0.0, xc[0] - dx / 2, 0.0, -dy, yc[-1] + dy / 2))
with rasterio.open(f"netcdf:{path}:h_max") as r:
    got = tuple(r.transform)[:6]
    size = (r.width, r.height)
if size != (nx, ny) or not np.allclose(got, want, rtol=1e-9, atol=1e-12):
    sys.exit(
        f"GDAL netCDF driver: geotransform {got} of {size} cells, expected {want} of {(nx, ny)}"
    )
print(
    f"GDAL netCDF driver: h_max {nx} x {ny} cells of {dx:g} x {dy:g} m from ({want[2]:g}, {want[5]:g}) m"
)
