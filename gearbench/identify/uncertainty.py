"""Standard errors of fitted parameters from the residuals' Jacobian.

For residuals ``r`` (each signal divided by its noise floor) with Jacobian
``J = dr/dx`` at the fitted parameters ``x`` (``n`` residuals, ``k``
parameters), the least-squares covariance is

    cov = s^2 (J^T J)^-1,   s^2 = RSS / (n - k),   RSS = r . r,

and the standard error of ``x_j`` is ``sqrt(cov_jj)``, in the units of ``x_j``.
It assumes white residuals: replay residuals are correlated in time, so these
are lower bounds there.  ``fit`` and the EMPS study both take theirs from here.
"""
from __future__ import annotations

import math
from typing import Callable, Sequence

import numpy as np


def standard_errors(jac: np.ndarray, rss: float, n: int) -> np.ndarray:
    """``sqrt(diag(s^2 (J^T J)^-1))`` with ``s^2 = rss / (n - k)``, one per column of ``jac``.

    A singular ``J^T J`` (a parameter the residuals do not see, or two that
    trade off exactly) gives NaN for every parameter, as does a negative
    diagonal entry (round-off) for its own parameter."""
    jac = np.asarray(jac, dtype=float)
    k = jac.shape[1]
    try:
        cov = np.linalg.inv(jac.T @ jac) * rss / max(n - k, 1)
    except np.linalg.LinAlgError:
        return np.full(k, math.nan)
    return np.array([math.sqrt(c) if c >= 0 else math.nan for c in np.diag(cov)])


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
