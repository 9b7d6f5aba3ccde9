"""How much of a signal is noise: the noise floor of a sampled record, from the data alone.

A measured signal ``y_j = s(t_j) + e_j`` is a smooth motion ``s`` plus white noise ``e``
of standard deviation ``σ`` (in the signal's unit).  The k-th forward difference

    Δᵏy_j = Σ_{i=0..k} (−1)^(k−i) C(k, i) y_{j+i}

nearly cancels a smooth ``s`` (it is ``hᵏ s⁽ᵏ⁾`` for a sample step ``h``) and leaves
noise of variance ``Var(Δᵏe) = C(2k, k) σ²`` (20 σ² for k = 3).  A robust scale
(1.4826 × median absolute deviation) of ``Δᵏy`` then gives ``σ`` without letting a few
steps or impacts dominate.

Quantisation (an encoder's counts, a logger's digits) adds an error uniform over one
quantum ``q``: standard deviation ``q/√12``.  Where the noise is large compared with
``q`` it dithers the grid and the difference estimate already contains it; where the
signal creeps along its grid the differences are mostly zero and see nothing.  The
floor is therefore ``max(σ_Δ, q/√12)``, not a root-sum-square that would count the
quantum twice.
"""
from __future__ import annotations

import math

import numpy as np

_MAD_TO_SIGMA = 1.4826          # σ / MAD for a normal distribution
_ORDER = 3                      # removes any local quadratic: position through accelerations
_MIN_SAMPLES = 8
_GRID_TOL = 1e-3                # allowed misfit of a level to the grid, in quanta
_MAX_SUBDIVISION = 10           # the smallest gap seen may be this many quanta


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


def noise_floor(y, quantum: float | None = None) -> float:
    """Standard deviation of the measurement noise on ``y`` (unit of ``y``).

    ``max(σ_Δ, q/√12)`` with ``σ_Δ`` from :func:`difference_noise` and ``q`` the given
    ``quantum`` or, when None, the one :func:`detect_quantum` finds (0 if none).
    """
    sigma = difference_noise(y)
    q = quantum if quantum is not None else detect_quantum(y)
    if q is not None and q < 0:
        raise ValueError(f"quantum must be positive, got {q}")
    return max(sigma, (q or 0.0) / math.sqrt(12.0))


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


__all__ = ["noise_floor", "detect_quantum", "difference_noise", "rest_noise"]
