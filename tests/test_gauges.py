"""Gauges (``[[output.gauges]]``, tiseg.run.gauges): a row of gauges.csv per step state, each
value the bilinear interpolation of the fields as fields.nc stores them; observers only;
resumed bit for bit.

The reference values are interpolated here by hand from fields.nc (or from the step states a
callback records), never with the gauges' own code."""

from __future__ import annotations

import netCDF4
import numpy as np
import pytest

from tiseg.apps.cli import main
from tiseg.errors import InputError
from tiseg.output import read_diagnostics
from tiseg.run import checkpoint
from tiseg.run.callbacks import Callback
from tiseg.run.schedules import IterationInterval
from tiseg.run.simulation import Simulation
from tiseg.setup.scene import load_scene

# the dam break at x = 0.1 m onto a dry bed, 1D, 150 cells on [0, 0.3] m, to 0.2 s
DAM = {
    "domain.nx": 150,
    "time.t_end": 0.2,
    "output.interval": 0.05,
    "output.checkpoint_interval": 0.05,
    "output.gauges": [{"x": 0.1013, "name": "gate"}, {"x": 0.1234}, {"x": 0.0}],
}
# a small 2D fingers run (24 x 8 cells: inflow, segregation, the split sweeps) to 0.5 s
FINGERS = {
    "domain.resolution": 40,
    "domain.Lx": 0.6,
    "domain.Ly": 0.2,
    "time.t_end": 0.5,
    "output.times": [],
    "output.interval": 0.25,
}


def _bilinear(field, xc, yc, x, y):
    """field (ny, nx) on centres xc, yc at (x, y), clamped to the outermost centres, by hand."""

    def axis(c, v):
        if c.size == 1:
            return 0, 0, 0.0
        s = np.interp(v, c, np.arange(c.size))  # clamps outside
        i0 = min(int(s), c.size - 2)
        return i0, i0 + 1, s - i0

    i0, i1, wx = axis(xc, x)
    j0, j1, wy = axis(yc, y)
    corners = [(j0, i0, (1 - wx) * (1 - wy)), (j0, i1, wx * (1 - wy))]
    corners += [(j1, i0, (1 - wx) * wy), (j1, i1, wx * wy)]
    return sum(w * field[j, i] for j, i, w in corners if w > 0)


def test_scene_keys_defaults_and_mistakes():
    sc = load_scene("fingers", {**FINGERS, "output.gauges": [{"x": 0.3}, {"x": 0.1, "y": 0.05}]})
    g1, g2 = sc.output.gauges
    assert (g1.name, g1.x, g1.y) == ("g1", 0.3, 0.1)  # y: the centre line by default
    assert (g2.name, g2.y) == ("g2", 0.05)
    from tiseg.setup.reading import scene_from_text

    # the resolved scene.toml reads back to the same gauges
    assert scene_from_text(sc.to_toml()).output.gauges == sc.output.gauges
    assert load_scene("fingers", FINGERS).output.gauges == ()
    for gauges, words in (
        ([{"x": 0.7}], r"output.gauges\[0\].x=0.7: in \[0, Lx=0.6\]"),
        ([{"x": 0.1, "y": -0.01}], r"output.gauges\[0\].y"),
        ([{"x": 0.1, "name": "a"}, {"x": 0.2, "name": "a"}], "another gauge has this name"),
        ([{"x": 0.1, "name": "a,b"}], "letters, digits"),
        ([{"x": 0.1, "z": 1}], r"unknown key 'output.gauges\[0\].z'"),
        ([{"y": 0.1}], r"output.gauges\[0\].x is required"),
        (3, "expected an array of tables"),
    ):
        with pytest.raises(InputError, match=words):
            load_scene("fingers", {**FINGERS, "output.gauges": gauges})


@pytest.mark.slow  # a long run: the slow set (README), which CI runs after the suite
def test_gauges_interpolate_the_saved_fields_every_step(ti_cpu, tmp_path, capsys):
    """2D: gauges.csv has a row per diagnostics row (the initial state and every step), and
    at the last step (t_end, a step state and a snapshot) each gauge is the bilinear
    interpolation of fields.nc's h, u, v, phi at its point; the steps are those of a run
    without gauges, bit for bit."""
    pts = [
        {"x": 0.0437, "y": 0.0712, "name": "a"},  # inside a cell, in the flow
        {"x": 0.0625, "y": 0.0625, "name": "centre"},  # on a cell centre
        {"x": 0.01, "y": 0.199, "name": "corner"},  # beyond the outermost centres: clamped
        {"x": 0.55, "name": "dry"},  # ahead of the front
    ]
    sim = Simulation.from_scene("fingers", {**FINGERS, "output.gauges": pts})
    sim.run(out_dir=tmp_path / "g", progress=False)
    rows = read_diagnostics(tmp_path / "g" / "gauges.csv")
    diag = read_diagnostics(tmp_path / "g" / "diagnostics.csv")
    np.testing.assert_array_equal(rows["time"], diag["time"])  # a row per step
    assert rows["time"].size == sim.stats.steps + 1
    with netCDF4.Dataset(tmp_path / "g" / "fields.nc") as nc:
        xc, yc = nc["x"][:].data, nc["y"][:].data
        assert float(nc["time"][-1]) == rows["time"][-1] == 0.5
        fields = {q: np.ma.filled(nc[q][-1].astype(float), np.nan) for q in ("h", "u", "v", "phi")}
    assert fields["h"].max() > 0.001  # the flow is on the chute
    for p in pts:
        y = p.get("y", 0.1)
        for q, f in fields.items():
            want = _bilinear(f, xc, yc, p["x"], y)
            got = rows[f"{p['name']}_{q}"][-1]
            np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-300, err_msg=(p, q))
    assert rows["a_h"][-1] > 0 and 0 < rows["a_phi"][-1] <= 1
    assert rows["dry_h"][-1] == 0 and np.isnan(rows["dry_phi"][-1])  # no material: empty
    assert np.isnan(rows["a_phi"][0])  # the empty chute at t = 0
    # observers only: the run without gauges has the same final state, bit for bit
    plain = Simulation.from_scene("fingers", FINGERS)
    plain.run(out_dir=tmp_path / "plain", progress=False)
    assert plain.stats.steps == sim.stats.steps
    for q, f in plain.fields().items():
        np.testing.assert_array_equal(f, sim.fields()[q], err_msg=q)
    # tiseg render draws them; a run without gauges: one line naming the scene key
    assert main(["render", str(tmp_path / "g"), "--gauges"]) == 0
    assert (tmp_path / "g" / "gauges.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    capsys.readouterr()
    assert main(["render", str(tmp_path / "plain"), "--gauges"]) == 2
    err = capsys.readouterr().err
    assert "[[output.gauges]]" in err and err.count("\n") == 1


@pytest.mark.slow  # a long run: the slow set (README), which CI runs after the suite
def test_gauges_follow_every_step_state_in_1d_and_resume_bit_for_bit(ti_cpu, tmp_path):
    """1D (no v): each row is the interpolation of that step's state (recorded by a callback),
    and a run stopped after a checkpoint and resumed writes the uninterrupted run's gauges.csv
    byte for byte (the rows after the checkpoint are dropped and written again)."""
    ref = Simulation.from_scene("dam-break", DAM)
    states = [(ref.t, ref.fields())]
    ref.add_callback(lambda s: states.append((s.t, s.fields())), IterationInterval(1), "rec")
    ref.run(out_dir=tmp_path / "ref", progress=False)
    rows = read_diagnostics(tmp_path / "ref" / "gauges.csv")
    assert "gate_v" not in rows and rows["time"].size == len(states) == ref.stats.steps + 1
    xc, yc = ref.scene.domain.cell_centres()
    for k, (t, f) in enumerate(states):
        assert rows["time"][k] == t
        for name, x in (("gate", 0.1013), ("g2", 0.1234), ("g3", 0.0)):
            for q in ("h", "u", "phi"):
                if q not in f:
                    continue
                want = f[q] if q != "phi" else np.where(f["h"] < 1e-4, np.nan, f[q])
                want = _bilinear(np.atleast_2d(want), np.asarray(xc), np.asarray(yc), x, 0.0)
                np.testing.assert_allclose(rows[f"{name}_{q}"][k], want, rtol=1e-12, atol=0)
    assert rows["gate_h"].max() > 0 and rows["g2_u"].max() > 0  # the wave passed both

    class Killed(Exception):
        pass

    def kill(sim):
        if sim.t > 0.12:
            raise Killed

    first = Simulation.from_scene("dam-break", DAM)
    first.add_callback(Callback(kill, IterationInterval(1), name="kill", order=1000))
    with pytest.raises(Killed):  # (a checkpoint at every output time, however fast the run)
        first.run(out_dir=tmp_path / "cut", progress=False, checkpoint_spacing=0.0)
    ck = checkpoint.load(tmp_path / "cut" / checkpoint.CHECKPOINT_NAME)
    cut_rows = (tmp_path / "cut" / "gauges.csv").read_text().count("\n") - 1
    assert ck["diag_rows"] < cut_rows  # rows after the checkpoint: the resume drops them
    Simulation.resume(tmp_path / "cut").run(out_dir=tmp_path / "cut", progress=False)
    ref_text = (tmp_path / "ref" / "gauges.csv").read_bytes()
    assert (tmp_path / "cut" / "gauges.csv").read_bytes() == ref_text
