"""The replay's numerical error in fitted values, measured and taken out.

A fit's values minimise the RSS of a replay solved to a relative tolerance ``rtol``; its standard
errors are the noise's alone.  On a long, quiet record the noise's share can fall below the
solver's: the replay's error, smooth in the parameters, moves the minimum by more than a standard
error, and the truth falls outside the error bars for a reason no statistic sees.  On 16 s of the
bench rig with p04's datasheet errors and Coulomb friction at the load (``tests/test_datasheet.py``)
the torque constant, fitted at rtol 1e-6, sat 1.3 standard errors from the truth, and 3.4 after a
change of the solver's step sequence alone; fitted at rtol 1e-8, 0.03 and 0.01 (``docs/speed.md``).

:func:`refine` measures it at the fit's end ``p``, its weighted residual ``w`` and Jacobian
``J = dw/dp`` (the standard errors' own): the fitted plant replayed at ``rtol / TIGHTER``, the
fit's window seams held, gives ``w_t``, and the least squares of the tighter replay lies, to first
order, a Gauss-Newton step away,

    delta_p = -(J^T J)^-1 J^T w_t.

The step is solved within the values' bounds (a value at its bound stays there while the rest
take the step, ``scipy.optimize.lsq_linear``).  Where some ``|delta_p_i|`` exceeds
:data:`NUMERICAL_SHARE` of its standard error, the values move by it, or by a half, a quarter or an
eighth of it, whichever first lowers the tighter replay's RSS, at most :data:`STEPS` steps, and the
result is the plant there, scored by the tighter replay: the fit finished at the tighter
tolerance.  Its standard errors stay the fit's (the steps do not change ``J``'s statistics), and
``FitResult.refined`` is True.  ``FitResult.numerical`` gives the shift of each value, in its own
unit, taken or (below the share) not: the replay's tolerance's part (``J^T (w_t - w)``) and
whatever the least squares' stop had left (``J^T w``, 0 at an exact minimum).

The shorter steps and the count are for that second part.  The least squares stops where its own
Jacobian (a secant's, at the loose tolerance) foretells too small a gain, and along a valley of
values that trade off it can stop well short of the minimum.  On the same 16 s record the fit of
2026-12-07 had stopped 73 units of weighted RSS (of 47,542) above it, the torque constant 6.0 and
the motor's damping 5.5 standard errors from the truth.  The full step from there raised the
tighter replay's RSS (47,663: the Jacobian is the valley's slope, not its curve), and so the fit
was left there; a quarter-step twice, a half and two full steps reach it, every value within 0.42
standard errors of the truth.  The two parts were measured apart on the record above: the tolerance's alone
brought the torque constant from -1.34 to -0.65 standard errors and the motor's damping from
+1.93 to +0.88; both, to +0.09 and +0.09, where the fit at rtol 1e-8 is at +0.03 and +0.07.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np
from scipy.optimize import lsq_linear

from .fit import FitResult, get_value, param_value, set_values
from .replay import Replay, ReplayError
from .scoring import Scorer

TIGHTER = 100.0
"""The check replays at the fit's relative tolerance divided by this."""
NUMERICAL_SHARE = 0.3
"""A numerical shift above this share of a value's standard error is taken out: it would widen a
95 % interval's miss rate from 5 % to about 6 %; below it the fit is left as it is."""
STEPS = 8
"""Most Gauss-Newton steps on the tighter replay."""
SHORTER = (1.0, 0.5, 0.25, 0.125)
"""The fractions of a Gauss-Newton step tried, in turn, until one lowers the tighter replay's RSS."""


def tighter(replay: Replay, factor: float = TIGHTER) -> Replay:
    """``replay`` with its solver's relative tolerance divided by ``factor`` (its meter kept)."""
    out = replace(replay, options=replace(replay.options, rtol=replay.options.rtol / factor))
    return out.metered(replay.meter) if replay.meter is not None else out


def _excess_map(frees: list) -> np.ndarray:
    """``M`` with ``dp = M du``: a shift ``du`` of the fit's coordinates as a shift of the values' own
    (an excess ``u_s = p_s - p_c`` over a free floor ``p_c`` moves ``p_s`` by ``du_s + du_c``)."""
    m = np.eye(len(frees))
    for s, f in enumerate(frees):
        if f.above:
            for c, g in enumerate(frees):
                if g.index == f.index and g.key == f.above:
                    m[s, c] = 1.0
    return m


def _step(jac: np.ndarray, u: np.ndarray, low: np.ndarray, high: np.ndarray, w: np.ndarray,
          scale: np.ndarray) -> np.ndarray:
    """The Gauss-Newton step ``du`` of the coordinates ``u``, ``min |w + jac du|`` within the bounds
    ``low <= u + du <= high``, solved in units of ``scale`` (the standard errors) for its conditioning."""
    return scale * lsq_linear(jac * scale, -w, bounds=((low - u) / scale, (high - u) / scale), method="bvls").x


def refine(replay: Replay, scorer: Scorer, res: FitResult) -> FitResult:
    """``res`` (a converged fit of ``replay``) with its replay's numerical error measured
    (``numerical``) and, where it exceeds :data:`NUMERICAL_SHARE` of a standard error, taken out by
    the tighter replay (module docstring); ``res`` unchanged but for ``numerical`` when it does not,
    and as it is when it has no parameters, no Jacobian or the tighter replay fails."""
    if not res.converged or not res.params or res.jac is None:
        return res
    frees = [p.free for p in res.params.values()]
    se = np.array([p.stderr for p in res.params.values()])
    low, high = np.array([f.low for f in frees]), np.array([f.high for f in frees])
    tight = tighter(replay)
    u = np.array([get_value(res.plant, f) for f in frees])
    m = _excess_map(frees)
    jac, scale = res.jac @ m, np.where(np.isfinite(se) & (se > 0.0), se, 1.0)
    plant, done, runs = res.plant, 0, 1
    try:
        sim = tight.run(plant, seams=res.seams)
        w = scorer.weighted(sim)
        while True:
            du = _step(jac, u, low, high, w, scale)
            dp = m @ du
            if done == STEPS or not np.any(np.abs(dp) > NUMERICAL_SHARE * se):
                break
            for a in SHORTER:
                u_next = np.clip(u + a * du, low, high)
                p_next = set_values(res.plant, frees, u_next)
                sim_next = tight.run(p_next, seams=res.seams)
                w_next, runs = scorer.weighted(sim_next), runs + 1
                if float(w_next @ w_next) < float(w @ w):
                    break
            else:
                break
            u, plant, sim, w, done = u_next, p_next, sim_next, w_next, done + 1
    except ReplayError:
        return res
    if not done:
        return replace(res, numerical={n: float(dp[i]) for i, n in enumerate(res.params)})
    params = {n: replace(p, value=param_value(plant, p.free)) for n, p in res.params.items()}
    shift = np.array([params[n].value - p.value for n, p in res.params.items()])
    msg = (f"{res.message}; finished at rtol {tight.options.rtol:g} (the replay's at rtol {replay.options.rtol:g} "
           f"had left the values up to {np.max(np.abs(shift) / se):.2g} standard errors off; {done} Gauss-Newton "
           f"step{'s' * (done > 1)})")
    return replace(res, plant=plant, params=params, error=scorer.error(sim), rss=float(w @ w),
                   message=msg, nfev=res.nfev + runs, sim=sim, signals=scorer.per_signal(sim),
                   seams=sim.seams, noise=scorer.noise_models(sim),
                   numerical={n: float(shift[i]) for i, n in enumerate(res.params)}, refined=True)
