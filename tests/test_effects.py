"""The effects as physics: each one's equation, checked on a plant where it is
the only thing that matters, and friction's regularisation against Modelica's
event-driven stick-slip."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from conftest import DATA, REPO
from gearbench import layout as L
from gearbench.experiment.files import load_plant
from gearbench.experiment.writer import plant_to_yaml
from gearbench.plant.components import Gear, Load, Motor, Plant
from gearbench.plant.effects import REGISTRY, AddedEffect
from gearbench.plant.pack import pack_plant, rest_state, tolerance_scales
from gearbench.simulate import Segments, SolverOptions, simulate_packed

ANCHOR = DATA / "modelica" / "Translational_Examples_Friction.csv"
PLANTS = REPO / "experiments" / "plants"


def body(*effects, inertia=1.0) -> Plant:
    """One rigid body (inertia kg m^2) driven by a torque, nothing else acting on it."""
    return Plant(Motor(None, None, None, None, inertia, 0.0, math.inf), Gear(1.0, 0.0, 0.0, 0.0, rigid=True),
                 Load(0.0, 0.0), name="body", drive="torque", effects=tuple(effects))


def run(plant, t, v, s=None, t_end=None, rel=1e-4, rtol=1e-8, dt=1e-3):
    """Open-loop run with input segments (t, v, slopes s); returns (time, outputs)."""
    p = pack_plant(plant)
    p[L.P_CTRL] = L.CTRL_OPEN
    s = np.zeros(len(t)) if s is None else s
    opts = SolverOptions(rtol=rtol, max_step_s=1e-3, output_dt_s=dt, friction_speed_rel=rel)
    r = simulate_packed(p, tolerance_scales(plant), Segments(np.asarray(t, float), np.asarray(v, float),
                                                               np.asarray(s, float)),
                        t_end or float(t[-1]) + 1.0, rest_state(plant), opts)
    assert r.ok, r.status
    return r.time_s, r.outputs


def coulomb(torque, loc="motor"):
    return AddedEffect("coulomb_friction", {"location": loc, "torque": torque})


def test_registry_has_the_spec_effects():
    assert set(REGISTRY) >= {"backlash", "coulomb_friction", "stribeck_friction", "viscous_friction",
                             "shaft_compliance", "load_spring", "bias_torque", "amplifier_deadzone",
                             "sensor_delay", "encoder_quantization"}
    for e in REGISTRY.values():
        assert e.params and e.acts_on and e.describe()
        assert (type(e).__module__.rsplit(".", 1)[1] == e.name), "one module per effect, named for it"


def test_coulomb_slides_with_constant_deceleration_and_sticks_below_its_level():
    # a push of 3 N m against 2 N m of friction accelerates at exactly 1 rad/s^2
    t, out = run(body(coulomb(2.0)), [0.0], [3.0], t_end=1.0)
    assert out[-1, L.O_WM] == pytest.approx(1.0, rel=1e-3)
    assert out[-1, L.O_MOTOR] == pytest.approx(0.5, rel=2e-3)
    # a push of 1.5 N m does not move it at all (stick-slip, the default) ...
    t, out = run(body(coulomb(2.0)), [0.0], [1.5], t_end=1.0)
    assert np.all(out[:, L.O_MOTOR] == 0.0)
    # ... and regularized, it creeps at the regularisation speed only
    creep = AddedEffect("coulomb_friction", {"location": "motor", "torque": 2.0, "model": "regularized"})
    t, out = run(body(creep), [0.0], [1.5], t_end=1.0, rel=1e-6)
    assert 0.0 < abs(out[-1, L.O_MOTOR]) < 2e-6
    # asymmetric: backward friction 3 N m
    eff = AddedEffect("coulomb_friction", {"location": "motor", "torque": 2.0, "torque_negative": 3.0})
    t, out = run(body(eff), [0.0], [-4.0], t_end=1.0)
    assert out[-1, L.O_WM] == pytest.approx(-1.0, rel=1e-3)


def test_viscous_friction_terminal_speed_and_time_constant():
    eff = AddedEffect("viscous_friction", {"location": "load", "coefficient": 4.0})
    t, out = run(body(eff, inertia=2.0), [0.0], [8.0], t_end=3.0)
    w = out[:, L.O_WM]
    assert w[-1] == pytest.approx(2.0 * (1 - math.exp(-3.0 * 4.0 / 2.0)), rel=1e-5)
    i = np.searchsorted(t, 0.5)
    assert w[i] == pytest.approx(2.0 * (1 - math.exp(-0.5 * 2.0)), rel=1e-5)


def test_load_spring_oscillates_at_its_natural_frequency():
    eff = AddedEffect("load_spring", {"stiffness": 16.0, "rest_angle_deg": math.degrees(0.1)})
    t, out = run(body(eff, inertia=1.0), [0.0], [0.0], t_end=2.0)
    # starts at 0, rest at 0.1 rad: x(t) = 0.1 (1 - cos 4t)
    assert np.max(np.abs(out[:, L.O_LOAD] - 0.1 * (1 - np.cos(4.0 * t)))) < 1e-6


def test_bias_torque_is_a_constant_push_on_the_load():
    eff = AddedEffect("bias_torque", {"torque": -0.5})
    t, out = run(body(eff, inertia=0.25), [0.0], [0.0], t_end=1.0)
    assert out[-1, L.O_LOAD] == pytest.approx(0.5 * (-2.0) * 1.0, rel=1e-6)


def test_carriage_force_is_a_screw_torque():
    plant = load_plant(PLANTS / "emps_bare.yaml")
    r = plant.leadscrew.radius
    eff = AddedEffect("bias_torque", {"location": "carriage", "force": 10.0})
    t, out = run(plant.with_effects(eff), [0.0], [0.0], t_end=1.0)
    # x = F t^2 / (2 m) with m the carriage (the rotor is 1 g at the carriage)
    x_mm = out[-1, L.O_LOAD] * r * 1e3
    m = plant.leadscrew.mass + plant.motor.inertia / r ** 2
    assert x_mm == pytest.approx(1e3 * 10.0 / (2 * m), rel=1e-6)


def test_amplifier_deadzone_steady_speed():
    motor = Motor(2.0, 1e-3, 0.05, 0.05, 1e-5, 0.0, 12.0)
    base = Plant(motor, Gear(1.0, 0.0, 0.0, 0.0, rigid=True), Load(0.0, 1e-3), name="m")
    dz = base.with_effects(AddedEffect("amplifier_deadzone", {"threshold": 1.5}))
    for u in (1.0, 6.0):
        t, out = run(dz, [0.0], [u], t_end=2.0)
        seen = max(u - 1.5, 0.0)
        w_ss = 0.05 * seen / (2.0 * 1e-3 + 0.05 * 0.05)  # kt u / (R b + kt ke)
        assert out[-1, L.O_WM] == pytest.approx(w_ss, rel=1e-6, abs=1e-9)


def test_sensor_effects_distort_only_their_signal():
    t = np.linspace(0, 1, 1001)
    y = np.sin(2 * np.pi * t)
    delay = REGISTRY["sensor_delay"]
    v = {"signal": "load_angle_deg", "delay": 0.01}
    assert np.allclose(delay.measure(v, "load_angle_deg", y, t, None)[20:], np.sin(2 * np.pi * (t[20:] - 0.01)),
                       atol=1e-4)
    assert delay.measure(v, "motor_angle_deg", y, t, None) is y
    q = REGISTRY["encoder_quantization"]
    out = q.measure({"signal": "motor_angle_deg", "counts_per_rev": 360}, "motor_angle_deg", 100 * y, t, None)
    assert np.allclose(out, np.round(100 * y)) and np.all(out == np.round(out))


def test_friction_regularisation_against_modelica_stick_slip():
    """Modelica.Mechanics.Translational.Examples.Friction: stop1, a mass with
    friction (m = 1, F = 25 sin(pi t / 2), viscous 1, Coulomb 5, Stribeck 10 with
    fexp 2) whose stops at +-24.5 m it never reaches (it peaks at 13.5 m),
    solved by Dymola with event-driven stick-slip.  (The example's ``mass`` has
    the same friction from a 50-point table and differs from stop1 by 0.038 m.)  Ours: the same as a
    torque-driven body (1 rad = 1 m), Stribeck T_s = 15, T_c = 5, w_s = 0.5 m/s.
    The error of the tanh regularisation (``model: regularized``) falls as its
    speed shrinks; the event-driven default is in ``test_stick_slip.py``."""
    ref = pd.read_csv(ANCHOR).drop_duplicates("time", keep="last")
    plant = body(AddedEffect("stribeck_friction", {"location": "motor", "static_torque": 15.0,
                                                   "coulomb_torque": 5.0, "stribeck_speed": 0.5,
                                                   "model": "regularized"}),
                 AddedEffect("viscous_friction", {"location": "motor", "coefficient": 1.0}))
    tk = np.linspace(0.0, 5.0, 5001)
    f = 25.0 * np.sin(2 * np.pi * 0.25 * tk)
    errs = {}
    for rel in (1e-3, 1e-4, 1e-5):
        t, out = run(plant, tk[:-1], f[:-1], np.diff(f) / np.diff(tk), t_end=5.0, rel=rel, rtol=1e-7)
        s = np.interp(ref["time"], t, out[:, L.O_MOTOR])
        errs[rel] = float(np.max(np.abs(s - ref["stop1.s"])))
    # measured (2026-11-21): 24 mm, 2.9 mm, 0.39 mm of a 13.5 m stroke: first order in the speed
    assert errs[1e-5] < errs[1e-4] / 5 < errs[1e-3] / 25, errs
    assert errs[1e-5] < 1e-3, errs


def test_plant_with_effects_round_trips_through_its_file(tmp_path):
    plant = load_plant(PLANTS / "bench_rig.yaml").with_effects(
        coulomb(0.01), AddedEffect("sensor_delay", {"signal": "load_angle_deg", "delay": 0.002}),
        AddedEffect("shaft_compliance", {"stiffness": 30.0, "damping": 1e-4, "pinion_inertia": 5e-6}))
    text = plant_to_yaml(plant, {"effects[0].torque": 0.001})
    assert "standard error 0.001" in text
    path = tmp_path / "p.yaml"
    path.write_text(text)
    again = load_plant(path)
    assert again == plant
    assert np.array_equal(pack_plant(again), pack_plant(plant))


CAUSAL_VALUES = {"sensor_delay": {"signal": "motor_angle_deg", "delay": 0.0123},
                 "encoder_quantization": {"signal": "motor_angle_deg", "counts_per_rev": 1000},
                 "sensor_offset": {"signal": "motor_angle_deg", "offset": 0.3}}


def test_a_sensor_effect_declared_causal_measures_a_records_start_as_the_whole_records():
    """Every library effect that overrides ``measure`` declares ``causal``, and is: its measure of a
    record's first samples is the first samples of its measure of the whole (what lets a scan stop a
    replay part-way, ``Replay.run(stop=...)``)."""
    from gearbench.plant.effects.base import Effect
    library = {name: e for name, e in REGISTRY.items() if e.source is None}  # not a test's own effects
    measuring = {name for name, e in library.items() if type(e).measure is not Effect.measure}
    assert measuring == set(CAUSAL_VALUES)
    plant = load_plant(REPO / "experiments" / "plants" / "bench_rig.yaml")
    t = np.arange(2000) * 1e-3
    y = np.cumsum(np.random.default_rng(4).normal(size=t.size))
    for name, values in CAUSAL_VALUES.items():
        e = REGISTRY[name]
        assert e.causal and e.measures_causally()
        whole = e.measure(values, "motor_angle_deg", y, t, plant)
        assert not np.array_equal(whole, y), name
        for n in (1, 17, 1000, 1999):
            assert np.array_equal(e.measure(values, "motor_angle_deg", y[:n], t[:n], plant), whole[:n]), (name, n)
    assert all(e.measures_causally() for name, e in library.items() if name not in measuring)
