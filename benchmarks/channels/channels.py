"""Selection-free channel speed / phi, selection-bias checks, fines budget and flux argument.

Reads existing fields.nc only (no simulation). Usage:
    python benchmarks/channels/channels.py RUNS       # every run set under RUNS -> results.json
    python benchmarks/channels/summarize.py           # results.json -> summary.txt

RUNS holds the sweeps of the paper's studies as `tiseg figures fingers` keeps them
(RUNS/grid-study, RUNS/nu-study, RUNS/inviscid-study) and the unsplit scheme's 750 cells/m
ensemble in RUNS/unsplit-750 (benchmarks/split_fingers/README.md); missing sets are skipped.

Definitions (per snapshot; wet = h >= h_min; fingered zone Z = x_f^- <= x <= x_f^+ as in
tiseg.post.analysis.fingers; speed s = |u|; u0 = 0.2079 m/s; G(phi) = (1-alpha) phi (1-phi)):
 (a) speed, no phi selection
   colmax_med   median over the columns of Z of max_y s (per cross-slope line maximum)
   colmax_med_front  same over the front half of Z (x > x_f^- + x_l/2)
   pNN          percentiles of s over all wet cells of Z; max = largest s in Z
   peak_speed   median of s at the local maxima of s along y (find_peaks, prominence 0.05 u0)
   finger_max   per counted finger (2D object of the diagnostic), max s; median over fingers
 (b) phi, no phi threshold
   phi_colmax   mean phi at the argmax_y s of each column of Z
   phi_fast95   mean phi over wet cells of Z with s >= p95
   phi_peaks    mean phi at the speed peaks (centrelines found from speed alone)
   phi_flux     sum h u phi / sum h u over Z (flux-weighted)
   phi_transp   phi_eq such that phi_eq - G(phi_eq) = sum h u (phi - G) / sum h u over Z
                (composition of the material actually crossing the sections, as an
                 equivalent depth-averaged phi; inflow: phi0 = 0.8)
 (2) diagnostic reproduced (threshold phi0/2, runs, counted fingers) and variants:
   diag_speed, diag_phi  == channel_speed_over_u0, channel_phi of fingers.json
   diag_phi_mid   mean phi over the middle third of each run (edges excluded)
   diag_phi_ctr   mean phi at the run centre cells
   diag_runmax    median over runs of max s within the run (instead of the centre cell)
   diag_*_front   same restricted to the front half of Z
   diag_phi_thr0.6 / 0.7: channel_phi with higher thresholds (same pipeline)
 (3) budget: V = int h, Vs = int h phi; inflow volume Vin(t) = Ly h0 u0 (t - (1-e^{-10t})/10);
   phi_dom = Vs/V; phi_behind (x < x_f^-), phi_zone (in Z), phi in channel / non-channel cells;
   section fluxes Q(x), Qs(x) = int h (u phi - u G) dy at x = 0.3 m, x_f^-, x_f^- + f x_l;
   closure: d/dt int_{x>s} h phi (centred, t +- 0.25 s) vs Qs(s).
 (4) flux argument per column of Z (median over columns): Q/Q0 (Q0 = h0 u0 Ly), channel
   flux share, channel width fraction w, channel thickness hc/h0, h-weighted channel speed,
   and the paper-style estimate u_c/u0 = (Q/Q0) * share / (w hc/h0) and h0/(w hc) (all
   inflow through the channels).
"""

from __future__ import annotations

import glob
import json
import math
import os
import sys

os.environ.setdefault("TI_SKIP_VERSION_CHECK", "ON")
os.environ.setdefault("ENABLE_TAICHI_HEADER_PRINT", "0")
import numpy as np  # noqa: E402
import netCDF4 as nc  # noqa: E402
from scipy.signal import find_peaks  # noqa: E402

from tiseg.post.analysis.channels import column_runs, count_channels  # noqa: E402
from tiseg.post.analysis.fingers import front_max, front_min  # noqa: E402

OUT = os.path.dirname(os.path.abspath(__file__))
H0, PHI0, HMIN, LY = 0.002, 0.8, 1e-4, 0.5
ALPHA = 1.0 / 7.0
U0 = 0.2079326797124702
TIMES = (5.0, 6.2, 7.5)
SETS = {  # name -> run folders under RUNS
    "split-250": "grid-study/resolution-250_seed-*",
    "split-375": "grid-study/resolution-375_seed-*",
    "split-500": "grid-study/resolution-500_seed-*",
    "split-750": "grid-study/resolution-750_seed-*",
    "unsplit-750": "unsplit-750/resolution-750_seed-*",
    "nu0.005-500": "nu-study/nu-0.005_seed-*",
    "nu0.02-500": "nu-study/nu-0.02_seed-*",
    "nu0.05-500": "nu-study/nu-0.05_seed-*",
    "inviscid-500": "inviscid-study/resolution-500_seed-*",
}


def G(phi):
    return (1.0 - ALPHA) * phi * (1.0 - phi)


def phi_equiv(r):
    """phi with phi - G(phi) = r (phi - G = (1-a) phi^2 + a phi)."""
    a = ALPHA
    return (-a + math.sqrt(a * a + 4.0 * (1.0 - a) * r)) / (2.0 * (1.0 - a))


def snapshot(ds, i):
    """h, u, v, phi of output i; phi is NaN where the file masks it (dry cells, h < h_min)."""
    out = []
    for k in ("h", "u", "v", "phi"):
        a = ds[k][i]
        out.append(np.ma.filled(np.ma.asarray(a, dtype=float), np.nan))
    h, u, v, phi = out
    return np.nan_to_num(h), np.nan_to_num(u), np.nan_to_num(v), phi


def diag_runs(h, phi, x, zone_cols, thr, dy, xl):
    """The diagnostic's runs (threshold thr, 2-cell filters) and their counted-finger flags."""
    chan = (h >= HMIN) & (phi > thr)
    runs = column_runs(chan[:, zone_cols], 2, 2)
    _, inf = count_channels(runs, zone_cols, x, 0.1 * xl)
    return runs.lists(), runs.by_column(inf.tolist())


def finger_maxima(runs, cols, x, s, ny, span):
    """Max speed (/u0) per finger: objects of the diagnostic's sweep at its best column."""
    parent, tip, low, smax = [], [], [], []

    def find(a):
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    dx = float(np.median(np.diff(x)))
    q = lambda r_: tip[r_] - low[r_] + dx >= span * (1 - 1e-12)  # noqa: E731
    prev = np.full(ny, -1)
    best, best_snapshot = -1, None
    for k in range(len(cols) - 1, -1, -1):
        j = cols[k]
        lab = np.full(ny, -1)
        for st, ln in runs[k]:
            rows = (st + np.arange(ln)) % ny
            n = len(parent)
            parent.append(n)
            tip.append(x[j])
            low.append(x[j])
            smax.append(float(s[rows, j].max()))
            for p in np.unique(prev[rows]):
                if p >= 0:
                    ra, rb = find(int(p)), find(n)
                    if ra != rb:
                        parent[ra] = rb
                        tip[rb] = max(tip[rb], tip[ra])
                        low[rb] = min(low[rb], low[ra])
                        smax[rb] = max(smax[rb], smax[ra])
            lab[rows] = n
        prev = lab
        roots = {find(a) for a in range(len(parent))}
        qual = [r_ for r_ in roots if q(r_)]
        if len(qual) > best:
            best, best_snapshot = len(qual), [smax[r_] / U0 for r_ in qual]
    fm = sorted(best_snapshot or [], reverse=True)
    return {
        "finger_max_med": float(np.median(fm)) if fm else None,
        "finger_max_min": float(min(fm)) if fm else None,
        "finger_max_list": [round(v, 3) for v in fm],
        "n_fingers": len(fm),
    }


def analyse(ds, i, ds_prev=None):
    x = np.asarray(ds["x"][:], float)
    y = np.asarray(ds["y"][:], float)
    dx, dy = x[1] - x[0], y[1] - y[0]
    t = float(ds["time"][i])
    h, u, v, phi = snapshot(ds, i)
    ny = h.shape[0]
    wet = h >= HMIN
    s = np.hypot(u, v)
    xfp, xfm = front_max(h, x, HMIN), front_min(h, phi, x, HMIN, PHI0)
    xl = xfp - xfm
    zc = np.flatnonzero((x >= xfm) & (x <= xfp))
    front = zc[x[zc] > xfm + 0.5 * xl]
    r = {"t": t, "x_f+": xfp, "x_f-": xfm, "x_l": xl}
    # uniform flow behind: speed at x = 0.3 m
    j3 = int(np.argmin(abs(x - 0.3)))
    r["u_behind"] = float(np.median(s[:, j3])) / U0
    r["h_behind"] = float(np.median(h[:, j3])) / H0
    r["phi_behind_0.3"] = float(np.median(phi[:, j3]))

    # (a) speed without phi selection
    sz = np.where(wet[:, zc], s[:, zc], np.nan)
    colmax = np.nanmax(sz, axis=0)
    r["colmax_med"] = float(np.nanmedian(colmax)) / U0
    r["colmax_med_front"] = (
        float(np.nanmedian(np.nanmax(np.where(wet[:, front], s[:, front], np.nan), axis=0))) / U0
    )
    wz = sz[np.isfinite(sz)]
    for p in (50, 90, 95, 99):
        r[f"p{p}"] = float(np.percentile(wz, p)) / U0
    r["max"] = float(wz.max()) / U0
    p95 = np.percentile(wz, 95)
    # speed peaks along y (periodic): pad by a third of the line
    pk_s, pk_phi, pk_h, pk_x = [], [], [], []
    pad = ny // 3
    for j in zc:
        col = np.where(wet[:, j], s[:, j], 0.0)
        ext = np.concatenate([col[-pad:], col, col[:pad]])
        idx, _ = find_peaks(ext, prominence=0.05 * U0)
        idx = idx[(idx >= pad) & (idx < pad + ny)] - pad
        pk_s.extend(col[idx])
        pk_phi.extend(phi[idx, j])
        pk_h.extend(h[idx, j])
        pk_x.extend([x[j]] * len(idx))
    pk_s, pk_phi, pk_x = map(np.asarray, (pk_s, pk_phi, pk_x))
    r["peak_speed"] = float(np.median(pk_s)) / U0
    fr = pk_x > xfm + 0.5 * xl
    r["peak_speed_front"] = float(np.median(pk_s[fr])) / U0 if fr.any() else None
    # (b) phi without threshold
    am = np.nanargmax(np.where(np.isfinite(sz), sz, -1), axis=0)
    r["phi_colmax"] = float(np.mean(phi[am, zc]))
    r["phi_colmax_front"] = float(np.mean(phi[am[np.isin(zc, front)], front]))
    fast = wet[:, zc] & (s[:, zc] >= p95)
    r["phi_fast95"] = float(phi[:, zc][fast].mean())
    r["phi_peaks"] = float(pk_phi.mean())
    r["phi_peaks_front"] = float(pk_phi[fr].mean()) if fr.any() else None
    hz, uz, pz = h[:, zc] * wet[:, zc], u[:, zc], np.nan_to_num(phi[:, zc])
    q = hz * uz
    r["phi_flux"] = float((q * pz).sum() / q.sum())
    r["phi_transp"] = phi_equiv(float((q * (pz - G(pz))).sum() / q.sum()))

    # (2) the diagnostic and its variants
    thr = 0.5 * PHI0
    runs, inf = diag_runs(h, phi, x, list(zc), thr, dy, xl)
    ctr_s, runmax_s, all_phi, mid_phi, ctr_phi, ctr_front, runmax_front = [], [], [], [], [], [], []
    chan_mask = np.zeros_like(wet)
    for k, j in enumerate(zc):
        for (st, ln), ok in zip(runs[k], inf[k]):
            if not ok:
                continue
            rows = (st + np.arange(ln)) % ny
            chan_mask[rows, j] = True
            c = rows[ln // 2]
            ctr_s.append(s[c, j])
            runmax_s.append(s[rows, j].max())
            all_phi.extend(phi[rows, j])
            mid_phi.extend(phi[rows[ln // 3 : ln - ln // 3], j])
            ctr_phi.append(phi[c, j])
            if x[j] > xfm + 0.5 * xl:
                ctr_front.append(s[c, j])
                runmax_front.append(s[rows, j].max())
    r["diag_speed"] = float(np.median(ctr_s)) / U0
    r["diag_phi"] = float(np.mean(all_phi))
    r["diag_phi_mid"] = float(np.mean(mid_phi))
    r["diag_phi_ctr"] = float(np.mean(ctr_phi))
    r["diag_runmax"] = float(np.median(runmax_s)) / U0
    r["diag_speed_front"] = float(np.median(ctr_front)) / U0 if ctr_front else None
    r["diag_runmax_front"] = float(np.median(runmax_front)) / U0 if runmax_front else None
    r["diag_maxchan"] = float(s[:, zc][((h >= HMIN) & (phi > thr))[:, zc]].max()) / U0
    for th in (0.6, 0.7):
        rr, ii = diag_runs(h, phi, x, list(zc), th, dy, xl)
        vals = [
            phi[(st + np.arange(ln)) % ny, j]
            for k, j in enumerate(zc)
            for (st, ln), ok in zip(rr[k], ii[k])
            if ok
        ]
        r[f"diag_phi_thr{th}"] = float(np.mean(np.concatenate(vals))) if vals else None
    # per-finger max speed: sweep the runs from the front back (as count_channels does), stop
    # at the column where the number of qualifying objects is largest; each qualifying object
    # there is one finger; its max speed over its runs downstream of that column.
    r.update(finger_maxima(runs, list(zc), x, s, ny, 0.1 * xl))
    # (3) budget
    A = dx * dy
    hp = np.where(wet, h * np.nan_to_num(phi), 0.0)  # h phi on wet cells (phi unknown on dry)
    hw = np.where(wet, h, 0.0)
    Vall, V, Vs = float(h.sum() * A), float(hw.sum() * A), float(hp.sum() * A)
    Vin = LY * H0 * U0 * (t - (1 - math.exp(-10 * t)) / 10)
    r["V_over_Vin"] = Vall / Vin
    r["dry_vol_frac"] = 1.0 - V / Vall
    r["phi_dom"] = Vs / V  # wet cells; the exact all-cell value is in diagnostics.csv
    r["Vs_over_Vin_fines"] = Vs / ((PHI0 - G(PHI0)) * Vin)
    r["phi_dom_expected"] = PHI0 - G(PHI0)
    beh = x < xfm
    r["phi_behind"] = float(hp[:, beh].sum() / hw[:, beh].sum())
    zm = (x >= xfm) & (x <= xfp)
    r["phi_zone"] = float(hp[:, zm].sum() / hw[:, zm].sum())
    r["vol_zone_frac"] = float(hw[:, zm].sum() * A / V)
    cm = chan_mask
    nm = wet[:, zc] & ~cm[:, zc]
    r["phi_zone_chan_hw"] = float(hp[cm].sum() / hw[cm].sum())
    r["phi_zone_nonchan_hw"] = float(hp[:, zc][nm].sum() / hw[:, zc][nm].sum())
    r["zone_chan_vol_frac"] = float(hw[cm].sum() / hw[:, zc].sum())
    pw = np.where(wet, phi, 0.0)
    Q = (hw * u).sum(axis=0) * dy
    Qs = (hw * u * (pw - G(pw))).sum(axis=0) * dy
    Q0 = H0 * U0 * LY
    secs = {"x0.3": 0.3, "xf-": xfm}
    for f in (0.25, 0.5, 0.75):
        secs[f"xf-+{f}xl"] = xfm + f * xl
    r["sections"] = {}
    for name, xs in secs.items():
        j = int(np.argmin(abs(x - xs)))
        r["sections"][name] = {
            "x": float(x[j]),
            "Q/Q0": float(Q[j] / Q0),
            "transp_fines_frac": float(Qs[j] / Q[j]) if Q[j] > 0 else None,
            "phi_eq": phi_equiv(float(Qs[j] / Q[j])) if Q[j] > 0 else None,
            "phi_mean_hw": float(hp[:, j].sum() / hw[:, j].sum()),
        }
    if ds_prev is not None:  # closure over [s, inf) with the t +- 0.25 snapshots
        i0, i1 = ds_prev
        tt0, tt1 = float(ds["time"][i0]), float(ds["time"][i1])
        h0_, _, _, p0_ = snapshot(ds, i0)
        h1_, _, _, p1_ = snapshot(ds, i1)
        p0_, p1_ = np.nan_to_num(p0_), np.nan_to_num(p1_)  # dry: h < h_min, negligible
        clo = {}
        for name in ("x0.3", "xf-", "xf-+0.5xl"):
            j = int(np.argmin(abs(x - secs[name])))
            dVs = ((h1_ * p1_)[:, j:].sum() - (h0_ * p0_)[:, j:].sum()) * A / (tt1 - tt0)
            dV = (h1_[:, j:].sum() - h0_[:, j:].sum()) * A / (tt1 - tt0)
            clo[name] = {
                "dVs/dt/Qs": float(dVs / Qs[j]),
                "dV/dt/Q": float(dV / Q[j]),
                "accum_fines_frac": float(dVs / dV),
            }
        r["closure"] = clo

    # (4) flux argument per column of Z
    rows_ = []
    for j in zc:
        c = cm[:, j]
        if c.sum() < 2 or Q[j] <= 0:
            continue
        wfrac = c.sum() * dy / LY
        hc = h[c, j].mean()
        qc = (h[c, j] * u[c, j]).sum() * dy
        share = qc / Q[j]
        uc = (h[c, j] * u[c, j]).sum() / h[c, j].sum()
        rows_.append(
            (
                x[j],
                Q[j] / Q0,
                share,
                wfrac,
                hc / H0,
                uc / U0,
                (Q[j] / Q0) * share / (wfrac * hc / H0),
                1.0 / (wfrac * hc / H0),
            )
        )
    a = np.asarray(rows_)
    keys = ("Q/Q0", "chan_share", "w", "hc/h0", "uc_hw", "uc_pred", "uc_paper")
    r["flux_arg"] = {k: float(np.median(a[:, n + 1])) for n, k in enumerate(keys)}
    fa = a[a[:, 0] > xfm + 0.5 * xl]
    r["flux_arg_front"] = (
        {k: float(np.median(fa[:, n + 1])) for n, k in enumerate(keys)} if len(fa) else None
    )
    return r


def main():
    if len(sys.argv) != 2:
        sys.exit("usage: python benchmarks/channels/channels.py RUNS")
    root = sys.argv[1]
    sets = {k: sorted(glob.glob(os.path.join(root, p))) for k, p in SETS.items()}
    res = {}
    for name, runs in sets.items():
        for run in runs:
            f = os.path.join(run, "fields.nc")
            if not os.path.isfile(f):
                continue
            with nc.Dataset(f) as ds:
                tt = np.asarray(ds["time"][:], float)
                out = {}
                for T in TIMES:
                    i = int(np.argmin(abs(tt - T)))
                    if abs(tt[i] - T) > 1e-6:
                        continue
                    prev = None
                    if T == 7.5:  # closure centred at 7.25 would need fluxes there; use 7.25
                        i = int(np.argmin(abs(tt - 7.25)))
                        prev = (i - 1, i + 1)
                        out["7.25"] = analyse(ds, i, prev)
                        i = int(np.argmin(abs(tt - 7.5)))
                    out[f"{T:g}"] = analyse(ds, i)
            # largest speed anywhere over all steps (diagnostics.csv), in 4 <= t <= 7.5 s
            dg = np.genfromtxt(os.path.join(run, "diagnostics.csv"), delimiter=",", names=True)
            sel = (dg["time"] >= 4.0) & np.isfinite(dg["max_speed"])
            out["steps_max_speed_4_7.5"] = float(dg["max_speed"][sel].max()) / U0
            out["steps_max_speed_t"] = float(dg["time"][sel][np.argmax(dg["max_speed"][sel])])
            res.setdefault(name, {})[os.path.basename(run)] = out
            print(name, os.path.basename(run), "done", flush=True)
    path = os.path.join(OUT, "results.json")
    with open(path, "w") as fh:
        json.dump(res, fh, indent=1)
    print("wrote", path)


if __name__ == "__main__":
    main()
