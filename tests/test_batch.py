"""A batch runs its members together and each member's run is bitwise the member run alone:
its fields.nc, diagnostics.csv and final state; a member that fails its guard stops alone."""

import netCDF4
import numpy as np
import pytest

from tiseg.errors import InputError
from tiseg.run.failures import SimulationError
from tiseg.run.batch import Batch
from tiseg.run.simulation import Simulation
from tiseg.setup.reading import load_scene

SMALL = {"output.interval": 0.25}


def _fields(path):
    with netCDF4.Dataset(path) as ds:
        return {k: np.array(v[:]) for k, v in ds.variables.items()}


def _diagnostics(path):
    # every column but the wall time, which no two runs share
    rows = [ln.split(",") for ln in path.read_text().splitlines()]
    keep = [k for k, name in enumerate(rows[0]) if "wall" not in name]
    return [[r[k] for k in keep] for r in rows]


def _same_runs(a, b) -> None:
    fa, fb = _fields(a / "fields.nc"), _fields(b / "fields.nc")
    assert fa.keys() == fb.keys()
    for k in fa:
        assert np.array_equal(fa[k], fb[k], equal_nan=True), k
    assert _diagnostics(a / "diagnostics.csv") == _diagnostics(b / "diagnostics.csv")


CASES = {
    # the split sweeps with their viscous sub-step, seeds and nu differing; the members end
    # at different times
    "fingers": (
        {"domain.resolution": 40, "time.t_end": 1.5},
        [{"inflow.seed": 3}, {"inflow.seed": 4, "flow.nu": 0.004}, {"time.t_end": 1.0}],
    ),
    # RKC with the projected friction and a law with hysteresis (resting regions skipped)
    "finite-release-deposit": (
        {"domain.resolution": 60, "time.t_end": 0.6},
        [{}, {"material.zeta_deg": 31.5}],
    ),
}


@pytest.mark.parametrize("name", sorted(CASES))
def test_a_batch_member_is_the_member_run_alone(ti_cpu, tmp_path, name):
    base, members = CASES[name]
    scenes = [load_scene(name, {**SMALL, **base, **m}) for m in members]
    batch = Batch(scenes)
    dirs = [tmp_path / f"batch{e}" for e in range(len(scenes))]
    stats = batch.run(out_dirs=dirs)
    for e, sc in enumerate(scenes):
        alone = Simulation(sc)
        alone.run(out_dir=tmp_path / f"alone{e}", progress=False)
        assert stats[e].steps == alone.stats.steps and stats[e].stages == alone.stats.stages
        assert batch.sims[e].t == alone.t
        assert np.array_equal(batch.sims[e].conserved(), alone.conserved())
        _same_runs(dirs[e], tmp_path / f"alone{e}")
    assert not np.array_equal(batch.sims[0].conserved(), batch.sims[1].conserved())


def test_a_member_that_fails_stops_alone(ti_cpu, tmp_path):
    scenes = [
        load_scene("fingers", {**SMALL, "domain.resolution": 40, "time.t_end": 0.5, **m})
        for m in ({}, {"inflow.seed": 2})
    ]
    batch = Batch(scenes)

    def poison(snap):  # the second member's state turns to NaN after its first snapshot
        if snap.t > 0:
            op = batch.op
            op.state.par[1, 0] = float("nan")

    stats = batch.run(on_output=[None, poison], out_dirs=[tmp_path / "a", tmp_path / "b"])
    assert isinstance(stats[1], SimulationError)
    assert not isinstance(stats[0], Exception) and batch.sims[0].t == 0.5
    alone = Simulation(scenes[0])
    alone.run(progress=False)
    assert np.array_equal(batch.sims[0].conserved(), alone.conserved())


def test_members_must_share_their_compiled_options(ti_cpu):
    a = load_scene("fingers", {"domain.resolution": 40})
    b = load_scene("fingers", {"domain.resolution": 50})
    with pytest.raises(InputError, match="share"):
        Batch([a, b])
    with pytest.raises(InputError, match="at least two"):
        Batch([a])
