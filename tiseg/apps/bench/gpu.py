"""The GPU check (``tiseg bench gpu``): what a GPU does for tiseg, measured in one sitting.

Meant for a machine with a CUDA GPU (``--arch gpu``, the default), and runnable anywhere with
``--arch vulkan`` (software Vulkan: a correctness check of the code path, not of speed) or
``--arch cpu``. It records, in this order:

1. **throughput**: operator cell-updates per second and steps per second of the full fingers
   physics on the paper's 1125 x 375 grid, in f32 and f64, on the device and on the CPU in the
   same run (`tiseg.apps.bench.throughput`, each in a child process); a precision the device
   lacks is recorded as unsupported;
2. **the paper's run**: the fingers scene at 750 cells/m to t = 7.5 s on the device (f64 where
   the device has it, else f32), with its wall time (target: under 7.5 s, faster than the
   flow itself), steps and mass balance; output only at the end, so that the disk does not
   set the pace;
3. **the viewer**: simulated seconds per wall second of the GGUI viewer at 250 cells/m,
   headless (``python -m tiseg.apps.viewer --offscreen``; target: at least 1, real time). GGUI needs
   Vulkan; without it the same loop (steps plus the colour kernel of every frame) is timed
   without the window, and the row says so;
4. **Vulkan against CUDA**, where the device offers both: the fingers scene at 250 cells/m to
   t = 2 s on each;
5. **the ensemble**: members × cells × stages per second of 64 seeds of the fingers scene at
   250 cells/m to t = 0.5 s, f32 and f64, on the CPU and on the device
   (`tiseg.apps.bench.ensemble`; the row names how the members advance).

``--quick`` shrinks every size (grids, end times) so that the whole check runs in about a
minute on software Vulkan; it is what the tests run. It prints a short table and writes
``gpu_check.json`` (and ``gpu_check.md``) into ``--out``.
"""

from __future__ import annotations

import json
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from . import child_env, log_stderr, machine_info
from ... import backend
from ...post.render import FrameRenderer
from ...errors import TisegError
from . import ensemble, throughput
from . import available_backends
from ...errors import InputError

FULL = {
    "throughput_grid": None,
    "resolution": 750,
    "t_end": 7.5,
    "viewer_resolution": 250,
    "viewer_frames": 60,
    "steps_per_frame": 4,
    "compare_resolution": 250,
    "compare_t_end": 2.0,
    "ensemble_members": 64,
    "ensemble_resolution": 250,
    "ensemble_t_end": 0.5,
}
QUICK = {
    "throughput_grid": (96, 32),
    "resolution": 60,
    "t_end": 0.5,
    "viewer_resolution": 40,
    "viewer_frames": 6,
    "steps_per_frame": 2,
    "compare_resolution": 40,
    "compare_t_end": 0.3,
    "ensemble_members": 4,
    "ensemble_resolution": 40,
    "ensemble_t_end": 0.3,
}


def _run(cmd: list[str], timeout: float) -> tuple[int, str, str, float]:
    t0 = time.perf_counter()
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, env=child_env(), timeout=timeout)
    except subprocess.TimeoutExpired:
        return 124, "", f"timed out after {timeout:.0f} s", time.perf_counter() - t0
    return p.returncode, p.stdout, p.stderr, time.perf_counter() - t0


def _last_error(stderr: str) -> str:
    """The last line of a child's stderr that names an error (else its last line)."""
    lines = [ln.strip() for ln in stderr.splitlines() if ln.strip()]
    errors = [ln for ln in lines if "error" in ln.lower()]
    return (errors or lines or ["failed"])[-1]


def fingers_run(
    arch: str, precision: str, resolution: float, t_end: float, work: Path, timeout: float = 900
) -> dict:
    """``tiseg run fingers`` on ``arch``: wall time, steps, mass balance (or the error)."""
    out = work / f"fingers-{arch}-{precision}-{resolution:g}"
    cmd = [
        sys.executable,
        "-m",
        "tiseg.apps.cli",
        "run",
        "fingers",
        "--arch",
        arch,
        "--precision",
        precision,
        "--no-progress",
        "--json",
        "--out",
        str(out),
        "--set",
        f"domain.resolution={resolution:g}",
        "--set",
        f"time.t_end={t_end:g}",
        "--set",
        "output.times=[]",
        "--set",
        f"output.interval={t_end:g}",
    ]
    rc, so, se, wall = _run(cmd, timeout)
    row = {"arch": arch, "precision": precision, "resolution": resolution, "t_end": t_end}
    if rc != 0:
        return {**row, "ok": False, "error": _last_error(se)}
    s = json.loads(so)
    return {
        **row,
        "ok": True,
        "wall_s": s["wall_time_s"],
        "process_s": wall,
        "steps": s["steps"],
        "rhs_evaluations": s["rhs_evaluations"],
        "grid": s["grid"],
        "cell_updates_per_s": s["cell_updates_per_s"],
        "mass_balance_error": s["mass_balance_error"],
        "resolved_arch": s["arch"],
        "faster_than_real_time": s["wall_time_s"] < t_end,
    }


_VIEWER_LINE = re.compile(r"viewer: (\d+) frames, t = ([\d.e+-]+) s, (\d+) steps in ([\d.]+) s")


def viewer_speed(
    arch: str,
    precision: str,
    resolution: float,
    frames: int,
    steps_per_frame: int,
    timeout: float = 600,
) -> dict:
    """Simulated seconds per wall second of the headless viewer (or its loop without GGUI)."""
    row = {
        "arch": arch,
        "precision": precision,
        "resolution": resolution,
        "frames": frames,
        "steps_per_frame": steps_per_frame,
    }
    cmd = [
        sys.executable,
        "-m",
        "tiseg.apps.viewer",
        "fingers",
        "--arch",
        arch,
        "--precision",
        precision,
        "--offscreen",
        "--frames",
        str(frames),
        "--steps-per-frame",
        str(steps_per_frame),
        "--set",
        f"domain.resolution={resolution:g}",
        "--set",
        "output.times=[]",
    ]
    rc, so, se, _ = _run(cmd, timeout)
    m = _VIEWER_LINE.search(so)
    if rc == 0 and m:
        t, steps, wall = float(m[2]), int(m[3]), float(m[4])
        return {
            **row,
            "ok": True,
            "how": "GGUI viewer, offscreen",
            "sim_t": t,
            "steps": steps,
            "wall_s": wall,
            "steps_per_s": steps / wall,
            "sim_s_per_wall_s": t / wall,
            "real_time": t >= wall,
        }
    # GGUI needs Vulkan: time the same loop (steps + colour kernel per frame) without it
    rc2, so2, se2, _ = _run(
        [
            sys.executable,
            "-m",
            "tiseg.apps.bench.gpu",
            "viewer-loop",
            arch,
            precision,
            f"{resolution:g}",
            str(frames),
            str(steps_per_frame),
        ],
        timeout,
    )
    if rc2 != 0:
        return {**row, "ok": False, "error": _last_error(se2)}
    d = json.loads(so2.strip().splitlines()[-1])
    return {
        **row,
        "ok": True,
        "how": f"steps + colour kernel, no window ({_last_error(se)})",
        "sim_t": d["sim_t"],
        "steps": d["steps"],
        "wall_s": d["wall"],
        "steps_per_s": d["steps"] / d["wall"],
        "sim_s_per_wall_s": d["sim_t"] / d["wall"],
        "real_time": d["sim_t"] >= d["wall"],
    }


def viewer_loop(
    arch: str, precision: str, resolution: float, frames: int, steps_per_frame: int
) -> dict:
    """The viewer's work without its window: per frame, steps and the colour kernel into a
    NumPy image. Runs in its own process (``python -m tiseg.apps.bench.gpu viewer-loop ...``)."""
    from ...run.simulation import Simulation

    backend.init(arch, precision)
    sim = Simulation.from_scene(
        "fingers", {"domain.resolution": resolution, "output.times": []}, precision=precision
    )
    renderer = FrameRenderer(sim, "phi")
    sim.step()  # compile outside the timing
    renderer.to_numpy()
    t0, steps0, sim_t0 = time.perf_counter(), sim.stats.steps, sim.t
    for _ in range(frames):
        for _ in range(steps_per_frame):
            sim.step()
        renderer.to_numpy()
    return {
        "wall": time.perf_counter() - t0,
        "steps": sim.stats.steps - steps0,
        "sim_t": sim.t - sim_t0,
    }


def throughput_rows(arch: str, grid, quick: bool, log) -> list[dict]:
    """Full-physics operator and step throughput, f32 and f64, on the CPU and on ``arch``."""

    rows = []
    backends = ["cpu"] + ([arch] if arch != "cpu" else [])
    nx, ny = grid or throughput.PAPER_GRID
    for be in backends:
        for prec in ("f32", "f64"):
            try:
                rep = throughput.run_benchmark(
                    nx=nx,
                    ny=ny,
                    quick=quick,
                    precisions=[prec],
                    backends=[be],
                    variants=["full"],
                    in_process=False,
                    log=log,
                )
            except TisegError as exc:
                rows.append({"backend": be, "precision": prec, "ok": False, "error": str(exc)})
                continue
            r = rep["results"][0]
            v = r["variants"][0]
            rows.append(
                {
                    "backend": be,
                    "arch": r["arch"],
                    "precision": prec,
                    "ok": True,
                    "cells": v["cells"],
                    "rhs_cell_updates_per_s": v["cells"] / v["rhs_s"],
                    "step_s": v["step_s"],
                    "steps_per_s": 1.0 / v["step_s"],
                    "stages_per_step": v["stages_per_step"],
                }
            )
    cpu = {r["precision"]: r for r in rows if r["backend"] == "cpu" and r["ok"]}
    for r in rows:
        if r["ok"] and r["backend"] != "cpu" and r["precision"] in cpu:
            c = cpu[r["precision"]]
            r["rhs_speedup_vs_cpu"] = r["rhs_cell_updates_per_s"] / c["rhs_cell_updates_per_s"]
            r["step_speedup_vs_cpu"] = c["step_s"] / r["step_s"]
    return rows


def vulkan_available() -> bool:
    code = "import tiseg; tiseg.init('vulkan', 'f32')"
    return _run([sys.executable, "-c", code], 120)[0] == 0


def run_check(arch: str = "gpu", quick: bool = False, out_dir=None, log=log_stderr) -> dict:
    """Every measurement of the module docstring; returns the report (and writes it)."""
    if arch == "gpu":
        if "gpu" not in available_backends():
            raise InputError(
                "no CUDA or Metal GPU is available here: run the GPU check on a "
                "machine with one, or check the code path with --arch vulkan "
                "(software Vulkan) or --arch cpu"
            )
    cfg = QUICK if quick else FULL
    t0 = time.perf_counter()
    work = Path(tempfile.mkdtemp(prefix="tiseg-gpu-check-"))
    log(f"[gpu check] throughput on cpu and {arch}")
    rows = throughput_rows(arch, cfg["throughput_grid"], quick, log)
    dev_f64 = any(r["ok"] and r["backend"] == arch and r["precision"] == "f64" for r in rows)
    prec = "f64" if dev_f64 or arch == "cpu" else "f32"
    log(
        f"[gpu check] fingers at {cfg['resolution']} cells/m to t = {cfg['t_end']} s "
        f"({arch}/{prec})"
    )
    run = fingers_run(arch, prec, cfg["resolution"], cfg["t_end"], work)
    log(f"[gpu check] viewer at {cfg['viewer_resolution']} cells/m ({arch}/{prec})")
    view = viewer_speed(
        arch, prec, cfg["viewer_resolution"], cfg["viewer_frames"], cfg["steps_per_frame"]
    )
    compare = []
    if arch == "gpu" and vulkan_available():
        log("[gpu check] Vulkan against CUDA")
        for a in ("gpu", "vulkan"):
            compare.append(
                fingers_run(a, prec, cfg["compare_resolution"], cfg["compare_t_end"], work)
            )
    log(
        f"[gpu check] ensemble of {cfg['ensemble_members']} members at "
        f"{cfg['ensemble_resolution']} cells/m on cpu and {arch}"
    )
    members = ensemble.ensemble_rows(
        arch,
        cfg["ensemble_members"],
        cfg["ensemble_resolution"],
        cfg["ensemble_t_end"],
        work,
    )
    report = {
        "machine": machine_info(),
        "arch": arch,
        "quick": quick,
        "throughput": rows,
        "fingers_run": run,
        "viewer": view,
        "vulkan_vs_cuda": compare,
        "ensemble": members,
        "wall_s": time.perf_counter() - t0,
    }
    if out_dir is not None:
        from ...output import write_json_atomic, write_text_atomic

        out = Path(out_dir)
        write_json_atomic(out / "gpu_check.json", report)
        write_text_atomic(out / "gpu_check.md", markdown(report))
    return report


def _f(v, fmt: str) -> str:
    return "-" if v is None else format(v, fmt)


def markdown(report: dict) -> str:
    """The short table the check prints."""
    m = report["machine"]
    lines = [
        f"GPU check ({report['arch']}{', quick' if report['quick'] else ''}) on "
        f"{m.get('cpu_model', '?')}, {m.get('date', '')}; {report['wall_s']:.0f} s",
        "",
        "| backend | precision | operator [M cell-updates/s] | step [ms] | "
        "vs CPU (operator / step) |",
        "|---|---|---|---|---|",
    ]
    for r in report["throughput"]:
        if not r["ok"]:
            lines.append(f"| {r['backend']} | {r['precision']} | unsupported: {r['error']} | | |")
            continue
        vs = (
            f"{r['rhs_speedup_vs_cpu']:.3g}x / {r['step_speedup_vs_cpu']:.3g}x"
            if "rhs_speedup_vs_cpu" in r
            else "-"
        )
        lines.append(
            f"| {r.get('arch', r['backend'])} | {r['precision']} | "
            f"{r['rhs_cell_updates_per_s'] / 1e6:.1f} | {1e3 * r['step_s']:.2f} | {vs} |"
        )
    lines.append("")
    for label, r in [("fingers run", report["fingers_run"])] + [
        (f"Vulkan vs CUDA: {c['arch']}", c) for c in report["vulkan_vs_cuda"]
    ]:
        if r["ok"]:
            lines.append(
                f"- {label} at {r['resolution']:g} cells/m to t = {r['t_end']:g} s "
                f"({r['resolved_arch']}/{r['precision']}): {r['wall_s']:.1f} s wall, "
                f"{r['steps']} steps, mass balance {r['mass_balance_error']:.2g} m^3"
                f"{'; faster than real time' if r['faster_than_real_time'] else ''}"
            )
        else:
            lines.append(f"- {label}: failed: {r['error']}")
    v = report["viewer"]
    if v["ok"]:
        lines.append(
            f"- viewer at {v['resolution']:g} cells/m: {v['steps_per_s']:.0f} steps/s, "
            f"{v['sim_s_per_wall_s']:.2f} simulated s per wall s "
            f"({'real time' if v['real_time'] else 'slower than real time'}; "
            f"{v['how']})"
        )
    else:
        lines.append(f"- viewer: failed: {v['error']}")
    for e in report.get("ensemble", []):
        if e["ok"]:
            lines.append(
                f"- ensemble on {e['arch']}/{e['precision']}: {e['members']} members of "
                f"{e['cells']} cells ({e['resolution']:g} cells/m, t = {e['t_end']:g} s), "
                f"{e['member_cell_stages_per_s'] / 1e6:.1f} M member-cell-stages/s "
                f"({e['mode']})"
            )
        else:
            lines.append(f"- ensemble on {e['backend']}/{e['precision']}: failed: {e['error']}")
    return "\n".join(lines)


__all__ = ["run_check", "markdown", "fingers_run", "viewer_speed", "viewer_loop", "throughput_rows"]


if __name__ == "__main__":
    # child entry: python -m tiseg.apps.bench.gpu viewer-loop ARCH PRECISION RESOLUTION FRAMES STEPS
    if len(sys.argv) == 7 and sys.argv[1] == "viewer-loop":
        a, p, r, n, k = sys.argv[2:]
        print(json.dumps(viewer_loop(a, p, float(r), int(n), int(k))))
    else:
        sys.exit(
            "usage: python -m tiseg.apps.bench.gpu viewer-loop ARCH PRECISION RESOLUTION "
            "FRAMES STEPS_PER_FRAME"
        )
