"""The fit's Jacobian: finite differences, kept up to date by Broyden's secant updates
(``gearbench.identify.fit.SecantJacobian``): the same optimum as finite differences at every step,
for fewer residual evaluations; fresh where the update is not to be trusted; and a stop on the step
size after updates goes on (``secant_least_squares``)."""
from __future__ import annotations

import hashlib
import math
from functools import partial

import numpy as np
import pytest
from scipy.optimize import least_squares
from scipy.optimize._numdiff import approx_derivative

from gearbench.errors import FitSettled
from gearbench.identify import fit as fit_module
from gearbench.identify.fit import FD_STEP, POOR_STEPS, SecantJacobian, fd_step, secant_least_squares

T = np.linspace(0.0, 4.0, 200)
TRUE = np.array([2.0, 1.3, 0.4, 3.0])


def model(p):
    a, b, c, w = p
    return a * np.exp(-b * T) + c * np.sin(w * T)


DATA = model(TRUE) + 0.01 * np.random.default_rng(1).standard_normal(T.size)


class Counted:
    """The residual, counting its calls (each one a replay in a fit)."""

    def __init__(self):
        self.calls = 0

    def __call__(self, p):
        self.calls += 1
        return model(p) - DATA


BOUNDS = (np.array([0.0, 0.0, -5.0, 0.5]), np.array([10.0, 10.0, 5.0, 5.0]))
START = np.array([1.0, 0.5, 0.1, 2.7])


def jacobian(p):
    a, b, c, w = p
    e = np.exp(-b * T)
    return np.column_stack([e, -a * T * e, np.sin(w * T), c * T * np.cos(w * T)])


def test_the_secant_fit_ends_where_finite_differences_do_for_fewer_evaluations():
    exact = least_squares(lambda p: model(p) - DATA, START, jac=jacobian, bounds=BOUNDS, ftol=1e-12, xtol=1e-12)
    j = jacobian(exact.x)
    stderr = np.sqrt(np.diag(np.linalg.inv(j.T @ j)) * (exact.fun @ exact.fun) / (T.size - 4))
    fd = Counted()
    ref = least_squares(fd, START, bounds=BOUNDS, jac="2-point", diff_step=1e-3, ftol=1e-10, xtol=1e-10)
    fun = Counted()
    secant = SecantJacobian(fun, BOUNDS, central=False)
    got = least_squares(secant.residual, START, bounds=BOUNDS, jac=secant, ftol=1e-10, xtol=1e-10)
    assert ref.status > 0 and got.status > 0
    # both at the least-squares optimum, to a hundredth of its standard errors (neither's Jacobian is exact)
    assert np.all(np.abs(got.x - exact.x) < 0.01 * stderr), (got.x - exact.x) / stderr
    assert np.all(np.abs(ref.x - exact.x) < 0.01 * stderr), (ref.x - exact.x) / stderr
    assert exact.x == pytest.approx(TRUE, rel=0.02)
    assert fun.calls < fd.calls, (fun.calls, fd.calls)   # 27 for 34 when written
    # the standard errors' Jacobian is a finite-difference one at the end
    end = secant.fresh(got.x, got.fun)
    np.testing.assert_allclose(end, approx_derivative(fun, got.x, method="2-point", abs_step=fd_step(got.x),
                                                       f0=got.fun, bounds=BOUNDS))
    np.testing.assert_allclose(end, jacobian(got.x), atol=0.01)
    assert not secant.updated


def test_an_update_holds_the_secant_equation_and_costs_no_evaluation():
    fun = Counted()
    secant = SecantJacobian(fun, BOUNDS, central=False)
    z0, z1 = START, START + np.array([0.3, 0.1, 0.05, 0.02])
    secant.residual(z0)
    secant(z0)
    fresh_calls = fun.calls
    assert fresh_calls == 1 + 4 and not secant.updated   # the point, then a difference per parameter
    j0 = secant.J.copy()
    r0, r1 = fun(z0), secant.residual(z1)
    before = fun.calls
    j1 = secant(z1)
    assert secant.updated and fun.calls == before   # a rank-one update, no evaluation
    np.testing.assert_allclose(j1 @ (z1 - z0), r1 - r0, atol=1e-9)
    assert np.linalg.matrix_rank(j1 - j0) == 1


def test_a_rejected_step_or_poorly_foretold_steps_bring_a_fresh_jacobian():
    fun = Counted()
    secant = SecantJacobian(fun, BOUNDS, central=False)
    z0 = START
    secant.residual(z0)
    secant(z0)
    # two trials before the next Jacobian: the trust region rejected the first
    secant.residual(z0 + 1.0)
    z1 = z0 + np.array([0.1, 0.0, 0.0, 0.0])
    secant.residual(z1)
    n = fun.calls
    secant(z1)
    assert fun.calls == n + 4 and not secant.updated
    # steps whose cost rose where the model foretold a fall: fresh after POOR_STEPS in a row
    z = z1
    for i in range(POOR_STEPS):
        secant.J = np.zeros_like(secant.J) + 1e3 * (i + 1)   # a Jacobian that foretells nothing right
        z = z + np.array([0.0, 0.0, 0.0, 0.5])
        secant.residual(z)
        n = fun.calls
        secant(z)
        fresh = fun.calls == n + 4
        assert fresh == (i == POOR_STEPS - 1), i


@pytest.mark.parametrize("z", [0.0, 2e-7, -3e-6, 0.5, -40.0])
def test_the_difference_step_does_not_shrink_with_the_value(z):
    """A replay's residual is smooth only down to its solver's error: here a ripple of 1e-9 every
    1e-8.  The step is ``FD_STEP max(1, |z|)`` whatever ``z`` (scipy's relative step, ``1e-3 |z|``,
    was 2e-10 at the tutorial's rest angle, and its slope there the ripple's: a standard error of
    8e-9 deg where the estimates spread by 6e-6 deg over noise seeds)."""
    def rippled(p):
        ripple = 1e-9 * np.sin(2 * np.pi * p[0] / 1e-8)
        return np.array([3.0 * p[0] + ripple, ripple - p[0]])
    x = np.array([z])
    np.testing.assert_allclose(fd_step(x), [FD_STEP * max(1.0, abs(z)) * (1 if z >= 0 else -1)])
    for central in (False, True):
        secant = SecantJacobian(rippled, (np.array([-np.inf]), np.array([np.inf])), central)
        np.testing.assert_allclose(secant.fresh(x, rippled(x), central)[:, 0], [3.0, -1.0], atol=1e-5)


def beale(z):
    return np.array([1.5 - z[0] * (1 - z[1]), 2.25 - z[0] * (1 - z[1] ** 2), 2.625 - z[0] * (1 - z[1] ** 3)])


def rosenbrock(z):
    return np.array([10 * (z[1] - z[0] ** 2), 1 - z[0]])


@pytest.mark.parametrize("fun, start, optimum", [(beale, [1.0, 1.0], [3.0, 0.5]),
                                                 (rosenbrock, [-3.0, -4.0], [1.0, 1.0])],
                         ids=["beale", "rosenbrock from far"])
def test_a_stop_on_the_step_size_after_secant_updates_goes_on_to_the_optimum(fun, start, optimum):
    """Two test functions (More, Garbow & Hillstrom 1981) whose zero residual least squares with
    finite differences reaches: with the secant updates alone the trust region shrinks short of it
    and the fit stops on its step size (Beale's at a cost of 2.2, Rosenbrock's from (-3, -4) at
    3300); going on from there with a fresh Jacobian and trust region reaches it."""
    bounds = (np.full(2, -np.inf), np.full(2, np.inf))
    secant = SecantJacobian(fun, bounds, central=False)
    alone = least_squares(secant.residual, np.array(start), jac=secant, bounds=bounds, method="trf",
                          ftol=1e-6, xtol=1e-6, max_nfev=400)
    assert alone.status == 3 and secant.updates and alone.cost > 1.0  # the stop this is about
    res = secant_least_squares(fun, np.array(start), bounds, max_nfev=400)
    assert res.cost < 1e-12 and np.allclose(res.x, optimum, atol=1e-5), (res.cost, res.x)
    assert least_squares(fun, np.array(start), method="trf", ftol=1e-6, xtol=1e-6).cost < 1e-12


SCATTER = 1e-5
"""The standard deviation of :func:`scattered`'s scatter (0.1 % of the noise)."""


def scattered(p, salt: int = 0):
    """The model's residual with a replay's numerical scatter: at every new point a different
    :data:`SCATTER`, a function of the point (and ``salt``) alone, so the cost is not smooth
    below it."""
    key = np.asarray(p, dtype=float).tobytes() + bytes([salt])
    seed = int.from_bytes(hashlib.sha1(key).digest()[:4], "little")
    return model(p) - DATA + SCATTER * np.random.default_rng(seed).standard_normal(T.size)


class ReplayingEveryTrial(SecantJacobian):
    """The Jacobian as it was: every trial replayed (``ftol`` 0)."""

    def __init__(self, fun, bounds, central, ftol=0.0):
        super().__init__(fun, bounds, central, 0.0)


def test_a_trial_foretold_to_gain_less_than_ftol_is_not_replayed(monkeypatch):
    """Where the cost is scattered below the steps that matter, the trust region shrank, one rejected
    replay after another, until the step size stopped the fit (xtol); after a rejection, a trial the
    finite-difference Jacobian foretells to lower the RSS by less than FTOL of itself is not
    replayed: the same end for fewer evaluations.  Over 16 scatters, since which of them meets
    such a cascade depends on the last bits of the trust region's steps: the one scatter this test
    had met it with the packages of 2026-11-30 and not with numpy 2.4.6 and scipy 1.17.1, where 4
    of the first 8 of these do.

    "The same end": the two ends lie closer (in standard errors, the Mahalanobis distance) than
    the cost's scatter lets a fit tell apart, the distance ``d`` over which the smooth RSS rises by
    the scatter's standard deviation at the end, ``d^2 s^2 = 2 |r| SCATTER`` (``s^2`` the residual
    variance): 0.17 here.  On one machine (AMD EPYC, the same packages) scatter 3's ends lay 0.103
    apart, the ftol stop 15 replays in, the step-size stop 23; on the machine of 2026-12-01 all 16 lay
    within 0.01 standard errors in every coordinate (the assertion this replaced, green there)."""
    settling, every, ends = [], [], []
    for salt in range(16):
        fun = partial(scattered, salt=salt)
        calls = Counted()
        ends.append(secant_least_squares(lambda p: (calls(p), fun(p))[1], START, BOUNDS))
        settling.append(calls.calls)
    monkeypatch.setattr(fit_module, "SecantJacobian", ReplayingEveryTrial)
    for salt, after in enumerate(ends):
        fun = partial(scattered, salt=salt)
        calls = Counted()
        before = secant_least_squares(lambda p: (calls(p), fun(p))[1], START, BOUNDS)
        every.append(calls.calls)
        assert after.status > 0, (salt, after.status)
        j, r = jacobian(after.x), after.fun
        variance = float(r @ r) / (T.size - 4)
        dx = after.x - before.x
        apart = math.sqrt(float(dx @ (j.T @ j) @ dx) / variance)
        assert apart < math.sqrt(2.0 * np.linalg.norm(r) * SCATTER / variance), (salt, apart)
        assert after.x == pytest.approx(TRUE, rel=0.02)
    # withheld trials end a fit on the path the fit replaying every trial takes: never more calls
    assert all(a <= b for a, b in zip(settling, every)), (settling, every)
    assert sum(settling) < sum(every), (settling, every)


def test_only_a_trial_foretold_to_gain_less_than_ftol_after_a_rejection_is_withheld():
    fun = Counted()
    secant = SecantJacobian(fun, BOUNDS, central=False, ftol=1e-6)
    secant.residual(START)
    secant(START)
    rss = float(secant.r @ secant.r)
    step = np.linalg.lstsq(secant.J, -secant.r, rcond=None)[0]   # the Gauss-Newton step

    def foretold(t):
        linear = secant.r + secant.J @ (t * step)
        return rss - float(linear @ linear)
    small = next(t for t in 0.5 ** np.arange(60) if foretold(t) < 1e-6 * rss)
    n = fun.calls
    secant.residual(START + small * step)                  # the first trial from a point: replayed
    secant.residual(START + 1.5 * step)                    # a trial, as if the trust region rejected it
    assert fun.calls == n + 2
    with pytest.raises(FitSettled):
        secant.residual(START + small * step)
    assert fun.calls == n + 2                              # withheld: no evaluation
    assert foretold(1.0) >= 1e-6 * rss
    secant.residual(START + step)                          # foretold to gain more: replayed
    assert fun.calls == n + 3
    end = secant.settled()
    assert end.status == 2 and np.array_equal(end.x, START) and end.cost == 0.5 * rss
    # after a secant update the foresight is not trusted: every trial is replayed (FTOL says why)
    secant = SecantJacobian(fun, BOUNDS, central=False, ftol=1e-6)
    secant.residual(START)
    secant(START)
    z1 = START + 0.01 * step
    secant.residual(z1)
    secant(z1)
    assert secant.updated
    secant.residual(z1 + 1.5 * step)
    n = fun.calls
    secant.residual(z1 + 1e-12 * step)
    assert fun.calls == n + 1


class Seamed:
    """A fit's replays (``fit._Trials``' two calls) where a reset switches on past ``z = 0.5``: with
    the resets held, the residual ``z - 1`` has its least squares at 1; by the replay's own resets
    the RSS there is ``jump`` more."""

    def __init__(self, jump: float):
        self.jump = jump

    def residual(self, z, seams):
        return np.array([z[0] - 1.0, 0.5 * (z[0] - 1.0)])

    def settle(self, z):
        seams = (7,) if z[0] > 0.5 else ()
        r = self.residual(z, seams)
        return seams, float(r @ r) + (self.jump if seams else 0.0)


@pytest.mark.parametrize("jump, back", [(10.0, True), (0.5, False)])
def test_a_fit_whose_first_round_ends_worse_by_its_own_resets_ends_where_it_started(jump, back):
    """The first round of a fit's least squares is held to its start's resets; where its end scores
    worse than the start by the replay's own resets, the fit ends at the start, with the start's
    Jacobian for the standard errors; where better, at the end.  The start scores 1.25 (at z = 0)."""
    z0 = np.array([0.0])
    res, nfev, rounds = fit_module._rounds(Seamed(jump), z0, (np.array([-5.0]), np.array([5.0])),
                                           central=False, max_nfev=50, restarts=0, rounds_below=None)
    assert res.status > 0 and nfev > 1
    if back:
        assert np.array_equal(res.x, z0) and rounds == 0 and "ended where it started" in res.message
        np.testing.assert_allclose(res.fun, [-1.0, -0.5])
        np.testing.assert_allclose(res.jac, [[1.0], [0.5]], rtol=1e-9)
    else:
        np.testing.assert_allclose(res.x, [1.0], atol=1e-6)


def test_a_lazy_end_jacobian_is_made_only_when_asked_and_is_the_same():
    """``secant_least_squares(lazy=True)``: a fit that ended after a secant update leaves its
    finite-difference Jacobian for later (``fresh_jac``), no replay made for it until
    ``fresh_jacobian`` asks, which then gives exactly the one an eager fit ends with."""
    bounds = (np.full(2, -np.inf), np.full(2, np.inf))
    eager = secant_least_squares(beale, np.array([1.0, 1.0]), bounds, max_nfev=400)
    calls = []
    lazy = secant_least_squares(lambda z: (calls.append(z), beale(z))[1], np.array([1.0, 1.0]), bounds,
                                max_nfev=400, lazy=True)
    assert lazy.fresh_jac is not None
    before = len(calls)
    kept = fit_module.fresh_jacobian(lazy)
    assert len(calls) == before + 2 and kept.fresh_jac is None   # forward differences, 2 values
    np.testing.assert_array_equal(kept.x, eager.x)
    np.testing.assert_array_equal(kept.jac, eager.jac)


class Moved:
    """A fit's replays (``fit._Trials``' two calls): Rosenbrock's residual whatever the resets, which
    switch to other seams once the fit has left its start, so a second round follows the first."""

    def residual(self, z, seams):
        return rosenbrock(z)

    def settle(self, z):
        r = rosenbrock(z)
        return ((7,) if not np.array_equal(z, [-3.0, -4.0]) else ()), float(r @ r)


def test_a_round_that_is_not_kept_costs_no_end_jacobian(monkeypatch):
    """``fit._rounds``: the finite-difference Jacobian at a round's end is for the standard errors
    of the round kept; a round followed by another costs none (k replays each, 2k central: the
    calibration's rounds of 8-9 values), and the kept one ends with it."""
    bounds = (np.full(2, -np.inf), np.full(2, np.inf))
    made = []
    fresh = SecantJacobian.fresh

    def counted(self, z, r, central=False):
        made.append((self.fun.keywords["seams"], tuple(z)))
        return fresh(self, z, r, central)
    monkeypatch.setattr(SecantJacobian, "fresh", counted)
    first = secant_least_squares(partial(Moved().residual, seams=()), np.array([-3.0, -4.0]), bounds, max_nfev=400)
    assert made[-1] == ((), tuple(first.x))  # the first round alone ends after a secant update: made there
    made.clear()
    res, nfev, rounds = fit_module._rounds(Moved(), np.array([-3.0, -4.0]), bounds, central=False,
                                           max_nfev=400, restarts=0, rounds_below=None)
    assert rounds == 1 and np.allclose(res.x, [1.0, 1.0], atol=1e-6)
    assert ((), tuple(first.x)) not in made                     # the first round's end: none
    assert made[-1] == ((7,), tuple(res.x))                     # the kept round's end: made last
    np.testing.assert_array_equal(res.jac, fresh(SecantJacobian(partial(Moved().residual, seams=(7,)), bounds,
                                                                False), res.x, res.fun))


@pytest.mark.parametrize("central", [False, True])
def test_a_central_fit_steps_on_forward_differences_and_ends_on_central_ones(monkeypatch, central):
    """``central`` is for the standard errors: the Jacobians a fit steps on are forward differences
    either way (k replays each, not 2k: the calibration's fits of 9 values on practice record p04,
    1,360 replays with central ones, 775 with forward ones, the same end), and the one at its end
    is central with ``central`` (Rosenbrock's residual from far, eagerly and lazily)."""
    methods = []
    derivative = fit_module.approx_derivative

    def recorded(*args, method, **kwargs):
        methods.append(method)
        return derivative(*args, method=method, **kwargs)
    monkeypatch.setattr(fit_module, "approx_derivative", recorded)
    bounds = (np.full(2, -np.inf), np.full(2, np.inf))
    res = secant_least_squares(rosenbrock, np.array([-3.0, -4.0]), bounds, central, max_nfev=400)
    assert np.allclose(res.x, [1.0, 1.0], atol=1e-6) and len(methods) >= 3
    end = "3-point" if central else "2-point"
    assert set(methods[:-1]) == {"2-point"} and methods[-1] == end
    np.testing.assert_array_equal(res.jac, derivative(rosenbrock, res.x, method=end, abs_step=fd_step(res.x),
                                                      f0=res.fun, bounds=bounds))
    methods.clear()
    lazy = secant_least_squares(rosenbrock, np.array([-3.0, -4.0]), bounds, central, max_nfev=400, lazy=True)
    assert set(methods) == {"2-point"}                      # the end's is left for later
    assert lazy.fresh_jac is not None or not central
    np.testing.assert_array_equal(fit_module.fresh_jacobian(lazy).jac, res.jac)
