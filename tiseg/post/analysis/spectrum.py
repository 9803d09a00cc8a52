"""The dominant cross-slope wavelength of a fingered front from the power spectrum of phi.

``wavelength_spectral`` needs no channel detection at all, so it checks the finger count
independently:

1. On each grid column of the fingered zone x_f^- <= x <= x_f^+, the signal across the slope
   is phi where the cell is wet (h >= h_min) and 0 where it is dry: channels (phi near 1),
   levees (phi near 0) and the empty slope between finger tips alternate with the finger
   period. The column mean is removed.
2. The power |FFT_y|^2 of the columns (y is periodic, section 6.2) is averaged over the columns;
   mode n has the wavelength Ly / n.
3. The peak is sought among the modes n >= 2 (wavelengths up to Ly / 2). Mode 1, one period
   across the whole chute, is the envelope of the pattern, not a finger spacing: the inflow
   perturbation (6.9) is one sine period across Ly, and the fingers it favours grow longer
   (measured at nu = 0.005, 500 cells/m: mode 1 held the largest power from 6 s on, above a
   broad finger peak at n = 8-11). So a chute must hold at least two fingers for their
   wavelength to be measured this way; one finger reads as a harmonic.
4. The peak mode n* is refined between the bins by fitting a parabola to log P at
   n* - 1, n*, n* + 1 (Gaussian interpolation: exact for a Gaussian peak); the refinement is
   skipped where a neighbour has no power (a pattern of exactly n* periods has none at
   n* +- 1, and then n* is exact). The result is Ly / n.

Undefined (None) without a fingered zone, or when the cross-slope RMS of the signal averaged
over the zone is below ``min_rms`` (default 0.02 in phi): a uniform front has no wavelength.
"""

from __future__ import annotations

import math

import numpy as np

DEFAULT_MIN_RMS = 0.02


def spectral_wavelength(
    h, phi, cols, Ly: float, h_min: float, min_rms: float = DEFAULT_MIN_RMS
) -> float:
    """Ly / n of the peak of the column-averaged cross-slope power spectrum; NaN if undefined."""
    if len(cols) == 0 or h.shape[0] < 6:  # modes 1..3 at least
        return math.nan
    s = np.where(h[:, cols] >= h_min, phi[:, cols], 0.0)
    s = s - s.mean(axis=0)
    if not float(np.mean(s * s)) > min_rms**2:  # the mean cross-slope variance
        return math.nan
    power = (np.abs(np.fft.rfft(s, axis=0)) ** 2).mean(axis=1)
    n = int(np.argmax(power[2:])) + 2  # mode 1 is the envelope (step 3)
    shift = 0.0
    if n + 1 < power.size:
        lo, mid, hi = power[n - 1], power[n], power[n + 1]
        if lo > 1e-12 * mid and hi > 1e-12 * mid:
            a, b, c = math.log(lo), math.log(mid), math.log(hi)
            den = a - 2.0 * b + c
            if den < 0:
                shift = 0.5 * (a - c) / den
    return Ly / (n + shift)


__all__ = ["spectral_wavelength", "DEFAULT_MIN_RMS"]
