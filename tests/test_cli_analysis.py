"""Command line: `tiseg steady`, `tiseg stability` and `tiseg figures stability`."""

import json
import math

import pytest

from tiseg.apps.cli import main
from tiseg.model.stability import dispersion1d as d1
from tiseg.model.stability import dispersion2d as d2
from tiseg.model.stability.base import base_state
from tiseg.model.steady import steady_state

from solver_helpers import exit_code


def run_json(capsys, argv):
    rc = main(argv)
    out, err = capsys.readouterr()
    assert rc == 0, err
    return json.loads(out)


def test_steady_json(capsys):
    o = run_json(capsys, ["steady", "--h0", "0.002", "--phi0", "0.8", "--json"])
    s = steady_state(0.002, 0.8)
    for key in ("F", "u0", "phi0_star", "Fc", "h0_at_Fc"):
        assert o[key] == pytest.approx(getattr(s, key), rel=1e-14)
    assert round(o["F"], 2) == 1.57 and round(o["u0"], 3) == 0.208


def test_steady_with_bagnold_transport(capsys):
    """--transport bagnold: the same steady flow (G plays no part in (4.2)), and the critical
    Froude number of (5.27) from the Bagnold G'(phi0) = 5/3 (1 - phi0)^{3/2} - 2/3."""
    lin = run_json(capsys, ["steady", "--h0", "0.002", "--phi0", "0.8", "--json"])
    bag = run_json(
        capsys, ["steady", "--h0", "0.002", "--phi0", "0.8", "--transport", "bagnold", "--json"]
    )
    assert bag["F"] == lin["F"] and bag["u0"] == lin["u0"]
    assert bag["Fc"] == pytest.approx(1.0 / abs(5 / 3 * 0.2**1.5 - 2 / 3), rel=1e-13)
    assert bag["Fc"] != lin["Fc"]


def test_stability_json(capsys):
    o = run_json(
        capsys,
        [
            "stability",
            "--h0",
            "0.002",
            "--phi0",
            "0.8",
            "--nu",
            "0.001",
            "--k",
            "0.1",
            "1",
            "10",
            "--json",
        ],
    )
    for key in (
        "F",
        "R",
        "Fc",
        "k",
        "sigma_max",
        "k_max",
        "sigma_Max",
        "k_cutoff",
        "u0",
        "sigma_Max_per_s",
        "wavelength_at_k_max_m",
        "sigma_Max_is_limit",
    ):
        assert key in o, key
    bs = base_state(0.002, 0.8, 1e-3)
    assert o["F"] == pytest.approx(bs.F, rel=1e-14) and o["R"] == pytest.approx(bs.R, rel=1e-14)
    assert o["k"] == [0.1, 1.0, 10.0]
    assert o["sigma_max"] == pytest.approx(list(d1.sigma_M(bs, [0.1, 1.0, 10.0])), rel=1e-10)
    kM, sM = d1.most_unstable(bs)
    assert o["k_max"] == pytest.approx(kM, rel=1e-8) and o["sigma_Max"] == pytest.approx(sM)
    assert round(o["sigma_Max"], 5) == 0.06378 and round(o["R"], 3) == 9.299  # prototype
    assert o["sigma_Max_per_s"] == pytest.approx(sM * bs.u0 / bs.h0)
    assert o["wavelength_at_k_max_m"] == pytest.approx(2 * math.pi * 0.002 / kM)
    assert o["k_cutoff"] is None and o["sigma_Max_is_limit"] is False


def test_stability_cutoff_json(capsys):
    o = run_json(
        capsys,
        ["stability", "--h0", "0.003", "--phi0", "0.8", "--nu", "0.001", "--k", "3", "--json"],
    )
    assert round(o["k_cutoff"], 5) == 2.00345  # (A42), independent prototype
    assert o["k_cutoff_analytic"]["A42"] == pytest.approx(o["k_cutoff"], rel=1e-9)
    assert o["sigma_M"][0] < 0  # k = 3 > k_c decays
    # independent prototype, linear mode case 2: sigma = -8.22235 - 573.0111 i 1/s at k = 3
    assert o["sigma_M_per_s"][0] == pytest.approx(-8.22235, abs=1e-5)


def test_stability_from_froude(capsys):
    o = run_json(
        capsys, ["stability", "--F", "2.0", "--phi0", "0.8", "--nu", "0.001", "--k", "1", "--json"]
    )
    assert o["F"] == pytest.approx(2.0, rel=1e-14)
    assert round(o["k_cutoff"], 2) == 4.48  # figure 11 table, independent prototype


def test_stability_inviscid(capsys):
    o = run_json(
        capsys,
        ["stability", "--h0", "0.002", "--phi0", "0.8", "--nu", "0", "--k", "1", "100", "--json"],
    )
    assert o["R"] is None and o["k_max"] is None and o["sigma_Max_is_limit"] is True
    assert round(o["sigma_Max"], 5) == 0.10911  # (5.30), independent prototype
    assert o["k_cutoff"] is None and o["wavelength_at_k_max_m"] is None
    assert max(o["sigma_M"]) < o["sigma_Max"]


def test_stability_json_keeps_the_older_names(capsys):
    """sigma_max* (per k) are aliases of sigma_M*, distinct from sigma_Max (over k)."""
    o = run_json(
        capsys,
        ["stability", "--h0", "0.003", "--phi0", "0.8", "--k", "1", "3"]
        + ["--ky", "0.5", "--json"],
    )
    for old, new in (
        ("sigma_max", "sigma_M"),
        ("sigma_max_per_s", "sigma_M_per_s"),
        ("sigma_max_imag", "sigma_M_imag"),
        ("sigma_max_2d", "sigma_M_2d"),
    ):
        assert o[old] == o[new] and len(o[new]) == (1 if "2d" in new else 2)
    assert o["sigma_Max"] >= max(o["sigma_M"])  # the maximum over all k


def test_stability_inviscid_critical(capsys):
    o = run_json(
        capsys,
        ["stability", "--F", str(7 / 3.6), "--phi0", "0.8", "--nu", "0", "--k", "1", "--json"],
    )
    assert o["sigma_Max"] is None and o["sigma_Max_is_limit"] is True  # unbounded (5.31)


def test_stability_2d(capsys):
    o = run_json(
        capsys,
        [
            "stability",
            "--h0",
            "0.002",
            "--phi0",
            "0.8",
            "--nu",
            "0.01",
            "--k",
            "0.24",
            "1",
            "--ky",
            "0",
            "0.24",
            "--json",
        ],
    )
    assert o["ky"] == [0.0, 0.24]
    grid = o["sigma_max_2d"]
    assert len(grid) == 2 and all(len(row) == 2 for row in grid)
    assert grid[0] == pytest.approx(o["sigma_max"], rel=1e-9)  # ky = 0 is the 1D case
    assert round(grid[1][0], 5) == 0.02316  # independent prototype (2D linear mode)
    bs = base_state(0.002, 0.8, 0.01)
    assert grid[1][1] == pytest.approx(float(d2.sigma_M(bs, 1.0, 0.24)), rel=1e-10)


def test_stability_text_and_plot(capsys, tmp_path):
    png = tmp_path / "growth.png"
    rc = main(
        [
            "stability",
            "--h0",
            "0.003",
            "--phi0",
            "0.8",
            "--k",
            "0.5",
            "3",
            "--ky",
            "0.5",
            "--plot",
            str(png),
        ]
    )
    out, err = capsys.readouterr()
    assert rc == 0, err
    assert "k_M" in out and "2.00345" in out and "2D" in out
    assert png.exists() and png.stat().st_size > 1000
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.slow  # a long run: the slow set (README), which CI runs after the suite
def test_figures_stability(capsys, tmp_path):
    rc = main(["figures", "stability", "--out", str(tmp_path), "--dpi", "50"])
    out, err = capsys.readouterr()
    assert rc == 0, err
    for name in (
        "fig08_froude.png",
        "fig09_growth_rates.png",
        "fig10_critical.png",
        "fig11_sigma_max.png",
    ):
        p = tmp_path / name
        assert p.exists() and p.stat().st_size > 1000, name
        assert name in out


LIBRARY_ERRORS = [  # rejected by the library (InputError): exactly one line on stderr
    ["stability", "--h0", "-0.002", "--phi0", "0.8"],
    ["stability", "--h0", "0", "--phi0", "0.8"],
    ["stability", "--h0", "0.002", "--phi0", "1.2"],
    ["stability", "--h0", "0.002", "--phi0", "-0.2"],
    ["stability", "--h0", "0.002", "--phi0", "0.8", "--nu", "-0.001"],
    ["stability", "--h0", "0.002", "--phi0", "0.8", "--zeta", "35"],
    ["stability", "--h0", "0.002", "--phi0", "0.1"],  # phi0 < phi0*
    ["stability", "--h0", "0.002", "--phi0", "0.8", "--k", "-1"],
    ["stability", "--h0", "0.002", "--phi0", "0.8", "--k", "nan"],
    ["stability", "--F", "-1", "--phi0", "0.8"],
    ["steady", "--h0", "-0.002", "--phi0", "0.8"],
    ["steady", "--h0", "0.002", "--phi0", "0.1"],
    ["figures", "stability", "--out", "unused", "--zeta", "35"],
]
PARSER_ERRORS = [  # rejected by argparse: its usage line plus one error line
    ["stability", "--phi0", "0.8"],  # neither --h0 nor --F
    ["stability", "--h0", "abc", "--phi0", "0.8"],
    ["figures"],  # no figure set
    ["figures", "stability"],  # missing --out
]


@pytest.mark.parametrize("argv", LIBRARY_ERRORS)
def test_bad_input_one_line_error(capsys, argv, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # nothing may be written, but stay out of the checkout
    rc = exit_code(argv)
    out, err = capsys.readouterr()
    assert rc == 2
    assert out == ""
    assert "Traceback" not in err
    assert len(err.strip().splitlines()) == 1 and "error:" in err, err
    assert not (tmp_path / "unused").exists()


@pytest.mark.parametrize("argv", PARSER_ERRORS)
def test_bad_arguments_usage_error(capsys, argv):
    rc = exit_code(argv)
    _, err = capsys.readouterr()
    assert rc == 2
    assert "Traceback" not in err
    assert sum("error:" in ln for ln in err.splitlines()) == 1, err


@pytest.mark.slow  # a long run: the slow set (README), which CI runs after the suite
def test_figures_assets_folder_is_the_checkouts(capsys, tmp_path, monkeypatch):
    """--assets copies into the source checkout's assets/figures (the README's media)."""
    from pathlib import Path

    from tiseg.apps.commands import figures as cmd

    repo = Path(__file__).resolve().parents[1]
    assert cmd.ASSETS_DIR == repo / "assets" / "figures"
    # the copy itself, into a stand-in checkout
    (tmp_path / "pyproject.toml").write_text("")
    monkeypatch.setattr(cmd, "ASSETS_DIR", tmp_path / "assets" / "figures")
    rc = main(["figures", "stability", "--out", str(tmp_path / "out"), "--dpi", "30", "--assets"])
    out, err = capsys.readouterr()
    assert rc == 0, err
    assert (tmp_path / "assets" / "figures" / "fig09_growth_rates.png").stat().st_size > 1000
