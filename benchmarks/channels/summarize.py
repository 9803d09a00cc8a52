"""Tables (mean +- sd over seeds) from results.json written by channels_alt.py -> summary.txt."""

import json
import os
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
res = json.load(open(os.path.join(HERE, "results.json")))
KEYS = [
    "diag_speed",
    "diag_runmax",
    "peak_speed",
    "peak_speed_front",
    "colmax_med",
    "colmax_med_front",
    "p95",
    "p99",
    "max",
    "finger_max_med",
    "n_fingers",
    "diag_phi",
    "diag_phi_mid",
    "diag_phi_ctr",
    "diag_phi_thr0.6",
    "diag_phi_thr0.7",
    "phi_peaks",
    "phi_peaks_front",
    "phi_colmax",
    "phi_fast95",
    "phi_flux",
    "phi_transp",
    "phi_dom",
    "phi_behind",
    "phi_zone",
    "phi_zone_chan_hw",
    "phi_zone_nonchan_hw",
    "vol_zone_frac",
    "sec:xf-:phi_eq",
    "sec:xf-+0.5xl:phi_eq",
    "sec:xf-+0.5xl:Q/Q0",
    "fa:w",
    "fa:hc/h0",
    "fa:Q/Q0",
    "fa:chan_share",
    "fa:uc_hw",
    "fa:uc_paper",
    "faf:w",
    "faf:hc/h0",
    "faf:uc_hw",
    "faf:uc_paper",
]


def get(r, k):
    if k.startswith("sec:"):
        _, s, q = k.split(":")
        return r["sections"][s][q]
    if k.startswith("fa:"):
        return r["flux_arg"][k[3:]]
    if k.startswith("faf:"):
        return (r["flux_arg_front"] or {}).get(k[4:])
    return r.get(k)


lines = []
for t in ("5", "6.2", "7.5"):
    sets = [s for s in res]
    lines.append(f"\n=== t = {t} s   (mean +- sd over seeds; n = runs)")
    lines.append(f"{'key':24s}" + "".join(f"{s:>17s}" for s in sets))
    lines.append(
        f"{'n':24s}" + "".join(f"{len([1 for r in res[s].values() if t in r]):>17d}" for s in sets)
    )
    for k in KEYS:
        row = f"{k:24s}"
        for s in sets:
            v = [get(r[t], k) for r in res[s].values() if t in r]
            v = np.array([a for a in v if a is not None], float)
            row += (
                f"{v.mean():>10.3f}+-{v.std(ddof=1) if len(v) > 1 else 0:<5.3f}"
                if len(v)
                else f"{'-':>17s}"
            )
        lines.append(row)
lines.append("\n=== largest speed over all steps 4-7.5 s (diagnostics.csv), /u0")
for s in res:
    v = np.array([r["steps_max_speed_4_7.5"] for r in res[s].values()])
    lines.append(f"{s:14s} {v.mean():.3f} +- {v.std(ddof=1):.3f}  (max {v.max():.3f}, n={len(v)})")
lines.append(
    "\n=== closure at 7.25 s (d/dt of inventory downstream of s over the flux through s), split-750"
)
for run, r in res["split-750"].items():
    lines.append(
        run
        + " "
        + json.dumps(
            {k: {a: round(b, 4) for a, b in v.items()} for k, v in r["7.25"]["closure"].items()}
        )
    )
out = "\n".join(lines)
open(os.path.join(HERE, "summary.txt"), "w").write(out)
print(out)
