"""Engaged linear model: matrix against the compiled right-hand side, modes against
closed forms, headline figures against a simulation."""
import math
from dataclasses import replace

import numpy as np
import pytest

from gearbench import layout as L
from gearbench.control.controllers import Controller
from gearbench.plant.components import Gear, Leadscrew, Load, Motor, Plant, Shaft
from gearbench.plant.effects import AddedEffect
from gearbench.plant.linear import (engaged_matrix, engaged_state_space, modes, plant_info,
                                    state_names)
from gearbench.simulate import Segments, pack, simulate

MOTOR = Motor(resistance=2.5, inductance=1.0e-3, torque_constant=0.02, back_emf_constant=0.02,
              inertia=1.0e-6, damping=1.0e-6, max_voltage=12.0)
SAMPLE = Plant(MOTOR, Gear(100.0, 3.0, 2.4e7, 3.4), Load(5.0e-5, 15.0), name="sample")
LIGHT = Plant(MOTOR, Gear(100.0, 3.0, 2.4e7, 0.01), Load(5.0e-5, 1.0e-4), name="light")
SHAFT = replace(LIGHT, motor=replace(MOTOR, inertia=7e-7), shaft=Shaft(50.0, 1e-5, 3e-7))
SCREW = replace(SAMPLE, leadscrew=Leadscrew(lead_mm=1.27, mass=0.5, damping=2.0))
# effects linear in the state (Effect.linear), on a plant with a shaft so theta_l involves phi
LINEAR_EFFECTS = SHAFT.with_effects(
    AddedEffect("load_spring", {"stiffness": 3.0, "rest_angle_deg": 20.0}),
    AddedEffect("viscous_friction", {"location": "motor", "coefficient": 2e-5}),
    AddedEffect("viscous_friction", {"location": "load", "coefficient": 0.4}))

COLUMNS = {"i": L.X_I, "theta_m": L.X_THM, "w_m": L.X_WM, "phi": L.X_PHI, "w_p": L.X_WP,
           "delta": L.X_DELTA, "w_l": L.X_WL}


def mesh_closed_form(plant):
    """Undamped mesh frequency of the two-inertia system, Hz."""
    jm = plant.motor.inertia + (plant.shaft.pinion_inertia if plant.shaft else 0.0)
    n, k = plant.gear.ratio, plant.gear.mesh_stiffness
    return math.sqrt(k * (1.0 / plant.output_inertia + 1.0 / (jm * n ** 2))) / (2 * math.pi)


@pytest.mark.parametrize("plant", [SAMPLE, SHAFT, SCREW, LINEAR_EFFECTS],
                         ids=["rigid", "shaft", "leadscrew", "linear-effects"])
def test_matrix_matches_compiled_rhs(plant):
    """Engaged on the positive flank, the compiled rhs is affine: its differences are A."""
    from gearbench.plant.effects.codegen import compiled_model
    rhs = compiled_model().derivative
    p = pack(plant, Controller("open"))
    modes_ = np.zeros(L.N_MODES, dtype=np.int64)
    modes_[L.M_CONTACT] = 1
    ss = engaged_state_space(plant)
    x0 = np.zeros(L.N_STATE)
    x0[L.X_DELTA] = plant.gear.half_clearance + 1e-6
    f0 = rhs(p, x0, modes_, 0.0)
    rows = [COLUMNS[s] for s in ss.states]
    for j, name in enumerate(ss.states):
        x = x0.copy()
        x[COLUMNS[name]] += 1.0
        f = rhs(p, x, modes_, 0.0)
        np.testing.assert_allclose((f - f0)[rows], ss.a[:, j], rtol=1e-9,
                                   atol=1e-9 * np.abs(ss.a).max(), err_msg=name)
    f = rhs(p, x0, modes_, 1.0)  # one volt of input
    np.testing.assert_allclose((f - f0)[rows], ss.b, rtol=1e-9)


def test_state_names_and_torque_input():
    assert state_names(SAMPLE) == ("i", "theta_m", "w_m", "delta", "w_l")
    assert state_names(SHAFT) == ("i", "theta_m", "w_m", "phi", "w_p", "delta", "w_l")
    ss = engaged_state_space(SAMPLE, electrics=False)
    assert ss.states == ("theta_m", "w_m", "delta", "w_l")
    assert ss.b[1] == pytest.approx(1.0 / MOTOR.inertia)
    assert engaged_matrix(SHAFT).shape == (7, 7)
    assert modes(SAMPLE, electrics=False)[-1][0] == pytest.approx(modes(SAMPLE)[-1][0], rel=1e-3)


def test_mesh_frequency_matches_closed_form():
    info = plant_info(LIGHT)
    assert info["mesh_frequency_hz"] == pytest.approx(mesh_closed_form(LIGHT), rel=0.01)
    assert info["mesh_frequency_hz"] == pytest.approx(110_541, rel=0.01)
    assert 0.0 < info["mesh_damping_ratio"] < 0.01
    assert modes(LIGHT)[-1][0] == info["mesh_frequency_hz"]  # the highest mode
    assert info["shaft_frequency_hz"] is None


def test_shaft_mode_is_found_by_participation():
    info = plant_info(SHAFT)
    n = SHAFT.gear.ratio
    jp = SHAFT.shaft.pinion_inertia + SHAFT.output_inertia / n ** 2  # mesh rigid at this scale
    closed = math.sqrt(50.0 * (1.0 / SHAFT.motor.inertia + 1.0 / jp)) / (2 * math.pi)
    assert info["shaft_frequency_hz"] == pytest.approx(closed, rel=0.02)
    assert info["mesh_frequency_hz"] == pytest.approx(mesh_closed_form(SHAFT), rel=0.05)
    states = {m["dominant_state"] for m in info["modes"]}
    assert {"phi", "delta"} <= states


def test_headline_figures():
    info = plant_info(SAMPLE)
    b = 1e-6 + 15.0 / 100 ** 2
    w0 = 0.02 * 12.0 / (2.5 * b + 0.02 * 0.02)
    assert info["ratio"] == 100.0 and info["clearance_deg"] == 3.0
    assert info["electrical_time_constant_s"] == pytest.approx(4e-4)
    assert info["mechanical_time_constant_s"] == pytest.approx(2.5 * (1e-6 + 5e-9) / 4e-4)
    assert info["stall_torque_Nm"] == pytest.approx(0.096)
    assert info["stall_torque_output_Nm"] == pytest.approx(9.6)
    assert info["no_load_speed_rad_s"] == pytest.approx(w0)
    assert info["no_load_speed_rpm"] == pytest.approx(w0 * 60 / (2 * math.pi))
    assert info["output_top_speed_deg_s"] == pytest.approx(math.degrees(w0 / 100))
    assert "top_speed_mm_s" not in info and "top_speed_in_s" not in info


def test_leadscrew_top_speed():
    info = plant_info(SCREW)
    r = 1.27e-3 / (2 * math.pi)
    b = 1e-6 + (15.0 + 2.0 * r ** 2) / 100 ** 2
    w_out = 0.02 * 12.0 / (2.5 * b + 4e-4) / 100
    assert info["top_speed_mm_s"] == pytest.approx(w_out * 1.27 / (2 * math.pi))
    assert info["top_speed_in_s"] == pytest.approx(info["top_speed_mm_s"] / 25.4)


def _friction_plant():
    """A leadscrew plant with every steady-motion effect; lead 2 pi mm makes r = 1e-3 m/rad."""
    from gearbench.plant.effects import AddedEffect as E
    base = Plant(MOTOR, Gear(10.0, 3.0, 2.4e7, 3.4), Load(5.0e-5, 1.0e-3), name="friction",
                 leadscrew=Leadscrew(lead_mm=2 * math.pi, mass=0.5, damping=100.0))
    return base.with_effects(
        E("coulomb_friction", {"location": "motor", "torque": 0.004}),
        E("coulomb_friction", {"location": "carriage", "force": 20.0, "force_negative": 5.0}),
        E("stribeck_friction", {"location": "load", "static_torque": 0.05, "coulomb_torque": 0.03,
                                "stribeck_speed": 0.5}),
        E("viscous_friction", {"location": "motor", "coefficient": 1.0e-6}),
        E("viscous_friction", {"location": "load", "coefficient": 9.0e-4}),
        E("viscous_friction", {"location": "carriage", "coefficient": 100.0}),
        E("bias_torque", {"location": "carriage", "force": -10.0}))


FRICTION = _friction_plant()


def test_top_speed_with_friction_effects_by_hand():
    """kt (V - ke w) / R = b w + T0 at the motor, worked by hand (r = 1e-3 m/rad, N = 10):
    b  = bm 1e-6 + c_m 1e-6 + (bl 1e-3 + slide 100 r^2 + c_l 9e-4 + c_c 100 r^2) / 10^2
       = 2e-6 + 2.1e-3 / 100 = 2.3e-5 N m s/rad;
    T0 = Tc_m 0.004 + (F_c 20 r + Stribeck's Tc 0.03 + bias -(-10 r)) / 10 = 0.010 N m
    (the forward Coulomb level; the backward 5 N does not enter);
    w  = (0.02 * 12 - 2.5 * 0.010) / (2.5 * 2.3e-5 + 0.02 * 0.02) = 0.215 / 4.575e-4
       = 469.945 rad/s; carriage 469.945 / 10 * 1e-3 m/s = 46.9945 mm/s."""
    info = plant_info(FRICTION)
    assert info["drag_coefficient_Nm_s_rad"] == pytest.approx(2.3e-5)
    assert info["drag_torque_Nm"] == pytest.approx(0.010)
    assert info["no_load_speed_rad_s"] == pytest.approx(469.945355, rel=1e-8)
    assert info["top_speed_mm_s"] == pytest.approx(46.9945355, rel=1e-8)
    assert info["top_speed_in_s"] == pytest.approx(46.9945355 / 25.4, rel=1e-8)
    # friction the motor cannot overcome holds it: T0 = 0.010 + 1.0 / 10 = 0.11 N m > kt V / R = 0.096
    from gearbench.plant.effects import AddedEffect
    stuck = FRICTION.with_effects(AddedEffect("coulomb_friction", {"location": "load", "torque": 1.0}))
    assert plant_info(stuck)["no_load_speed_rad_s"] == 0.0


@pytest.mark.parametrize("plant", [SAMPLE, SHAFT, FRICTION], ids=["rigid", "shaft", "friction"])
def test_no_load_speed_matches_simulation(plant):
    vmax = plant.motor.max_voltage
    run = simulate(plant, Controller("open"),
                   Segments(t=np.array([0.0]), v=np.array([vmax]), s=np.array([0.0])), 2.0)
    assert run.ok, run.status
    assert run.outputs[-1, L.O_WM] == pytest.approx(plant_info(plant)["no_load_speed_rad_s"], rel=1e-3)
