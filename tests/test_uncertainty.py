"""Standard errors that hold for correlated residuals (gearbench.identify.uncertainty)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from gearbench.identify import uncertainty as U
from gearbench.synth import ar1
from studies import coverage as C


def _linear_case(rho: float, seed: int, t: int = 4000):
    """A straight-line fit y = a + b s (s in [-1, 1]) to AR(1) noise on two identical signals:
    returns the estimate's error, the Jacobian and the residual, in the layout ``fit`` uses."""
    rng = np.random.default_rng(seed)
    s = np.linspace(-1.0, 1.0, t)
    j1 = -np.column_stack([np.ones(t), s])            # r = y - (a + b s): dr/d(a, b)
    jac = np.vstack([j1, j1])
    noise = np.concatenate([ar1(rng.standard_normal(t), rho), ar1(rng.standard_normal(t), rho)])
    x, *_ = np.linalg.lstsq(-jac, noise, rcond=None)   # truth (0, 0); fitted x
    return x, jac, noise + jac @ x


@pytest.mark.parametrize("rho", [0.0, 0.9])
def test_linear_regression_coverage(rho):
    """On a linear model with known noise the sandwich's +-2 SE covers the truth ~95 % of the
    time, white or AR(1); the white formula does not on AR(1) noise (the lag-1 correlation
    0.9 makes the variance of a mean 19x larger)."""
    hits, white_hits = [], []
    for seed in range(200):
        x, jac, r = _linear_case(rho, seed)
        se = U.standard_errors(U.covariance(jac, r, 2))
        hits.append(np.all(np.abs(x) <= 2 * se))
        white_hits.append(np.all(np.abs(x) <= 2 * U.standard_errors(U.white_covariance(jac, r))))
    assert np.mean(hits) >= 0.85
    if rho:
        assert np.mean(white_hits) < 0.5


def test_singular_jacobian_gives_nan():
    jac = np.column_stack([np.ones(100), np.ones(100)])
    cov = U.covariance(jac, np.random.default_rng(0).standard_normal(100), 1)
    assert np.all(np.isnan(U.standard_errors(cov)))


def test_ar1_noise_keeps_the_marginal_sigma():
    e = np.random.default_rng(1).standard_normal(200_000)
    w = ar1(e, 0.9)
    assert abs(w.std() - 1.0) < 0.02
    assert abs(np.corrcoef(w[1:], w[:-1])[0, 1] - 0.9) < 0.01
    assert ar1(e, 0.0) is e
    with pytest.raises(ValueError):
        ar1(e, 1.0)


@pytest.mark.parametrize("rho", [0.0, C.RHO])
def test_fit_coverage(rho):
    """``studies.coverage`` on the steps records: over 60 seeds the truth lies within +-2 reported
    standard errors in >= 90 % of fits for each of the five parameters (stick-slip Coulomb
    torque, spring stiffness and rest angle, viscous coefficient, motor resistance); the white
    formula fails on AR(1) noise.  About 35 s per noise type on a free core (fits ~0.5 s each), on two
    processes."""
    c = C.run("steps", rho, C.SEEDS, workers=2)
    assert c["converged"] == C.SEEDS
    low = {n: v for n, v in c["coverage"].items() if v < 0.9}
    assert not low, f"coverage below 90 %: {low} (rms z {c['rms_z']})"
    if rho:
        assert min(c["coverage_white_formula"].values()) < 0.6
    assert all(math.isfinite(v) for r in c["fits"] for v in r["stderr"].values())


TUTORIAL_SEEDS = 60
"""Twice the study's 30: over 30 seeds a coverage of 90 % is 27 of them, give or take 1.6 (its
binomial standard error), and the rest angle's sat at 27 when this test was written.  A change
that leaves every answer alone but a far bound of the friction's fit (its floor,
``location.stick_slip_floor``) moved the fits' ends by up to 1.2 standard errors (they stop on a
relative step of 1e-6, some 5 standard errors of the friction), and the rest angle's count to 26
(2026-11-30).  Over 60 seeds: 93, 90 and 92 % before that change, 95, 90 and 93 % after."""


def test_the_tutorials_fits_coverage():
    """``studies.coverage``'s second part: the tutorial's two fits (the spring alone, then the
    friction with ``refit``) on :data:`TUTORIAL_SEEDS` seeds of its 10 s record, rest angle at 0 deg:
    the truth within +-2 reported standard errors in >= 90 % of fits for the stiffness, rest angle
    and friction (over 30 seeds 100, 90 and 93 % when written; with the finite-difference step
    relative to the value, as scipy's, the rest angle's was 10 %, RMS z 425).  About 80 s on two
    cores."""
    t = C.tutorial_run(TUTORIAL_SEEDS, workers=2)
    low = {n: v for n, v in t["coverage"].items() if v < 0.9}
    assert not low, f"coverage below 90 %: {low} (rms z {t['rms_z']})"
    assert all(math.isfinite(v) for r in t["fits"] for v in r["stderr"].values())


def test_strongly_correlated_looks_past_the_diagonal_and_ignores_nan():
    """Which fits take their errors' Jacobian again (``fit._sharp_jacobian``): any pair beyond
    ``STRONG_CORRELATION``, either sign; the diagonal's ones and NaN (a singular pair) do not count."""
    rho = np.eye(3)
    assert not U.strongly_correlated(rho)
    rho[0, 2] = rho[2, 0] = -(U.STRONG_CORRELATION + 0.01)
    assert U.strongly_correlated(rho)
    rho[0, 2] = rho[2, 0] = U.STRONG_CORRELATION
    assert not U.strongly_correlated(rho)
    rho[1, 2] = rho[2, 1] = math.nan
    assert not U.strongly_correlated(rho)


def test_sharpening_later_gives_the_fits_own_sharpened_errors():
    """A multi-start fits each start with ``sharp=False`` and sharpens only the fit it keeps
    (``fit.sharpen``): that must be exactly the fit's own answer, not an approximation of it.
    The rotor's and the load's inertias trade off along the reflected inertia the motor drives."""
    from gearbench.experiment.files import load_plant
    from gearbench.identify.fit import Free, fit, sharpen
    from gearbench.identify.replay import Replay
    from gearbench.identify.scoring import Scorer
    from gearbench.synth import excitation, synthesize
    from conftest import REPO

    plant = load_plant(REPO / "experiments" / "plants" / "bench_rig.yaml")
    t, u = excitation("mixed", plant, duration_s=2.0, seed=5)
    replay = Replay(synthesize(plant, [], t, u, noise={"motor_angle_deg": 0.02, "current_A": 0.008}, seed=5,
                               signals=["motor_angle_deg", "current_A"]))
    scorer = Scorer(replay)
    frees = [Free.plant(plant, "motor.inertia"), Free.plant(plant, "load.inertia")]
    start = [plant.motor.inertia * 1.1, plant.load.inertia * 0.9]
    sharp = fit(replay, plant, frees, scorer, start=start)
    first = fit(replay, plant, frees, scorer, start=start, sharp=False)
    assert sharp.converged and abs(first.correlation["motor.inertia"]["load.inertia"]) > U.STRONG_CORRELATION
    later = sharpen(replay, scorer, first)
    assert first.unsharp is not None and later.unsharp is None
    assert later.values == sharp.values and later.stderr == sharp.stderr and later.nfev == sharp.nfev
    assert later.correlation == sharp.correlation and later.stderr != first.stderr
