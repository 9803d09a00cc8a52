"""Hardening of the members of sweeps and calibrations (issue 48, items 3 to 7): a member's
result is used only when all of it was read and it succeeded, a search never sees a failed
member as a number, a finished member is never replaced by another command's member of the
same name, and a result that cannot be made again does not survive as a stale file."""

from __future__ import annotations

import json
from pathlib import Path

import netCDF4
import numpy as np
import pytest

from tiseg.apps.sweep import sweep_from_dict

# a 1D dam break of three members (their fields files are written here, nothing runs)
PROB = {
    "scene": "dam-break",
    "set": {"domain": {"nx": 40}, "time": {"t_end": 0.15}, "output": {"interval": 0.15}},
    "sample": {"method": "lhs", "n": 3, "seed": 3, "initial.h_left": [0.001, 0.003]},
    "probability": {"h_thresholds": [0.001]},
}


def peak_file(path: Path, *, compress: str | None = None) -> None:
    """A member's fields.nc with peak fields on a 2 x 8 grid where the flow reached every
    cell (arrival_time given everywhere); ``compress``: the one field stored compressed."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with netCDF4.Dataset(path, "w") as ds:
        ds.createDimension("y", 2)
        ds.createDimension("x", 8)
        for name, n in (("y", 2), ("x", 8)):
            ds.createVariable(name, "f8", (name,))[:] = 0.01 * np.arange(n) + 0.005
            ds[name].setncatts({"long_name": name, "units": "m"})
        rng = np.random.default_rng(1)
        for name in ("h_max", "speed_max", "arrival_time"):
            v = ds.createVariable(
                name, "f8", ("y", "x"), fill_value=np.nan, zlib=name == compress, complevel=4
            )
            v.setncatts({"long_name": name, "units": "s" if name == "arrival_time" else "m"})
            v[:] = 0.002 + 0.01 * rng.random((2, 8))


def damage_the_compressed_block(path: Path) -> None:
    """Overwrite the zlib stream of the file's one compressed variable (its header kept)."""
    data = bytearray(path.read_bytes())
    o = next(i for i in range(len(data) - 1) if data[i] == 0x78 and data[i + 1] == 0x5E)
    data[o + 2 : o + 40] = b"\xff" * 38
    path.write_bytes(bytes(data))


# ------------------------------------------------------------------ 3: one damaged peak field
@pytest.mark.parametrize("which", ["speed_max", "arrival_time"])
def test_a_member_with_one_unreadable_peak_field_is_left_out_whole(tmp_path, caplog, which):
    """A read failure on a member's second (or third) field left its first fields stacked:
    the stacks misaligned and p_arrival topped out at 2/3 where every member arrived."""
    from tiseg.apps.sweep.probability import write_probability
    import xarray as xr

    sw = sweep_from_dict(json.loads(json.dumps(PROB)), source="s.toml")
    names = [r.name for r in sw.runs]
    for name in names:
        peak_file(tmp_path / name / "fields.nc", compress=which if name == names[1] else None)
    damage_the_compressed_block(tmp_path / names[1] / "fields.nc")
    path = write_probability(sw, tmp_path, {n: {"status": "reused"} for n in names})
    with xr.open_dataset(path) as ds:
        assert ds.run.values.tolist() == [names[0], names[2]]
        assert float(ds.p_arrival.min()) == 1.0  # the flow reached every cell in each member
        assert ds.attrs["members_left_out"] == names[1]
    assert f"member {names[1]} is left out" in caplog.text


def test_sweep_nc_keeps_no_part_of_a_member_whose_peak_fields_cannot_all_be_read(tmp_path):
    from tiseg.apps.sweep import write_dataset
    import xarray as xr

    sw = sweep_from_dict(json.loads(json.dumps(PROB)), source="s.toml")
    names = [r.name for r in sw.runs]
    for name in names:
        peak_file(tmp_path / name / "fields.nc", compress="speed_max" if name == names[1] else None)
    damage_the_compressed_block(tmp_path / names[1] / "fields.nc")
    path = write_dataset(sw, tmp_path, {n: {"status": "reused"} for n in names})
    with xr.open_dataset(path) as ds:
        assert np.isnan(ds.h_max.isel(member=1)).all()  # not its h_max without its speed_max
        assert not np.isnan(ds.h_max.isel(member=0)).any()
