"""Every example runs, tiny, as a test and says something checkable: parametrised over the
files in examples/, each with its physics check here (a new example without one fails)."""

import importlib.util
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def _load(name):
    spec = importlib.util.spec_from_file_location(name, EXAMPLES / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def check_quickstart(tmp_path, capsys):
    """An inflow onto an empty chute: everything on the chute came through the inflow."""
    sim = _load("quickstart").main(["--resolution", "40", "--t-end", "0.5", "--out", str(tmp_path)])
    assert (tmp_path / "fields.nc").exists()
    tot, bud = sim.totals(), sim.budget()
    assert abs(tot["mass"] - bud["mass_in"]) < 1e-12 * tot["mass"]
    assert "entered through the inflow" in capsys.readouterr().out


def check_growth_rate(tmp_path, capsys):
    """The measured growth rate of the most unstable mode against linear theory (5.19)."""
    rate, theory = _load("growth_rate").main(["--cells", "32"])
    assert abs(rate - theory) < 0.03 * theory


def check_relief(tmp_path, capsys):
    """The channel of the shipped relief carries more of a release than the same band of a
    flat chute (measured: 63 % against 50 % at 100 cells/m)."""
    mod = _load("relief")
    share, _ = mod.main(["--resolution", "100", "--out", str(tmp_path / "relief")])
    flat, _ = mod.main(["--resolution", "100", "--flat", "--out", str(tmp_path / "flat")])
    assert share > flat + 0.07
    assert "of the peak flow" in capsys.readouterr().out


CHECKS = {
    "quickstart": check_quickstart,
    "growth_rate": check_growth_rate,
    "relief": check_relief,
}


@pytest.mark.parametrize("name", sorted(p.stem for p in EXAMPLES.glob("*.py")))
def test_example_runs_tiny(name, ti_cpu, tmp_path, capsys):
    assert name in CHECKS, f"examples/{name}.py has no physics check in this file: add one"
    CHECKS[name](tmp_path, capsys)
