"""What the peak fields (tiseg.run.peaks, ``output.peak_fields``) cost per time step.

    python benchmarks/peak_fields.py [--scene fingers] [--set domain.resolution=250 ...]
                                     [--warm 1.0] [--steps 50] [--rounds 5] [--threads 0]

Two simulations of the same scene, one with the peak fields and one without, take the same
steps (the peak fields only observe). They are first advanced to ``--warm`` seconds (so the
flow covers part of the chute and the active range is not trivially small), then stepped side
by side: ``--rounds`` rounds of ``--steps`` steps each, alternating which goes first, so that
the load of the machine falls on both alike. Reported: the time per step of each (the median
over the rounds), their relative difference, and the peak kernel's own time per launch
(`PeakFields.update` timed alone on the state the steps ended with) against the step.

Clock: with ``--threads 1`` the process's CPU time (``time.process_time``), which other
processes on a busy machine do not inflate; else the wall time.
"""

from __future__ import annotations

import argparse
import platform
import statistics
import time


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scene", default="fingers")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    ap.add_argument("--warm", type=float, default=1.0, help="simulated seconds before timing")
    ap.add_argument("--steps", type=int, default=50, help="steps per round")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--threads", type=int, default=0)
    ap.add_argument("--arch", default="cpu")
    args = ap.parse_args(argv)
    clock = time.process_time if args.threads == 1 else time.perf_counter

    import tiseg
    from tiseg.run.simulation import Simulation
    from tiseg.setup.scene import load_scene

    tiseg.init(args.arch, "f64", args.threads)
    sims = {
        label: Simulation(load_scene(args.scene, args.set + [f"output.peak_fields={flag}"]))
        for label, flag in (("on", "true"), ("off", "false"))
    }
    for sim in sims.values():
        sim.check_every = 0  # the guard is not what is measured
        sim.advance(args.warm)
    assert sims["on"].stats.steps == sims["off"].stats.steps
    per_step = {k: [] for k in sims}
    order = list(sims)
    for r in range(args.rounds):
        for label in order if r % 2 == 0 else order[::-1]:
            sim = sims[label]
            t0 = clock()
            for _ in range(args.steps):
                sim.step(t_stop=1e9)
            per_step[label].append((clock() - t0) / args.steps)
    assert sims["on"].t == sims["off"].t  # the same steps
    on = statistics.median(per_step["on"])
    off = statistics.median(per_step["off"])
    peaks = sims["on"].peaks
    n = 200
    t0 = clock()
    for _ in range(n):
        peaks.update(sims["on"].t)
    kernel = (clock() - t0) / n
    sc = sims["on"].scene
    a, b = sims["on"].op.active
    print(
        f"| {args.scene} {sc.domain.nx} x {sc.domain.ny} | {' '.join(args.set) or '-'} | "
        f"{args.arch} {args.threads or 'all'} threads, {platform.processor() or platform.machine()}, "
        f"{'CPU' if clock is time.process_time else 'wall'} time "
        f"| active columns {b - a} of {sc.domain.nx} at t = {sims['on'].t:.3g} s "
        f"| on {1e3 * on:.3f} ms | off {1e3 * off:.3f} ms | {100 * (on - off) / off:+.1f} % "
        f"| kernel {1e3 * kernel:.4f} ms = {100 * kernel / off:.2f} % of a step |"
    )


if __name__ == "__main__":
    main()
