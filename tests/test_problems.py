"""Problems as data: every shipped problem file loads, the accuracy study runs exactly the
problems the files describe, a broken file is refused with one line that names the key and
the rule, and a new problem on a registered solution is just a file."""

import math
import tomllib

import numpy as np
import pytest

from tiseg.apps.bench import accuracy
from tiseg.data import PROBLEM_DIR
from tiseg.errors import InputError
from tiseg.post.problems import (
    RECORDS,
    SCORES,
    SOLUTIONS,
    builtin_problems,
    list_builtin_problems,
    load_problem,
)
from tiseg.post.problems.reader import problem_from_dict

STUDY = [
    "transport",
    "ritter",
    "growth",
    "fingers",
    "fingers-late",
    "channel",
    "channel-speed",
    "mangeney",
    "parabolic-cap",
    "sliding-layer",
]


def test_every_shipped_problem_loads_and_builds_its_scene():
    assert sorted(list_builtin_problems()) == sorted(STUDY)
    assert list(builtin_problems()) == STUDY  # the study's table order (each file's order)
    for name in STUDY:
        p = load_problem(name)
        assert p.name == name and p.title and p.error_label and p.resolution_label
        assert p.record["name"] in RECORDS and p.score_by["name"] in SCORES
        assert p.exact["name"] in SOLUTIONS
        for quick in (False, True):
            res = (p.quick_resolutions if quick else p.resolutions)[0]
            sc = p.build(res, {"stepper": "ssprk3"}, quick)
            assert sc.numerics.stepper == "ssprk3"
            if p.end(quick) is not None:
                assert sc.t_end == p.end(quick)


def test_the_study_runs_what_the_files_say():
    """The bench's registry is the loader's problems, and so are its plan and its scenes."""
    assert list(accuracy.PROBLEMS) == STUDY
    for name in STUDY:
        assert accuracy.PROBLEMS[name] == load_problem(name)
    for quick in (False, True):
        plan = accuracy.plan_points(quick, steppers=["rkc"], reconstructions=["weno"])
        for name in STUDY:
            p = load_problem(name)
            res = [pt["resolution"] for pt in plan if pt["problem"] == name and not pt["reference"]]
            assert tuple(res) == (p.quick_resolutions if quick else p.resolutions)
            refs = [pt["resolution"] for pt in plan if pt["problem"] == name and pt["reference"]]
            want = p.reference_resolution
            assert refs == ([want["quick" if quick else "full"]] if want else [])
    # the two fingers problems are scored against their finest run, the others exactly
    assert {n for n in STUDY if load_problem(n).reference_resolution} == {"fingers", "fingers-late"}


def test_problem_scenes_are_those_the_study_ran_before():
    """The files reproduce the scenes the study's Python built: spot values of each."""
    t = load_problem("transport").build(50, {}, False)
    assert t.name == "bench-transport" and t.domain.nx == 50
    assert t.t_end == 0.5 * 7 * 0.1 / (12 * 0.2 * 0.25 * 2 * math.pi)  # half the breaking time
    assert t.effects.coulomb_mu == math.tan(math.radians(27.0))
    r = load_problem("ritter").build(100)
    assert (r.domain.nx, r.t_end, r.numerics.h_min, r.numerics.h_eps) == (100, 0.1, 1e-7, 1e-9)
    g = load_problem("growth").build(16)
    assert g.initial.amplitude == 1e-4 and g.domain.nx == 16
    f = load_problem("fingers").build(40, {}, quick=True)
    assert (f.domain.Lx, f.domain.Ly, f.t_end, f.output.interval) == (0.8, 0.5, 1.0, 1.0)
    late = load_problem("fingers-late").build(40, {}, quick=False)
    assert (late.domain.Ly, late.t_end) == (0.25, 7.5)
    c = load_problem("channel-speed").build(250, {}, quick=True)
    assert (c.t_end, c.output.interval) == (1.0, 1.0)


def test_transport_solution_is_the_characteristics_solution():
    p = load_problem("transport")
    sc = p.build(50)
    exact = p.solution(sc)
    x, _ = sc.domain.cell_centres()
    # cell averages of a smooth profile: within dx^2 of the point values
    point = accuracy.transport_exact(x, sc.t_end)
    assert exact.shape == (50,) and np.max(np.abs(exact - point)) < 0.25 * (2 * np.pi / 50) ** 2
    # a perfect run scores zero
    assert p.score({"phi": exact}, sc)[1] == 0.0


def test_transport_solution_agrees_with_an_independent_root_finder():
    """The registry's bisection against scipy's brentq on phi = phi_init(x - u0 (1 - G') t)."""
    from scipy.optimize import brentq

    L, u0, mean, amp = 0.1, 0.2, 0.5, 0.25
    t = load_problem("transport").end(quick=False)
    speed = lambda p: u0 * (1.0 / 7.0 + 12.0 * p / 7.0)  # noqa: E731
    init = lambda s: mean + amp * np.cos(2 * np.pi * s / L)  # noqa: E731
    x = np.linspace(0.0, L, 37)
    want = [
        brentq(lambda p: p - init(xi - speed(p) * t), mean - amp, mean + amp, xtol=1e-15)  # noqa: B023
        for xi in x
    ]
    assert np.allclose(accuracy.transport_exact(x, t, L, u0, mean, amp), want, rtol=0, atol=1e-13)


def test_dam_break_solution_is_stoker_on_a_wet_bed():
    from tiseg.model.exact_dambreak import cell_averages, stoker

    p = load_problem("ritter")
    sc = p.build(120)
    dry = p.solution(sc)
    assert dry.max() == pytest.approx(0.002, rel=1e-12) and dry[-1] == 0.0
    wet = sc.with_overrides({"initial.h_right": 0.0005})
    x, _ = wet.domain.cell_centres()
    want = cell_averages(lambda q: stoker(q, 0.1, 0.002, 0.0005, 0.1)[0], x, wet.dx)
    assert np.array_equal(p.solution(wet), want)


# ------------------------------------------------------------------------------ bad files
def _good(name="ritter") -> dict:
    return tomllib.loads((PROBLEM_DIR / f"{name}.toml").read_text())


def _refused(data, match):
    with pytest.raises(InputError, match=match) as e:
        problem_from_dict(data, "bad", source="bad.toml")
    msg = str(e.value)
    assert "\n" not in msg and msg.startswith("problem file 'bad.toml': "), msg
    return msg


def test_bad_problem_files_are_refused_with_one_line():
    d = _good()
    d["exact"]["name"] = "riter"
    _refused(d, r"unknown exact solution 'riter'; known: .*dam-break.*finest-run")
    d = _good()
    d["exact"]["name"] = "dam-brake"
    _refused(d, r"unknown exact solution 'dam-brake' \(did you mean 'dam-break'\?\)")
    d = _good()
    d["score"]["name"] = "relative-l2"
    _refused(d, r"unknown score 'relative-l2' \(did you mean 'relative-l1'\?\)")
    d = _good()
    del d["score"]["field"]
    _refused(d, r"missing key 'score.field'")
    d = _good()
    del d["exact"]
    _refused(d, r"missing table \[exact\]")
    d = _good()
    d["scene"]["resolutoin"] = 3
    _refused(d, r"unknown key 'scene.resolutoin' \(did you mean 'resolution'\?\)")
    d = _good()
    d["scene"]["builtin"] = "dam-brake"
    _refused(d, r"unknown built-in scene 'dam-brake' \(did you mean 'dam-break'\?\)")
    d = _good()
    d["resolutions"]["quick"] = [100, -2]
    _refused(d, r"resolutions.quick must be a non-empty list of positive integers")
    d = _good()
    d["score"] = {"name": "growth-rate", "discard": 3}
    _refused(d, r"score 'growth-rate' compares with a rate, but exact solution 'dam-break'")
    d = _good()
    d["score"]["field"] = "phi"
    _refused(d, r"score.field 'phi' is not among record.fields \['h'\]")
    d = _good("growth")
    d["score"]["discard"] = 48
    _refused(d, r"score.discard must be an integer in \[0, record.samples - 2\]")
    d = _good("fingers")
    d["exact"]["resolution"] = {"full": 300}
    _refused(d, r"exact.resolution must be \{full = .., quick = ..\}")
    d = _good("fingers")
    del d["scene"]["end"]
    _refused(d, r"scene.snapshot_at_end needs scene.end")
    d = _good()
    d["scene"]["set"]["numerics.h_mni"] = 1e-7
    msg = _refused(d, r"its scene: .*h_mni")
    assert "h_min" in msg  # the scene reader's close-match hint comes through


def test_unknown_or_unreadable_problem_files(tmp_path):
    with pytest.raises(InputError, match=r"unknown built-in problem 'riter' \(did you mean"):
        load_problem("riter")
    bad = tmp_path / "mine.toml"
    bad.write_text((PROBLEM_DIR / "ritter.toml").read_text().replace('"relative-l1"', '"nope"'))
    with pytest.raises(InputError, match=r"^problem file '.*mine.toml': unknown score 'nope'"):
        load_problem(bad)
    bad = tmp_path / "x.toml"
    bad.write_text("title = [")
    with pytest.raises(InputError, match="is not valid TOML"):
        load_problem(bad)
    with pytest.raises(InputError, match="cannot read problem file"):
        load_problem(tmp_path / "none.toml")


# -------------------------------------------------------------------- a problem is a file
def test_a_new_problem_file_runs_and_scores(ti_cpu, tmp_path):
    """Stoker's wet-bed dam break, declared only as a file on the registered solution: it
    loads, runs and scores, and its error falls as the grid is refined."""
    from tiseg.run.simulation import Simulation

    text = (PROBLEM_DIR / "ritter.toml").read_text()
    text = text.replace(
        '"numerics.h_eps" = 1e-9', '"numerics.h_eps" = 1e-9\n"initial.h_right" = 5e-4'
    )
    path = tmp_path / "stoker.toml"
    path.write_text(text)
    p = load_problem(path)
    assert p.name == "stoker" and p.source == str(path)
    errors = []
    for n in (100, 200):
        sc = p.build(n, {"stepper": "ssprk3"})
        value, err = p.score(p.run(Simulation(sc)), sc)
        assert math.isnan(value) and 0 < err < 0.1
        errors.append(err)
    assert errors[1] < 0.8 * errors[0], errors
