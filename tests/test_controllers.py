"""Controllers: what each law does to the motor-side angle, and clear solver failures."""
import math

import numpy as np

from gearbench import layout as L
from gearbench.control.controllers import Controller
from gearbench.simulate import Segments, SolverOptions, failure_message, simulate

HOLD = Segments(t=np.array([0.0]), v=np.array([math.radians(10.0)]), s=np.array([0.0]))


def motor_side_deg(run):
    return np.degrees(run.outputs[:, L.O_MOTOR]) / 100.0


def test_p_settles_on_set_point_from_motor_side(plant):
    run = simulate(plant, Controller("p", kp=50), HOLD, 1.0)
    assert run.ok
    # a heavily damped load needs no torque at rest: no steady-state error on the motor side
    assert abs(motor_side_deg(run)[-1] - 10.0) < 1e-3
    # the output lags by half the clearance (it was pushed, then left on the driving flank)
    h = plant.gear.backlash_deg / 2
    assert abs(np.degrees(run.outputs[-1, L.O_LOAD]) - (10.0 - h)) < 0.01


def test_bang_bang_stops_inside_its_dead_band(plant):
    run = simulate(plant, Controller("bang_bang", band_deg=0.25), HOLD, 1.0)
    assert run.ok
    err = 10.0 - motor_side_deg(run)[-200:]
    assert np.all(np.abs(err) <= 0.125 + 0.05)  # half band, plus coasting after switch-off
    assert np.all(run.outputs[-50:, L.O_VOLTAGE] == 0.0)


def test_pid_with_filtered_derivative_tracks(plant):
    run = simulate(plant, Controller("pid", kp=50, ki=0.005, kd=0.002, derivative_filter_s=1e-3),
                   HOLD, 1.0)
    assert run.ok
    assert abs(motor_side_deg(run)[-1] - 10.0) < 1e-2


def test_set_point_shift_follows_thesis_equation_1(plant):
    """From rest the motor speed is >= 0, so the shift is added: the motor heads for
    r + s and lays the output onto the set point itself.  The engaged loop is
    overdamped here, so the speed decays to zero without changing sign: the shift
    never flips and nothing chatters (round-off alone must not flip it)."""
    h = plant.gear.backlash_deg / 2
    run = simulate(plant, Controller("p", kp=50, shift=True), HOLD, 1.0)
    assert abs(motor_side_deg(run)[-1] - (10.0 + h)) < 1e-3
    assert abs(np.degrees(run.outputs[-1, L.O_LOAD]) - 10.0) < 1e-3
    assert run.impacts == 1
    # after the first approach the output error is a fraction of the unshifted lag h
    plain = simulate(plant, Controller("p", kp=50), HOLD, 1.0)
    tail = slice(450, None)
    err = lambda r: np.abs(np.degrees(r.outputs[tail, L.O_SETPOINT] - r.outputs[tail, L.O_LOAD]))
    assert abs(err(plain).mean() - h) < 0.01
    assert err(run).mean() < h / 4


def test_voltage_never_exceeds_the_limit(plant):
    run = simulate(plant, Controller("pi", kp=5000, ki=1.0), HOLD, 0.5)
    assert np.max(np.abs(run.outputs[:, L.O_VOLTAGE])) <= plant.motor.max_voltage
    assert run.saturated_fraction > 0.0


def test_failed_run_says_which_where_and_why(plant):
    run = simulate(plant, Controller("p", kp=50), HOLD, 1.0, SolverOptions(max_steps=200),
                   label="tiny-budget")
    assert not run.ok
    msg = failure_message(run, plant.name)
    assert "tiny-budget" in msg and "t = " in msg and "likely cause" in msg
    assert 0.0 < run.stats[L.S_T_FAIL] < 1.0
