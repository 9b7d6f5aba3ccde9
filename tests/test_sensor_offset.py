"""``sensor_offset``: a constant on a measured signal, the dynamics untouched.

The physics: the simulated states of a record made with an offset are those made without it (the
same solver, the same input), the offset's column is shifted by exactly the offset and every other
column is unchanged.  The replay: a right offset is no drift to a window's reset.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gearbench.experiment.files import load_plant
from gearbench.identify.candidates import candidates, not_tried
from gearbench.identify.evidence import SIGNATURES
from gearbench.identify.replay import Replay
from gearbench.plant.effects import REGISTRY, AddedEffect
from gearbench.plant.effects.sensor_offset import SIGNALS, unit
from gearbench.synth import excitation, synthesize

RIG = Path(__file__).resolve().parents[1] / "experiments" / "plants" / "bench_rig.yaml"
CLEAN = {"motor_angle_deg": 0.0, "load_angle_deg": 0.0, "current_A": 0.0}


@pytest.fixture(scope="module")
def rig():
    return load_plant(RIG)


@pytest.fixture(scope="module")
def drive(rig):
    return excitation("steps", rig, duration_s=2.0, seed=4)


def offset(signal, value):
    return AddedEffect("sensor_offset", {"signal": signal, "offset": value})


@pytest.mark.parametrize("signal,value", [("current_A", 0.01), ("motor_angle_deg", -2.5), ("load_angle_deg", 0.3)])
def test_only_its_column_moves_and_by_exactly_the_offset(rig, drive, signal, value):
    t, u = drive
    plain = synthesize(rig, [], t, u, noise=CLEAN)
    shifted = synthesize(rig, [offset(signal, value)], t, u, noise=CLEAN)
    for name, y in plain.signals.items():
        moved = np.asarray(shifted.signals[name]) - np.asarray(y)
        if name == signal:
            # the same states: the difference is the offset to round-off, at every sample
            np.testing.assert_allclose(moved, value, rtol=0, atol=1e-12 * max(1.0, float(np.max(np.abs(y)))))
        else:
            assert np.array_equal(np.asarray(shifted.signals[name]), np.asarray(y)), name


def test_the_states_are_untouched(rig, drive):
    """Every column the truth's outputs give, with and without the offset, from one simulation each:
    the same numbers (a sensor effect is applied after the solver, never in it)."""
    t, u = drive
    cols = ("motor_angle_deg", "load_angle_deg", "current_A")
    a = synthesize(rig, [], t, u, signals=cols, noise=CLEAN)
    b = synthesize(rig, [offset("current_A", 0.5)], t, u, signals=cols, noise=CLEAN)
    for name in ("motor_angle_deg", "load_angle_deg"):
        assert np.array_equal(np.asarray(a.signals[name]), np.asarray(b.signals[name]))
    np.testing.assert_allclose(np.asarray(b.signals["current_A"]) - np.asarray(a.signals["current_A"]), 0.5,
                               rtol=0, atol=1e-12)


def test_declarations():
    e = REGISTRY["sensor_offset"]
    assert e.acts_on == "measured signal" and e.shifts and not e.rounds
    assert e.signature in SIGNATURES and SIGNATURES[e.signature][0] == "signal"
    assert {"bias_torque", "coulomb_friction", "load_spring"} <= set(e.confounders)
    q, = e.params
    assert q.name == "offset" and q.low < 0 < q.high and q.start == 0.0
    assert [unit(s) for s in SIGNALS] == ["A", "deg", "deg", "mm", "mm"]
    y = np.arange(5.0)
    assert e.measure({"signal": "current_A", "offset": 0.2}, "load_angle_deg", y, y, None) is y


def test_diagnose_tries_it_on_the_signals_the_record_has(rig, drive):
    t, u = drive
    data = synthesize(rig, [], t, u, signals=("motor_angle_deg", "current_A"))
    tried = [c.options["signal"] for c in candidates(rig, Replay(data)) if c.name == "sensor_offset"]
    assert sorted(tried) == ["current_A", "motor_angle_deg"]
    assert "sensor_offset" not in not_tried(rig, Replay(data))


def test_a_right_angle_offset_is_no_drift_to_the_window_resets(rig, drive):
    """The motor angle read 2.5 deg high: the rig with that offset replays the record exactly, window
    after window (a reset that took the offset for drift would move the model off by it)."""
    t, u = drive
    truth = offset("motor_angle_deg", 2.5)
    data = synthesize(rig, [truth], t, u, noise=CLEAN)
    replay = Replay(data, window_s=0.5)
    run = replay.run(rig.with_effects(truth))
    assert len(replay.windows(rig)) >= 3
    r = replay.residuals(run)["motor_angle_deg"]
    assert float(np.max(np.abs(r))) < 1e-3 * 2.5
    # without it, the first window carries the offset and the resets take it from there on
    r0 = replay.residuals(replay.run(rig))["motor_angle_deg"]
    assert float(np.mean(r0[: replay.windows(rig)[0][1] - 5])) == pytest.approx(2.5, rel=0.05)
