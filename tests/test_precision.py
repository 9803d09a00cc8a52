"""f64 means f64: the step limits (wave speeds, max |u|, stiffness) follow the run's precision,
not the order in which modules were imported.

Taichi types built from Python's ``float`` are fixed when they are created; one created at
import time, before ``tiseg.init`` sets the precision, is f32. That once rounded every f64
run's step limits to f32. Each precision runs in its own process (the precision is process
wide) that imports the whole package first and only then initialises Taichi, which is the order
a user's script takes.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest

HERE = os.path.dirname(os.path.abspath(__file__))

# Runs in a fresh interpreter: import everything, then init, then measure.
SCRIPT = r"""
import json, sys, tempfile
sys.path.insert(0, sys.argv[1])
import numpy as np
import tiseg, tiseg.run.simulation, tiseg.solver.numerics.operator, tiseg.solver.reference.operator, tiseg.apps.cli
from solver_helpers import PERIODIC, make_config, random_state

precision = sys.argv[2]
tiseg.init("cpu", precision)
from tiseg.solver.numerics.operator import TaichiOperator
from tiseg.solver.reference.operator import ReferenceOperator

out = {"ops": []}
rng = np.random.default_rng(7)
for nx, ny in ((24, 1), (16, 8)):
    cfg = make_config(nx, ny, bc=tuple(PERIODIC.values()), reconstruction="weno")
    lay = cfg.layout
    op = TaichiOperator(cfg)
    q = random_state(lay, rng)
    op.set(0, q)
    st = op.stability(0, 0.0)
    # the same numbers from the NumPy reference (f64) of the state as stored (f32 or f64);
    # the x range includes the first ghost layer, as in the kernel
    qr = op.get(0)
    ref = ReferenceOperator(cfg)
    ref.fill_ghosts(qr, 0.0)
    w = ref.primitives(qr)
    sl = (slice(lay.gx - 1, lay.gx + lay.nx + 1), slice(lay.gy, lay.gy + lay.ny))
    spd = np.abs(w[1]) if lay.is_1d else np.hypot(w[1], w[lay.HV])
    row = {"max_speed": st.max_speed, "ax": st.ax, "ref_max_speed": float(spd[sl].max()),
           "ref_ax": float(ref.speed(w, 0)[sl].max())}
    if not lay.is_1d:
        row.update(ay=st.ay, ref_ay=float(ref.speed(w, 1)[sl].max()))
    out["ops"].append(row)

# a whole run through the command line: every max_speed in diagnostics.csv
d = tempfile.mkdtemp()
rc = tiseg.apps.cli.main(["run", "uniform-flow", "--out", d, "--no-progress", "--precision", precision,
                     "--set", "time.t_end=0.02", "--set", "initial.amplitude=1e-3"])
from tiseg.output import read_diagnostics
out["rc"] = rc
out["diag_max_speed"] = [float(v) for v in read_diagnostics(d + "/diagnostics.csv")["max_speed"]]
print(json.dumps(out))
"""


@pytest.fixture(scope="module")
def measured():
    procs = {
        p: subprocess.Popen(
            [sys.executable, "-c", SCRIPT, HERE, p],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        for p in ("f64", "f32")
    }
    res = {}
    for p, proc in procs.items():
        out, err = proc.communicate(timeout=600)
        assert proc.returncode == 0, err
        res[p] = json.loads(out.strip().splitlines()[-1])
    return res


def _is_f32(x: float) -> bool:
    return float(np.float32(x)) == x


@pytest.mark.slow  # a long run: the slow set (README), which CI runs after the suite
def test_f64_step_limits_are_f64(measured):
    """Wave speeds and max |u| of an f64 operator equal an f64 recomputation from the state
    (to a few ulps: the kernel and NumPy round sqrt(2) h / sqrt(...) differently) and are not
    f32 numbers."""
    for row in measured["f64"]["ops"]:
        for key in ("max_speed", "ax", "ay"):
            if key not in row:
                continue
            assert row[key] == pytest.approx(row["ref_" + key], rel=1e-14), (key, row)
            assert not _is_f32(row[key]), (key, row)


def test_f32_step_limits_are_f32(measured):
    for row in measured["f32"]["ops"]:
        for key in ("max_speed", "ax", "ay"):
            if key not in row:
                continue
            assert _is_f32(row[key]), (key, row)
            assert row[key] == pytest.approx(row["ref_" + key], rel=1e-6), (key, row)


@pytest.mark.parametrize("precision", ["f64", "f32"])
def test_diagnostics_max_speed_follows_the_precision(measured, precision):
    """Every per-step max_speed of `tiseg run uniform-flow` is f32-rounded exactly when the
    run is f32 (the t = 0 row has no step and is NaN)."""
    m = measured[precision]
    assert m["rc"] == 0
    speeds = [v for v in m["diag_max_speed"] if np.isfinite(v)]
    assert len(speeds) >= 5 and all(v > 0.1 for v in speeds)
    if precision == "f64":
        assert not any(_is_f32(v) for v in speeds), speeds
    else:
        assert all(_is_f32(v) for v in speeds), speeds
