"""``identify.numerics._step`` and ``_excess_map``: the Gauss-Newton step of the numerical check,
solved within the values' bounds and in the fit's coordinates (an excess over a free floor)."""
from types import SimpleNamespace

import numpy as np

from gearbench.identify.numerics import _excess_map, _step


def _free(index=0, key="a", above=None):
    return SimpleNamespace(index=index, key=key, above=above)


def _problem(seed=0, n=200, k=3):
    rng = np.random.default_rng(seed)
    jac = rng.normal(size=(n, k)) * np.array([1.0, 1e3, 1e-2])[:k]  # columns of unlike scales
    return jac, rng.normal(size=n)


def test_the_step_without_active_bounds_is_the_least_squares():
    jac, w = _problem()
    frees = [_free(key=k) for k in "abc"]
    u, se = np.zeros(3), np.array([1.0, 1e-3, 1e2])
    m = _excess_map(frees)
    du = _step(jac @ m, u, -np.full(3, 1e9), np.full(3, 1e9), w, se)
    assert np.allclose(m @ du, -np.linalg.lstsq(jac, w, rcond=None)[0], rtol=1e-8, atol=0)
    assert np.array_equal(m, np.eye(3))


def test_a_value_at_its_bound_stays_there_and_the_rest_take_the_least_squares():
    jac, w = _problem(1)
    free_step = -np.linalg.lstsq(jac, w, rcond=None)[0]
    # the first value at the bound its free step would cross: the least squares over the half-space
    # (convex, its minimum outside) lies on that bound
    u = np.zeros(3)
    low, high = -np.full(3, 1e9), np.full(3, 1e9)
    if free_step[0] > 0:
        high[0] = 0.0
    else:
        low[0] = 0.0
    dp = _step(jac, u, low, high, w, np.ones(3))  # no excess: the coordinates are the values
    assert dp[0] == 0.0
    assert np.allclose(dp[1:], -np.linalg.lstsq(jac[:, 1:], w, rcond=None)[0], rtol=1e-8, atol=0)


def test_an_excess_over_a_free_floor_moves_by_its_difference():
    """``u_s = p_s - p_c``: the step in own values is the least squares; in coordinates the excess
    moves by ``dp_s - dp_c``."""
    jac, w = _problem(2, k=2)
    frees = [_free(key="floor"), _free(key="top", above="floor")]
    m = _excess_map(frees)
    du = _step(jac @ m, np.zeros(2), -np.full(2, 1e9), np.full(2, 1e9), w, np.ones(2))
    dp = m @ du
    assert np.allclose(dp, -np.linalg.lstsq(jac, w, rcond=None)[0], rtol=1e-8, atol=0)
    assert np.allclose(du, [dp[0], dp[1] - dp[0]], rtol=1e-8, atol=1e-15)
