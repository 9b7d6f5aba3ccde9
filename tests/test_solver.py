"""The solver's own parts: the linear algebra of a Rosenbrock stage, and the
amplifier's limit located as an event.

Units are SI (s, rad, V).
"""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from conftest import Controller, SolverOptions
from gearbench import layout as L
from gearbench.experiment.files import load_experiment
from gearbench.profiles import load_profile
from gearbench.simulate import simulate
from gearbench.solver.steppers import _factor, _solve

N = L.N_STATE


@settings(max_examples=60, deadline=None)
@given(na=st.integers(1, N - 2), seed=st.integers(0, 2**32 - 1), log_diag=st.floats(-3.0, 9.0))
def test_stage_solve_matches_a_dense_solve(na, seed, log_diag):
    """``_factor`` + ``_solve`` solve ``(d I - J) x = b`` where J's columns are
    zero outside the feedback states ``order[:na]`` (any order), from a Jacobian
    scale of 1 to far beyond it (d is 1/(gamma h): short and long steps)."""
    rng = np.random.default_rng(seed)
    order = rng.permutation(N)
    jac = rng.normal(size=(na, N)) * 10.0 ** rng.uniform(-2, 4, size=(na, N))
    full = np.zeros((N, N))  # full[i, j] = d f_i / d y_j
    for a in range(na):
        full[:, order[a]] = jac[a]
    d = 10.0 ** log_diag
    b = rng.normal(size=N)
    w = np.empty((na, 2 * na))
    _factor(jac, order, d, w)
    out = np.empty(N)
    _solve(w, jac, order, d, b, np.empty(N), np.empty(N), out)
    m = d * np.eye(N) - full
    want = np.linalg.solve(m, b)
    assert np.linalg.norm(m @ out - b) <= 1e-9 * np.linalg.norm(m, 1) * max(np.linalg.norm(want), 1.0)


@pytest.fixture(scope="module")
def thesis():
    return load_experiment("experiments/table1.yaml")


@pytest.mark.parametrize("ctrl", [Controller("p", kp=50.0), Controller("pi", kp=50.0, ki=0.005),
                                  Controller("p", kp=200.0, shift=True),
                                  Controller("bang_bang", band_deg=0.25)],
                         ids=lambda c: f"{c.kind}-{c.kp:g}-{'shift' if c.shift else 'plain'}")
def test_saturated_time_is_the_time_at_the_limit(thesis, ctrl):
    """The saturated time is summed over the steps at the limit, whose ends are
    located events; it must equal the share of a fine trace at +-Vmax."""
    dt = 1e-4
    run = simulate(thesis.plant, ctrl, load_profile("profile1").segments(), 10.0,
                   SolverOptions(output_dt_s=dt, max_step_s=1.0))
    vmax = thesis.plant.motor.max_voltage
    at_limit = np.abs(run.column(L.O_VOLTAGE)) >= vmax * (1.0 - 1e-9)
    crossings = int(np.count_nonzero(np.diff(at_limit.astype(int))))
    assert run.saturated_fraction > 0.01
    # each crossing can put one sample on the wrong side
    assert abs(run.saturated_fraction - at_limit.mean()) <= (crossings + 1) * dt / 10.0
