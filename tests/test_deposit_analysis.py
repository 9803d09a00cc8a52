"""The deposit report of `tiseg fingers` (tiseg.post.analysis.deposit), on fields files whose
answers are known by construction, and on a real run that comes to rest."""

from __future__ import annotations

import json

import numpy as np
import pytest

from tiseg.post.analysis.deposit import deposit_metrics, settle_index, stop_index
from tiseg.post.analysis.fingers import analyse_run
from tiseg.apps.cli import main


def test_stop_index_is_the_first_time_from_which_the_flow_stays_at_rest():
    assert stop_index([0.3, 0.1, 0.0, 0.0]) == 2
    assert stop_index([0.3, 0.0, 0.2, 0.0]) == 3  # a flow that restarts has not stopped
    assert stop_index([0.3, 0.1, 2e-3]) is None
    assert stop_index([0.3, 0.0, None]) == 1  # a time without wet cells is at rest
    assert stop_index([0.3, 5e-4, 1e-4], rest_speed=1e-3) == 1
    assert stop_index([]) is None


def test_settle_index_is_the_first_time_from_which_the_momentum_stays_small():
    assert settle_index([0.0, 2.0, 1.0, 1e-5, 1e-6]) == 3  # at most 1e-5 of the peak 2
    assert settle_index([0.0, 2.0, 1.0, 1e-4, 1e-6]) == 4
    assert settle_index([2.0, 1e-6, 1.0, 1e-6]) == 3  # a flow that picks up again had not
    assert settle_index([2.0, 1e-6, 1.0], settle_fraction=0.5) == 1
    assert settle_index([0.0, 0.0]) == 0  # nothing ever moved
    assert settle_index([]) is None


@pytest.fixture(scope="module")
def deposit_run(tmp_path_factory):
    """A fields.nc of the fingers scene at 40 cells/m (60 x 20 cells, dx = dy = 2.5 cm): a front
    moving at t = 1, 2, at rest from t = 3 on. The deposit covers columns 0..29 in rows 0..9
    (channels: phi = 0.9, h = 1 mm) and columns 0..24 in rows 10..19 (levees: phi = 0.1,
    h = 3 mm)."""
    from tiseg.output import FieldsWriter
    from tiseg.setup.scene import load_scene

    scene = load_scene("fingers", {"domain.resolution": 40})
    x, y = scene.domain.cell_centres()
    ny, nx = scene.domain.shape
    d = tmp_path_factory.mktemp("deposit")
    cols = np.arange(nx)[None, :]
    rows = np.arange(ny)[:, None]
    chan = rows < 10
    with FieldsWriter(
        d / "fields.nc", x, y, attrs={"scene": scene.to_toml()}, fields=("h", "u", "v", "phi")
    ) as w:
        for t, tip, speed in [(1.0, 20, 0.1), (2.0, 27, 0.02), (3.0, 30, 0.0), (4.0, 30, 0.0)]:
            wet = cols < np.where(chan, tip, tip - 5)
            h = np.where(wet, np.where(chan, 1e-3, 3e-3), 0.0)
            phi = np.where(wet, np.where(chan, 0.9, 0.1), 0.0)
            u = np.where(wet, speed, 0.0)
            w.write(t, h=h, u=u, v=0.5 * u, phi=phi)
    return d


def test_deposit_of_a_run_that_came_to_rest(deposit_run):
    d = analyse_run(deposit_run)["deposit"]
    dx = 0.025
    assert d["stopped"] and d["stop_time"] == 3.0 and d["moving_until"] == 2.0
    assert d["max_speed"] == pytest.approx([0.1 * np.hypot(1, 0.5), 0.02 * np.hypot(1, 0.5), 0, 0])
    assert d["run_out"] == pytest.approx(29.5 * dx)  # the cell centre of the last wet column
    assert not d["run_out_at_domain_end"]
    n_ch, n_lev = 10 * 30, 10 * 25
    assert d["channel_thickness"] == pytest.approx(1e-3)
    assert d["levee_thickness"] == pytest.approx(3e-3)
    assert d["thickness_max"] == pytest.approx(3e-3)
    assert d["thickness_mean"] == pytest.approx((n_ch * 1e-3 + n_lev * 3e-3) / (n_ch + n_lev))
    assert d["area"] == pytest.approx((n_ch + n_lev) * dx * dx)
    assert d["volume"] == pytest.approx((n_ch * 1e-3 + n_lev * 3e-3) * dx * dx)
    # at rest is settled, by the same time; the snapshots at 3 and 4 s are the same
    assert d["settled"] and d["settle_time"] == 3.0 and d["basis"] == "rest"
    assert d["thickness_change"] == 0.0
    assert d["moving_cells"] == 0 and d["moving_volume"] == 0.0
    # momentum: sum of h |u| dx dy over the wet cells; at 1 s the channels (1 mm) reach
    # column 20, the levees (3 mm) column 15
    m1 = (10 * 20 * 1e-3 + 10 * 15 * 3e-3) * 0.1 * np.hypot(1, 0.5) * dx * dx
    assert d["momentum"][0] == pytest.approx(m1) and d["momentum"][2:] == [0.0, 0.0]


@pytest.fixture(scope="module")
def creeping_run(tmp_path_factory):
    """A fields.nc (fingers scene at 40 cells/m, 60 x 20 cells) of a deposit that settles but
    keeps one slow cell: a 2 mm layer over columns 0..29 moving at 0.1 m/s at t = 1 s, 1e-2
    at 2 s, then at rest but for the cell (row 5, column 10) of 0.2 mm moving at 1e-3 m/s
    at t = 3 and 4 s, where h also changes by 1e-6 m in column 29."""
    from tiseg.output import FieldsWriter
    from tiseg.setup.scene import load_scene

    scene = load_scene("fingers", {"domain.resolution": 40})
    x, y = scene.domain.cell_centres()
    ny, nx = scene.domain.shape
    d = tmp_path_factory.mktemp("creeping")
    wet = np.arange(nx)[None, :] < 30 + 0 * np.arange(ny)[:, None]
    with FieldsWriter(
        d / "fields.nc", x, y, attrs={"scene": scene.to_toml()}, fields=("h", "u", "v", "phi")
    ) as w:
        for t, speed in [(1.0, 0.1), (2.0, 1e-2), (3.0, 0.0), (4.0, 0.0)]:
            h = np.where(wet, 2e-3, 0.0)
            u = np.where(wet, speed, 0.0)
            if speed == 0.0:
                h[5, 10] = 2e-4
                u[5, 10] = 1e-3
                h[:, 29] += 1e-6 * (t - 3.0)
            w.write(t, h=h, u=u, v=0 * u, phi=np.where(wet, 0.3, 0.0))
    return d


def test_a_deposit_that_settles_with_a_creeping_cell(creeping_run, capsys):
    dx = 0.025
    d = analyse_run(creeping_run)["deposit"]
    # the momentum 2e-4 * 1e-3 dx^2 of the slow cell is 1e-6 of the peak at 1 s
    peak = 600 * 2e-3 * 0.1 * dx * dx
    assert d["momentum"][0] == pytest.approx(peak)
    assert d["momentum"][2] / peak == pytest.approx(2e-4 * 1e-3 / (600 * 2e-3 * 0.1))
    assert not d["stopped"] and d["stop_time"] is None
    assert d["settled"] and d["basis"] == "settled"
    assert d["settle_time"] == 3.0 and d["settling_until"] == 2.0
    assert d["run_out"] == pytest.approx(29.5 * dx)
    assert d["moving_cells"] == 1 and d["moving_max_speed"] == pytest.approx(1e-3)
    assert d["moving_volume"] == pytest.approx(2e-4 * dx * dx)
    assert d["thickness_change"] == pytest.approx(1e-6)
    # with a stricter fraction it has not settled either
    strict = analyse_run(creeping_run, settle_fraction=1e-7)["deposit"]
    assert not strict["settled"] and strict["run_out"] is None
    assert main(["fingers", str(creeping_run)]) == 0
    last = capsys.readouterr().out.splitlines()[-1]
    assert last.startswith("deposit: settled between t = 2 and 3 s"), last
    assert "1 cell (" in last and "0.001 m/s" in last
    assert main(["fingers", str(creeping_run), "--settle-fraction", "1.5"]) == 2
    assert "--settle-fraction" in capsys.readouterr().err


def test_cli_reports_the_deposit(deposit_run, capsys):
    assert main(["fingers", str(deposit_run)]) == 0
    last = capsys.readouterr().out.splitlines()[-1]
    assert last.startswith("deposit: at rest between t = 2 and 3 s") and "0.7375 m" in last
    assert main(["fingers", str(deposit_run), "--json", "--time", "1"]) == 0
    o = json.loads(capsys.readouterr().out)
    assert o["time"] == [1.0] and o["deposit"]["stop_time"] == 3.0  # all times, whatever --time
    # with a rest speed above the front's last speed, it counts as stopped one output earlier
    assert main(["fingers", str(deposit_run), "--json", "--rest-speed", "0.05"]) == 0
    assert json.loads(capsys.readouterr().out)["deposit"]["stop_time"] == 2.0
    assert main(["fingers", str(deposit_run), "--rest-speed", "-1"]) == 2
    assert "--rest-speed" in capsys.readouterr().err


def test_a_flow_still_moving_has_no_deposit():
    d = deposit_metrics(
        [1.0, 2.0],
        [0.2, 0.05],
        np.ones((2, 3)) * 1e-3,
        np.ones((2, 3)),
        np.arange(3) * 0.1,
        np.arange(2) * 0.1,
        1e-4,
        0.4,
        0.2,
    )
    assert d["stopped"] is False and d["run_out"] is None and d["thickness_mean"] is None


@pytest.mark.slow  # a long run: the slow set (README), which CI runs after the suite
def test_a_finite_release_with_the_extended_law_comes_to_rest(ti_cpu, tmp_path, capsys):
    """A coarse-rich block (phi = 0.2) released on a 27 degree slope: its static friction
    holds only thinner layers, so it slumps, spreads, and comes to rest on the chute; `tiseg
    fingers` reports the stop between two output times and the run-out inside the domain."""
    import tomli_w

    scene = {
        "flow": {"h0": 0.002, "phi0": 0.2, "nu": 0.0},
        "effects": {"friction": "pouliquen-extended", "viscosity": False},
        "domain": {"Lx": 0.4, "Ly": 0.1, "nx": 80, "ny": 4},
        "boundary": {"x_lo": "wall", "x_hi": "outflow", "y_lo": "periodic", "y_hi": "periodic"},
        "initial": {"kind": "release", "x0": 0.02, "x1": 0.1, "h": 0.006, "phi": 0.2},
        "numerics": {
            "reconstruction": "minmod",
            "stepper": "ssprk3",
            "friction_scheme": "projected",
        },
        "time": {"t_end": 2.0},
        "output": {"times": [0.5, 1.0, 1.5, 2.0]},
    }
    path = tmp_path / "block.toml"
    path.write_text(tomli_w.dumps(scene))
    out = tmp_path / "run"
    assert main(["run", str(path), "--out", str(out), "--no-progress", "-q"]) == 0
    capsys.readouterr()
    assert main(["fingers", str(out), "--json"]) == 0
    d = json.loads(capsys.readouterr().out)["deposit"]
    assert d["stopped"] and d["stop_time"] <= 2.0 and d["basis"] == "rest"
    assert d["max_speed"][-1] == 0.0
    assert d["thickness_change"] == 0.0  # a deposit at rest keeps its h bitwise
    assert 0.1 < d["run_out"] < 0.39 and not d["run_out_at_domain_end"]
    # all the material is in the deposit: nothing reached the outflow
    assert d["volume"] / 0.1 == pytest.approx(0.006 * 0.08, rel=1e-2)  # films < h_min aside


def test_deposit_figure(deposit_run, tmp_path, capsys):
    """`tiseg figures deposit RUN_DIR` draws the deposit with its numbers in the caption."""
    import imageio.v3 as iio

    out = tmp_path / "fig"
    assert main(["figures", "deposit", str(deposit_run), "--out", str(out), "--dpi", "40"]) == 0
    png = out / "deposit.png"
    assert capsys.readouterr().out.strip() == str(png)
    img = iio.imread(png)
    assert img.ndim == 3 and img.shape[0] > 200 and img.shape[1] > 200
    assert main(["figures", "deposit", str(tmp_path / "nowhere"), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "does not exist" in err, err


@pytest.mark.slow
def test_the_finite_release_deposit_scene_comes_to_rest(ti_cpu, tmp_path, capsys):
    """The finite-release-deposit scene at 75 cells/m: every cell is at rest by 90 s, and the
    deposit then keeps its h bit for bit. Before the mass flux had a floor where a cell
    outruns its neighbour (RestRules.rest_face), 11 isolated fine-rich films
    just thicker than h_stop kept 5e-3 m/s from 90 s on at this resolution, while no mass
    moved."""
    out = tmp_path / "run"
    argv = ["run", "finite-release-deposit", "--out", str(out), "--no-progress", "-q"]
    for kv in ("domain.resolution=75", "time.t_end=90", "output.times=[]", "output.interval=15"):
        argv += ["--set", kv]
    assert main(argv) == 0
    capsys.readouterr()
    assert main(["fingers", str(out), "--json"]) == 0
    d = json.loads(capsys.readouterr().out)["deposit"]
    assert d["stopped"] and d["basis"] == "rest" and d["stop_time"] <= 90.0
    assert d["max_speed"][-1] == 0.0 and d["moving_cells"] == 0
    assert d["thickness_change"] == 0.0
    assert d["levee_thickness"] > 2 * d["channel_thickness"]  # coarse levees, thin channels
