"""Every example runs, tiny, as a test (and says something checkable)."""
import importlib.util
from pathlib import Path

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def _load(name):
    spec = importlib.util.spec_from_file_location(name, EXAMPLES / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_quickstart_example(ti_cpu, tmp_path, capsys):
    sim = _load("quickstart").main(["--resolution", "40", "--t-end", "0.5", "--out", str(tmp_path)])
    assert (tmp_path / "fields.nc").exists()
    tot, bud = sim.totals(), sim.budget()
    assert abs(tot["mass"] - bud["mass_in"]) < 1e-12 * tot["mass"]
    assert "entered through the inflow" in capsys.readouterr().out


def test_growth_rate_example(ti_cpu):
    rate, theory = _load("growth_rate").main(["--cells", "32"])
    assert abs(rate - theory) < 0.03 * theory
