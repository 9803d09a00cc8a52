"""`tiseg calibrate`: the search, the interval, resuming and bad input (issue 36, part 6).

The fast tests run the members with a stand-in for `execute_run` whose numbers are known
functions of the parameters (written as a finished member folder, as execute_run leaves one),
so the search, the uncertainty, the JSON and resuming are checked against values worked out
here by hand. The slow test recovers a hidden Coulomb friction coefficient from the run-out of
a real dam break, with the members on Dask."""

from __future__ import annotations

import json
import math
from pathlib import Path

import netCDF4
import numpy as np
import pytest

from tiseg.apps.calibration import calibration_from_args, run_calibration, target_names
from tiseg.apps.cli import main
from tiseg.apps.sweep.members import DONE_MARKER, MARKER_VERSION
from tiseg.errors import InputError
from tiseg.post.analysis.fingers import ANALYSIS_VERSION
from tiseg.setup.scene import scene_from_text

SCENE = "dam-break"
FIXED = {"domain.nx": 40, "effects.friction": "coulomb"}


def _value(scene, key):
    section, name = key.split(".")
    return getattr(getattr(scene, section), name)


class Model:
    """A stand-in for `execute_run`: a member folder with scene.toml, fields.nc (no data) and
    done.json whose numbers are ``numbers(scene)``; counts its runs and can stop ("a kill")
    before finishing its ``kill_at``-th run, leaving that folder without its marker."""

    def __init__(self, numbers, kill_at=None):
        self.numbers, self.kill_at, self.runs = numbers, kill_at, []

    def __call__(self, spec: dict) -> dict:
        d = Path(spec["dir"])
        d.mkdir(parents=True, exist_ok=True)
        (d / "scene.toml").write_text(spec["scene_toml"], encoding="utf-8")
        netCDF4.Dataset(d / "fields.nc", "w").close()  # a fields file that opens
        self.runs.append(spec["name"])
        if self.kill_at is not None and len(self.runs) == self.kill_at:
            raise KeyboardInterrupt
        scene = scene_from_text(spec["scene_toml"])
        per_time, deposit = self.numbers(scene)
        rec = {
            "marker_version": MARKER_VERSION,
            "name": spec["name"],
            "metrics": {
                "analysis_version": ANALYSIS_VERSION,
                "time": [0.1, scene.t_end],
                **{k: [None, v] for k, v in per_time.items()},
                "deposit": deposit,
            },
        }
        (d / DONE_MARKER).write_text(json.dumps(rec), encoding="utf-8")
        return {**rec, "status": "done"}


def run_out_of_mu(scene):
    """A run-out that falls as 1/mu, like a sliding mass: 0.05 + 0.02 / mu [m]."""
    return {}, {"run_out": 0.05 + 0.02 / scene.effects.coulomb_mu}


def test_one_parameter_is_recovered_with_the_interval_of_its_tolerance(tmp_path):
    """Brent finds mu = 0.2 from its run-out to 1e-3; the interval is tol / |dR/dmu| with
    dR/dmu = -0.02 / mu^2 (central differences: to 1 %); calibration.json says how."""
    cal = calibration_from_args(
        SCENE,
        ["effects.coulomb_mu=0.1:0.4"],
        ["run_out=0.15+-0.001"],
        fixed=FIXED,
        budget=12,
    )
    model = Model(run_out_of_mu)
    res = run_calibration(cal, tmp_path, echo=None, execute=model)
    mu = res.best["effects.coulomb_mu"]
    assert mu == pytest.approx(0.2, rel=1e-3)
    data = json.loads((tmp_path / "calibration.json").read_text())
    assert data["complete"] is True
    search = [e for e in data["evaluations"] if e["purpose"] == "search"]
    assert 2 <= len(search) <= 12
    assert len([e for e in data["evaluations"] if e["purpose"] == "sensitivity"]) == 2
    assert len(model.runs) == len(data["evaluations"])  # each point ran once
    u = data["uncertainty"]["params"]["effects.coulomb_mu"]
    assert u["half_width"] == pytest.approx(0.001 / (0.02 / mu**2), rel=0.01)
    assert u["interval"][0] < mu < u["interval"][1]
    assert data["uncertainty"]["spread"]["deposit.run_out"]["source"] == "tolerance"
    assert (
        "Brent" in data["method"]["search"]
        and "central differences" in data["method"]["uncertainty"]
    )
    # the best member's own record holds the number the JSON reports
    rec = json.loads((tmp_path / data["best"]["member"] / DONE_MARKER).read_text())
    assert data["best"]["outputs"]["deposit.run_out"] == rec["metrics"]["deposit"]["run_out"]
    assert (tmp_path / "misfit.png").stat().st_size > 1000


def linear_pair(scene):
    """Two targets linear in two parameters: x_front_max = 1 + p + q, thickness_mean =
    p - 2 q, with p = effects.coulomb_mu and q = initial.h_left."""
    p, q = scene.effects.coulomb_mu, scene.initial.h_left
    return {"x_front_max": 1.0 + p + q}, {"thickness_mean": p - 2.0 * q}


def test_two_parameters_and_their_covariance(tmp_path):
    """A Latin hypercube then Nelder-Mead recover (p, q) = (0.3, 0.004); the intervals are
    the square roots of the diagonal of (J^T S^-2 J)^-1 with J = [[1, 1], [1, -2]]."""
    p0, q0, tol1, tol2 = 0.3, 0.004, 0.002, 0.001
    targets = [
        f"x_front_max={1 + p0 + q0}+-{tol1}",
        f"deposit.thickness_mean={p0 - 2 * q0}+-{tol2}",
    ]
    cal = calibration_from_args(
        SCENE,
        ["effects.coulomb_mu=0.1:0.5", "initial.h_left=0.001:0.01"],
        targets,
        time=0.2,
        fixed={**FIXED, "output.interval": 0.1, "time.t_end": 0.2},
        budget=60,
    )
    res = run_calibration(cal, tmp_path, echo=None, execute=Model(linear_pair))
    data = res.result
    assert "Latin hypercube" in data["method"]["search"]
    assert len([e for e in data["evaluations"] if e["purpose"] == "search"]) <= 60
    assert res.best["effects.coulomb_mu"] == pytest.approx(p0, abs=0.004)
    assert res.best["initial.h_left"] == pytest.approx(q0, abs=1e-4)
    # by hand: A = J^T S^-2 J; C = A^-1 (2 x 2)
    a11 = 1 / tol1**2 + 1 / tol2**2
    a12 = 1 / tol1**2 - 2 / tol2**2
    a22 = 1 / tol1**2 + 4 / tol2**2
    det = a11 * a22 - a12**2
    unc = data["uncertainty"]["params"]
    assert unc["effects.coulomb_mu"]["half_width"] == pytest.approx(math.sqrt(a22 / det), rel=1e-6)
    assert unc["initial.h_left"]["half_width"] == pytest.approx(math.sqrt(a11 / det), rel=1e-6)
    sens = data["uncertainty"]["sensitivity"]
    assert sens["initial.h_left"]["deposit.thickness_mean"] == pytest.approx(-2.0, rel=1e-6)


def test_points_asked_for_at_once_run_together_on_dask(tmp_path, monkeypatch):
    """On Dask, the points of the initial design (2P + 1 = 5) run in tasks of up to --batch
    members (`execute_batch`), the search's single points alone; the result is the one of
    the points run one at a time in this process."""
    import distributed

    from tiseg.apps.sweep import runner

    p0, q0 = 0.3, 0.004
    targets = [f"x_front_max={1 + p0 + q0}+-0.002", f"deposit.thickness_mean={p0 - 2 * q0}+-0.001"]
    fixed = {**FIXED, "output.interval": 0.1, "time.t_end": 0.2}
    cal = calibration_from_args(
        SCENE,
        ["effects.coulomb_mu=0.1:0.5", "initial.h_left=0.001:0.01"],
        targets,
        time=0.2,
        fixed=fixed,
        budget=20,
    )
    tally = tmp_path / "tasks"
    tally.mkdir()
    real = runner.execute_batch

    def batch(specs, run=None):  # (Dask runs a copy of this: count in files)
        (tally / specs[0]["name"]).write_text(str(len(specs)))
        return real(specs, run=run)

    monkeypatch.setattr(runner, "execute_run", Model(linear_pair))
    monkeypatch.setattr(runner, "execute_batch", batch)
    with distributed.LocalCluster(
        n_workers=1, threads_per_worker=1, processes=False, dashboard_address=":0"
    ) as cluster:
        res = run_calibration(
            cal, tmp_path / "dask", echo=None, scheduler=cluster.scheduler_address, batch=4
        )
    # tasks of several: the design's 5 points (4, the fifth alone as the search's points)
    # and the 2P = 4 points of the sensitivity around the best
    assert [int(f.read_text()) for f in tally.iterdir()] == [4, 4]
    alone = run_calibration(cal, tmp_path / "alone", echo=None, execute=Model(linear_pair))
    assert res.best == alone.best
    assert len(res.result["evaluations"]) == len(alone.result["evaluations"])


def test_the_seeds_spread_adds_to_the_tolerance(tmp_path):
    """With --seeds 3 the best point runs again with inflow.seed 1 and 2; the wavelength's
    spread over the three (sd 0.002) and the tolerance (0.0015) add in quadrature, and the
    interval is that spread over dLambda/dnu = 2."""

    def wavelength(scene):
        return {"wavelength": 0.05 + 2.0 * (scene.flow.nu - 0.01) + 0.002 * scene.inflow.seed}, {}

    cal = calibration_from_args(
        "fingers",
        ["flow.nu=0.002:0.05:log"],
        ["wavelength=0.05+-0.0015"],
        fixed={"inflow.noise": 1e-4, "inflow.seed": 0, "domain.resolution": 20},
        budget=12,
        seeds=3,
    )
    res = run_calibration(cal, tmp_path, echo=None, execute=Model(wavelength))
    assert res.best["flow.nu"] == pytest.approx(0.01, rel=1e-3)
    unc = res.result["uncertainty"]
    assert unc["spread"]["wavelength"]["source"] == "tolerance + seeds (3)"
    assert unc["spread"]["wavelength"]["value"] == pytest.approx(math.hypot(0.0015, 0.002))
    half = unc["params"]["flow.nu"]["half_width"]
    assert half == pytest.approx(math.hypot(0.0015, 0.002) / 2.0, rel=1e-6)
    seeds = [e for e in res.result["evaluations"] if e["purpose"] == "seed"]
    assert [e["values"]["inflow.seed"] for e in seeds] == [1, 2]
    assert all((tmp_path / e["member"] / DONE_MARKER).is_file() for e in seeds)


def test_a_killed_calibration_resumes_without_rerunning_or_duplicating(tmp_path):
    """Killed in its 4th run, the calibration leaves three finished members and one without
    a marker; run again, it runs that one and the rest only, and ends as an uninterrupted
    calibration does; a third time it runs nothing."""
    args = (SCENE, ["effects.coulomb_mu=0.1:0.4"], ["deposit.run_out=0.15"])
    cal = calibration_from_args(*args, fixed=FIXED, budget=8)
    ref = run_calibration(cal, tmp_path / "ref", echo=None, execute=Model(run_out_of_mu))

    out = tmp_path / "killed"
    killed = Model(run_out_of_mu, kill_at=4)
    with pytest.raises(KeyboardInterrupt):
        run_calibration(cal, out, echo=None, execute=killed)
    partial = json.loads((out / "calibration.json").read_text())
    assert partial["complete"] is False
    again = Model(run_out_of_mu)
    res = run_calibration(cal, out, echo=None, execute=again)
    assert again.runs[0] == killed.runs[-1]  # the interrupted member, run again
    assert not set(again.runs[1:]) & set(killed.runs)  # no finished member ran twice
    assert res.result["best"] == ref.result["best"]
    assert [e["member"] for e in res.result["evaluations"]] == [
        e["member"] for e in ref.result["evaluations"]
    ]
    members = sorted(p.name for p in out.iterdir() if p.is_dir())
    assert members == sorted(p.name for p in (tmp_path / "ref").iterdir() if p.is_dir())
    assert len(members) == len(set(killed.runs) | set(again.runs))

    third = Model(run_out_of_mu)
    res3 = run_calibration(cal, out, echo=None, execute=third)
    assert third.runs == [] and res3.result["best"] == ref.result["best"]
    assert set(res3.result["runs"]) == {"reused"}


def test_an_undefined_target_is_penalised_and_the_search_goes_on(tmp_path):
    """Below mu = 0.15 the flow never stops (no run-out): those runs get the penalty and the
    search still finds mu = 0.25."""

    def numbers(scene):
        mu = scene.effects.coulomb_mu
        return {}, {"run_out": None if mu < 0.15 else 0.05 + 0.02 / mu}

    cal = calibration_from_args(
        SCENE, ["effects.coulomb_mu=0.1:0.4"], ["runout=0.13"], fixed=FIXED, budget=14
    )
    res = run_calibration(cal, tmp_path, echo=None, execute=Model(numbers))
    assert res.best["effects.coulomb_mu"] == pytest.approx(0.25, rel=2e-3)


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--param", "effects.coulomb_mu=0.3:0.1", "--target", "runout=0.2"], "LO < HI"),
        (["--param", "effects.coulomb_mu=0.3:0.3", "--target", "runout=0.2"], "LO < HI"),
        (["--param", "effects.coulomb_mu=0.1-0.3", "--target", "runout=0.2"], "LO:HI"),
        (["--param", "effects.coulomb_mu=0.1:0.3", "--target", "runout"], "NAME=VALUE"),
        (["--param", "effects.coulomb_mu=0.1:0.3", "--target", "spread=1"], "deposit.run_out"),
        (["--param", "domain.nx=100:200", "--target", "runout=0.2"], "whole numbers"),
        (["--param", "numerics.stepper=0:1", "--target", "runout=0.2"], "numeric"),
        (["--param", "effects.mu=0:1", "--target", "runout=0.2"], "unknown key"),
        (
            ["--param", "effects.coulomb_mu=0.1:0.3", "--target", "runout=0.2", "--budget", "1"],
            "budget",
        ),
        (["--param", "effects.coulomb_mu=0.1:0.3", "--target", "wavelength=0.1"], "segregation"),
        (
            ["--param", "effects.coulomb_mu=0.1:0.3", "--target", "runout=0.2", "--seeds", "3"],
            "seed",
        ),
        (
            [
                "--param",
                "effects.coulomb_mu=0.1:0.3",
                "--target",
                "x_front_max=0.2",
                "--time",
                "0.013",
            ],
            "not an output time",
        ),
        (
            [
                "--param",
                "effects.coulomb_mu=0.1:0.3",
                "--target",
                "runout=0.2",
                "--set",
                "effects.coulomb_mu=0.2",
            ],
            "both",
        ),
    ],
)
def test_bad_input_is_one_line_before_any_run(tmp_path, capsys, argv, message):
    out = tmp_path / "cal"
    status = main(
        ["calibrate", SCENE, *argv, "--set", "effects.friction=coulomb", "--out", str(out)]
    )
    err = capsys.readouterr().err.strip()
    assert status == 2 and "\n" not in err and message in err, err
    assert not out.exists()


def test_unknown_target_lists_every_valid_name(capsys):
    assert (
        main(["calibrate", SCENE, "--param", "effects.coulomb_mu=0.1:0.3", "--target", "x=1"]) == 2
    )
    err = capsys.readouterr().err
    for name in target_names():
        assert name in err


def test_a_folder_of_another_scene_is_refused(tmp_path):
    cal = calibration_from_args(
        SCENE, ["effects.coulomb_mu=0.1:0.4"], ["runout=0.15"], fixed=FIXED, budget=3
    )
    run_calibration(cal, tmp_path, echo=None, execute=Model(run_out_of_mu))
    other = calibration_from_args(
        SCENE, ["effects.coulomb_mu=0.1:0.4"], ["runout=0.15"], fixed={**FIXED, "domain.nx": 50}
    )
    with pytest.raises(InputError, match="another scene"):
        run_calibration(other, tmp_path, echo=None, execute=Model(run_out_of_mu))


# A dam break with Coulomb friction that comes to rest (projected friction, section 6.2 of
# docs/numerics.md): a 2 cm column 5 cm long spreading over 30 cm, 200 cells; it stops by
# t = 0.8 s for mu >= 0.12, its run-out moves 1.3 cells per 1 % of mu near mu = 0.15.
COULOMB = {
    "effects.friction": "coulomb",
    "numerics.friction_scheme": "projected",
    "domain.nx": 200,
    "domain.Lx": 0.3,
    "initial.x0": 0.05,
    "initial.h_left": 0.02,
    "time.t_end": 1.0,
    "output.interval": 0.05,
}


@pytest.mark.slow
def test_a_hidden_friction_coefficient_is_recovered_from_its_run_out(ti_cpu, tmp_path):
    """Run mu = 0.15 and read its run-out as `tiseg fingers --json` reports it; calibrate mu on
    [0.12, 0.25] from it with 10 runs on Dask: within 2 % (issue 36's target)."""
    hidden = tmp_path / "hidden"
    sets = [f"--set={k}={v}" for k, v in COULOMB.items()]
    assert (
        main(["run", SCENE, *sets, "--set=effects.coulomb_mu=0.15", "--out", str(hidden), "-q"])
        == 0
    )
    from tiseg.post.analysis.fingers import analyse_run

    run_out = analyse_run(hidden)["deposit"]["run_out"]
    assert run_out is not None
    cal = calibration_from_args(
        SCENE,
        ["effects.coulomb_mu=0.12:0.25"],
        [f"deposit.run_out={run_out}+-{0.3 / 200}"],
        fixed=COULOMB,
        budget=10,
    )
    res = run_calibration(cal, tmp_path / "cal", echo=None, workers=1)
    mu = res.best["effects.coulomb_mu"]
    assert abs(mu - 0.15) <= 0.02 * 0.15, mu
    lo, hi = res.result["uncertainty"]["params"]["effects.coulomb_mu"]["interval"]
    assert lo <= 0.15 <= hi
    assert np.isfinite(res.result["best"]["misfit"])


def test_the_command_prints_calibration_json(tmp_path, capsys, monkeypatch):
    """`tiseg calibrate ... --json` passes its options through and prints calibration.json."""
    import tiseg.apps.commands.calibrate as command

    real = command.run_calibration
    monkeypatch.setattr(
        command,
        "run_calibration",
        lambda cal, out, **kw: real(cal, out, **{**kw, "execute": Model(run_out_of_mu)}),
    )
    argv = ["calibrate", SCENE, "--param", "effects.coulomb_mu=0.1:0.4", "--target"]
    argv += ["runout=0.15+-0.001", "--budget", "12", "--json", "--out", str(tmp_path), "-q"]
    assert main([*argv, "--set", "effects.friction=coulomb", "--set", "domain.nx=40"]) == 0
    printed = json.loads(capsys.readouterr().out)
    assert printed == json.loads((tmp_path / "calibration.json").read_text())
    assert printed["calibration"]["budget"] == 12
    assert printed["calibration"]["set"] == FIXED
    assert printed["best"]["values"]["effects.coulomb_mu"] == pytest.approx(0.2, rel=1e-3)


def test_quiet_keeps_the_result_on_stdout(tmp_path, capsys, monkeypatch):
    """-q drops the progress lines (stderr), never the result: the best values, their
    intervals and where the files are go to stdout."""
    import tiseg.apps.commands.calibrate as command

    real = command.run_calibration
    monkeypatch.setattr(
        command,
        "run_calibration",
        lambda cal, out, **kw: real(cal, out, **{**kw, "execute": Model(run_out_of_mu)}),
    )
    argv = ["calibrate", SCENE, "--param", "effects.coulomb_mu=0.1:0.4", "--target"]
    argv += ["runout=0.15+-0.001", "--budget", "12", "--out", str(tmp_path), "-q"]
    assert main([*argv, "--set", "effects.friction=coulomb", "--set", "domain.nx=40"]) == 0
    out, err = capsys.readouterr()
    assert err == ""
    best = json.loads((tmp_path / "calibration.json").read_text())["best"]["values"]
    assert f"best: effects.coulomb_mu = {best['effects.coulomb_mu']:.6g}" in out
    assert "effects.coulomb_mu = " in out and "calibration.json" in out
