"""Output fields and writers as registries (`tiseg.output.fields`, `tiseg.run.run_folder`):
a field spec registered from this file is written by a run beside h and u, with its CF
attributes, masked where dry if it says so, read back by `read_fields`, and continued by a
resumed writer; a writer registered from this file runs on its own schedule."""

from __future__ import annotations

import numpy as np
import pytest

from tiseg.output import OUTPUT_FIELDS, FieldSpec, read_fields, register_field
from tiseg.output.fields import snapshot_fields
from tiseg.output.names import FIELDS_FILE
from tiseg.run.run_folder import RUN_WRITERS, RunWriter, register_writer
from tiseg.run.schedules import IterationInterval
from tiseg.run.simulation import Simulation

DAM = {"domain.nx": 60, "time.t_end": 0.1, "output.interval": 0.05}

MOMENTUM = FieldSpec(
    "test_hu",
    {"long_name": "downslope momentum per unit width", "units": "m2 s-1"},
    needs=("h", "u"),
    compute=lambda f: f["h"] * f["u"],
    missing_where_dry=True,
    label="momentum hu",
    unit="m²/s",
    short="hu [m2/s]",
)


@pytest.fixture
def momentum():
    register_field(MOMENTUM)
    try:
        yield MOMENTUM
    finally:
        del OUTPUT_FIELDS[MOMENTUM.name]


def test_a_registered_field_is_written_and_read_back(ti_cpu, tmp_path, momentum):
    assert snapshot_fields(("h", "u")) == ("h", "u", "test_hu")
    assert snapshot_fields(("h", "v")) == ("h", "v")  # a run without u has no hu
    sim = Simulation.from_scene("dam-break", DAM)
    sim.run(out_dir=tmp_path, progress=False)
    h_min = sim.scene.numerics.h_min
    with read_fields(tmp_path / FIELDS_FILE) as ds:
        assert ds["test_hu"].attrs["long_name"] == "downslope momentum per unit width"
        assert ds["test_hu"].attrs["units"] == "m2 s-1"
        assert ds["test_hu"].dims == ("time", "y", "x") and ds.sizes["time"] == 3
        h, u, hu = (ds[n].values[-1] for n in ("h", "u", "test_hu"))
    dry = h < h_min
    assert dry.any() and np.isnan(hu[dry]).all()  # missing where there is no material
    np.testing.assert_array_equal(hu[~dry], (h * u)[~dry])


def test_an_unregistered_field_is_not_written(ti_cpu, tmp_path):
    sim = Simulation.from_scene("dam-break", DAM)
    sim.run(out_dir=tmp_path, progress=False)
    with read_fields(tmp_path / FIELDS_FILE) as ds:
        assert set(ds.data_vars) >= {"h", "u"} and "test_hu" not in ds


def test_a_registered_writer_runs_on_its_schedule(ti_cpu, tmp_path):
    seen = []
    register_writer(
        RunWriter(
            "test-steps",
            lambda folder, times, wall: IterationInterval(2),
            lambda folder, sim: seen.append(sim.stats.steps),
        )
    )
    try:
        sim = Simulation.from_scene("dam-break", DAM)
        sim.run(out_dir=tmp_path, progress=False)
    finally:
        del RUN_WRITERS["test-steps"]
    assert seen and all(n % 2 == 0 for n in seen)
    assert list(RUN_WRITERS) == ["fields", "diagnostics", "gauges", "checkpoint"]
