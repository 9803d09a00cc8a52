"""Roll waves at benchmark size: the two built-in scenes, measured.

    python benchmarks/roll_waves.py OUT [--reuse]

runs ``tiseg run roll-waves`` (1 m periodic, 2000 cells, 30 s) and ``tiseg run
roll-waves-forced`` (2 m open chute, 2000 cells, 20 s; snapshots every 0.01 s) into OUT (with
``--reuse``, existing run folders there are read instead), and writes
benchmarks/roll_waves.md and assets/figures/roll_waves.png.

Measured (`tiseg.post.analysis.roll_waves`):

* periodic: every 0.25 s the number of waves (crests standing 5 % of h0 above their
  surroundings), their mean spacing, crest and trough thickness, and the speed of the train
  between snapshots; the linear stage's speed against the phase speed of the stability analysis
  (`tiseg.model.stability.monodisperse`), and the coarsening as waves merge;
* forced: at stations down the chute, the peak-to-peak amplitude and the dominant frequency of
  h(t) once the train's leading edge has passed (`arrival`); the spatial growth rate of the small waves near the inlet against the
  linear theory's, sigma_R / c_g at the forcing frequency (Gaster's relation, valid while
  sigma_R is small against the frequency); the wave speed as frequency times crest spacing.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tiseg.apps.bench import machine_info, machine_line  # noqa: E402
from tiseg.model.stability import monodisperse as mono  # noqa: E402
from tiseg.model.stability.base import base_state  # noqa: E402
from tiseg.output.netcdf import read_fields  # noqa: E402
from tiseg.post.analysis.roll_waves import (  # noqa: E402
    crests,
    station_signal,
    train_speed,
    wave_train,
)
from tiseg.setup.scene import load_scene  # noqa: E402

RUNS = {"roll-waves": [], "roll-waves-forced": ["output.interval=0.01"]}
STATIONS = (0.1, 0.2, 0.3, 0.4, 0.5, 0.75, 1.0, 1.25, 1.5, 1.75, 1.9)
REPORT = ROOT / "benchmarks" / "roll_waves.md"
FIGURE = ROOT / "assets" / "figures" / "roll_waves.png"


def run(name: str, out: Path, reuse: bool) -> tuple[Path, float]:
    """Run a scene into out/name (unless reused); (folder, wall seconds of the run)."""
    folder = out / name
    if reuse and (folder / "fields.nc").exists():
        # the run's own wall time: the last row of its diagnostics
        last = (folder / "diagnostics.csv").read_text().strip().splitlines()[-1]
        return folder, float(last.split(",")[-1])
    env = dict(os.environ, TI_SKIP_VERSION_CHECK="ON", ENABLE_TAICHI_HEADER_PRINT="0")
    cmd = [sys.executable, "-m", "tiseg.apps.cli", "run", name, "--out", str(folder)]
    cmd += ["--no-progress", "--overwrite"] if folder.exists() else ["--no-progress"]
    for o in RUNS[name]:
        cmd += ["--set", o]
    import time

    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, env=env, cwd=ROOT)
    return folder, time.perf_counter() - t0


def fields(folder: Path):
    ds = read_fields(folder / "fields.nc")
    try:
        return ds["time"].values, ds["x"].values, ds["h"].values[:, 0, :], ds["u"].values[:, 0, :]
    finally:
        ds.close()


def theory(sc):
    bs = base_state(sc.flow.h0, sc.flow.phi0, sc.flow.nu, sc.material)
    return bs, sc.flow.h0 / sc.flow.u0


def periodic(folder: Path) -> dict:
    sc = load_scene("roll-waves")
    bs, T = theory(sc)
    t, x, H, U = fields(folder)
    dx, h0, u0 = sc.dx, sc.flow.h0, sc.flow.u0
    rows = []
    for j in range(1, len(t)):
        w = wave_train(H[j], dx, h0)
        w["t"] = float(t[j])
        w["speed"] = train_speed(H[j - 1], H[j], dx, t[j] - t[j - 1], 8 * u0) / u0
        w["dev"] = float(np.abs(H[j] / h0 - 1).max())
        w["umax"] = float(U[j].max() / u0)
        rows.append(w)
    k_M, s_M = mono.most_unstable(bs)
    lam = mono.bulk_roots(bs, np.array([k_M]))[0][0]
    return {
        "scene": sc,
        "rows": rows,
        "k_M": k_M,
        "sigma_M": s_M / T,
        "lambda_M": 2 * np.pi * h0 / k_M,
        "c_M": -lam.imag / k_M,
        "k_c": mono.cutoff(bs),
        "t": t,
        "x": x,
        "H": H,
    }


def arrival(x: float, u0: float) -> float:
    """The time [s] from which a station at x [m] is measured: the forced train, whose waves
    run at about 1.64 u0, has passed it even at a conservative 1.2 u0, plus 1 s."""
    return x / (1.2 * u0) + 1.0


def forced(folder: Path) -> dict:
    sc = load_scene("roll-waves-forced")
    bs, T = theory(sc)
    t, x, H, _ = fields(folder)
    h0, u0, f = sc.flow.h0, sc.flow.u0, sc.inflow.forcing_frequency
    st = []
    for xs in STATIONS:
        i = int(np.searchsorted(x, xs))
        sel = t >= arrival(xs, u0)  # the train's leading edge has passed the station
        s = station_signal(t[sel], H[sel, i])
        s["x"], s["from"] = xs, arrival(xs, u0)
        st.append(s)
    # the linear theory at the forcing frequency: the real k with -Im sigma(k) = 2 pi f (T)
    k = np.linspace(1e-3, 2.0, 20001)
    lam = mono.bulk_roots(bs, k)[:, 0]
    omega = -lam.imag / T  # [rad/s]
    i = int(np.argmin(np.abs(omega - 2 * np.pi * f)))
    c_g = np.gradient(omega, k / h0)[i]  # [m/s]
    kappa = (lam.real[i] / T) / c_g  # spatial growth rate [1/m]
    # measured: the amplitude's growth along the stations still in the linear range
    amps = np.array([s["amplitude"] for s in st])
    xs = np.array(STATIONS)
    lin = amps < 0.1 * h0
    fit = np.polyfit(xs[lin], np.log(amps[lin]), 1)[0] if lin.sum() >= 2 else float("nan")
    # wave speed = frequency x crest spacing, over the saturated reach 1-1.9 m in every
    # snapshot after the train has passed 1.9 m (a time lag between stations is ambiguous by
    # whole periods for a periodic train)
    reach = (x >= 1.0) & (x <= 1.9)
    spacing = []
    for j in np.nonzero(t >= arrival(1.9, u0))[0]:
        c = crests(H[j, reach], 0.05 * h0, periodic=False)
        if c.size >= 2:
            spacing.append((c[-1] - c[0]) / (c.size - 1) * sc.dx)
    wavelength = float(np.mean(spacing))
    freq = float(np.mean([s["frequency"] for s in st if s["x"] >= 1.0]))
    speeds = [freq * wavelength / u0, wavelength]
    return {
        "scene": sc,
        "stations": st,
        "k_forced": k[i],
        "lambda_forced": 2 * np.pi * h0 / k[i],
        "kappa_theory": kappa,
        "kappa_measured": fit,
        "linear_stations": xs[lin].tolist(),
        "speeds": speeds,
        "c_linear": 2 * np.pi * f / (k[i] / h0) / u0,
        "t": t,
        "x": x,
        "H": H,
    }


def figure(p: dict, q: dict) -> None:
    from matplotlib.figure import Figure

    fig = Figure(figsize=(9.0, 6.4))
    ax = fig.subplots(2, 2)
    h0 = p["scene"].flow.h0
    for tt, style in ((3.0, ":"), (6.0, "--"), (10.0, "-."), (30.0, "-")):
        j = int(np.argmin(np.abs(p["t"] - tt)))
        ax[0, 0].plot(p["x"], p["H"][j] / h0, style, lw=1, label=f"t = {p['t'][j]:g} s")
    ax[0, 0].set_xlabel("x [m]")
    ax[0, 0].set_ylabel("h / h0")
    ax[0, 0].set_title("periodic: growth, then merging", fontsize=10)
    ax[0, 0].legend(fontsize=7)
    rows = p["rows"]
    t = [r["t"] for r in rows]
    ax[0, 1].semilogy(t, [max(r["waves"], 0.5) for r in rows], "k-", label="waves in 1 m")
    ax[0, 1].semilogy(t, [r["crest"] for r in rows], "r-", label="mean crest h / h0")
    ax[0, 1].semilogy(t, [r["speed"] for r in rows], "b-", label="train speed / u0")
    ax[0, 1].set_xlabel("t [s]")
    ax[0, 1].set_title("periodic: coarsening", fontsize=10)
    ax[0, 1].legend(fontsize=7)
    j = len(q["t"]) - 1
    ax[1, 0].plot(q["x"], q["H"][j] / h0, "k-", lw=0.8)
    ax[1, 0].set_xlabel("x [m]")
    ax[1, 0].set_ylabel("h / h0")
    ax[1, 0].set_title(
        f"forced at {q['scene'].inflow.forcing_frequency:g} Hz: t = {q['t'][j]:g} s", fontsize=10
    )
    xs = [s["x"] for s in q["stations"]]
    amps = np.array([s["amplitude"] for s in q["stations"]]) / h0
    ax[1, 1].semilogy(xs, amps, "ko-", label="peak-to-peak h / h0")
    x_lin = np.array(q["linear_stations"])
    if x_lin.size:
        a0 = amps[0] * np.exp(q["kappa_theory"] * (x_lin - xs[0]))
        ax[1, 1].semilogy(x_lin, a0, "r--", label="linear theory (Gaster)")
    ax[1, 1].set_xlabel("station x [m]")
    ax[1, 1].set_title("forced: spatial growth and saturation", fontsize=10)
    ax[1, 1].legend(fontsize=7)
    fig.tight_layout()
    FIGURE.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(FIGURE, dpi=80)


def report(p: dict, q: dict, walls: dict) -> str:
    sc = p["scene"]
    u0, h0 = sc.flow.u0, sc.flow.h0
    rows = p["rows"]
    lines = [
        "# Roll waves at benchmark size",
        "",
        f"Written by `benchmarks/roll_waves.py` ({machine_line(machine_info(1))}).",
        f"Flow: Table 1's small grains, h0 = {h0 * 1e3:g} mm at {sc.material.zeta_deg:g}°, "
        f"F = {sc.flow.F:.3f}, u0 = {u0:.4f} m/s, ν = {sc.flow.nu:g} m^1.5/s.",
        "",
        "Wall time of the runs (`tiseg run` defaults, on a machine shared with other jobs): "
        + ", ".join(f"`{k}` {v:.0f} s" for k, v in walls.items())
        + ".",
        "",
        "## Linear stability (tiseg.model.stability.monodisperse)",
        "",
        "| quantity | value |",
        "|---|---|",
        "| roll-wave threshold F_rw | 2/3 |",
        f"| fastest-growing k̂_M, wavelength | {p['k_M']:.4f}, {p['lambda_M'] * 1e3:.1f} mm |",
        f"| its growth rate | {p['sigma_M']:.3f} 1/s |",
        f"| its phase speed | {p['c_M']:.4f} u0 |",
        f"| viscous cut-off k̂_c, wavelength | {p['k_c']:.4f}, "
        f"{2 * np.pi * h0 / p['k_c'] * 1e3:.2f} mm |",
        "",
        "## Periodic scene `roll-waves` (1 m, 2000 cells)",
        "",
        "| t [s] | waves | spacing [m] | crest h/h0 | trough h/h0 | max h/h0 − 1 | "
        "train speed / u0 | max u / u0 |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        if abs(r["t"] - round(r["t"])) < 1e-9 and (r["t"] <= 16 or r["t"] % 5 == 0):
            lines.append(
                f"| {r['t']:g} | {r['waves']} | {r['spacing']:.3f} | {r['crest']:.3f} | "
                f"{r['trough']:.3f} | {r['dev']:.3g} | {r['speed']:.3f} | {r['umax']:.3f} |"
            )
    lin = [r["speed"] for r in rows if r["dev"] < 0.05]
    lines += [
        "",
        f"Linear stage (max |h/h0 − 1| < 0.05, {len(lin)} snapshots): train speed "
        f"{np.mean(lin):.4f} u0 (sd {np.std(lin):.4f}); the phase speed of the fastest-growing "
        f"mode is {p['c_M']:.4f} u0.",
        "",
        "## Forced scene `roll-waves-forced` (2 m chute, 2000 cells, snapshots every 0.01 s)",
        "",
        f"Forcing {q['scene'].inflow.forcing_frequency:g} Hz, relative amplitude "
        f"{q['scene'].inflow.forcing_amplitude:g}. Stations: h(t) from the time given (the "
        "train's leading edge has passed) to the end.",
        "",
        "| x [m] | from t [s] | peak-to-peak h / h0 | mean h / h0 | frequency [Hz] |",
        "|---|---|---|---|---|",
    ]
    for s in q["stations"]:
        lines.append(
            f"| {s['x']:g} | {s['from']:.1f} | {s['amplitude'] / h0:.4g} | "
            f"{s['mean'] / h0:.4f} | {s['frequency']:.3f} |"
        )
    lines += [
        "",
        f"Linear theory at the forcing frequency: k̂ = {q['k_forced']:.4f} (wavelength "
        f"{q['lambda_forced'] * 1e3:.1f} mm), phase speed {q['c_linear']:.4f} u0, spatial growth "
        f"rate σ_R / c_g = {q['kappa_theory']:.3f} 1/m. Measured over the stations "
        f"{q['linear_stations']} (amplitude < 0.1 h0): {q['kappa_measured']:.3f} 1/m.",
        "",
        f"Saturated train (1–1.9 m): crest spacing {q['speeds'][1] * 1e3:.1f} mm, so a wave "
        f"speed (frequency × spacing) of {q['speeds'][0]:.3f} u0.",
        "",
    ]
    return "\n".join(lines)


def main(argv: list[str]) -> None:
    out = Path(argv[0])
    reuse = "--reuse" in argv
    out.mkdir(parents=True, exist_ok=True)
    walls = {}
    folders = {}
    for name in RUNS:
        folders[name], walls[name] = run(name, out, reuse)
    p = periodic(folders["roll-waves"])
    q = forced(folders["roll-waves-forced"])
    figure(p, q)
    REPORT.write_text(report(p, q, walls), encoding="utf-8")
    print(REPORT.read_text(encoding="utf-8"))


if __name__ == "__main__":
    main(sys.argv[1:])
