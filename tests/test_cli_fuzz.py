"""Every subcommand, fed bad options and damaged inputs, answers with one line and exit code 2:
never a traceback, never silent garbage, and nothing heavy started first."""

from __future__ import annotations

import os
import shutil

import pytest

from solver_helpers import tiny_fingers

from tiseg.apps.cli import build_parser, main


@pytest.fixture(scope="module")
def places(tmp_path_factory, ti_cpu):
    """{run}: a finished run; {trunc}: the same with fields.nc cut in half; {edited}: its
    scene.toml edited to another grid; {deep}: a TOML file nested 5000 deep; {tmp}: a folder."""
    base = tmp_path_factory.mktemp("fuzz")
    run = base / "run"
    assert (
        main(
            [
                *tiny_fingers(0.1, interval=0.05),
                "--out",
                str(run),
            ]
        )
        == 0
    )
    trunc = base / "trunc"
    shutil.copytree(run, trunc)
    with open(trunc / "fields.nc", "r+b") as fh:
        fh.truncate(os.path.getsize(trunc / "fields.nc") // 2)
    edited = base / "edited"
    shutil.copytree(run, edited)
    text = (edited / "scene.toml").read_text()
    (edited / "scene.toml").write_text(text.replace("resolution = 40", "resolution = 60"))
    deep = base / "deep.toml"
    deep.write_text("[a]\nx = " + "[" * 5000 + "]" * 5000 + "\n")
    sweep_deep = base / "deep-sweep.toml"
    sweep_deep.write_text(deep.read_text())
    return {
        "run": str(run),
        "trunc": str(trunc),
        "edited": str(edited),
        "deep": str(deep),
        "sweepdeep": str(sweep_deep),
        "tmp": str(base),
    }


CASES = [
    # steady / stability
    ["steady", "--h0", "nan", "--phi0", "0.8"],
    ["steady", "--h0", "-1", "--phi0", "0.8"],
    ["steady", "--h0", "0.002", "--phi0", "2"],
    ["steady", "--h0", "0.002", "--phi0", "0.8", "--zeta", "100"],
    ["stability", "--h0", "0.002", "--phi0", "0.8", "--k", "1e308"],
    ["stability", "--h0", "0.002", "--phi0", "0.8", "--k", "nan"],
    ["stability", "--h0", "0.002", "--phi0", "0.8", "--k", "1", "--plot", "{tmp}/x.txt"],
    ["stability", "--h0", "0.002", "--phi0", "0.8", "--nu", "-1"],
    ["stability", "--F", "nan", "--phi0", "0.8"],
    # figures / demo
    ["figures", "stability", "--out", "/dev/null"],
    ["figures", "stability", "--dpi", "1e9"],
    ["figures", "fingers", "--out", "/dev/null", "--no-run"],
    ["demo", "--out", "/dev/null"],
    ["demo", "--resolution", "1e9"],
    ["demo", "--t-end", "nan", "--out", "{tmp}/demo"],
    # run / estimate / view
    ["run", "fingers", "--threads", "100000"],
    ["run", "fingers", "--set", "name=.."],
    ["run", "fingers", "--set", "flow.nu=1e308"],
    ["run", "fingers", "--set", "domain.Ly=1e308"],
    ["run", "fingers", "--set", "flow.nu=0.01", "--set", "flow.nu=0.02"],
    ["run", "{deep}"],
    ["run", "{run}"],  # a run folder is not a scene
    ["run", "fingers", "--out", "{run}"],  # a finished run: needs --overwrite
    ["run", "--resume", "{run}"],  # finished: nothing to resume
    ["estimate", "fingers", "--threads", "-1"],
    ["estimate", "fingers", "--set", "flow.h0=-1"],
    ["view", "fingers", "--frames", "-1"],
    ["view", "fingers", "--steps-per-frame", "0"],
    # fingers / render on damaged runs
    ["fingers", "{tmp}/nowhere"],
    ["fingers", "{run}", "--time", "nan"],
    ["fingers", "{run}", "--min-span", "2"],
    ["fingers", "{trunc}"],
    ["render", "{trunc}", "--movie", "{tmp}/m.mp4"],
    ["render", "{run}", "--scale", "1e6", "--movie", "{tmp}/m.mp4"],
    ["render", "{run}", "--fps", "0", "--movie", "{tmp}/m.mp4"],
    ["render", "{run}", "--panels", "{tmp}/p.png", "--times", "nan"],
    ["render", "{tmp}/nowhere"],
    # sweeps
    ["sweep", "{tmp}/missing.toml"],
    ["sweep", "{sweepdeep}"],
    ["sweep", "tiny", "--workers", "0", "--out", "{tmp}/sw"],
    ["sweep", "tiny", "--threads-per-task", "100000", "--out", "{tmp}/sw"],
    ["sweep", "tiny", "--scheduler", "foo", "--out", "{tmp}/sw"],
    ["sweep", "tiny", "--scheduler", "http://", "--out", "{tmp}/sw"],
    # calibrations
    ["calibrate", "dam-break", "--param", "effects.coulomb_mu=0.2:0.1", "--target", "runout=1"],
    ["calibrate", "dam-break", "--param", "effects.coulomb_mu=0.1:0.2", "--target", "nope=1"],
    ["calibrate", "dam-break", "--param", "effects.coulomb_mu=0.1:0.2", "--target", "runout=nan"],
    ["calibrate", "dam-break", "--param", "domain.nx=10:20", "--target", "runout=1"],
    ["calibrate", "{deep}", "--param", "effects.coulomb_mu=0.1:0.2", "--target", "runout=1"],
    [
        "calibrate",
        "fingers",
        "--param",
        "flow.nu=0.01:0.02",
        "--target",
        "wavelength=0.1",
        "--time",
        "nan",
    ],
    [
        "calibrate",
        "dam-break",
        "--param",
        "effects.coulomb_mu=0.1:0.2",
        "--target",
        "runout=1",
        "--out",
        "/dev/null",
    ],
    [
        "calibrate",
        "dam-break",
        "--param",
        "effects.coulomb_mu=0.1:0.2",
        "--target",
        "runout=1",
        "--workers",
        "0",
        "--out",
        "{tmp}/cal",
    ],
    # benchmarks
    ["bench", "throughput", "--threads", "100000"],
    ["bench", "steppers", "{trunc}"],
    ["bench", "steppers", "{edited}"],
    ["bench", "steppers", "{tmp}/nowhere"],
    ["scenes", "show", "fingrs"],
    ["scenes", "show", "{deep}"],
    ["scenes", "show"],
    ["scenes", "list"],
]


@pytest.mark.parametrize("argv", CASES, ids=[" ".join(c) for c in CASES])
def test_bad_input_is_one_line(argv, places, capfd):
    args = [a.format(**places) for a in argv]
    try:
        rc = main(args)
    except SystemExit as exc:  # argparse refuses before main runs
        rc = exc.code
    out, err = capfd.readouterr()
    assert rc == 2, (out, err)
    assert "Traceback" not in err + out, err
    lines = [
        ln for ln in err.strip().splitlines() if not ln.startswith(("[Taichi]", "tiseg: "))
    ]  # notes, progress lines
    assert len(lines) == 1, err


def test_every_subcommand_is_fuzzed():
    parser = build_parser()
    sub = next(a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction")
    fuzzed = {c[0] for c in CASES}
    assert set(sub.choices) <= fuzzed, set(sub.choices) - fuzzed
