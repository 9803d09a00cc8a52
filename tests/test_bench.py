"""Benchmarks and the run-time estimate: correctness of what they compute and write, on tiny
problems. No test asserts a speed: timings are only checked to be positive and finite, and the
estimate against a real run of the same tiny scene in the same process (factor 1.5)."""

import csv
import json
import math

import numpy as np
import pytest

from tiseg.apps.bench import accuracy, throughput


# ------------------------------------------------------------------------------- Pareto front
def test_pareto_front_on_synthetic_points():
    # (error, wall): 0 and 2 are dominated by 1; 4 ties 3 in time but is less accurate;
    # 5 is the most accurate; 6 has no error (unstable) and 7 no time
    pts = [
        (0.5, 2.0),
        (0.1, 1.0),
        (0.2, 3.0),
        (0.05, 4.0),
        (0.07, 4.0),
        (0.01, 9.0),
        (math.nan, 0.1),
        (0.001, math.inf),
    ]
    err, wall = zip(*pts)
    assert accuracy.pareto_front(err, wall) == [1, 3, 5]
    # no point off the front beats a front point in both, and every other point is beaten
    front = set(accuracy.pareto_front(err, wall))
    for i in range(6):
        dominated = any(
            err[j] <= err[i] and wall[j] <= wall[i] and (err[j], wall[j]) != (err[i], wall[i])
            for j in range(6)
        )
        assert (i in front) == (not dominated), i
    assert accuracy.pareto_front([], []) == []


def _row(problem, res, rec, stepper, error, wall, prec="f64", status="ok"):
    return {
        "problem": problem,
        "resolution": res,
        "reconstruction": rec,
        "flux": "kt",
        "phi_flux": "upwind",
        "stepper": stepper,
        "precision": prec,
        "backend": "cpu",
        "cfl": 0.25,
        "error": error,
        "wall_s": wall,
        "steps": 10,
        "rhs_evals": 20,
        "cells": res,
        "value": math.nan,
        "status": status,
    }


def test_defaults_assessed_against_the_front():
    rows = [
        _row("p", 100, "weno", "rkc", 0.010, 2.0),  # default, dominated by minmod
        _row("p", 100, "minmod", "rkc", 0.008, 1.0),
        _row("p", 200, "weno", "rkc", 0.002, 5.0),  # default, on the front
        _row("p", 200, "minmod", "ssprk3", 0.003, 6.0),
        _row("p", 50, "weno", "euler", math.nan, 0.1, status="unstable"),
    ]
    accuracy.mark_pareto(rows)
    assert [r["pareto"] for r in rows] == [False, True, True, False, False]
    a = accuracy.assess_defaults(rows)["p"]
    assert a["count"] == 2 and a["on_front"] == 1
    d100, d200 = a["defaults"]
    assert not d100["on_front"] and d100["overhead"] == pytest.approx(2.0)
    assert d100["instead"]["reconstruction"] == "minmod"
    assert d200["on_front"] and d200["overhead"] == pytest.approx(1.0)
    assert "1/2 default points on the front" in accuracy.verdict({"p": a})
    # in cell-updates (evaluations x cells, 20 x 100 each here) the default is as cheap
    assert d100["work_overhead"] == pytest.approx(1.0)


def test_transport_exact_solution_solves_the_characteristics():
    x = np.linspace(0, 0.1, 41)
    assert np.allclose(accuracy.transport_exact(x, 0.0), 0.5 + 0.25 * np.cos(2 * np.pi * x / 0.1))
    t = accuracy.T6B_T_END
    phi = accuracy.transport_exact(x, t)
    speed = 0.2 * (1 / 7 + 12 * phi / 7)
    assert np.allclose(phi, 0.5 + 0.25 * np.cos(2 * np.pi * (x - speed * t) / 0.1), atol=1e-12)


# ---------------------------------------------------------------------------- accuracy study
def test_accuracy_points_csv_and_plots(ti_cpu, tmp_path):
    """Two real Ritter points (scored against the exact solution; one simulation, its stepper
    swapped) plus synthetic ones through the writer: every CSV column, the Pareto flags, a PNG
    per problem, the summary."""
    pts = [
        {
            "problem": "ritter",
            "resolution": 100,
            "reconstruction": rec,
            "stepper": st,
            "cfl": 0.25,
            "reference": False,
        }
        for rec, st in (("weno", "rkc"), ("weno", "ssprk3"))
    ]
    rows = accuracy.run_points(pts, quick=True, precision="f64")
    for r in rows:
        assert r["status"] == "ok"
        assert 1e-3 < r["error"] < 0.05  # the L1 error of Ritter at 100 cells
        assert r["wall_s"] > 0 and r["steps"] > 0 and r["cells"] == 100
    assert rows[0]["rhs_evals"] == 2 * rows[0]["steps"]  # inviscid RKC: 2 stages per step
    assert rows[1]["rhs_evals"] == 3 * rows[1]["steps"]  # SSP-RK3
    rows += [
        _row("growth", 16, "weno", "rkc", 0.07, 0.5),
        _row("growth", 16, "minmod", "rkc", 0.1, 0.4),
    ]
    summary = accuracy.write_outputs(rows, tmp_path, {"cpu_model": "test", "cpu_count": 2})
    with open(tmp_path / "accuracy.csv") as fh:
        reader = csv.DictReader(fh)
        assert tuple(reader.fieldnames[:11]) == (
            "problem",
            "resolution",
            "reconstruction",
            "stepper",
            "precision",
            "backend",
            "error",
            "wall_s",
            "steps",
            "rhs_evals",
            "cells",
        )
        table = list(reader)
    assert len(table) == 4
    back = accuracy.read_csv(tmp_path / "accuracy.csv")
    assert sum(r["pareto"] for r in back if r["problem"] == "growth") == 2  # neither dominates
    assert (tmp_path / "ritter.png").stat().st_size > 1000
    assert (tmp_path / "growth.png").stat().st_size > 1000
    saved = json.loads((tmp_path / "summary.json").read_text())
    assert set(saved["assessment"]) == {"ritter", "growth"}
    assert "default points on the front" in summary["verdict"]
    assert "Pareto" in (tmp_path / "summary.md").read_text()


def test_study_plan_covers_every_combination():
    full = accuracy.plan_points(quick=False)
    for name, prob in accuracy.PROBLEMS.items():
        pts = [p for p in full if p["problem"] == name and not p["reference"]]
        assert len(pts) == len(prob.resolutions) * 3 * 3  # resolutions x 3 recs x 3 steppers
    # the finest run of each problem scored against it: the early and the late fingers front
    assert sum(p["reference"] for p in full) == 2
    quick = accuracy.plan_points(quick=True)
    assert len(quick) < len(full) / 3
    # the scheme dimensions: theta only for minmod, every flux x phi_flux pair
    pts = accuracy.plan_points(
        quick=False,
        problems=["channel"],
        steppers=["rkc"],
        reconstructions=["weno", "minmod"],
        thetas=[1.5, 2.0],
        fluxes=["kt", "central-upwind"],
        phi_fluxes=["central", "upwind"],
    )
    labels = {accuracy.scheme_label(p) for p in pts}
    assert len(pts) == len(accuracy.PROBLEMS["channel"].resolutions) * (1 + 2) * 4
    assert {"weno", "weno+cu+up", "minmod2", "minmod1.5+up"} <= labels and len(labels) == 12
    with pytest.raises(Exception, match="not known"):
        accuracy.plan_points(quick=True, problems=["nope"])


# -------------------------------------------------------------------------------- throughput
@pytest.mark.slow  # a long run: the slow set (README), which CI runs after the suite
def test_throughput_report_fields(ti_cpu, tmp_path):
    report = throughput.run_benchmark(
        nx=48,
        ny=16,
        quick=True,
        precisions=["f64"],
        backends=["cpu"],
        variants=["full", "no-viscosity"],
        out_dir=tmp_path,
    )
    assert report["machine"]["cpu_count"] >= 1 and report["machine"]["cpu_model"]
    assert report["grid"] == {"nx": 48, "ny": 16, "cells": 768, "cells_per_metre": 750.0}
    (res,) = report["results"]
    assert res["precision"] == "f64" and res["backend"] == "cpu"
    assert res["bandwidth"]["used_GBps"] > 0
    names = [v["name"] for v in res["variants"]]
    assert names == ["full", "no-viscosity"]
    for v in res["variants"]:
        for key in (
            "rhs_s",
            "cell_updates_per_s",
            "stage_s",
            "plan_s",
            "step_s",
            "steps_per_s",
            "numpy_rhs_s",
            "speedup_vs_numpy",
            "bound_s",
            "times_the_bound",
        ):
            assert math.isfinite(v[key]) and v[key] > 0, (v["name"], key)
        assert v["cells"] == 768 and v["min_bytes_per_cell"] == 2 * v["nc"] * 8
        assert v["implemented_bytes_per_cell"] > v["min_bytes_per_cell"]
    full, novisc = res["variants"]
    assert full["nc"] == 4 and full["stages_per_step"] >= novisc["stages_per_step"] >= 2
    (eff,) = res["effects"]
    assert eff["variant"] == "no-viscosity" and eff["stages_full"] == full["stages_per_step"]
    for f in ("throughput.json", "throughput.md", "effects.json", "effects.md"):
        assert (tmp_path / f).exists()
    assert json.loads((tmp_path / "throughput.json").read_text())["grid"]["cells"] == 768
    assert "| viscosity" in throughput.effects_markdown(report)


def test_variant_scenes_switch_one_effect_each():
    full = throughput.variant_scene("full", 30, 10)
    assert full.segregation and full.viscous and full.feedback and not full.is_1d
    assert full.dx == pytest.approx(1 / 750) and full.dy == pytest.approx(1 / 750)
    assert not throughput.variant_scene("no-segregation", 30, 10).segregation
    assert not throughput.variant_scene("no-feedback", 30, 10).feedback
    assert not throughput.variant_scene("no-viscosity", 30, 10).viscous
    assert throughput.variant_scene("friction-none", 30, 10).effects.friction == "none"
    one = throughput.variant_scene("1d", 30, 10)
    assert one.is_1d and one.domain.nx == 300


# ------------------------------------------------------------------------------------ estimate
@pytest.mark.slow  # a long regression run: CI runs it in the slow set
def test_estimate_predicts_a_small_fingers_run(ti_cpu, tmp_path, capsys):
    """`tiseg estimate` on a small fingers run against the real run in this process: steps and
    operator evaluations within a factor 1.5. (Wall time is compared in the benchmark report,
    not here: a shared machine's load makes a timed assertion flaky.)"""
    from tiseg.apps.cli import main
    from tiseg.setup.scene import load_scene
    from tiseg.run.simulation import Simulation

    sets = ["domain.resolution=40", "time.t_end=1.5", "output.times=[]", "output.interval=0.5"]
    assert main(["estimate", "fingers", *sum((["--set", s] for s in sets), []), "--json"]) == 0
    est = json.loads(capsys.readouterr().out)
    sim = Simulation(load_scene("fingers", sets))
    stats = sim.run(out_dir=tmp_path / "run", progress=False)
    for key, real in (("steps", stats.steps), ("rhs_evals", stats.stages)):
        ratio = est[key] / real
        assert 1 / 1.5 < ratio < 1.5, (key, est[key], real)


def test_predicted_steps_of_a_uniform_flow_match_the_run(ti_cpu):
    """Constant speeds: the model's CFL and RKC stage rule give the run's own step and stage
    counts (one trimmed step per output interval)."""
    from tiseg.apps.estimate import predict_steps
    from tiseg.setup.scene import load_scene
    from tiseg.run.simulation import Simulation

    sc = load_scene("uniform-flow", {"time.t_end": 0.05, "output.interval": 0.01})
    p = predict_steps(sc)
    sim = Simulation(sc)
    for t in sc.output_times[1:]:
        sim.advance(t)
    assert abs(p["steps"] - sim.stats.steps) <= 1, (p["steps"], sim.stats.steps)
    # a trimmed step may need a stage less than the model's full one
    assert abs(p["rhs_evals"] - sim.stats.stages) <= 0.03 * sim.stats.stages, (
        p["rhs_evals"],
        sim.stats.stages,
    )


def test_run_estimate_flag_prints_and_does_not_run(tmp_path, capsys, monkeypatch):
    import tiseg.apps.estimate as E
    from tiseg.apps.cli import main

    def fake(scene, **kw):
        return E.Estimate(
            scene=scene.name,
            grid=(1, 1),
            t_end=1.0,
            steps=7,
            rhs_evals=14,
            mean_stages=2.0,
            dt_min=0.1,
            dt_max=0.1,
            mean_active_cells=1.0,
            wall_steps_s=1.0,
            wall_diagnostics_s=0.0,
            wall_output_s=0.0,
            wall_compile_s=0.0,
            wall_s=1.0,
            wall_idle_s=1.0,
            setup_s=0.0,
            model=["m"],
            calibration={},
        )

    monkeypatch.setattr(E, "estimate", fake)
    out = tmp_path / "never"
    assert main(["run", "dam-break", "--estimate", "--json", "--out", str(out)]) == 0
    assert json.loads(capsys.readouterr().out)["steps"] == 7
    assert not out.exists()


def test_front_position_interpolates_between_cell_centres():
    x = (np.arange(10) + 0.5) * 0.1
    h = np.zeros((3, 10))
    h[:, :4] = 2e-3
    h[1, 4] = 5.5e-4  # the last wet cell (h_min = 1e-4), in one row
    xf = accuracy.front_position(h, x, 1e-4)
    # crossing of h_min between x = 0.45 (5.5e-4) and 0.55 (0): 0.45 + 0.1 * 4.5/5.5
    assert xf == pytest.approx(0.45 + 0.1 * 4.5 / 5.5)
    assert math.isnan(accuracy.front_position(np.zeros((2, 10)), x, 1e-4))


# ------------------------------------------------------------------------------- steppers
@pytest.mark.slow
def test_stepper_benchmark_from_a_runs_own_states(ti_cpu, tmp_path, capsys):
    """tiseg bench steppers restarts from a run's snapshots: each stepper against SSP-RK3 at a
    5x smaller Courant number on the same grid. With a smooth friction source (the regularised
    scheme, an SSP-RK3 run) the time errors must rank by order: forward Euler (first order)
    well above SSP-RK3 (third order); everything finite; the report names the run's stepper and
    whether it is on the front. The default numerics (RKC, projected friction) are measured
    too: the projection is a first-order splitting, whose error at these long steps (40 cells
    per metre) keeps the higher-order steppers from ranking by order (RKC 1.0e-2 against
    6.9e-4 with the regularised source over the same span), so only RKC's own row is held to
    the bound there."""
    from tiseg.apps.cli import main
    from tiseg.errors import InputError
    from tiseg.apps.bench import steppers

    def make_run(out, *sets):
        args = ["run", "fingers", "--set", "domain.resolution=40", "--set", "time.t_end=1.5"]
        args += ["--set", "output.interval=0.5", "--set", "output.times=[]"]
        for kv in sets:
            args += ["--set", kv]
        assert main(args + ["--out", str(out), "--no-progress"]) == 0
        capsys.readouterr()

    def bench(out, *names):
        argv = ["bench", "steppers", str(out), "--times", "1.5", "--repeats", "1", "--json"]
        assert main(argv + (["--steppers", *names] if names else [])) == 0
        return json.loads(capsys.readouterr().out)

    run = tmp_path / "run"
    make_run(
        run,
        'numerics.friction_scheme="regularised"',
        'numerics.stepper="ssprk3"',
        "numerics.cfl=0.25",
    )
    ssp = ("ssprk3", "ssprk2", "ssprk4_2", "ssprk10_4", "euler")
    rep = bench(run, *ssp)
    (start,) = rep["starts"]
    assert start["time"] == 1.5 and start["span"] > 0
    rows = {r["stepper"]: r for r in start["rows"]}
    assert set(rows) == set(ssp)
    for r in rows.values():
        assert r["status"] == "ok" and r["steps"] > 0 and r["wall_s"] > 0
        assert 0 < r["error"] < 0.05, r
    assert rows["euler"]["error"] > 3 * rows["ssprk3"]["error"], rows
    assert rows["ssprk3"]["evaluations"] == 3 * rows["ssprk3"]["steps"]
    assert rows["ssprk4_2"]["evaluations"] == 4 * rows["ssprk4_2"]["steps"]
    # the fourth-order method's time error is below the first-order one's
    assert rows["ssprk10_4"]["error"] < rows["euler"]["error"], rows
    assert any(r["pareto"] for r in rows.values())
    assert rep["own_stepper"] == "ssprk3" and "t = 1.5 s: ssprk3" in rep["verdict"]
    assert (run / "bench-steppers" / "steppers.md").read_text().count("| ssprk3 (run) |") == 1

    default = tmp_path / "default"
    make_run(default, 'numerics.stepper="rkc"', 'numerics.step_rule="sum"', "numerics.cfl=0.5")
    rep = bench(default, "rkc")
    (row,) = rep["starts"][0]["rows"]
    assert row["stepper"] == "rkc" and row["status"] == "ok"
    assert 0 < row["error"] < 0.05, row
    assert rep["own_stepper"] == "rkc" and "t = 1.5 s: rkc" in rep["verdict"]
    assert (default / "bench-steppers" / "steppers.md").read_text().count("| rkc (run) |") == 1
    with pytest.raises(InputError, match="no snapshot at that time"):
        steppers.measure(run, times=[0.7])
    with pytest.raises(InputError, match="no scene.toml"):
        steppers.measure(tmp_path)


def test_ensemble_row_counts_every_members_cell_stages(tmp_path):
    """The ensemble row of `tiseg bench gpu` on the CPU, f32 and f64 (a child process each):
    every member ran (two seeds here) on the scene's grid, and the throughput is the members'
    cells × stages over the wall time (so it cannot exceed cells × the largest possible stage
    count per second). Its mode says how the members advanced."""
    from tiseg.apps.bench import ensemble
    from tiseg.setup.scene import load_scene

    rows = ensemble.ensemble_rows("cpu", 2, 40, 0.2, tmp_path)
    sc = load_scene("fingers", {"domain.resolution": 40, "time.t_end": 0.2})
    assert [(r["backend"], r["precision"]) for r in rows] == [("cpu", "f32"), ("cpu", "f64")]
    for r in rows:
        assert r["ok"] and r["arch"] == "cpu" and r["members"] == 2, r
        assert r["cells"] == sc.domain.nx * sc.domain.ny
        assert r["steps"] >= 2 and r["wall_s"] > 0 and r["mode"] == ensemble.MODE
        assert 0 < r["member_cell_stages_per_s"] <= r["cells"] * 2 * r["steps"] * 200 / r["wall_s"]
