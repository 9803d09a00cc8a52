"""Values that could never finish, or that silently changed meaning, and the checks that
refuse them (issue 31): output and checkpoint intervals, schedules that must not enumerate
every multiple inside a step, the memory check, deeply nested scenes, lower bounds on
numerics and physics values, and the steady-state message.

Nothing here builds a simulation except where noted; the whole file runs in a few seconds.
"""

from __future__ import annotations

import pytest

from tiseg.errors import InputError
from tiseg.scene import load_scene
from tiseg.schedules import TimeInterval

from solver_helpers import exit_code as _call


@pytest.fixture(scope="module", autouse=True)
def _imported():
    """Import the commands (and Taichi) once: Taichi announces itself on stderr at its first
    import, which is not a message of ours."""
    import tiseg.simulation  # noqa: F401
    from tiseg.cli import build_parser

    build_parser()


def _one_line_error(capfd, rc) -> str:
    out, err = capfd.readouterr()
    assert rc == 2, (out, err)
    assert "Traceback" not in err and "Traceback" not in out
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("tiseg") and "error:" in lines[0], err
    return lines[0]


def _run_refused(capfd, tmp_path, *sets: str) -> str:
    argv = ["run", "dam-break", "--out", str(tmp_path / "out"), "--no-progress"]
    for s in sets:
        argv += ["--set", s]
    line = _one_line_error(capfd, _call(argv))
    assert not (tmp_path / "out").exists()
    return line


# ------------------------------------------------------------------ item 1: intervals
class _Counting(TimeInterval):
    """A TimeInterval that counts the scheduled times it computes, and gives up past a few
    thousand (the unfixed schedule enumerated every multiple, forever for some)."""

    calls = 0

    def _time(self, k):
        self.calls += 1
        assert self.calls < 5000, "the schedule enumerates the multiples"
        return super()._time(k)


def test_due_costs_the_same_however_many_multiples_a_step_crosses():
    s = _Counting(1e-6)
    assert s.due(0.0, 1.0, 1)  # a million multiples in one step
    assert s.calls <= 4
    s.calls = 0
    assert not s.due(0.25, 0.25 + 0.5e-6, 2)  # none
    assert s.calls <= 4
    s.calls = 0
    assert s.due(0.5, 0.5 + 1e-6, 3)  # exactly one, at 0.500001
    assert s.calls <= 4


def test_time_interval_still_names_the_times_a_user_wrote():
    s = TimeInterval(0.1)
    assert s.times_in(0.0, 0.35) == [0.1, 0.2, 0.3]
    assert s.times_in(1.8, 1.9) == [1.9]  # 19 * 0.1 rounded to 12 digits
    assert not s.due(0.3, 0.35, 4)
    assert s.contains(1.9) and not s.contains(1.95) and not s.contains(0.0)


def test_an_interval_lost_in_the_times_rounding_is_refused_not_a_hang():
    # at t = 1 s, multiples of 1e-12 s differ in the 13th digit: the 12-digit times collapse
    s = _Counting(1e-12)
    with pytest.raises(InputError, match="interval is too short"):
        s.due(1.0, 2.0, 1)
    with pytest.raises(InputError, match="interval is too short"):
        s.times_in(1.0, 2.0)
    assert not TimeInterval(1e-320).contains(1.0)  # no OverflowError


@pytest.mark.parametrize(
    "setting, word",
    [
        ("output.checkpoint_interval=1e-300", "1e+300 checkpoint times"),  # hung, unfixed
        ("output.checkpoint_interval=9.9e-7", "1.01e+06 checkpoint times"),
        ("output.interval=1e-320", "over 1e308 snapshots"),  # t_end / interval overflows
    ],
)
def test_intervals_giving_too_many_times_are_refused(setting, word):
    key = setting.split("=")[0]
    with pytest.raises(InputError) as info:
        load_scene("dam-break", ["time.t_end=1", setting])
    msg = str(info.value)
    assert f"{key}=" in msg and word in msg and "at most 1000000" in msg, msg
    assert "at least 1e-06 s" in msg, msg


@pytest.mark.parametrize("setting", ["output.checkpoint_interval=9.9e-7", "output.interval=1e-320"])
def test_intervals_giving_too_many_times_are_one_line(setting, capfd, tmp_path):
    line = _run_refused(capfd, tmp_path, "domain.nx=40", "time.t_end=1", setting)
    assert setting.split("=")[0] in line and "at most 1000000" in line, line


def test_an_interval_of_a_millionth_of_the_run_is_accepted():
    sc = load_scene("dam-break", ["time.t_end=1", "output.checkpoint_interval=1e-6"])
    assert sc.output.checkpoint_interval == 1e-6
