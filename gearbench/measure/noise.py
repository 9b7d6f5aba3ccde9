"""How much of a signal is noise: the noise floor of a sampled record, from the data alone.

A measured signal ``y_j = s(t_j) + e_j`` is a smooth motion ``s`` plus white noise ``e``
of standard deviation ``σ`` (in the signal's unit).  The k-th forward difference

    Δᵏy_j = Σ_{i=0..k} (−1)^(k−i) C(k, i) y_{j+i}

nearly cancels a smooth ``s`` (it is ``hᵏ s⁽ᵏ⁾`` for a sample step ``h``) and leaves
noise of variance ``Var(Δᵏe) = C(2k, k) σ²`` (20 σ² for k = 3).  A robust scale
(1.4826 × median absolute deviation) of ``Δᵏy`` then gives ``σ`` without letting a few
steps or impacts dominate: the rule ``"differences"`` of :func:`noise_estimate`.

A quantized signal (an encoder's counts, a logger's digits: every value on a grid of step
``q``, which :func:`detect_quantum` finds) needs another rule.  Its error
``e = Q(s + n) − s`` (``Q`` rounding to the grid, ``n`` the noise before it, of standard
deviation ``σ_n``) depends on the motion:

* moving across many counts, ``s`` is spread evenly over the cells, so the rounding error
  ``Q(x) − x`` is uniform on ``[−q/2, q/2]`` and independent of ``n`` (Widrow's
  quantization theorem), and

      Var(e) = q²/12 + σ_n²;

  where the signal moves at more than about a count per sample, or where ``σ_n ≳ q/2``
  dithers it, successive errors are also uncorrelated, and ``Var(Δ³y) = 20 Var(e)``;
* at standstill with ``σ_n ≪ q`` the error is a constant, up to ``q/2``: correlated
  with the motion, not noise, and the third differences are zero there.

The median absolute deviation is no scale for it: the differences are whole multiples of
``q``, so the median jumps between them (one count gives ``1.4826 q/√20 = 1.148 q/√12``
whatever the noise under it).  The rule of a quantized signal is therefore

    floor = max( q/√12 ,  σ_Δq ),   σ_Δq = RMS(Δ³y − median) / √20,

with the RMS taken over the differences within 5 scales of their median (the scale first
``max(1.4826 MAD, q √(20/12))``, then the clipped RMS, three times: a few impacts do not
count, and the largest third difference of pure rounding error, 4 q, is always kept).
Rounding error alone gives ``σ_Δq ≈ q/√12`` where the signal moves and less where it
creeps or rests, so the floor is ``q/√12`` (rule ``"quantum"``); noise above the grid
adds to it, ``σ_Δq ≈ √(q²/12 + σ_n²)``, the total variance above (rule
``"quantized differences"``).  Not a root-sum-square of ``σ_Δq`` and ``q/√12``, which
would count the quantum twice.  A known limit: a record that creeps at 0.3-0.8 counts per
sample most of its length has a periodic rounding error near the Nyquist frequency, where
the third difference weighs most, and its floor reads up to 17 % high.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

_MAD_TO_SIGMA = 1.4826          # σ / MAD for a normal distribution
_ORDER = 3                      # removes any local quadratic: position through accelerations
_MIN_SAMPLES = 8
_GRID_TOL = 1e-3                # allowed misfit of a level to the grid, in quanta
_MAX_SUBDIVISION = 10           # the smallest gap seen may be this many quanta
_CLIP = 5.0                     # differences beyond this many scales from the median are not noise
_CLIP_PASSES = 3

RULES = {
    "differences": "robust scale of the third differences (white noise)",
    "quantum": "q/sqrt(12): a quantized signal's rounding error, no noise above its grid",
    "quantized differences": "RMS of a quantized signal's third differences: noise above its grid, "
                             "sqrt(q^2/12 + sigma_n^2)",
}
"""The rules :func:`noise_estimate` reads a floor by, each in words (see the module docstring)."""


def _finite(y) -> np.ndarray:
    y = np.asarray(y, dtype=float).ravel()
    return y[np.isfinite(y)]


def difference_noise(y, order: int = _ORDER) -> float:
    """White-noise standard deviation from the robust scale of the ``order``-th difference:
    ``σ = 1.4826 · MAD(Δᵏy) / √C(2k, k)`` (unit of ``y``)."""
    y = _finite(y)
    if y.size < max(_MIN_SAMPLES, order + 2):
        raise ValueError(f"noise estimate needs at least {max(_MIN_SAMPLES, order + 2)} finite samples, got {y.size}")
    d = np.diff(y, n=order)
    mad = np.median(np.abs(d - np.median(d)))
    return float(_MAD_TO_SIGMA * mad / math.sqrt(math.comb(2 * order, order)))


def detect_quantum(y) -> float | None:
    """The grid step ``q`` the values sit on, or None.

    The values are on a grid when every gap between adjacent distinct values is an
    integer multiple of one step, to within ``1e-3 q``.  The step is the smallest gap,
    or a fraction 1/m of it (m ≤ 10) when the signal skipped levels, refined as
    (sum of gaps) / (sum of their counts).  At least three distinct levels are needed.
    """
    y = _finite(y)
    levels = np.unique(y)
    if levels.size < 3:
        return None
    # Levels closer than float round-off are one level written twice.
    scale = float(np.max(np.abs(levels)))
    gaps = np.diff(levels)
    gaps = gaps[gaps > 64 * np.finfo(float).eps * scale]
    if gaps.size < 2:
        return None
    smallest = float(gaps.min())
    for m in range(1, _MAX_SUBDIVISION + 1):
        counts = np.rint(gaps / (smallest / m))
        q = float(gaps.sum() / counts.sum())
        if np.all(np.abs(gaps - counts * q) <= _GRID_TOL * q):
            return q
    return None


def quantized_difference_noise(y, q: float, order: int = _ORDER) -> float:
    """Standard deviation of the error of a signal on a grid of step ``q`` from its ``order``-th
    differences: their RMS about the median within 5 scales of it, over ``√C(2k, k)`` (unit of ``y``).

    The scale starts at ``max(1.4826 MAD, q √(C(2k, k)/12))`` (so the differences pure rounding
    error makes, at most ``2^(k-1) q``, are never clipped) and is the clipped RMS after each of
    three passes."""
    y = _finite(y)
    if y.size < max(_MIN_SAMPLES, order + 2):
        raise ValueError(f"noise estimate needs at least {max(_MIN_SAMPLES, order + 2)} finite samples, got {y.size}")
    d = np.diff(y, n=order)
    d = d - np.median(d)
    gain = math.sqrt(math.comb(2 * order, order))
    scale = max(_MAD_TO_SIGMA * float(np.median(np.abs(d))), q * gain / math.sqrt(12.0))
    for _ in range(_CLIP_PASSES):
        kept = d[np.abs(d) <= _CLIP * scale]
        scale = float(np.sqrt(np.mean(kept ** 2))) if kept.size else 0.0
    return scale / gain


@dataclass(frozen=True)
class NoiseEstimate:
    """A signal's noise floor and how it was read.

    floor: the standard deviation of its noise (unit of the signal); rule: a key of
    :data:`RULES`; quantum: the grid step ``q`` it sits on (its unit), None for none;
    difference: the difference estimate the rule compared with ``q/√12`` (its unit)."""
    floor: float
    rule: str
    quantum: float | None
    difference: float

    @property
    def description(self) -> str:
        """The rule in words, with the quantum."""
        q = "" if self.quantum is None else f" (q = {self.quantum:.4g})"
        return RULES[self.rule] + q


def noise_estimate(y, quantum: float | None = None) -> NoiseEstimate:
    """The noise floor of ``y`` and the rule it was read by (module docstring).

    ``quantum``: the grid step ``q`` (unit of ``y``) when known, else the one
    :func:`detect_quantum` finds.  Values on a grid: ``max(q/√12, σ_Δq)``
    (:func:`quantized_difference_noise`; rule ``"quantum"`` or ``"quantized differences"``);
    otherwise the robust difference estimate (:func:`difference_noise`; rule ``"differences"``),
    raised to ``q/√12`` when a ``quantum`` is given (rule ``"quantum"``).
    """
    if quantum is not None and not quantum > 0:
        raise ValueError(f"quantum must be positive, got {quantum}")
    found = detect_quantum(y)
    q = quantum if quantum is not None else found
    if found is not None:
        sigma = quantized_difference_noise(y, q)
    else:
        sigma = difference_noise(y)
    if q is None:
        return NoiseEstimate(sigma, "differences", None, sigma)
    rounding = q / math.sqrt(12.0)
    if sigma > rounding:
        return NoiseEstimate(sigma, "quantized differences" if found is not None else "differences", q, sigma)
    return NoiseEstimate(rounding, "quantum", q, sigma)


def noise_floor(y, quantum: float | None = None) -> float:
    """Standard deviation of the measurement noise on ``y`` (unit of ``y``): the floor of
    :func:`noise_estimate` (``max(σ, q/√12)``, ``σ`` read by the rule that fits the signal,
    ``q`` the given ``quantum`` or the one :func:`detect_quantum` finds)."""
    return noise_estimate(y, quantum).floor


def rest_noise(y, name: str = "signal") -> float:
    """Standard deviation of the noise on ``y``, a record of the machine at rest (unit of ``y``).

    At rest the signal is a constant, so every deviation from the record's mean is noise, white
    or coloured: ``max(std(y), q/√12)`` with ``q`` the grid step :func:`detect_quantum` finds
    (an encoder at rest may not toggle at all).  What :func:`noise_floor` cannot give for
    coloured noise, whose slow part hides in a moving machine's motion; the record should be
    many times longer than the noise's correlation time.  ``ValueError`` (naming ``name``) for
    fewer than ``8`` finite samples, or a signal that does not vary at all (its noise is below
    one step of its resolution: state it).
    """
    y = _finite(y)
    if y.size < _MIN_SAMPLES:
        raise ValueError(f"{name}: the noise at rest needs at least {_MIN_SAMPLES} finite samples, got {y.size}")
    q = detect_quantum(y)
    sigma = max(float(np.std(y)), (q or 0.0) / math.sqrt(12.0))
    if sigma <= 0:
        raise ValueError(f"{name} does not vary at all in the record at rest: its noise is below its "
                         "resolution; state it (--noise SIGNAL=STD)")
    return sigma


STILL_CORRELATION = 0.5
"""The most autocorrelation at the line's span that :func:`line_end_noise` reads as noise (AR(1)
noise of lag-1 correlation 0.9 has 0.12 at lag 20; 0.95, 0.36)."""


def line_end_noise(rest, m: int) -> float:
    """Standard deviation of a least-squares straight line through ``m`` consecutive samples of
    the noise that ``rest``, a stretch of the signal at rest, carries, evaluated at the next
    sample (unit of ``rest``); 0 where it holds fewer than ``5 m`` finite samples, and where its
    autocorrelation at lag ``m - 1`` is above :data:`STILL_CORRELATION`: what outlasts the line is
    no noise of a machine at rest but motion (a drive the record does not show, a spring's swing),
    or a noise as slow as the drift the line looks for, which a stretch at rest cannot tell from it.

    That value is a weighted sum ``c^T e`` of the ``m`` noise samples (``c`` the least-squares
    weights of the line's value one sample past its last), so its variance is ``c^T Γ c`` with
    ``Γ_ij = γ(|i - j|)`` the noise's autocovariance, read from ``rest`` with its straight line
    taken out (the biased estimator ``γ(l) = Σ e_j e_{j+l} / n``, which keeps ``Γ`` positive
    semidefinite).  White noise of standard deviation ``σ`` gives ``0.45 σ`` for ``m = 21``;
    AR(1) noise of lag-1 correlation 0.9 gives ``1.09 σ``: its samples move together, so a line
    through a few of them is as far off as one sample.  A quantized signal that does not toggle
    at rest gives 0 (its rounding is a constant there).
    """
    y = _finite(rest)
    n = y.size
    if n < 5 * m:
        return 0.0
    j = np.arange(n, dtype=float) - 0.5 * (n - 1)
    e = y - y.mean()
    e = e - j * (j @ e) / (j @ j)
    gamma = np.array([e[:n - lag] @ e[lag:] / n for lag in range(m)])
    if not gamma[0] > 0.0 or gamma[m - 1] > STILL_CORRELATION * gamma[0]:
        return 0.0
    x = np.vstack([np.arange(m, dtype=float), np.ones(m)]).T
    c = np.array([float(m), 1.0]) @ np.linalg.solve(x.T @ x, x.T)   # the line at sample m, per sample
    lags = np.abs(np.subtract.outer(np.arange(m), np.arange(m)))
    return float(np.sqrt(max(float(c @ gamma[lags] @ c), 0.0)))


__all__ = ["noise_floor", "noise_estimate", "NoiseEstimate", "RULES", "detect_quantum", "difference_noise",
           "quantized_difference_noise", "rest_noise", "line_end_noise"]
