"""A record's frequency response, and the two-mass resonance it may show.

The FRF from a drive ``u`` (a torque, a current, a voltage) to an angle ``y`` is estimated by
Welch's averaged cross-spectra, ``H1 = P_uy / P_uu`` (``scipy.signal.csd``), as MATLAB's
``tfestimate`` does.  A motor coupled to its load by a compliance shows, in the FRF to the
motor's acceleration ``|H| w^2``, a dip (the anti-resonance, where the load swings against the
motor) and above it a peak (the resonance of the whole train):

    w_ar^2 = k / J_L,    w_r^2 = k (J_M + J_L) / (J_M J_L),    so  J_M / (J_M + J_L) = (w_ar / w_r)^2,

with ``J_M`` the inertia on the motor's side of the compliance and ``J_L`` on the far side
(reflected), ``k`` the stiffness.  A rigid train has neither: ``|H| w^2`` is flat (or falls with a
voltage drive's electrical pole).
"""
from __future__ import annotations

import math

import numpy as np
from scipy import signal

PROMINENCE = 4.0
"""How far (a factor on ``|H| w^2``) the peak must rise above, and the dip fall below, the FRF on
both sides of it to count.  A lightly damped coupling stands out by far more: on the FdiTools
bench's 1 s slice the peak is 16x its level above the resonance and the dip 7x below the level
under it.  The voltage-to-angle FRFs of the 13 practice cases (rigid trains) show no pair
(``tests/test_spectrum.py``)."""


TRUSTED = 0.4
"""The top of the band an FRF is read in, a fraction of the sampling rate: nearer Nyquist a
record's anti-alias filter and a sampled drive's hold shape it (a white torque on a rigid
0.009 kg m^2, sampled at 2.5 kHz through scipy's ``lsim``: |H| w^2 falls 9x at 1065 Hz and
recovers by 1119 Hz, a false pair)."""


def frf(u, y, sample_time_s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(f_hz, H, band)``: the H1 estimate of the FRF from ``u`` to ``y`` (units of y
    per unit of u) on segments of a power of two about a quarter of the record, Hann windows
    overlapping by half; ``band``, the frequencies up to :data:`TRUSTED` of the
    sampling rate where the drive has power (its spectrum above 1e-3 of its highest, 0 Hz
    excluded)."""
    u, y = np.asarray(u, dtype=float), np.asarray(y, dtype=float)
    fs = 1.0 / sample_time_s
    nper = 1 << int(math.floor(math.log2(max(16, len(u) // 4))))
    f, puu = signal.welch(u, fs, nperseg=nper)
    _, puy = signal.csd(u, y, fs, nperseg=nper)
    with np.errstate(divide="ignore", invalid="ignore"):
        h = puy / puu
    band = (f > 0) & (f <= TRUSTED * fs) & (puu > 1e-3 * puu[1:].max()) & np.isfinite(h)
    return f, h, band


def resonance_pair(f_hz, h, band) -> tuple[float, float] | None:
    """``(anti-resonance, resonance)`` in Hz: the most prominent peak of ``|H| w^2`` inside
    ``band`` and the most prominent dip below it, each standing :data:`PROMINENCE` clear of the
    FRF around it; None when the band shows no such pair."""
    f = np.asarray(f_hz)[band]
    if f.size < 5:
        return None
    g = np.log(np.abs(np.asarray(h)[band]) * (2 * math.pi * f) ** 2)
    level = math.log(PROMINENCE)
    peaks, pp = signal.find_peaks(g, prominence=level)
    if not peaks.size:
        return None
    top = int(peaks[np.argmax(pp["prominences"])])
    dips, dp = signal.find_peaks(-g[:top], prominence=level)
    if not dips.size:
        return None
    return float(f[int(dips[np.argmax(dp["prominences"])])]), float(f[top])
