"""Finger diagnostics (section 6.3, (6.10)-(6.12)) on synthetic fields with known answers.

Every expected number below follows from how the fields are built (cell indices of tips, rear,
channels), never from the code under test.
"""

import json

import numpy as np
import pytest

from tiseg.post.analysis.channels import column_runs, count_channels
from tiseg.post.analysis.fingers import analyse_run, finger_metrics, front_speed, periodic_runs
from tiseg.apps.cli import main

PHI0 = 0.8
H_MIN = 1e-4
U0 = 0.2
NX, NY = 100, 200
DX = 0.01  # Lx = 1 m
LY = 0.5
DY = LY / NY  # 2.5 mm
X = (np.arange(NX) + 0.5) * DX
Y = (np.arange(NY) + 0.5) * DY
I_REAR = 40  # first column of the coarse-rich zone: x_f- = 0.405 m
I_TIP = 79  # last wet column of the channels: x_f+ = 0.795 m


def build(
    channel,
    *,
    i_rear=I_REAR,
    i_tip=I_TIP,
    levee_tip=None,
    phi_channel=0.95,
    phi_levee=0.1,
    u_channel=2.0 * U0,
    u_levee=0.1 * U0,
):
    """Fields of a fingered front: behind column ``i_rear`` the mixed inflow (phi0, u0); from it
    on fine channels (rows where ``channel`` is True, wet up to ``i_tip``) and coarse levees
    (wet up to ``levee_tip``, default 10 cells behind the tips); dry (h = 0, phi = 0) ahead."""
    channel = np.asarray(channel, dtype=bool)
    levee_tip = i_tip - 10 if levee_tip is None else levee_tip
    i = np.arange(NX)[None, :]
    tip = np.where(channel, i_tip, levee_tip)[:, None]
    wet = i <= tip
    rear = i < i_rear
    chan = np.broadcast_to(channel[:, None], (NY, NX))
    h = np.where(wet, 0.002, 0.0)
    phi = np.where(rear, PHI0, np.where(chan, phi_channel, phi_levee))
    u = np.where(rear, U0, np.where(chan, u_channel, u_levee))
    phi = np.where(wet, phi, 0.0)
    u = np.where(wet, u, 0.0)
    return h, u, np.zeros_like(h), phi


def equal_channels(n, frac=0.6, y0=0.0):
    """n channels of width frac * Ly/n, the first starting at y0 (periodic)."""
    lam = LY / n
    return np.mod(Y - y0, lam) < frac * lam


def metrics(fields, **kw):
    h, u, v, phi = fields
    return finger_metrics(h, u, v, phi, X, Y, H_MIN, PHI0, kw.pop("u0", U0), **kw)


# ---- periodic runs --------------------------------------------------------------------------
def test_periodic_runs_basic():
    assert periodic_runs([1, 1, 0, 0, 1]) == [(4, 3)]  # wraps through the seam
    assert periodic_runs([0, 1, 1, 0, 1, 0]) == [(1, 2), (4, 1)]
    assert periodic_runs([1, 1, 1]) == [] and periodic_runs([0, 0]) == []
    assert periodic_runs([0, 1, 0, 1, 1, 0], min_width=2) == [(3, 2)]
    # a 1-cell gap closes a line on itself -> no levee -> no run
    assert periodic_runs([1, 1, 0, 1, 1, 1], min_gap=2) == []
    assert periodic_runs([1, 1, 0, 1, 1, 1, 0, 0], min_gap=2) == [(0, 6)]


def _runs_cell_by_cell(line, min_width, min_gap):
    """The noise-filtered periodic runs of one line, found cell by cell (a reference for
    `column_runs`): the sets of cells of each run, as (start, length) from the first gap cell
    on."""
    n = len(line)
    if all(line) or not any(line):
        return []
    k = line.index(False)  # walk from a gap cell: no run is cut by the walk's start
    runs, run = [], []
    for i in range(k, k + n):
        if line[i % n]:
            run.append(i)
        elif run:
            runs.append(run)
            run = []
    if run:
        runs.append(run)
    runs = [r for r in runs if len(r) >= min_width]
    merged = []
    for r in runs:  # join a run to the previous one across a gap narrower than min_gap
        if merged and r[0] - merged[-1][-1] - 1 < min_gap:
            merged[-1] = list(range(merged[-1][0], r[-1] + 1))
        else:
            merged.append(r)
    if merged and merged[0][0] + n - merged[-1][-1] - 1 < min_gap:
        if len(merged) == 1:
            return []
        last = merged.pop()
        merged[0] = list(range(last[0], merged[0][-1] + n + 1))
    return [(r[0] % n, len(r)) for r in merged]


@pytest.mark.parametrize("seed", range(4))
def test_column_runs_are_each_columns_runs_found_cell_by_cell(seed):
    rng = np.random.default_rng(seed)
    for _ in range(200):
        ny, ncols = int(rng.integers(1, 30)), int(rng.integers(1, 6))
        mask = rng.uniform(size=(ny, ncols)) < rng.uniform()
        width, gap = int(rng.integers(0, 4)), int(rng.integers(0, 5))
        runs = column_runs(mask, width, gap)
        for c in range(ncols):
            want = _runs_cell_by_cell(mask[:, c].tolist(), width, gap)
            assert runs.of(c) == want == periodic_runs(mask[:, c], width, gap)


def _count_by_flood_fill(chan, x, min_span):
    """max over s of the channels at x >= s reaching min_span along x, each found afresh by a
    flood fill of the channel cells of the columns at x >= s (4-neighbours, periodic in y): a
    reference for `count_channels` on masks that need no noise filter (a column that is
    channel all across has no levee: no channel)."""
    chan = chan & ~chan.all(axis=0)
    ny, nx = chan.shape
    dx = x[1] - x[0]
    best = 0
    for first in range(nx - 1, -1, -1):
        seen = np.zeros_like(chan)
        found = 0
        for i0, j0 in zip(*np.nonzero(chan[:, first:])):
            if seen[i0, j0 + first]:
                continue
            stack, cols = [(i0, j0 + first)], []
            seen[i0, j0 + first] = True
            while stack:
                i, j = stack.pop()
                cols.append(j)
                for a, b in ((i + 1) % ny, j), ((i - 1) % ny, j), (i, j + 1), (i, j - 1):
                    if first <= b < nx and chan[a, b] and not seen[a, b]:
                        seen[a, b] = True
                        stack.append((a, b))
            found += x[max(cols)] - x[min(cols)] + dx >= min_span * (1 - 1e-12)
        best = max(best, found)
    return best


@pytest.mark.parametrize("seed", range(3))
def test_channel_count_is_the_flood_fill_count(seed):
    rng = np.random.default_rng(seed)
    x = 0.01 * np.arange(12)
    for _ in range(60):
        chan = rng.uniform(size=(10, 12)) < rng.uniform(0.2, 0.7)
        span = float(rng.choice([0.0, 0.03, 0.06]))
        runs = column_runs(chan)
        count, _ = count_channels(runs, list(range(12)), x, span)
        assert count == _count_by_flood_fill(chan, x, span)


# ---- counting -------------------------------------------------------------------------------
@pytest.mark.parametrize("n", [1, 2, 3, 5, 8])
def test_equal_step_fingers(n):
    m = metrics(build(equal_channels(n)))
    assert m["finger_count"] == n
    assert m["wavelength"] == pytest.approx(LY / n)
    assert m["line_counts"] == [n] * (I_TIP - I_REAR + 1)


@pytest.mark.parametrize("n", [1, 4, 7])
def test_sinusoidal_fingers(n):
    h, u, v, _ = build(np.ones(NY, bool), levee_tip=I_TIP)
    phi_y = 0.5 + 0.45 * np.cos(2 * np.pi * n * Y / LY)
    phi = np.where(np.arange(NX)[None, :] < I_REAR, PHI0, phi_y[:, None]) * (h > 0)
    m = finger_metrics(h, u, v, phi, X, Y, H_MIN, PHI0, U0)
    assert m["finger_count"] == n
    assert m["wavelength"] == pytest.approx(LY / n)


@pytest.mark.parametrize("n", [1, 3, 6])
def test_fingers_straddling_the_seam_count_once(n):
    lam = LY / n
    chan = equal_channels(n, frac=0.5, y0=-0.25 * lam)  # a channel centred on y = 0 = Ly
    assert chan[0] and chan[-1]  # the set-up straddles the seam
    m = metrics(build(chan))
    assert m["finger_count"] == n
    assert m["wavelength"] == pytest.approx(LY / n)
    # half a wavelength, to within the cell the channel edges snap to
    assert sorted(m["channel_widths"]) == pytest.approx([0.5 * lam] * n, abs=1.01 * DY)


def test_uneven_widths():
    chan = np.zeros(NY, bool)
    chan[190:] = chan[:5] = True  # 15 cells through the seam
    chan[8:10] = True  # 2 cells (the narrowest kept by default)
    chan[12:42] = True
    chan[50:62] = True
    chan[70:130] = True
    m = metrics(build(chan))
    assert m["finger_count"] == 5
    assert m["wavelength"] == pytest.approx(LY / 5)
    assert sorted(m["channel_widths"]) == pytest.approx(sorted(np.array([15, 2, 30, 12, 60]) * DY))


def test_merging_across_narrow_gap():
    chan = np.zeros(NY, bool)
    chan[20:60] = True
    chan[61:100] = True  # 1-cell coarse gap at 60
    chan[140:170] = True
    m = metrics(build(chan))
    assert m["finger_count"] == 2  # 20..100 is one finger
    assert sorted(m["channel_widths"]) == pytest.approx([30 * DY, 80 * DY])
    assert metrics(build(chan), min_gap=0.0)["finger_count"] == 3  # no merging
    chan[60:65] = False  # a 5-cell levee: two fingers ...
    assert metrics(build(chan))["finger_count"] == 3
    assert metrics(build(chan), min_gap=6 * DY)["finger_count"] == 2  # ... unless min_gap > 5 cells


def test_narrow_runs_are_noise():
    chan = equal_channels(4)
    chan[85] = True  # an isolated fine cell in a levee
    chan[91:93] = True  # a 2-cell run
    assert not chan[84] and not chan[86] and not chan[90] and not chan[93]
    assert metrics(build(chan))["finger_count"] == 5  # the 2-cell run counts by default
    assert metrics(build(chan), min_width=3 * DY)["finger_count"] == 4


def test_persistent_count_and_median_lines():
    # the band x_f- .. x_f+ spans columns 40..79 (40 lines); four fingers
    chan = equal_channels(4)
    h, u, v, phi = build(chan)
    phi[10:15, 45:56] = 0.1  # a coarse island splits the first channel on columns 45..55
    h[50:80, 71:] = 0.0  # the second finger ends at column 70
    m = finger_metrics(h, u, v, phi, X, Y, H_MIN, PHI0, U0)
    assert m["line_x"] == pytest.approx(X[40:80])
    expect = [4] * 5 + [5] * 11 + [4] * 15 + [3] * 9
    assert m["line_counts"] == expect
    assert m["finger_count"] == 4 and m["count_length"] == pytest.approx(20 * DX)
    # the median of three lines (columns 50, 59 or 60, 69 -> counts 5, 4, 4)
    assert (
        finger_metrics(h, u, v, phi, X, Y, H_MIN, PHI0, U0, line_fractions=[0.25, 0.5, 0.75])[
            "finger_count"
        ]
        == 4
    )
    assert (
        finger_metrics(h, u, v, phi, X, Y, H_MIN, PHI0, U0, line_fractions=[0.25])["finger_count"]
        == 5
    )
    assert m["finger_count_lines"] == 4
    # the island now covers most of the band: 5 persists longest on the lines, but the split
    # channel joins again at both ends of the island: still 4 fingers as 2D channels
    phi[10:15, 41:71] = 0.1
    m = finger_metrics(h, u, v, phi, X, Y, H_MIN, PHI0, U0)
    assert m["finger_count_lines"] == 5 and m["finger_count"] == 4


def test_persistent_count_tie_goes_to_more_fingers():
    chan = equal_channels(4)
    h, u, v, phi = build(chan)
    h[150:180, 60:] = 0.0  # the fourth finger ends at column 59: 4 on 20 columns, 3 on 20
    m = finger_metrics(h, u, v, phi, X, Y, H_MIN, PHI0, U0)
    assert m["line_counts"] == [4] * 20 + [3] * 20
    assert m["finger_count"] == 4


def test_count_must_persist():
    # two fingers only on the last 3 of 40 columns (a short-lived incursion): not enough by
    # default (channels: 10 % of x_l = 3.9 cm > 3 cells; lines: 10 % = 4 columns), enough with
    # a lower min_span or persistence
    h, u, v, phi = build(np.zeros(NY, bool), levee_tip=I_TIP)  # coarse head, no fingers
    phi[20:40, 77:80] = 0.9
    phi[120:140, 77:80] = 0.9
    m = finger_metrics(h, u, v, phi, X, Y, H_MIN, PHI0, U0)
    assert m["finger_count"] == 0 and m["finger_count_lines"] == 0
    m = finger_metrics(h, u, v, phi, X, Y, H_MIN, PHI0, U0, min_persistence=0.05)
    assert m["finger_count_lines"] == 2 and m["finger_count"] == 0
    m = finger_metrics(h, u, v, phi, X, Y, H_MIN, PHI0, U0, min_span=0.07)
    assert m["finger_count"] == 2 and m["wavelength"] == pytest.approx(LY / 2)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_noise_does_not_add_fingers(seed):
    rng = np.random.default_rng(seed)
    h, u, v, phi = build(equal_channels(5))
    phi = phi + np.where(h > 0, rng.normal(0.0, 0.08, phi.shape), 0.0)
    # salt and pepper: isolated single cells flipped between fine and coarse (every 7th row)
    rows = np.arange(3, NY, 7)
    cols = rng.integers(I_REAR, I_TIP - 10, rows.size)
    phi[rows, cols] = np.where(phi[rows, cols] > 0.5, 0.05, 0.95)
    m = finger_metrics(h, u, v, phi, X, Y, H_MIN, PHI0, U0)
    assert m["finger_count"] == 5


def test_uniform_coarse_head_has_no_fingers():
    h, u, v, phi = build(np.zeros(NY, bool), levee_tip=I_TIP)  # coarse all across the front
    m = finger_metrics(h, u, v, phi, X, Y, H_MIN, PHI0, U0)
    assert m["finger_count"] == 0 and m["wavelength"] is None
    assert m["max_channel_speed_over_u0"] is None
    assert m["x_front_max"] == pytest.approx((I_TIP + 0.5) * DX)
    assert m["x_front_min"] == pytest.approx((I_REAR + 0.5) * DX)


@pytest.mark.parametrize("phi0", [1.0, 0.8])
def test_monodisperse_front_has_no_fingers(phi0):
    h, u, v, _ = build(np.ones(NY, bool))
    phi = np.where(h > 0, 1.0, 0.0)
    m = finger_metrics(h, u, v, phi, X, Y, H_MIN, phi0, U0)
    assert m["finger_count"] == 0 and m["wavelength"] is None
    assert m["x_front_min"] is None and m["elongation"] is None
    assert m["x_front_max"] == pytest.approx((I_TIP + 0.5) * DX)


def test_all_fine_band_has_no_fingers():
    # coarse only in a small island far behind: every sample line is wet and fine all across
    h, u, v, _ = build(np.ones(NY, bool))
    phi = np.where(h > 0, 0.9, 0.0)
    phi[7, 12] = 0.1
    m = finger_metrics(h, u, v, phi, X, Y, H_MIN, PHI0, U0)
    assert m["x_front_min"] == pytest.approx(12.5 * DX)
    assert m["finger_count"] == 0 and m["wavelength"] is None


# ---- fronts (6.10)-(6.12) -------------------------------------------------------------------
def test_front_positions():
    chan = equal_channels(3)
    h, u, v, phi = build(chan)
    # one finger runs further: its tip at column 86; a wet cell exactly at h_min counts as wet,
    # one just below does not
    row = int(np.flatnonzero(chan)[5])
    h[row, 80:87] = 0.002
    phi[row, 80:87] = 0.95
    h[row, 87] = H_MIN
    phi[row, 87] = 0.9
    h[row, 88] = 0.999 * H_MIN
    # a coarse island further back (x_f-), and a dry cell with phi = 0 even further back, which
    # must not count as coarse
    levee_row = int(np.flatnonzero(~chan)[3])
    phi[levee_row, 31] = 0.2
    h[levee_row, 20] = 0.0
    phi[levee_row, 20] = 0.0
    m = finger_metrics(h, u, v, phi, X, Y, H_MIN, PHI0, U0)
    assert m["x_front_max"] == pytest.approx(0.875)
    assert m["x_front_min"] == pytest.approx(0.315)
    assert m["elongation"] == pytest.approx(0.875 - 0.315)


def test_empty_slope():
    z = np.zeros((NY, NX))
    m = finger_metrics(z, z, z, z, X, Y, H_MIN, PHI0, U0)
    assert m["x_front_max"] is None and m["x_front_min"] is None and m["finger_count"] == 0


def test_front_speed():
    assert front_speed([1.0, 1.5], [0.30, 0.41]) == pytest.approx([0.22, 0.22])
    # chord through the neighbours for unequal spacing, one-sided at the ends
    s = front_speed([0.0, 1.0, 3.0], [0.1, 0.3, 0.9])
    assert s == pytest.approx([0.2, 0.8 / 3.0, 0.3])
    # no flow at t = 0: undefined there, one-sided next to it
    assert front_speed([0.0, 0.5, 1.0, 1.5], [None, 0.1, 0.2, 0.4]) == [
        None,
        pytest.approx(0.2),
        pytest.approx(0.3),
        pytest.approx(0.4),
    ]
    assert front_speed([2.0], [0.5]) == [None]


def test_channel_speed_ratio():
    chan = equal_channels(4)
    h, u, v, phi = build(chan, u_channel=1.5 * U0)
    r = int(np.flatnonzero(chan)[10])
    u[r, 60], v[r, 60] = 1.6 * U0, 1.2 * U0  # |u| = 2 u0 in a channel
    lv = int(np.flatnonzero(~chan)[4])
    u[lv, 55] = 5 * U0  # fast but coarse (levee): not a channel
    u[r, 10] = 6 * U0  # fast but behind x_f-: not in the fingers
    u[r, 95] = 7 * U0  # fast but dry
    m = finger_metrics(h, u, v, phi, X, Y, H_MIN, PHI0, U0)
    assert m["max_channel_speed"] == pytest.approx(2 * U0)
    assert m["max_channel_speed_over_u0"] == pytest.approx(2.0)
    assert finger_metrics(h, u, v, phi, X, Y, H_MIN, PHI0)["max_channel_speed_over_u0"] is None


def test_speed_criterion_option():
    chan = equal_channels(3)
    h, u, v, phi = build(chan)
    # one channel is fine-rich but slow: with the speed criterion it is not a channel
    slow = np.flatnonzero(chan)[: int(chan.sum() / 3)]
    u[slow, I_REAR:] = 0.2 * U0
    assert finger_metrics(h, u, v, phi, X, Y, H_MIN, PHI0, U0)["finger_count"] == 3
    assert (
        finger_metrics(h, u, v, phi, X, Y, H_MIN, PHI0, U0, min_speed_over_u0=1.0)["finger_count"]
        == 2
    )


# ---- saved runs and the command line ----------------------------------------------------------
@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    """A tiny fields.nc of the fingers scene at 40 cells/m (60 x 20 cells, dx = dy = 2.5 cm):
    t = 1, 2: uniform coarse head; t = 3: two fingers (rows 2..7 and 12..17)."""
    from tiseg.output import FieldsWriter
    from tiseg.setup.scene import load_scene

    scene = load_scene("fingers", {"domain.resolution": 40})
    x, y = scene.domain.cell_centres()
    ny, nx = scene.domain.shape
    u0 = scene.flow.u0
    d = tmp_path_factory.mktemp("run")
    cols = np.arange(nx)[None, :]
    with FieldsWriter(
        d / "fields.nc", x, y, attrs={"scene": scene.to_toml()}, fields=("h", "u", "v", "phi")
    ) as w:
        for t, tip, rear in [(1.0, 10, 6), (2.0, 14, 9), (3.0, 20, 11)]:
            chan = np.zeros(ny, bool)
            if t == 3.0:
                chan[2:8] = chan[12:18] = True
            tips = np.where(chan, tip, tip - 3)[:, None] if t == 3.0 else tip
            wet = np.broadcast_to(cols <= tips, (ny, nx))
            h = np.where(wet, 0.002, 0.0)
            phi = np.where(cols < rear, 0.8, np.where(chan[:, None], 0.9, 0.1)) * wet
            u = np.where(cols < rear, 1.0, np.where(chan[:, None], 2.0, 0.1)) * u0 * wet
            w.write(t, h=h, u=u, v=np.zeros_like(h), phi=phi)
    return d


def test_analyse_run(run_dir):
    r = analyse_run(run_dir)
    dx = 0.025
    assert r["time"] == [1.0, 2.0, 3.0]
    assert r["x_front_max"] == pytest.approx([10.5 * dx, 14.5 * dx, 20.5 * dx])
    assert r["x_front_min"] == pytest.approx([6.5 * dx, 9.5 * dx, 11.5 * dx])
    assert r["elongation"] == pytest.approx([4 * dx, 5 * dx, 9 * dx])
    assert r["finger_count"] == [0, 0, 2]
    assert r["wavelength"][:2] == [None, None] and r["wavelength"][2] == pytest.approx(0.25)
    assert r["front_speed"] == pytest.approx([4 * dx, 10 * dx / 2, 6 * dx])
    assert r["max_channel_speed_over_u0"][:2] == [None, None]
    assert r["max_channel_speed_over_u0"][2] == pytest.approx(2.0)
    assert r["phi0"] == 0.8 and r["h_min"] == 1e-4 and r["Ly"] == 0.5
    assert r["u0"] == pytest.approx(0.2079, abs=1e-4)  # the steady state of figure 12


def test_cli_json(run_dir, capsys):
    assert main(["fingers", str(run_dir), "--json"]) == 0
    o = json.loads(capsys.readouterr().out)
    for key in (
        "time",
        "x_front_max",
        "x_front_min",
        "elongation",
        "finger_count",
        "wavelength",
        "front_speed",
        "max_channel_speed_over_u0",
    ):
        assert len(o[key]) == 3, key
    assert o["finger_count"] == [0, 0, 2] and o["wavelength"][0] is None

    assert main(["fingers", str(run_dir / "fields.nc"), "--json", "--time", "3"]) == 0
    o = json.loads(capsys.readouterr().out)
    assert o["time"] == [3.0] and o["finger_count"] == [2]
    assert o["front_speed"] == pytest.approx([6 * 0.025])  # still uses t = 2


def test_cli_table(run_dir, capsys):
    assert main(["fingers", str(run_dir)]) == 0
    out = capsys.readouterr().out.splitlines()
    assert "phi0 = 0.8" in out[0]
    header = out[2].split()
    assert header[:3] == ["t", "[s]", "x_f+"] and "fingers" in header
    rows = [line.split() for line in out[3:-1]]
    assert len(rows) == 3 and rows[2][0] == "3"
    assert out[-1].startswith("deposit: the flow has not come to rest")  # it moves at t = 3
    assert rows[0][4] == "0" and rows[0][5] == "-" and rows[2][4] == "2"
    assert float(rows[2][5]) == pytest.approx(0.25)


def _fails(capsys, argv, *words):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("tiseg fingers: error:"), err
    for w in words:
        assert w in err, err


def test_cli_errors(tmp_path, run_dir, capsys):
    _fails(capsys, ["fingers", str(tmp_path / "nowhere")], "does not exist")
    _fails(capsys, ["fingers", str(tmp_path)], "no fields.nc")
    junk = tmp_path / "junk.nc"
    junk.write_text("not a netcdf file\n")
    _fails(capsys, ["fingers", str(junk)], "cannot read")
    _fails(capsys, ["fingers", str(run_dir), "--time", "2.5"], "not an output time", "2.5")
    _fails(capsys, ["fingers", str(run_dir), "--lines", "0.5", "1.5"], "--lines")
    _fails(capsys, ["fingers", str(run_dir), "--min-persistence", "2"], "--min-persistence")
    _fails(capsys, ["fingers", str(run_dir), "--min-span", "-0.1"], "--min-span")

    from tiseg.output import FieldsWriter

    nophi = tmp_path / "nophi"  # without a stored scene: h_min is unknown
    with FieldsWriter(nophi / "fields.nc", X[:5], Y[:4], fields=("h", "u")) as w:
        w.write(0.0, h=np.zeros((4, 5)), u=np.zeros((4, 5)))
    _fails(capsys, ["fingers", str(nophi)], "no readable scene", "give h_min")
    nou = tmp_path / "nou"
    with FieldsWriter(nou / "fields.nc", X[:5], Y[:4], fields=("h",)) as w:
        w.write(0.0, h=np.zeros((4, 5)))
    _fails(capsys, ["fingers", str(nou)], "no u field")


# ---- a run without segregation: fronts and deposit, no fingers -------------------------------
@pytest.fixture(scope="module")
def dam_dir(tmp_path_factory):
    """A fields.nc of the 1D dam-break scene (no phi) at 100 cells (dx = 3 mm) whose wet front
    stands on columns 40, 46, 50, 52, 52 at t = 0, 0.1, 0.2, 0.3, 0.4 and stops at t = 0.3."""
    from tiseg.output import FieldsWriter
    from tiseg.setup.scene import load_scene

    scene = load_scene("dam-break", {"domain.nx": 100})
    x, y = scene.domain.cell_centres()
    cols = np.arange(100)[None, :]
    d = tmp_path_factory.mktemp("dam")
    with FieldsWriter(
        d / "fields.nc", x, y, attrs={"scene": scene.to_toml()}, fields=("h", "u")
    ) as w:
        for t, tip in [(0.0, 40), (0.1, 46), (0.2, 50), (0.3, 52), (0.4, 52)]:
            wet = cols <= tip
            h = np.where(wet, 0.001, 0.0)
            u = np.where(wet & (t < 0.3) & (cols > 30), 0.05, 0.0)
            w.write(t, h=h, u=u)
    return d


def test_a_run_without_phi_has_fronts_and_a_deposit(dam_dir):
    """x_f^+ and its speed at every time, the deposit's run-out and stop time; every finger
    number is None and the JSON has every key of a run with phi."""
    from tiseg.post.analysis.fingers import RUN_KEYS

    dx = 0.003
    r = analyse_run(dam_dir)
    assert r["segregation"] is False and r["times"] == 5
    assert r["x_front_max"] == pytest.approx([(i + 0.5) * dx for i in (40, 46, 50, 52, 52)])
    assert r["front_speed"] == pytest.approx(
        [6 * dx / 0.1, 10 * dx / 0.2, 6 * dx / 0.2, 2 * dx / 0.2, 0.0]
    )
    for key in set(RUN_KEYS) - {"time", "x_front_max", "front_speed", "front_speed_over_u0"}:
        assert r[key] == [None] * 5, key
    d = r["deposit"]
    assert d["stopped"] and d["stop_time"] == 0.3 and d["moving_until"] == pytest.approx(0.2)
    assert d["run_out"] == pytest.approx(52.5 * dx)
    assert d["volume"] == pytest.approx(53 * 0.001 * dx)  # per metre of width (1D)
    assert d["channel_thickness"] is None and d["levee_thickness"] is None


def test_cli_on_a_run_without_phi(dam_dir, capsys):
    """The table shows the front columns only and the deposit without channels and levees;
    --json keeps the keys of a run with phi (null finger numbers) and adds segregation."""
    assert main(["fingers", str(dam_dir)]) == 0
    out = capsys.readouterr().out.splitlines()
    assert "no segregation" in out[0] and not any(line.startswith("channels:") for line in out)
    assert out[1].split() == ["t", "[s]", "x_f+", "[m]", "dx_f+/dt", "[m/s]"]
    assert len(out) == 2 + 5 + 1
    assert out[-1].startswith("deposit: at rest between t = 0.2 and 0.3 s; run-out x_f+ = 0.1575")
    assert "levees" not in out[-1]
    assert main(["fingers", str(dam_dir), "--json", "--time", "0.2"]) == 0
    o = json.loads(capsys.readouterr().out)
    assert o["segregation"] is False and o["finger_count"] == [None]
    assert o["x_front_max"] == [pytest.approx(50.5 * 0.003)]
    assert o["deposit"]["run_out"] == pytest.approx(52.5 * 0.003)


def test_bad_options():
    h, u, v, phi = build(equal_channels(2))
    with pytest.raises(ValueError, match="line_fractions"):
        finger_metrics(h, u, v, phi, X, Y, H_MIN, PHI0, line_fractions=[1.2])
    with pytest.raises(ValueError, match="shape"):
        finger_metrics(h, u, v, phi[:, :-1], X, Y, H_MIN, PHI0)
    with pytest.raises(ValueError, match="u0"):
        finger_metrics(h, u, v, phi, X, Y, H_MIN, PHI0, min_speed_over_u0=1.0)


# ---- the headline count as 2D channels, the spectral wavelength, channel numbers ------------
def unequal_fingers(n, tips, i_rear=I_REAR):
    """n equal channels whose k-th one is wet up to column tips[k] (levees to min(tips) - 10)."""
    chan = equal_channels(n)
    h, u, v, phi = build(chan, i_rear=i_rear, levee_tip=min(tips) - 10)
    lam_rows = NY // n
    for k, tip in enumerate(tips):
        rows = slice(k * lam_rows, (k + 1) * lam_rows)
        h[rows, tip + 1 :] = 0.0
        phi[rows, tip + 1 :] = 0.0
        u[rows, tip + 1 :] = 0.0
    return h, u, v, phi


@pytest.mark.parametrize("n", [2, 5, 8])
def test_unequal_finger_lengths_count_every_finger(n):
    """Fingers of very different lengths: the lines near the front cross only the longest,
    the 2D count finds all n, and with several fingers the spectral wavelength is Ly / n.
    (With two fingers, one alone over half of the zone, the spectrum leans to mode 1: it
    weighs every column, the count weighs every finger.)"""
    tips = [I_TIP - (k * 23) % 30 for k in range(n)]  # tips 30 columns apart at most
    m = metrics(unequal_fingers(n, tips))
    assert m["finger_count"] == n
    assert m["wavelength"] == pytest.approx(LY / n)
    if n > 2:
        assert m["wavelength_spectral"] == pytest.approx(LY / n, rel=0.05)
    assert min(m["line_counts"]) < n  # single lines do miss fingers


def test_equal_fingers_spectral_wavelength_is_exact():
    """n | NY: exactly n periods, no power in the neighbouring bins, Ly / n exactly; otherwise
    the edges snap to cells and the peak moves by a little."""
    for n in (2, 4, 5, 8):
        m = metrics(build(equal_channels(n)))
        assert m["wavelength_spectral"] == pytest.approx(LY / n, rel=1e-12)
    for n in (3, 7):
        m = metrics(build(equal_channels(n)))
        assert m["wavelength_spectral"] == pytest.approx(LY / n, rel=0.02)


@pytest.mark.parametrize("n", [2, 4, 5])
def test_seam_fingers_spectral(n):
    chan = equal_channels(n, frac=0.5, y0=-0.25 * LY / n)
    assert chan[0] and chan[-1]
    m = metrics(build(chan))
    assert m["finger_count"] == n
    assert m["wavelength_spectral"] == pytest.approx(LY / n, rel=1e-12)


def test_spectral_peak_is_refined_between_bins():
    """A cross-slope pattern whose power spectrum is a Gaussian around mode 5.3: the Gaussian
    interpolation of the peak gives Ly / 5.3, between the bins 5 and 6."""
    h, u, v, _ = build(np.ones(NY, bool), levee_tip=I_TIP)
    modes = np.arange(1, 20)
    amp = np.exp(-((modes - 5.3) ** 2) / (2 * 1.2**2))  # power exp(-(n - 5.3)^2 / 1.2^2)
    prof = 0.25 + 0.04 * (amp[:, None] * np.cos(2 * np.pi * np.outer(modes, Y) / LY)).sum(axis=0)
    phi = np.where(np.arange(NX)[None, :] < I_REAR, PHI0, prof[:, None]) * (h > 0)
    m = finger_metrics(h, u, v, phi, X, Y, H_MIN, PHI0, U0)
    assert m["wavelength_spectral"] == pytest.approx(LY / 5.3, rel=1e-9)


def test_merging_pair_counts_two_and_split_channel_counts_one():
    """A Y: two channels separate over the last 20 columns join into one behind: two fingers.
    A channel split by a coarse island that joins again before its tip: one finger."""
    chan = equal_channels(4)
    h, u, v, phi = build(chan)
    rows = np.flatnonzero(chan)
    a = rows[rows < 50]  # the first channel: rows 0..29
    lo, hi = a.max() + 1, 50  # its levee, rows 30..49
    phi[lo:hi, I_REAR:60] = 0.95  # ... fine behind column 60: a Y
    u[lo:hi, I_REAR:60] = 2 * U0
    m = finger_metrics(h, u, v, phi, X, Y, H_MIN, PHI0, U0)
    assert m["finger_count"] == 4  # the Y is two fingers
    # ... while the same join at the tips (an island behind) makes one finger
    h, u, v, phi = build(chan)
    phi[lo:hi, 60:] = np.where(h[lo:hi, 60:] > 0, 0.95, 0.0)
    h[lo:hi, 60:] = 0.002
    phi[lo:hi, 60:] = 0.95
    assert finger_metrics(h, u, v, phi, X, Y, H_MIN, PHI0, U0)["finger_count"] == 3


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_noise_keeps_the_count_and_the_spectral_wavelength(seed):
    rng = np.random.default_rng(10 + seed)
    tips = [I_TIP, I_TIP - 12, I_TIP - 5, I_TIP - 20, I_TIP - 8]
    h, u, v, phi = unequal_fingers(5, tips)
    phi = np.clip(phi + np.where(h > 0, rng.normal(0.0, 0.08, phi.shape), 0.0), 0, 1)
    rows = np.arange(3, NY, 7)
    cols = rng.integers(I_REAR, I_TIP - 30, rows.size)
    phi[rows, cols] = np.where(phi[rows, cols] > 0.5, 0.05, 0.95)
    m = finger_metrics(h, u, v, phi, X, Y, H_MIN, PHI0, U0)
    assert m["finger_count"] == 5
    assert m["wavelength_spectral"] == pytest.approx(LY / 5, rel=0.05)


def test_envelope_mode_1_does_not_hide_the_fingers():
    """Eight irregularly spaced fingers of which three neighbours are much longer, as the
    one-period inflow perturbation (6.9) makes them (seen at nu = 0.005, 500 cells/m: three
    long fingers side by side reaching far behind and ahead of the others): over most of the
    zone only the long ones exist, and mode 1 holds more power than the finger mode. The
    spectral wavelength still finds the fingers (mode 1 is excluded), and so does the count."""
    n = 8
    spacing = np.array([5.0, 7.5, 5.5, 7.0, 6.0, 6.5, 5.0, 7.5]) / 100  # irregular, sum Ly
    edges = np.concatenate(([0.0], np.cumsum(spacing)))
    k_of_y = np.searchsorted(edges, Y, side="right") - 1
    chan = (Y - edges[k_of_y]) < 0.3 * spacing[k_of_y]  # wide levees
    h, u, v, phi = build(chan, levee_tip=I_TIP)
    for k in range(n):
        rear, tip = (I_REAR, I_TIP) if k in (2, 3, 4) else (60, 66)
        strip = k_of_y == k
        phi[strip, I_REAR:rear], u[strip, I_REAR:rear] = PHI0, U0  # mixed flow behind
        h[strip, tip + 1 :], phi[strip, tip + 1 :], u[strip, tip + 1 :] = 0.0, 0.0, 0.0
    s = np.where(h >= H_MIN, phi, 0.0)[:, I_REAR : I_TIP + 1]
    power = (np.abs(np.fft.rfft(s - s.mean(axis=0), axis=0)) ** 2).mean(axis=1)
    assert power[1] > power[n]  # the envelope does dominate
    m = metrics((h, u, v, phi))
    assert m["finger_count"] == n
    assert m["wavelength_spectral"] == pytest.approx(LY / n, rel=0.15)


def test_uniform_front_has_no_spectral_wavelength():
    for chan in (np.zeros(NY, bool), np.ones(NY, bool)):
        h, u, v, phi = build(chan, levee_tip=I_TIP)
        m = metrics((h, u, v, phi))
        assert m["wavelength_spectral"] is None and m["finger_count"] == 0


def test_channel_and_levee_numbers():
    """Channels at 2 u0 with phi = 0.95, levees at 0.1 u0: the medians and mean are exact
    (levees are the coarse runs beside counted channels; the dry chute is left out)."""
    m = metrics(build(equal_channels(4), u_channel=2.0 * U0, u_levee=0.1 * U0))
    assert m["channel_speed_over_u0"] == pytest.approx(2.0)
    assert m["channel_phi"] == pytest.approx(0.95)
    assert m["levee_speed_over_u0"] == pytest.approx(0.1)
    # centrelines: a slow margin does not move the median of the channel centres
    h, u, v, phi = build(equal_channels(4), u_channel=2.0 * U0)
    chan = equal_channels(4)
    edges = np.flatnonzero(chan & ~np.roll(chan, 1))  # first row of each channel
    u[edges, :] = 0.5 * U0
    assert metrics((h, u, v, phi))["channel_speed_over_u0"] == pytest.approx(2.0)
    # coarse material moving with the front but not beside a channel (islands between the
    # finger tips, dry all round, more cells than the levees) is not a levee
    chan = equal_channels(4)
    h, u, v, phi = build(chan, u_channel=2.0 * U0, u_levee=0.1 * U0, levee_tip=I_REAR + 2)
    near = np.any([np.roll(chan, k) for k in range(-2, 3)], axis=0)  # within 2 rows (periodic)
    island = ~near
    h[np.ix_(island, np.arange(45, 76))] = 0.002
    phi[np.ix_(island, np.arange(45, 76))] = 0.1
    u[np.ix_(island, np.arange(45, 76))] = 1.0 * U0
    assert island.sum() * 31 > (~chan).sum() * 3  # the islands outnumber the levees
    assert metrics((h, u, v, phi))["levee_speed_over_u0"] == pytest.approx(0.1)
    none = metrics(build(np.zeros(NY, bool), levee_tip=I_TIP))
    assert none["channel_speed_over_u0"] is None and none["channel_phi"] is None


def test_a_finger_count_reads_as_words():
    """Messages say "1 finger" and "N fingers" (the demo's and the sweep's progress lines)."""
    from tiseg.apps.sweep.runner import _summary
    from tiseg.post.analysis.fingers import count_text

    assert [count_text(n) for n in (0, 1, 2, 11)] == [
        "0 fingers",
        "1 finger",
        "2 fingers",
        "11 fingers",
    ]
    rec = {
        "status": "done",
        "wall_s": 1.0,
        "steps": 3,
        "rhs_evaluations": 6,
        "metrics": {"time": [7.5], "finger_count": [1], "wavelength": [0.5], "elongation": [0.1]},
    }
    assert "at t = 7.5 s: 1 finger, wavelength 50.0 cm" in _summary(rec)
