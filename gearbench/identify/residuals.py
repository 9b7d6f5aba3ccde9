"""Residual tests, as MATLAB's ``resid`` and Ljung (1999, section 16.6) do them.

A model that explains a record leaves a residual ``e = measured − simulated`` that is
the measurement noise alone: white, and independent of the input that drove the run.
Two correlation functions test both, for lags in samples:

    ρ_e(k)  = R_e(k) / R_e(0),                    k = 0 .. M
    ρ_eu(k) = R_eu(k) / sqrt(R_e(0) R_u(0)),      k = −M .. M
    R_e(k)  = (1/N) Σ_t e(t) e(t−k),   R_eu(k) = (1/N) Σ_t e(t) u(t−k)

with the means of ``e`` and ``u`` removed over the whole record.  A positive lag pairs
the residual with an *earlier* input (unmodelled dynamics, a wrong delay); a negative
lag with a later one (feedback from the output to the input, expected in closed loop).

Confidence bands at level ``confidence`` (99 % by default, ``z = 2.576``):

- autocorrelation: ``±z/sqrt(N)``, the band of a white residual's estimate;
- cross-correlation: ``±z sqrt(P/N)``, ``P = Σ_{|k|≤M} w_k ρ_e(k) ρ_u(k)`` (Ljung's
  asymptotic variance of ``sqrt(N) ρ_eu``, as MATLAB's ``resid`` computes it, so an
  autocorrelated input, such as held voltage steps, widens the band), with Bartlett
  weights ``w_k = 1 − |k|/(M+1)`` so the estimate of ``P`` is never negative.  If
  either signal is constant, ``P = 1`` (the band of a white residual).

The verdicts hold the false-alarm rate of the whole test at ``1 − confidence``, not per
lag (with 25 lags at 1 % each, a white residual would leave the band somewhere one
time in five):

- ``white``: the Ljung–Box statistic ``Q = N (N+2) Σ_{k=1..M} ρ_e(k)² / (N−k)`` below
  the ``confidence`` quantile of χ² with M degrees of freedom;
- ``input_independent``: no ``|ρ_eu(k)|`` beyond a joint threshold ``T sqrt(P/N)``, ``T``
  the ``confidence`` quantile of ``max_k |Z_k| / sqrt(P)`` for ``Z ~ N(0, C)``, the
  estimates' asymptotic covariance ``C_kj = Σ_{|m|≤M} w_m ρ_e(m) ρ_u(m + k − j)`` (its
  diagonal is ``P``), drawn ``JOINT_DRAWS`` times from a fixed seed.  The lags of an
  autocorrelated input move together, so ``T`` is close to ``z`` for held voltage steps
  (1.15-1.25 z for white noise against steps held 100 samples) and near the Šidák value
  for ``2M+1`` independent lags (3.7 = 1.44 z for M = 25) for a white input.  With a
  constant residual or input, ``T`` is the Bonferroni value for the ``2M+1`` lags.

The lags outside the per-lag band (what the figure shows) are reported beside them.

Re-initialisation windows (:meth:`gearbench.identify.replay.Replay.windows`): the
replay may move the model's angles at a window's first sample, so a lagged product
that straddles a seam would pair residuals of two different initial conditions.
The sums therefore run only over pairs inside one window; ``N`` is the total number
of samples (the biased estimate, as ``resid``), so with W windows lag k has
``N − W k`` pairs.  All functions are O(N log N) (FFT correlation per window).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache
from typing import Sequence

import numpy as np
from scipy import signal, stats

DEFAULT_LAGS = 25               # MATLAB's resid default
DEFAULT_CONFIDENCE = 0.99
JOINT_DRAWS = 20_000            # the threshold's own sampling error: about 1 % of it


def _windows(n: int, windows: Sequence[tuple[int, int]] | None) -> list[tuple[int, int]]:
    """Check ``windows`` (sample ranges [a, b) covering 0..n in order) or make one window."""
    if windows is None:
        return [(0, n)]
    out = [(int(a), int(b)) for a, b in windows]
    if not out or out[0][0] != 0 or out[-1][1] != n or any(b <= a for a, b in out) or \
            any(b != a2 for (_, b), (a2, _) in zip(out, out[1:])):
        raise ValueError(f"windows must be consecutive sample ranges [a, b) covering 0..{n}; got {out}")
    return out


def windowed_correlation(x, y, max_lag: int, windows: Sequence[tuple[int, int]] | None = None) -> np.ndarray:
    """``(1/N) Σ x(t) y(t−k)`` for ``k = −max_lag .. max_lag`` (index ``k + max_lag``),
    summed only over pairs of samples inside the same window; ``x`` and ``y`` are used
    as given (remove their means first)."""
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    if x.shape != y.shape or x.ndim != 1:
        raise ValueError(f"x and y must be 1-D arrays of one length; got shapes {x.shape} and {y.shape}")
    n = x.size
    out = np.zeros(2 * max_lag + 1)
    for a, b in _windows(n, windows):
        m = b - a
        full = signal.correlate(x[a:b], y[a:b], mode="full")   # lag j − (m − 1)
        lo, hi = max(-max_lag, -(m - 1)), min(max_lag, m - 1)
        out[lo + max_lag:hi + max_lag + 1] += full[lo + m - 1:hi + m]
    return out / n


def _cross_covariance(rho_e: np.ndarray, rho_u: np.ndarray, lags: int) -> np.ndarray:
    """``C_kj = Σ_{|m|≤M} w_m ρ_e(m) ρ_u(m + k − j)`` for ``k, j = −M..M``, Bartlett ``w``;
    ``rho_e`` holds lags −M..M, ``rho_u`` lags −3M..3M."""
    m = np.arange(-lags, lags + 1)
    a = (1.0 - np.abs(m) / (lags + 1)) * rho_e
    # c_d = Σ_m a(m) ρ_u(m + d), d = −2M..2M: a sliding dot product of 2M+1 terms
    c_d = np.correlate(rho_u, a, mode="valid")
    d = m[:, None] - m[None, :]
    return c_d[d + 2 * lags]


def _psd_cholesky(c: np.ndarray) -> np.ndarray:
    """Lower-triangular ``L`` with ``L L^T = C`` for a positive semi-definite ``C``: a
    column whose remaining variance is round-off (a lag that is a combination of the
    earlier ones, as with a held input) is set to zero.  By hand rather than LAPACK,
    whose threaded 51x51 eigen-solve took 60 ms on a loaded 2-core machine."""
    n = c.shape[0]
    low = np.zeros_like(c)
    tiny = 1e-12 * max(float(np.max(np.diag(c))), 1e-300)
    for j in range(n):
        d = c[j, j] - low[j, :j] @ low[j, :j]
        if d > tiny:
            low[j, j] = np.sqrt(d)
            low[j + 1:, j] = (c[j + 1:, j] - low[j + 1:, :j] @ low[j, :j]) / low[j, j]
    return low


@lru_cache(maxsize=4)
def _normal_draws(dim: int) -> np.ndarray:
    draws = np.random.default_rng(0).standard_normal((JOINT_DRAWS, dim))
    draws.flags.writeable = False
    return draws


def _joint_quantile(c: np.ndarray, confidence: float) -> float:
    """``confidence`` quantile of ``max_k |Z_k| / sqrt(C_kk)`` for ``Z ~ N(0, C)``, by
    ``JOINT_DRAWS`` draws from a fixed seed (the same answer on every run)."""
    z = _normal_draws(c.shape[0]) @ _psd_cholesky(c).T
    scale = np.sqrt(np.clip(np.diag(c), 1e-300, None))
    return float(np.quantile(np.max(np.abs(z) / scale, axis=1), confidence))


def check_lags(lags, windows: Sequence[tuple[int, int]]) -> None:
    """``lags`` (samples) must be a whole number from 1 to under half the shortest window."""
    shortest = min(b - a for a, b in windows)
    if isinstance(lags, bool) or not isinstance(lags, (int, np.integer)) or not 1 <= lags < shortest // 2:
        raise ValueError(f"lags must be a whole number of samples from 1 to {max(shortest // 2 - 1, 0)} "
                         f"(under half the shortest window, {shortest} samples); got {lags!r}")


def _runs(lags: Sequence[int]) -> str:
    """[1, 2, 3, 5, 7, 8] -> '1-3, 5, 7-8'."""
    parts, lags = [], list(lags)
    i = 0
    while i < len(lags):
        j = i
        while j + 1 < len(lags) and lags[j + 1] == lags[j] + 1:
            j += 1
        parts.append(str(lags[i]) if i == j else f"{lags[i]}..{lags[j]}" if lags[i] < 0 else f"{lags[i]}-{lags[j]}")
        i = j + 1
    return ", ".join(parts)


@dataclass
class ResidualTest:
    """The residual tests of one signal.  Correlations are dimensionless; lags in
    samples (``sample_time_s`` converts them); bands are half-widths."""
    signal: str
    input_name: str
    samples: int
    windows: int
    sample_time_s: float
    confidence: float
    lags: np.ndarray                    # 0 .. M
    autocorrelation: np.ndarray
    band: float
    cross_lags: np.ndarray              # −M .. M
    cross_correlation: np.ndarray
    cross_band: float
    ljung_box_q: float
    ljung_box_p: float
    joint_threshold: float              # |ρ_eu| past this at any lag: not independent (module doc)
    outside_lags: list[int] = field(default_factory=list)
    cross_outside_lags: list[int] = field(default_factory=list)

    @property
    def white(self) -> bool:
        return bool(self.ljung_box_p >= 1.0 - self.confidence)

    @property
    def input_independent(self) -> bool:
        return bool(np.all(np.abs(self.cross_correlation) <= self.joint_threshold))

    def to_json(self) -> dict:
        return {"input": self.input_name, "samples": self.samples, "windows": self.windows,
                "sample_time_s": self.sample_time_s, "confidence": self.confidence,
                "lags": self.lags.tolist(), "autocorrelation": self.autocorrelation.tolist(),
                "band": self.band, "white": self.white, "outside_lags": self.outside_lags,
                "ljung_box_q": self.ljung_box_q, "ljung_box_p": self.ljung_box_p,
                "cross_lags": self.cross_lags.tolist(), "cross_correlation": self.cross_correlation.tolist(),
                "cross_band": self.cross_band, "cross_joint_threshold": self.joint_threshold,
                "cross_outside_lags": self.cross_outside_lags, "input_independent": self.input_independent,
                "sentence": self.sentence()}

    def _lags_text(self, lags: list[int]) -> str:
        return f"lag{'s' if len(lags) > 1 else ''} {_runs(lags)}"

    def sentence(self) -> str:
        """Whether the residual is white and independent of the input, and where it is not."""
        pct = f"{100 * self.confidence:g} %"
        m = len(self.lags) - 1
        of = f" of {self.sample_time_s * 1e3:.3g} ms" if self.sample_time_s > 0 else ""
        p = f"p = {self.ljung_box_p:.2g}" if self.ljung_box_p >= 1e-16 else "p < 1e-16"
        if self.white:
            first = (f"{self.signal}: the residual is white (Ljung-Box {p} on {m} lags{of}); "
                     f"{len(self.outside_lags)} of {m} lags outside the {pct} band"
                     + (f" ({self._lags_text(self.outside_lags)}), as chance allows" if self.outside_lags else ""))
        else:
            where = (f"it leaves the {pct} band at {self._lags_text(self.outside_lags)} "
                     f"({len(self.outside_lags)} of {m})" if self.outside_lags else
                     f"no single lag leaves the {pct} band, but together they are too large")
            first = f"{self.signal}: the residual is not white (Ljung-Box {p} on {m} lags{of}): {where}"
        if self.input_independent:
            second = (f"it is independent of the input {self.input_name} ({len(self.cross_outside_lags)} of "
                      f"{2 * m + 1} lags outside the {pct} band, none past the joint threshold)")
        else:
            past = [k for k in self.cross_outside_lags if k > 0]
            fut = [k for k in self.cross_outside_lags if k < 0]
            second = (f"it is correlated with the input {self.input_name} at "
                      f"{self._lags_text(self.cross_outside_lags)} ({len(self.cross_outside_lags)} of {2 * m + 1})")
            if past:
                second += ": the input drives something the model misses"
            if fut and not past:
                second += ": the residual leads the input (feedback)"
        return f"{first}; {second}."


def residual_test(residual, input, name: str = "residual", input_name: str = "input",
                  lags: int = DEFAULT_LAGS, windows: Sequence[tuple[int, int]] | None = None,
                  sample_time_s: float = 0.0, confidence: float = DEFAULT_CONFIDENCE) -> ResidualTest:
    """Autocorrelation of ``residual`` (lags 0..``lags``) and its cross-correlation with
    ``input`` (lags −``lags``..``lags``), bands and verdicts at ``confidence``; the
    equations are in the module docstring.  ``windows``: sample ranges [a, b) within
    which lagged products are taken (None: the whole record); ``sample_time_s`` (s)
    only labels the lags.  Non-finite samples are an error (name the signal)."""
    e = np.asarray(residual, dtype=float)
    u = np.asarray(input, dtype=float)
    if e.ndim != 1 or e.shape != u.shape:
        raise ValueError(f"{name}: residual and input {input_name} must be 1-D and of one length; "
                         f"got {e.shape} and {u.shape}")
    for what, arr in ((f"residual of {name}", e), (f"input {input_name}", u)):
        bad = np.flatnonzero(~np.isfinite(arr))
        if bad.size:
            raise ValueError(f"{what}: sample {bad[0]} is not a finite number")
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence must lie strictly between 0 and 1 (a fraction); got {confidence}")
    n = e.size
    wins = _windows(n, windows)
    check_lags(lags, wins)
    z = float(stats.norm.ppf(0.5 + confidence / 2))
    e = e - e.mean()
    u = u - u.mean()
    ree = windowed_correlation(e, e, lags, wins)
    ruu = windowed_correlation(u, u, 3 * lags, wins)        # lags -3M..3M: C needs m + k - j
    reu = windowed_correlation(e, u, lags, wins)
    e0, u0 = ree[lags], ruu[3 * lags]
    k = np.arange(-lags, lags + 1)
    band = z / np.sqrt(n)
    if e0 > 0 and u0 > 0:
        rho_e, rho_u, rho_eu = ree / e0, ruu / u0, reu / np.sqrt(e0 * u0)
        c = _cross_covariance(rho_e, rho_u, lags)
        p = float(c[0, 0])
        cross_band = z * np.sqrt(max(p, 0.0) / n)
        joint = _joint_quantile(c, confidence) * np.sqrt(max(p, 0.0) / n)
    else:   # a constant residual or input: nothing to correlate, the white-residual band
        rho_e = ree / e0 if e0 > 0 else np.zeros_like(ree)
        rho_eu = np.zeros_like(reu)
        cross_band = band
        joint = float(stats.norm.ppf(1.0 - (1.0 - confidence) / (2 * (2 * lags + 1)))) / np.sqrt(n)
    acf = rho_e[lags:]
    pos = np.arange(1, lags + 1)
    q = float(n * (n + 2) * np.sum(acf[1:] ** 2 / (n - pos)))
    return ResidualTest(
        signal=name, input_name=input_name, samples=n, windows=len(wins), sample_time_s=float(sample_time_s),
        confidence=confidence, lags=np.arange(lags + 1), autocorrelation=acf, band=float(band),
        cross_lags=k, cross_correlation=rho_eu, cross_band=float(cross_band),
        ljung_box_q=q, ljung_box_p=float(stats.chi2.sf(q, lags)), joint_threshold=joint,
        outside_lags=[int(j) for j in pos[np.abs(acf[1:]) > band]],
        cross_outside_lags=[int(j) for j in k[np.abs(rho_eu) > cross_band]])


def replay_residual_tests(replay, plant, residuals: dict, lags: int = DEFAULT_LAGS,
                          confidence: float = DEFAULT_CONFIDENCE) -> dict[str, ResidualTest]:
    """:func:`residual_test` of every compared column of a replay, within its
    re-initialisation windows, against the input that drove it: the measured input
    in open loop, the set point in closed loop (whose measured input is itself a
    compared column)."""
    data = replay.data
    if replay.closed_loop:
        u, u_name = data.setpoint, data.setpoint_name
    else:
        u, u_name = data.input, data.input_name
    wins = replay.windows(plant)
    return {name: residual_test(r, u, name, u_name, lags, wins, data.sample_time_s, confidence)
            for name, r in residuals.items()}


__all__ = ["ResidualTest", "residual_test", "check_lags", "replay_residual_tests", "windowed_correlation",
           "DEFAULT_LAGS", "DEFAULT_CONFIDENCE"]
