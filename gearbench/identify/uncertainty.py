"""Covariance and standard errors of fitted parameters, valid for correlated residuals.

A fit minimises ``sum r_i^2`` over the parameters ``x`` (``k`` of them), where
``r`` stacks ``S`` signals' residuals (each divided by its noise floor), every
signal sampled at the same ``T`` times: ``r = [r_1(t_1..t_T), ..., r_S(...)]``,
with Jacobian ``J = dr/dx`` (``S T`` rows).  Near the optimum
``x_hat - x = -(J^T J)^-1 sum_t g_t`` with the per-time score

    g_t = sum_s J_{s,t}^T r_{s,t}            (k-vector; the signals of one time together,
                                               so their correlation with each other counts),

so the covariance is the sandwich

    cov = H^-1 Omega H^-1,   H = J^T J,   Omega = Var(sum_t g_t).

Replay residuals are strongly correlated in time (model error is smooth, the
open-loop replay is re-initialised from measured states, the noise may be
coloured), so ``Omega`` is a long-run variance of the scores, estimated by
Newey-West with Andrews and Monahan's (1992) VAR(1) prewhitening:

    g_t = A g_{t-1} + e_t                       (least squares; singular values of A cut to 0.97),
    Omega_e = Gamma_0 + sum_{l=1}^{L} (1 - l/(L+1)) (Gamma_l + Gamma_l^T),   Gamma_l = sum_t e_t e_{t-l}^T,
    Omega = (I - A)^-1 Omega_e (I - A)^-T,

with the Bartlett bandwidth ``L`` from the data by Andrews' (1991) AR(1) plug-in:
each column's lag-1 autocorrelation ``rho_a`` and innovation variance ``s_a^2`` give

    alpha = sum_a 4 rho_a^2 s_a^4 / ((1-rho_a)^6 (1+rho_a)^2)  /  sum_a s_a^4 / (1-rho_a)^4,
    L = ceil(1.1447 (alpha T)^(1/3)),  at most T - 1.

The standard error of ``x_j`` is ``sqrt(cov_jj)`` in the units of ``x_j``; the
correlation ``cov_ij / (se_i se_j)``.

Why this estimator.  A fit's residuals are orthogonal to its Jacobian
(``sum_t g_t = 0``), which removes exactly the slow part of the scores that sets
the variance: plain Newey-West is biased low on correlated residuals, the more the
longer its bandwidth (on one AR(1) record its standard error of the motor resistance
was 1.3x too small at L = 80, 1.6x at L = 640, against the exact AR(1) covariance),
and batch means likewise.  Prewhitening takes the slow part into ``A``, estimated from
lag 1, which the orthogonality barely touches.  Measured in development on the records
of ``studies/coverage.py`` (30 seeds, coverage of +-2 SE for motor resistance, Coulomb
torque, spring stiffness, rest angle, viscous coefficient), AR(1) rho 0.9 noise, mixed
excitation: plain Newey-West (plug-in bandwidth) 80/90/83/90/90 %, batch means (20
batches) 80/87/87/83/83 %, a VAR(1) model of the residuals themselves 87/90/83/93/90 %,
prewhitened Newey-West 93/93/87/100/90 %, the white formula 30/33/33/40/27 %; with white
noise all four within a few points of each other (90-93 %).  A moving-block bootstrap
needs a refit per replicate (0.5-1 s each on those 4 s records): too dear inside
``diagnose``, not tried.  The figures of the method kept
(``python -m studies.coverage``, results/coverage.md, 60 seeds; 2026-11-27): steps excitation,
white noise 93/98/92/93/90 %, AR(1) 97/97/95/100/93 % (the white formula 25/37/20/32/38 %);
mixed excitation, white 93/93/90/95/92 %, AR(1) 92/97/90/100/97 % (white formula
28/35/38/37/28 %).  The RMS of (fitted - truth) / SE was 1.1-1.2 for most parameters on
mixed records even with white noise, where all estimators agree.  Part of that was the
replay's numerical error, not the statistics: at rtol 1e-6 it biased the resistance by -0.49
and the spring's stiffness by +0.60 standard errors on average (mean z over the 60 seeds); taken
out (``numerics.refine``, as ``gearbench.fit`` does since 2026-12-03) the means are within 0.17
of 0 and the RMS 1.00-1.16 (resistance 1.16 -> 1.07, stiffness 1.19 -> 1.04, viscous 1.19 ->
1.07; the friction 1.14 -> 1.16), coverage 92/92/90/97/95 %.  The estimator is conservative
where a score is nearly a random walk: the rest angle's standard error under AR(1) noise came
out about 2.5-4x too large (rms z 0.22-0.41).  On the README tutorial's two fits (the study's
second part, 30 seeds, a rest angle at 0) the stiffness, rest angle and friction are covered
in 100/97/97 % (RMS z 0.82/0.98/0.97; left at rtol 1e-6 the friction's estimates sat 0.64
standard errors above the truth on average, RMS z 1.27; 2026-12-03).

The white-residual formula ``s^2 (J^T J)^-1`` (:func:`white_covariance`) is kept for
that comparison only (``FitResult.stderr_white``): it is what the sandwich reduces to
for uncorrelated, equal-variance residuals, and on correlated ones it is far too small.
Estimates correlated beyond ``|rho| > STRONG_CORRELATION`` (0.9) are listed by ``fit``
and ``diagnose --json``.
"""
from __future__ import annotations

import math
from typing import Callable, Sequence

import numpy as np

ANDREWS_BARTLETT = 1.1447
"""Andrews' (1991) constant of the Bartlett kernel's optimal bandwidth, ``L = 1.1447 (alpha T)^(1/3)``."""
MAX_PREWHITEN = 0.97
"""Largest singular value kept in the prewhitening matrix ``A`` (Andrews and Monahan 1992: 0.97)."""


def scores(jac: np.ndarray, r: np.ndarray, n_signals: int) -> np.ndarray:
    """Per-time scores ``g_t = sum_s J_{s,t}^T r_{s,t}``, shape ``(T, k)``; ``r`` stacks
    ``n_signals`` signals of ``T`` samples each, in the order of ``jac``'s rows."""
    jac = np.asarray(jac, dtype=float)
    r = np.asarray(r, dtype=float)
    k = jac.shape[1]
    return (jac * r[:, None]).reshape(n_signals, -1, k).sum(axis=0)


def bandwidth(g: np.ndarray) -> int:
    """Andrews' AR(1) plug-in bandwidth ``L`` (samples) of the Bartlett kernel for the scores ``g``
    (see the module docstring); 0 for scores without lag-1 correlation."""
    t = len(g)
    a, b = g[1:], g[:-1]
    num, den = 0.0, 0.0
    for j in range(g.shape[1]):
        bb = float(b[:, j] @ b[:, j])
        if bb <= 0.0:
            continue
        rho = min(max(float(a[:, j] @ b[:, j]) / bb, -0.99), 0.99)
        e = a[:, j] - rho * b[:, j]
        s4 = (float(e @ e) / len(e)) ** 2
        num += 4.0 * rho ** 2 * s4 / ((1.0 - rho) ** 6 * (1.0 + rho) ** 2)
        den += s4 / (1.0 - rho) ** 4
    if den <= 0.0:
        return 0
    return int(min(math.ceil(ANDREWS_BARTLETT * (num / den * t) ** (1.0 / 3.0)), t - 1))


def long_run_variance(g: np.ndarray, lags: int) -> np.ndarray:
    """``Omega = Gamma_0 + sum_{l=1}^{lags} (1 - l/(lags+1)) (Gamma_l + Gamma_l^T)`` of the scores ``g``."""
    omega = g.T @ g
    for lag in range(1, lags + 1):
        gam = g[lag:].T @ g[:-lag]
        omega += (1.0 - lag / (lags + 1.0)) * (gam + gam.T)
    return omega


def _inverse(h: np.ndarray) -> np.ndarray | None:
    try:
        return np.linalg.inv(h)
    except np.linalg.LinAlgError:
        return None


def prewhitened_long_run_variance(g: np.ndarray) -> np.ndarray:
    """``Omega`` of the scores ``g`` by Andrews and Monahan's (1992) VAR(1) prewhitening:
    ``g_t = A g_{t-1} + e_t`` (least squares; singular values of ``A`` above ``MAX_PREWHITEN``
    cut to it, so that ``I - A`` stays well conditioned), the Newey-West variance of
    ``e`` with its own plug-in bandwidth, recoloured: ``(I - A)^-1 Omega_e (I - A)^-T``."""
    a, b = g[1:], g[:-1]
    u, sv, vt = np.linalg.svd(np.linalg.lstsq(b, a, rcond=None)[0].T)
    coef = (u * np.minimum(sv, MAX_PREWHITEN)) @ vt
    e = a - b @ coef.T
    m = np.linalg.inv(np.eye(g.shape[1]) - coef)
    return m @ long_run_variance(e, bandwidth(e)) @ m.T


def covariance(jac: np.ndarray, r: np.ndarray, n_signals: int) -> np.ndarray:
    """The sandwich covariance ``H^-1 Omega H^-1`` (prewhitened Newey-West, data-driven
    bandwidth) of the parameters, in their units squared; all NaN when ``J^T J`` is singular
    (a parameter the residuals do not see, or two that trade off exactly)."""
    jac = np.asarray(jac, dtype=float)
    k = jac.shape[1]
    hinv = _inverse(jac.T @ jac)
    if hinv is None:
        return np.full((k, k), math.nan)
    return hinv @ prewhitened_long_run_variance(scores(jac, r, n_signals)) @ hinv


def white_covariance(jac: np.ndarray, r: np.ndarray) -> np.ndarray:
    """``s^2 (J^T J)^-1`` with ``s^2 = r.r / (n - k)``: valid only for white residuals (the comparison)."""
    jac = np.asarray(jac, dtype=float)
    n, k = jac.shape
    hinv = _inverse(jac.T @ jac)
    if hinv is None:
        return np.full((k, k), math.nan)
    r = np.asarray(r, dtype=float)
    return hinv * float(r @ r) / max(n - k, 1)


def standard_errors(cov: np.ndarray) -> np.ndarray:
    """``sqrt(diag(cov))``; NaN for a negative diagonal entry (round-off)."""
    return np.array([math.sqrt(c) if c >= 0 else math.nan for c in np.diag(cov)])


def correlation(cov: np.ndarray) -> np.ndarray:
    """``cov_ij / sqrt(cov_ii cov_jj)`` (NaN where a variance is not positive)."""
    se = standard_errors(cov)
    with np.errstate(invalid="ignore", divide="ignore"):
        return cov / np.outer(se, se)


STRONG_CORRELATION = 0.9
"""``|rho|`` above which two estimates are reported as correlated (``fit``'s table, ``diagnose --json``'s
``correlations``): past it the two trade off so that each one's standard error alone misleads."""


def strongly_correlated(rho: np.ndarray) -> bool:
    """Whether any two estimates correlate beyond :data:`STRONG_CORRELATION` (``rho`` a correlation
    matrix; NaN entries do not count)."""
    off = np.abs(np.asarray(rho, dtype=float)) - np.eye(len(rho))
    return bool(np.any(np.nan_to_num(off, nan=0.0) > STRONG_CORRELATION))


def strong_correlations(correlation: dict, threshold: float = STRONG_CORRELATION) -> list[tuple[str, str, float]]:
    """``(a, b, rho)`` for each pair of parameters (``a`` before ``b``) of ``correlation``
    (name -> name -> rho) with ``|rho| > threshold``."""
    names = list(correlation)
    return [(a, b, correlation[a][b]) for i, a in enumerate(names) for b in names[i + 1:]
            if abs(correlation[a][b]) > threshold]


def central_jacobian(residual: Callable[[np.ndarray], np.ndarray], x0: Sequence[float],
                     steps: Sequence[float]) -> np.ndarray:
    """``dr/dx`` at ``x0`` by central differences, ``(r(x + h_j e_j) - r(x - h_j e_j)) / 2 h_j``."""
    x0 = np.asarray(x0, dtype=float)
    cols = []
    for j, h in enumerate(steps):
        xp, xm = x0.copy(), x0.copy()
        xp[j] += h
        xm[j] -= h
        cols.append((residual(xp) - residual(xm)) / (2 * h))
    return np.column_stack(cols)
