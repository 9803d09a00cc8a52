"""Roll-wave diagnostics of 1D thickness profiles h(x) (the `roll-waves` scenes).

* `crests`: the wave crests, local maxima of h that stand ``rise`` above the lowest thickness
  on both sides before the next higher crest (a topographic prominence, so the ripples on a
  wave's back are not counted); on a periodic domain the profile wraps round.
* `wave_train`: count, mean spacing, mean crest and trough thickness of one profile.
* `train_speed`: the speed of the whole train between two profiles, from the shift that
  maximises their periodic cross-correlation (sub-cell by a parabola through the peak).
* `station_signal`: the thickness at a station over time, its amplitude and dominant frequency
  (the forced scene, where the waves are measured as an experiment measures them: at fixed
  positions down the chute).
"""

from __future__ import annotations

import numpy as np


def crests(h: np.ndarray, rise: float, periodic: bool = True) -> np.ndarray:
    """Indices of the crests of h: local maxima whose prominence exceeds ``rise`` [m]."""
    h = np.asarray(h, dtype=float)
    n = h.size
    if periodic:
        start = int(np.argmin(h))  # cut the ring at its lowest point
        g = np.roll(h, -start)
    else:
        start, g = 0, h
    peaks = [i for i in range(1, n - 1) if g[i] >= g[i - 1] and g[i] > g[i + 1]]
    out = []
    for i in peaks:
        left = g[: i + 1][::-1]
        right = g[i:]
        hl = np.nonzero(left > g[i])[0]
        hr = np.nonzero(right > g[i])[0]
        base_l = left[: hl[0]].min() if hl.size else left.min()
        base_r = right[: hr[0]].min() if hr.size else right.min()
        if g[i] - max(base_l, base_r) >= rise:
            out.append((i + start) % n)
    return np.array(sorted(out), dtype=int)


def wave_train(h: np.ndarray, dx: float, h0: float, rise: float = 0.05) -> dict:
    """Count, spacing [m], and mean crest and trough thickness / h0 of a periodic profile;
    ``rise`` is the least prominence of a crest, relative to h0."""
    h = np.asarray(h, dtype=float)
    c = crests(h, rise * h0)
    n = int(c.size)
    out = {"waves": n, "spacing": float("nan"), "crest": float("nan"), "trough": float("nan")}
    if n == 0:
        return out
    out["spacing"] = h.size * dx / n
    out["crest"] = float(h[c].mean() / h0)
    # the trough of each wave: the lowest thickness between it and the next crest
    troughs = []
    for j in range(n):
        a, b = c[j], c[(j + 1) % n]
        seg = h[a : b + 1] if b > a else np.concatenate([h[a:], h[: b + 1]])
        troughs.append(seg.min())
    out["trough"] = float(np.mean(troughs) / h0)
    return out


def train_speed(h1: np.ndarray, h2: np.ndarray, dx: float, dt: float, max_speed: float) -> float:
    """Speed [m/s] of a periodic profile h1 that became h2 after dt: the shift s in [0,
    max_speed dt] maximising sum h1(x) h2(x + s), interpolated between cells."""
    a = np.asarray(h1, dtype=float) - np.mean(h1)
    b = np.asarray(h2, dtype=float) - np.mean(h2)
    corr = np.fft.irfft(np.conj(np.fft.rfft(a)) * np.fft.rfft(b), n=a.size)
    reach = min(int(np.ceil(max_speed * dt / dx)) + 1, a.size - 2)
    i = int(np.argmax(corr[: reach + 1]))
    cm, c0, cp = corr[i - 1], corr[i], corr[(i + 1) % a.size]
    denom = cm - 2 * c0 + cp
    frac = 0.5 * (cm - cp) / denom if denom != 0 else 0.0
    return float((i + frac) * dx / dt)


def station_signal(t: np.ndarray, h: np.ndarray) -> dict:
    """Peak-to-peak amplitude [m], mean [m] and dominant frequency [Hz] of h(t) at a station
    (evenly spaced t)."""
    t = np.asarray(t, dtype=float)
    h = np.asarray(h, dtype=float)
    dev = h - h.mean()
    spec = np.abs(np.fft.rfft(dev * np.hanning(dev.size)))
    freqs = np.fft.rfftfreq(dev.size, t[1] - t[0])
    return {
        "amplitude": float(h.max() - h.min()),
        "mean": float(h.mean()),
        "frequency": float(freqs[1:][np.argmax(spec[1:])]),
    }
