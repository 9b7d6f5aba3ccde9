"""The solver's own parts: the linear algebra of a Rosenbrock stage, the
Jacobian on the amplifier's limit, and events located on time (the amplifier's
limit, the bang-bang switch).

Units are SI (s, rad, V).
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from conftest import Controller, SolverOptions
from gearbench import layout as L
from gearbench.experiment.files import load_experiment
from gearbench.plant.pack import tolerance_scales
from gearbench.plant.effects.codegen import compiled_model
from gearbench.profiles import load_profile
from gearbench.simulate import Segments, pack, simulate
from gearbench.solver.steppers import _factor, _solve, jacobian

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
    _solve(w, jac, order, d, b, np.empty(N), np.empty(N), out, N)
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


@settings(max_examples=25, deadline=None)
@example(log_rtol=math.log10(3e-7), slope_deg_s=22.0, band_deg=0.25)  # profile 3's start: once missed
@given(log_rtol=st.floats(-9.0, -4.0), slope_deg_s=st.floats(1.0, 100.0), band_deg=st.floats(0.05, 2.0))
def test_bang_bang_switches_on_time(thesis, log_rtol, slope_deg_s, band_deg):
    """From rest under a ramp ``r = s t`` the motor does not move until the error
    leaves the band, so the first switch is at exactly ``t* = (band/2) / s``, at
    every tolerance.  (A step re-taken onto the root can end a round-off short of
    it, the guard then reading exactly 0 where the next step starts: the switch
    was seen a whole step late, 22 ms at rtol 3e-7 on profile 3.)"""
    t_star = band_deg / 2.0 / slope_deg_s
    dt = t_star * 1e-4
    seg = Segments(np.array([0.0]), np.array([0.0]), np.array([math.radians(slope_deg_s)]))
    run = simulate(thesis.plant, Controller("bang_bang", band_deg=band_deg), seg, 1.5 * t_star,
                   SolverOptions(rtol=10.0 ** log_rtol, output_dt_s=dt, max_step_s=1.0))
    assert run.ok
    on = np.flatnonzero(run.column(L.O_VOLTAGE) != 0.0)
    assert on.size, "never switched"
    t_first = run.time_s[on[0]]
    assert t_star - 1e-9 <= t_first <= t_star + dt * (1.0 + 1e-6), (t_first, t_star)


def test_a_train_at_rest_on_a_flank_does_not_switch_contact_forever(thesis):
    """Table I's profile 3, P at Kp = 50 with the shift, on the plant with the input shaft:
    at t = 5.73 s the train comes to rest exactly (speeds below 1e-12 of their tolerance
    are set to 0) on a flank at zero contact torque.  The teeth leave, and the guard of
    the contact that follows reads exactly 0 at the step's start, then dips below and
    comes back within the step (the pinion springs off the flank on its shaft and strikes
    it again): taken as reached at once, the contact was entered and left at one instant
    until the budget of 20 million steps and events ran out.  The strike is located
    where it happens, and the run's IAE is the rigid-input plant's to 1 %."""
    from gearbench.experiment.files import load_plant
    ctrl = Controller("p", kp=50.0, shift=True)
    segs = load_profile("profile3").segments()
    shaft = simulate(load_plant("experiments/plants/thesis_gear_shaft.yaml"), ctrl, segs, 10.0, thesis.solver)
    assert shaft.ok, shaft.status
    assert shaft.stats[L.S_EVENTS] < 1_000
    rigid = simulate(thesis.plant, ctrl, segs, 10.0, thesis.solver)
    assert shaft.iae_deg_s == pytest.approx(rigid.iae_deg_s, rel=0.01)


def test_jacobian_at_the_limit_is_that_of_the_side_it_heads_to(thesis):
    """After a located saturation event the state sits on the amplifier's limit
    within round-off, possibly just past it (here the command is Vmax + 8e-11 V)
    while the step heads inside.  The Jacobian taken there must be the inside
    piece's, which is constant (the plant is piecewise linear): equal to one
    taken well inside, to round-off.  (With the difference based on the clipped
    point, d(di/dt)/d(theta_m) was 1.4e-5 off, and the reused Jacobian held a
    3 s ramp to 0.5 ms steps.)"""
    plant = thesis.plant
    p = pack(plant, Controller("p", kp=50.0))
    kp = p[L.P_KP]
    n_ratio = p[L.P_N]
    vmax = p[L.P_VMAX]
    scale = tolerance_scales(plant)
    model = compiled_model()
    p = np.concatenate((p, np.zeros(model.SIZE - len(p))))
    order, na = model.feedback_order(p)
    modes = np.zeros(L.N_MODES, dtype=np.int64)
    slope = 0.26  # rad/s, the set point's ramp

    def jac_at(u):
        x = np.zeros(N)
        x[L.X_THM] = 13.0
        x[L.X_WM] = 26.0
        ref = x[L.X_THM] / n_ratio + u / kp
        f0 = model.derivative(p, x, modes, ref)
        lin = (np.empty((na, N)), np.empty((na, 2 * na)), order, np.empty(N))
        model.jacobian(0.0, x, f0, p, modes, ref, slope, scale, 0, lin, np.empty(N), np.empty(N), np.empty(N))
        return lin[0][:, :L.N_DYN].copy(), lin[3][:L.N_DYN].copy()

    j_edge, t_edge = jac_at(vmax + 8e-11)
    j_in, t_in = jac_at(0.5 * vmax)
    np.testing.assert_allclose(j_edge, j_in, rtol=1e-8, atol=1e-8 * np.abs(j_in).max())
    np.testing.assert_allclose(t_edge, t_in, rtol=1e-8, atol=1e-8 * np.abs(t_in).max())
    # and the feedback is there: the inside piece, not the saturated one
    assert j_edge[list(order[:na]).index(L.X_THM), L.X_I] == pytest.approx(-kp / n_ratio / p[L.P_L], rel=1e-8)


def test_the_integrator_knows_nothing_of_gears():
    """gearbench/solver/ imports only itself, numba, numpy and the standard library:
    the geartrain reaches it as a model (solver/model.py), never by import."""
    import ast

    allowed = {"math", "collections", "numba", "numpy", "__future__"}
    for path in sorted((Path(__file__).resolve().parents[1] / "gearbench" / "solver").glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom):
                assert node.level == 1 or node.module.split(".")[0] in allowed, (path.name, node.module)
            elif isinstance(node, ast.Import):
                assert all(a.name.split(".")[0] in allowed for a in node.names), path.name


def test_the_generated_model_meets_the_contract():
    """The geartrain's generated model module has every name the integrator asks for."""
    from gearbench.solver.model import NAMES, missing
    model = compiled_model()
    assert missing(model) == [] and len(NAMES) == 27
    assert model.args is model  # its effects' sums are its own args


def test_modes_switching_in_place_stop_the_run_with_their_cause():
    """A shaft of 0.37 N m/rad on a rotor of a sixth of the motor's inertia, on practice case p03's gear
    without clearance: at t = 7.058 s its modes switch back and forth without an accepted step (a
    diagnosis' shaft fit met such points 40 times, each running 1.6-2.5 million switches to the step
    budget).  The run stops after ``CHATTER_EVENTS`` switches in place and says so, where, and why."""
    import re
    from gearbench.errors import ReplayError
    from gearbench.experiment.files import load_plant
    from gearbench.identify.replay import Replay
    from gearbench.measure.data import read_measurement
    from gearbench.plant.effects import AddedEffect
    from gearbench.solver.integrate import CHATTER_EVENTS
    case = Path(__file__).parent.parent / "data" / "cases" / "p03"
    plant = load_plant(case / "nominal.yaml").with_effects(AddedEffect(
        "shaft_compliance", {"stiffness": 0.36645614606178184, "damping": 0.0047240869823510275,
                             "pinion_inertia": 1.336340347129278e-06}))
    with pytest.raises(ReplayError, match="modes switched back and forth without time advancing") as err:
        Replay(read_measurement(case / "data.csv")).run(plant)
    message = str(err.value)
    assert "failed at t = 7.058 s" in message
    switches, steps = (int(v) for v in re.search(r"(\d+) mode switches and (\d+) steps", message).groups())
    assert steps > 0 and CHATTER_EVENTS < switches < 2 * CHATTER_EVENTS   # not the millions of the budget
