"""Self-channelised flow from a gate: channel width and height against the mass flux.

    python benchmarks/levees.py [resolution ...]     (default: 150 200 cells/m)

runs the built-in `levees` scene on a 22 degree slope (h_stop = 0.79 mm for Table 1's small
grains under the extended law), 1 m x 0.3 m, for 40 s, once for each inflow thickness in
INFLOWS at the steady uniform speed u0(h) of that thickness (so the gate's mass flux is
0.04 m x h x u0(h)), at each resolution, one run after the other in this process, and writes
benchmarks/levees_channel.md and assets/figures/levees_channel.png.

Measured at the stations STATIONS (x [m]) from the fields at t = 35 s and 40 s: the wet width
(cells with h >= h_min), the flowing width (cells with |u| > 1 mm/s), the cells at rest among
the wet ones and their largest h, the largest h and u across the section, and the mass flux
through it (the sum of h u dy over the cells, equal to the gate's flux once the flow is
steady there).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tiseg.apps.bench import machine_info, machine_line  # noqa: E402
from tiseg.model.physics.friction import layer_thresholds  # noqa: E402
from tiseg.run.simulation import Simulation  # noqa: E402
from tiseg.setup.scene import load_scene  # noqa: E402

ZETA = 22.0  # [degrees]
INFLOWS = (0.0012, 0.0015, 0.002)  # inflow thickness [m]; the speed is u0 of that thickness
T_END = 40.0  # [s]
T_PREV = 35.0  # [s] the earlier field, for steadiness
STATIONS = (0.2, 0.3, 0.4)  # [m]
MOVING = 1e-3  # [m/s] a cell moves above this speed
REPORT = ROOT / "benchmarks" / "levees_channel.md"
FIGURE = ROOT / "assets" / "figures" / "levees_channel.png"


def scene(h_in: float, resolution: int):
    base = {"material.zeta_deg": ZETA, "flow.h0": h_in}
    u0 = load_scene("levees").with_overrides(base).flow.u0
    return load_scene("levees").with_overrides(
        {
            **base,
            "inflow.h": h_in,
            "inflow.u": u0,
            "domain.Lx": 1.0,
            "domain.Ly": 0.3,
            "domain.resolution": resolution,
            "time.t_end": T_END,
        }
    )


def section(sc, h: np.ndarray, u: np.ndarray, x: float) -> dict:
    """Measures of the cross-section at x of fields shaped (ny, nx)."""
    i = int(x / sc.dx)
    col, uc = h[:, i], u[:, i]
    wet = col >= sc.numerics.h_min
    moving = wet & (np.abs(uc) > MOVING)
    still = wet & ~moving
    return {
        "wet": wet.sum() * sc.dy,
        "flowing": moving.sum() * sc.dy,
        "still": int(still.sum()),
        "h_still": float(col[still].max()) if still.any() else 0.0,
        "h_max": float(col.max()),
        "u_max": float(uc.max()),
        "flux": float(np.sum(col * uc) * sc.dy),
        "h": col.copy(),
        "u": uc.copy(),
    }


def measure(h_in: float, resolution: int) -> dict:
    sc = scene(h_in, resolution)
    sim = Simulation(sc)
    t0 = time.perf_counter()
    shots = {}
    for t in (T_PREV, T_END):
        sim.advance(t)
        f = sim.fields()
        shots[t] = {x: section(sc, f["h"], f["u"], x) for x in STATIONS}
    mass, inflow = sim.totals()["mass"], sim.budget()["mass_in"]
    return {
        "h_in": h_in,
        "u_in": sc.inflow.u,
        "q_gate": sc.inflow.width * h_in * sc.inflow.u,
        "resolution": resolution,
        "dy": sc.dy,
        "y": (np.arange(sc.domain.ny) + 0.5) * sc.dy,
        "shots": shots,
        "mass_err": abs(mass - inflow) / mass,
        "wall": time.perf_counter() - t0,
        "steps": sim.stats.steps,
    }


def h_stop() -> float:
    sc = load_scene("levees").with_overrides({"material.zeta_deg": ZETA})
    return layer_thresholds(sc.material, sc.flow.phi0)[0]


def figure(results: list[dict], x: float = 0.3) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    finest = max(r["resolution"] for r in results)
    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 3.6))
    for r in results:
        if r["resolution"] != finest:
            continue
        s = r["shots"][T_END][x]
        y = (r["y"] - r["y"].mean()) * 100
        label = f"Q = {s['flux'] * 1e6:.2f} cm³/s"
        (line,) = a.plot(y, s["h"] * 1e3, lw=1.2, label=label, drawstyle="steps-mid")
        b.plot(y, s["u"] * 100, lw=1.2, color=line.get_color(), drawstyle="steps-mid")
    a.axhline(h_stop() * 1e3, color="k", lw=0.8, ls="--", label="h_stop")
    a.set_xlim(-12, 12)
    b.set_xlim(-12, 12)
    a.set_xlabel("y - Ly/2 [cm]")
    a.set_ylabel("h [mm]")
    a.set_title(f"thickness across the flow, x = {x} m, t = {T_END:g} s")
    a.legend(fontsize=7)
    b.set_xlabel("y - Ly/2 [cm]")
    b.set_ylabel("u [cm/s]")
    b.set_title(f"downslope speed ({finest} cells/m)")
    fig.tight_layout()
    FIGURE.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(FIGURE, dpi=90)


def report(results: list[dict]) -> str:
    lines = [
        "# Self-channelised flow from a gate: width and height against the mass flux",
        "",
        f"Written by `benchmarks/levees.py` ({machine_line(machine_info(1))}).",
        f"Scene `levees` at {ZETA:g} degrees (h_stop = {h_stop() * 1e3:.3f} mm), 1 m x 0.3 m, "
        f"4 cm gate, t_end = {T_END:g} s; inflow h and u = u0(h). Widths are counted in cells "
        f"(wet: h >= h_min; flowing: |u| > {MOVING * 1e3:g} mm/s); Q is the sum of h u dy "
        "across the section.",
        "",
        "| cells/m | inflow h [mm] | u0 [cm/s] | gate flux [cm^3/s] | x [m] | Q [cm^3/s] | "
        "wet width [cm] | flowing width [cm] | largest h [mm] | largest u [cm/s] | "
        "cells at rest (largest h [mm]) | at 35 s: wet width, largest h, Q | mass error | "
        "wall [s] |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in results:
        for x in STATIONS:
            s, p = r["shots"][T_END][x], r["shots"][T_PREV][x]
            cells = [
                f"{r['resolution']}",
                f"{r['h_in'] * 1e3:.2f}",
                f"{r['u_in'] * 100:.3f}",
                f"{r['q_gate'] * 1e6:.3f}",
                f"{x:g}",
                f"{s['flux'] * 1e6:.3f}",
                f"{s['wet'] * 100:.2f}",
                f"{s['flowing'] * 100:.2f}",
                f"{s['h_max'] * 1e3:.3f}",
                f"{s['u_max'] * 100:.3f}",
                f"{s['still']} ({s['h_still'] * 1e3:.3f})",
                f"{p['wet'] * 100:.2f}, {p['h_max'] * 1e3:.3f}, {p['flux'] * 1e6:.3f}",
                f"{r['mass_err']:.1e}",
                f"{r['wall']:.0f}",
            ]
            lines.append("| " + " | ".join(cells) + " |")
    lines += ["", "![channel profiles](../assets/figures/levees_channel.png)", ""]
    return "\n".join(lines)


def main() -> None:
    resolutions = [int(a) for a in sys.argv[1:]] or [150, 200]
    results = [measure(h, res) for res in resolutions for h in INFLOWS]
    figure(results)
    REPORT.write_text(report(results))
    print(REPORT.read_text())


if __name__ == "__main__":
    main()
