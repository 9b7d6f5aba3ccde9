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


# ---------------------------------------------------------------------------
# Identification on records whose sensors are not the fitted model's
# ---------------------------------------------------------------------------

OFFSET_A = 0.010        # A: the current sensor's zero, 2x its noise
RHO = 0.8               # lag-1 correlation of the AR(1) noise on the current and the load angle
ENCODER = AddedEffect("encoder_quantization", {"signal": "motor_angle_deg", "counts_per_rev": 4096})


def real_sensors(rig, seed, offset_A, noise=None):
    """4 s of voltage steps on the bench rig as real sensors give it: the motor angle on a
    4096-count encoder, AR(1) noise (rho 0.8) of the default levels on the load angle (0.01 deg) and
    the current (5 mA), and ``offset_A`` on the current.  The fitted model has none of these: no
    encoder, white noise read from the record."""
    t, u = excitation("steps", rig, duration_s=4.0, seed=seed)
    hidden = [ENCODER] + ([offset("current_A", offset_A)] if offset_A else [])
    return synthesize(rig, hidden, t, u, seed=seed, noise_ar1=RHO, noise=noise)


def solver_share(rig, seed) -> float:
    """The bias allowance, A: the largest current residual the right model leaves on the same record
    without noise (the replay's solver against the synthesis's, both at rtol 1e-6; ~2.5e-6 A, 0.03 %
    of the offset): what no standard error covers."""
    clean = real_sensors(rig, seed, 0.0, noise={"load_angle_deg": 0.0, "current_A": 0.0})
    replay = Replay(clean)
    return float(np.max(np.abs(replay.residuals(replay.run(rig.with_effects(ENCODER)))["current_A"])))


@pytest.mark.parametrize("seed", [1, 3])
def test_fit_recovers_a_current_offset_under_coloured_and_quantized_sensors(rig, seed, tmp_path):
    """``gearbench fit --effect 'sensor_offset signal=current_A'``: within 3 standard errors (the
    prewhitened sandwich's, which hold for the AR(1) noise: sigma sqrt((1+rho)/(1-rho)/n) = 0.24 mA
    here) plus the solver's share."""
    import json
    from click.testing import CliRunner
    from gearbench.cli import main
    from gearbench.measure.data import write_measurement
    data = tmp_path / "offset.csv"
    write_measurement(real_sensors(rig, seed, OFFSET_A), data)
    out = CliRunner().invoke(main, ["fit", str(RIG), str(data), "--effect", "sensor_offset signal=current_A",
                                    "-o", str(tmp_path / "fitted.yaml"), "--json"])
    assert out.exit_code == 0, out.output
    j = json.loads(out.stdout[out.stdout.index("{"):])
    (key, value), = j["values"].items()
    se = j["stderr"][key]
    assert j["effect"] == "sensor_offset (current_A)" and key.endswith("offset")
    assert 0 < se < 0.1 * OFFSET_A
    assert abs(value - OFFSET_A) <= 3 * se + solver_share(rig, seed), (value, se)


@pytest.mark.parametrize("seed", [2, 4])
def test_the_null_record_fits_no_offset(rig, seed):
    import gearbench as gb
    f = gb.fit(rig, real_sensors(rig, seed, 0.0), "sensor_offset", options={"signal": "current_A"})
    (key, value), = f.values.items()
    se = f.stderr[key]
    assert abs(value) <= 3 * se + solver_share(rig, seed), (value, se)


@pytest.mark.parametrize("signal", ["motor_angle_deg", "load_angle_deg"])
def test_encoder_quantization_is_a_candidate_on_any_angle_and_reads_its_counts(rig, drive, signal):
    """Found: diagnose tries ``encoder_quantization`` on each angle the record has, and reads the
    counts of the one on a grid straight from it (4096, the truth)."""
    t, u = drive
    data = synthesize(rig, [AddedEffect("encoder_quantization", {"signal": signal, "counts_per_rev": 4096})], t, u)
    places = [c.options["signal"] for c in candidates(rig, Replay(data)) if c.name == "encoder_quantization"]
    assert sorted(places) == ["load_angle_deg", "motor_angle_deg"]
    eq = REGISTRY["encoder_quantization"]
    assert eq.estimate({"signal": signal}, data.signals, rig) == {"counts_per_rev": 4096}
    other = "load_angle_deg" if signal == "motor_angle_deg" else "motor_angle_deg"
    assert eq.estimate({"signal": other}, data.signals, rig) is None    # noisy: on no grid


def test_diagnose_finds_the_current_offset_and_none_on_the_null(rig):
    """Among the sensor effects and the bias it is confounded with: the offset record's first rung is
    the offset on the current, within 3 standard errors of the truth; the null record (the same
    coloured, quantized sensors, no offset) takes no offset on any signal."""
    import gearbench as gb
    only = ("sensor_offset", "bias_torque", "encoder_quantization")
    d = gb.diagnose(rig, real_sensors(rig, 1, OFFSET_A), only=only, workers=1, max_steps=2).diagnosis
    first = d.ladder[0]
    assert (first.effect, first.options) == ("sensor_offset", {"signal": "current_A"})
    assert abs(first.params["offset"] - OFFSET_A) <= 3 * first.stderr["offset"] + solver_share(rig, 1)
    null = gb.diagnose(rig, real_sensors(rig, 2, 0.0), only=only, workers=1, max_steps=2).diagnosis
    assert "sensor_offset" not in [s.effect for s in null.ladder], [(s.effect, s.params) for s in null.ladder]
