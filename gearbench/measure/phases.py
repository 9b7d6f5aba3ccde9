"""Cut a record into motion phases, so that a model's error can be pinned to what the
machine was doing: standing, moving steadily, reversing, or speeding up / slowing down.

Rules of :func:`classify_phases` (``v`` speed, ``a`` its change; units of ``position``
per second):

1. **Speed.**  Given, or the Savitzky–Golay derivative of ``position`` (quadratic fit
   over a window of ~1 % of the record, at least 7 samples, on the median sample step).
2. **standstill**: ``|v| ≤ v₀`` with ``v₀ = max(0.02 · max|v|, 3 σ_v)``; ``σ_v`` is the
   position noise (:func:`gearbench.measure.noise.noise_floor`) carried through the
   derivative filter, ``σ_v = σ_y ‖h‖₂`` for filter taps ``h`` (or the noise floor of a
   given speed).  A motion stretch (``|v| > v₀``, one sign) shorter than
   ``max(3, half the filter window)`` samples is noise and counts as standstill.
3. **direction reversal**: two motion stretches of opposite sign, separated by a stop no longer than the reversal window ``w``
   (default ``max(2 % of the record, 10 samples)``); the stop and ``w/2`` either side of
   it are labelled.  A longer stop is a standstill followed by a fresh start.
4. **acceleration**: moving and the speed changes by more than 10 % of ``max|v|``
   across a window ``w`` centred on the sample: ``|v(t + w/2) − v(t − w/2)| > 0.1 max|v|``.
5. **steady motion**: the rest.

Where rules overlap, the earlier phase in this order wins: reversal, standstill,
acceleration, steady motion.
"""
from __future__ import annotations

import numpy as np
from scipy.signal import savgol_coeffs, savgol_filter

from .noise import noise_floor

PHASES = ("standstill", "steady motion", "direction reversal", "acceleration")
STANDSTILL, STEADY, REVERSAL, ACCELERATION = PHASES

_STANDSTILL_FRACTION = 0.02     # of the peak speed
_NOISE_LEVELS = 3.0             # a standstill threshold below 3 σ_v would flicker on noise
_ACCEL_FRACTION = 0.10          # of the peak speed, gained or lost within one window
_WINDOW_FRACTION = 0.02         # reversal / acceleration window, of the record length
_MIN_WINDOW_SAMPLES = 10
_MIN_STRETCH_SAMPLES = 3        # shorter motion is noise poking over the threshold
_POLYORDER = 2


def _savgol_window(n: int) -> int:
    w = max(7, n // 100)
    w = min(w, n if n % 2 else n - 1)
    return w if w % 2 else w - 1


def smoothed_speed(time_s, position) -> tuple[np.ndarray, float, int]:
    """Savitzky–Golay speed ``dy/dt`` (unit of ``position`` per s), its noise ``σ_v`` and
    the filter window (samples).

    ``σ_v = σ_y ‖h‖₂`` where ``h`` are the derivative filter's taps, for white position
    noise ``σ_y``.
    """
    t = np.asarray(time_s, dtype=float)
    y = np.asarray(position, dtype=float)
    if y.size < 7:
        raise ValueError(f"a speed estimate needs at least 7 samples, got {y.size}")
    dt = float(np.median(np.diff(t)))
    w = _savgol_window(y.size)
    v = savgol_filter(y, w, _POLYORDER, deriv=1, delta=dt, mode="interp")
    taps = savgol_coeffs(w, _POLYORDER, deriv=1, delta=dt)
    return v, noise_floor(y) * float(np.linalg.norm(taps)), w


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """Half-open index ranges [start, stop) where ``mask`` is True."""
    edges = np.diff(np.concatenate(([0], mask.astype(np.int8), [0])))
    return list(zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)))


def _motion_stretches(v: np.ndarray, v0: float, min_samples: int) -> list[tuple[int, int, int]]:
    """(start, stop, sign) of each run with ``|v| > v0`` of at least ``min_samples``."""
    stretches = []
    for sign in (1, -1):
        stretches += [(a, b, sign) for a, b in _runs(sign * v > v0) if b - a >= min_samples]
    return sorted(stretches)


def _reversal_mask(t: np.ndarray, stretches: list[tuple[int, int, int]], window_s: float) -> np.ndarray:
    """Samples within ``w/2`` of a short stop between motions of opposite sign."""
    mask = np.zeros(t.size, dtype=bool)
    for (_, end, s1), (start, _, s2) in zip(stretches, stretches[1:]):
        t_stop, t_go = t[end - 1], t[start]
        if s1 != s2 and t_go - t_stop <= window_s:
            mask |= (t >= t_stop - window_s / 2) & (t <= t_go + window_s / 2)
    return mask


def classify_phases(time_s, position, speed=None, standstill_speed: float | None = None,
                    reversal_window_s: float | None = None) -> np.ndarray:
    """Label each sample with one of :data:`PHASES` (rules in the module docstring).

    ``position`` in any unit ``U`` (deg, mm, ...); ``speed`` in ``U``/s if given;
    ``standstill_speed`` (``U``/s) and ``reversal_window_s`` (s) override the defaults.
    Returns an array of phase names, one per sample.
    """
    t = np.asarray(time_s, dtype=float)
    y = np.asarray(position, dtype=float)
    if t.shape != y.shape or t.ndim != 1:
        raise ValueError(f"time_s and position must be 1-D of one length, got {t.shape} and {y.shape}")
    if speed is None:
        v, sigma_v, smoothing = smoothed_speed(t, y)
    else:
        v, smoothing = np.asarray(speed, dtype=float), 0
        sigma_v = noise_floor(v)
    peak = float(np.max(np.abs(v)))
    v0 = standstill_speed if standstill_speed is not None else max(_STANDSTILL_FRACTION * peak,
                                                                   _NOISE_LEVELS * sigma_v)
    dt = float(np.median(np.diff(t)))
    w = reversal_window_s if reversal_window_s is not None else max(_WINDOW_FRACTION * (t[-1] - t[0]),
                                                                    _MIN_WINDOW_SAMPLES * dt)
    # Motion shorter than half the smoothing window cannot be resolved: it is noise
    # (often at the record's ends, where the filter's fit is poorest).
    stretches = _motion_stretches(v, v0, max(_MIN_STRETCH_SAMPLES, smoothing // 2))
    moving = np.zeros(t.size, dtype=bool)
    for a, b, _ in stretches:
        moving[a:b] = True
    dv = np.interp(t + w / 2, t, v) - np.interp(t - w / 2, t, v)
    labels = np.full(t.size, STEADY, dtype=object)
    labels[moving & (np.abs(dv) > _ACCEL_FRACTION * peak)] = ACCELERATION
    labels[~moving] = STANDSTILL
    labels[_reversal_mask(t, stretches, w)] = REVERSAL
    return labels.astype(str)


def error_shares(labels, residual, dt=None) -> dict[str, dict[str, float]]:
    """Per phase: its share of the time, its share of the squared error, and its RMS error.

    ``time_share = Σ_phase Δt / Σ Δt``; ``error_share = Σ_phase Δt r² / Σ Δt r²``;
    ``rms = √(Σ_phase Δt r² / Σ_phase Δt)`` (unit of ``residual``).  ``Δt`` is each
    sample's weight: ``dt`` as an array or a scalar, or 1 (equal samples) when None.
    ``labels`` are phase names or integer codes into :data:`PHASES`.  Shares of an
    empty total are 0.
    """
    labels = np.asarray(labels)
    if labels.dtype.kind in "iu":
        labels = np.asarray(PHASES, dtype=object)[labels]
    r = np.asarray(residual, dtype=float)
    if labels.shape != r.shape:
        raise ValueError(f"labels and residual differ in shape: {labels.shape} vs {r.shape}")
    weight = np.broadcast_to(np.asarray(1.0 if dt is None else dt, dtype=float), r.shape)
    sq = weight * r ** 2
    total_t, total_e = float(weight.sum()), float(sq.sum())
    shares = {}
    for phase in PHASES:
        sel = labels == phase
        t_p, e_p = float(weight[sel].sum()), float(sq[sel].sum())
        shares[phase] = {
            "time_share": t_p / total_t if total_t > 0 else 0.0,
            "error_share": e_p / total_e if total_e > 0 else 0.0,
            "rms": float(np.sqrt(e_p / t_p)) if t_p > 0 else 0.0,
        }
    return shares


def phase_codes(labels) -> np.ndarray:
    """Phase names as integer codes (index into :data:`PHASES`)."""
    lookup = {p: i for i, p in enumerate(PHASES)}
    return np.array([lookup[str(x)] for x in np.asarray(labels).ravel()], dtype=np.int8)


__all__ = ["PHASES", "classify_phases", "error_shares", "smoothed_speed", "phase_codes"]


def pulse_edges(disturbance) -> np.ndarray:
    """Sample indices where a disturbance input (e.g. a record's ``disturbance_V``) changes
    value: the sample after each jump.  Empty for ``None``."""
    if disturbance is None:
        return np.array([], dtype=int)
    return np.flatnonzero(np.diff(np.asarray(disturbance, dtype=float)) != 0.0) + 1


def edge_mask(time_s, disturbance, window_s: float) -> np.ndarray:
    """True in the ``window_s`` seconds that follow each of :func:`pulse_edges`."""
    t = np.asarray(time_s, dtype=float)
    mask = np.zeros(t.size, dtype=bool)
    for i in pulse_edges(disturbance):
        mask |= (t >= t[i]) & (t < t[i] + window_s)
    return mask
