"""The main job (`tiseg demo`) at 250 cells per metre: its printed numbers are its own
diagnostics, and the headline wavelength holds still once fingers have formed.

The headline count (2D channels, tiseg.post.analysis.channels) is checked against an independent
measure, the spectral wavelength of phi (tiseg.post.analysis.spectrum), which detects no channels.
Once fingers have formed (t >= 6.5 s) the wavelength Ly / count must be defined at every output
time, vary by at most a factor 1.5, and agree with the spectral wavelength within a third.
(Measured on 2026-12-01: 7 fingers at every output time from 6.0 s to 7.5 s, Lambda = 7.1 cm
against 7.2-7.3 cm spectral; the single-line count of earlier versions dropped to 2 at 6.2 s.)

The 250 cells/m run takes a minute of a core, so its two tests are in the slow set; the fast set
keeps the first property (the printed numbers are the run's diagnostics, its files are written)
on a coarse demo whose front has formed its first finger.
"""

from __future__ import annotations

import json
import re

import pytest

from solver_helpers import exit_code


def _run_demo(out, *args) -> str:
    """`tiseg demo --out OUT ARGS`; what it printed."""
    import contextlib
    import io

    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        assert exit_code(["demo", "--out", str(out), "--no-progress", *args]) == 0
    return buf.getvalue()


@pytest.fixture(scope="module")
def demo(tmp_path_factory):
    out = tmp_path_factory.mktemp("demo") / "run"
    return out, _run_demo(out, "--resolution", "250")


# a coarse, short demo (a third of the 250 cells/m run's wall time, most of it the figures and
# the movie) whose front has fingers at its end (measured: 8 fingers, 6.2 cm, at 6.5 s; at
# 120 cells/m the front has not broken by then)
COARSE = ("--resolution", "140", "--t-end", "6.5")


@pytest.fixture(scope="module")
def coarse_demo(tmp_path_factory):
    out = tmp_path_factory.mktemp("demo_coarse") / "run"
    return out, _run_demo(out, *COARSE)


def _assert_prints_its_own_final_diagnostics(out, text) -> None:
    m = json.loads((out / "fingers.json").read_text())
    line = next(s for s in text.splitlines() if s.startswith("at t = "))
    count, wl = re.search(r": (\d+) fingers?, wavelength ([\d.]+) cm", line).groups()
    assert int(count) == m["finger_count"][-1] > 0
    assert float(wl) == pytest.approx(100 * m["wavelength"][-1], abs=0.05)
    # and says what they are: one run, beside the converged values and their source
    after = text.split(line, 1)[1]
    assert "one run (the scene's inflow seed) at " in after and "converged at t = 7.5 s" in after
    assert "benchmarks/split_fingers/README.md" in after
    for name in ("fingers.mp4", "fig12_phi.png", "fig13_speed.png", "fig14_h.png"):
        assert (out / name).stat().st_size > 0


@pytest.mark.slow  # a long run: the slow set (README), which CI runs after the suite
def test_demo_prints_its_own_final_diagnostics(coarse_demo):
    _assert_prints_its_own_final_diagnostics(*coarse_demo)


@pytest.mark.slow
def test_demo_at_250_cells_per_metre_prints_its_own_final_diagnostics(demo):
    _assert_prints_its_own_final_diagnostics(*demo)


@pytest.mark.slow
def test_headline_wavelength_holds_still_once_fingers_formed(demo):
    out, _ = demo
    m = json.loads((out / "fingers.json").read_text())
    late = [i for i, t in enumerate(m["time"]) if t >= 6.5 - 1e-9]
    assert len(late) >= 10
    wl = [m["wavelength"][i] for i in late]
    spec = [m["wavelength_spectral"][i] for i in late]
    assert all(w is not None for w in wl), wl
    assert max(wl) / min(wl) <= 1.5, wl
    for w, s in zip(wl, spec):
        assert s is not None and abs(w - s) <= s / 3, (wl, spec)
