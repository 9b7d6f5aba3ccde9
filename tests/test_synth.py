"""Synthetic measurements (``gearbench.synth``, ``gearbench synth``).

The bench rig (experiments/plants/bench_rig.yaml) with hidden effects plays the
real rig; its records must read back as measurements, equal a plain open-loop
simulation when nothing is hidden, and show each hidden effect as its physics says.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

from gearbench.cli import main
from gearbench.control.controllers import Controller
from gearbench.experiment.files import load_plant
from gearbench import synth
from gearbench.identify.replay import Replay
from gearbench.measure.data import read_measurement, write_measurement
from gearbench.plant.effects.base import AddedEffect
from gearbench.simulate import Segments, SolverOptions, simulate

ROOT = Path(__file__).resolve().parent.parent
RIG = ROOT / "experiments" / "plants" / "bench_rig.yaml"


@pytest.fixture(scope="module")
def rig():
    return load_plant(RIG)


@pytest.fixture(scope="module")
def record(rig):
    """3 s of steps: enough for both directions, small and large levels."""
    return synth.excitation("steps", rig, duration_s=3.0, seed=0)


def clean(plant):
    return {s: 0.0 for s in synth.default_signals(plant)}


def runs_of(mask: np.ndarray) -> list[tuple[int, int]]:
    """[start, end) index ranges where ``mask`` is True."""
    d = np.diff(np.concatenate([[0], mask.astype(int), [0]]))
    return list(zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1)))


# ------------------------------------------------------------------ excitation

def test_steps_have_both_directions_rests_and_small_and_large_levels(rig):
    t, u = synth.excitation("steps", rig, seed=0)
    vmax = rig.motor.max_voltage
    assert t[0] == 0.0 and t[-1] == pytest.approx(10.0) and np.allclose(np.diff(t), 1e-3)
    assert np.all(np.abs(u) <= vmax)
    level = u / vmax
    for sign in (1.0, -1.0):
        on = level * sign
        assert np.any((on > 0.05) & (on <= 0.2)), "a small level (<= 20 % of the limit) each way"
        assert np.any(on >= 0.6), "a large level (>= 60 %) each way"
    dt = t[1] - t[0]
    rests = runs_of(u == 0.0)
    holds = runs_of(u != 0.0)
    assert rests[0][0] == 0, "the record opens at rest"
    assert len(holds) >= 8
    for a, b in rests[1:-1]:   # inner rests: the train comes to rest
        assert 0.3 - 1e-9 <= (b - a) * dt <= 0.5 + dt
    for a, b in holds[:-1]:     # each step held long enough to reach steady speed
        assert 0.3 - 1e-9 <= (b - a) * dt <= 0.6 + dt
        assert np.all(u[a:b] == u[a]), "a step is one level"
    signs = [np.sign(u[a]) for a, _ in holds]
    assert all(s1 != s2 for s1, s2 in zip(signs, signs[1:])), "successive steps reverse"


def test_short_steps_record_still_holds_small_and_large_levels(rig):
    for seed in range(5):
        t, u = synth.excitation("steps", rig, duration_s=1.6, seed=seed)
        mags = {round(abs(x) / rig.motor.max_voltage, 3) for x in u if x != 0.0}
        assert min(mags) <= 0.2 and max(mags) >= 0.6


def test_steps_depend_on_the_seed_only(rig):
    a = synth.excitation("steps", rig, duration_s=3.0, seed=4)
    b = synth.excitation("steps", rig, duration_s=3.0, seed=4)
    c = synth.excitation("steps", rig, duration_s=3.0, seed=5)
    assert np.array_equal(a[1], b[1]) and not np.array_equal(a[1], c[1])


def holds_of(t, u, min_s=0.1):
    """``(level, start s, length s)`` of each run of one constant nonzero input lasting >= ``min_s``."""
    dt = t[1] - t[0]
    edges = np.flatnonzero(np.diff(u) != 0.0) + 1
    runs = zip(np.concatenate([[0], edges]), np.concatenate([edges, [len(u)]]))
    return [(u[a], t[a], (b - a) * dt) for a, b in runs if u[a] != 0.0 and (b - a) * dt >= min_s - 1e-9]


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_mixed_excitation_has_the_practice_cases_pieces(rig, seed):
    t, u = synth.excitation("mixed", rig, seed=seed)
    vmax = rig.motor.max_voltage
    assert t[-1] == pytest.approx(16.0) and np.allclose(np.diff(t), 1e-3)
    assert np.all(u[t < 0.4] == 0.0) and u[-1] == 0.0, "opens and ends at rest"
    assert np.all(np.abs(u) <= vmax)
    holds = holds_of(t, u)
    levels = [lvl / vmax for lvl, _, _ in holds]
    # steps both ways with pauses: a hold of 20-70 % each way, followed by a rest
    for sign in (1.0, -1.0):
        assert any(0.2 <= sign * x <= 0.7 for x in levels)
        assert any(0.08 <= sign * x <= 0.13 for x in levels), "a low-level step each way"
    adjacent = [(h1, h2) for h1, h2 in zip(holds, holds[1:]) if abs(h1[1] + h1[2] - h2[1]) < 1e-6]
    direct = [(h1, h2) for h1, h2 in adjacent if h1[0] * h2[0] < 0.0]
    assert len(direct) >= 4, "a direct reversal from a step, then the fast reversals"
    fast = [h for h in holds if h[2] <= 0.4]
    assert len(fast) == 3 and all(abs(lvl) >= 0.59 * vmax for lvl, _, _ in fast)
    assert fast[0][0] * fast[1][0] < 0.0 < fast[0][0] * fast[2][0], "three fast steps, reversing"
    # after them the input varies at every sample: one sine period, then the triangle
    tail = t > fast[-1][1] + fast[-1][2]
    moving = tail & (np.abs(np.gradient(u)) > 0.0)
    assert np.ptp(t[moving]) > 6.0
    assert 0.25 * vmax <= u[tail].max() and u[tail].min() <= -0.25 * vmax, "a sine both ways"
    last = np.flatnonzero(u != 0.0)
    ramp = u[last[-1] - 400:last[-1]]
    assert np.all(ramp > 0.0) and np.allclose(np.diff(ramp), np.diff(ramp)[0], rtol=1e-6), \
        "the record ends with a linear ramp down"


def test_mixed_excitation_jitters_levels_and_fills_the_duration(rig):
    a = synth.excitation("mixed", rig, seed=4)
    b = synth.excitation("mixed", rig, seed=4)
    c = synth.excitation("mixed", rig, seed=5)
    assert np.array_equal(a[1], b[1]) and not np.array_equal(a[1], c[1])
    vmax = rig.motor.max_voltage
    nominal = {lvl for shape, lvl, _ in synth.MIXED if shape == "hold" and lvl != 0.0}
    for lvl, _, _ in holds_of(*a):
        assert any(abs(lvl / vmax / x - 1.0) <= synth.MIXED_JITTER + 1e-9 for x in nominal), lvl / vmax
    t, u = synth.excitation("mixed", rig, duration_s=15.0, seed=4)
    assert t[-1] == pytest.approx(15.0) and u[-1] == 0.0 and len(holds_of(t, u)) == len(holds_of(*a))


@pytest.mark.parametrize("kind", ["prbs", "chirp", "multisine"])
@pytest.mark.parametrize("dt", [1e-2, 1e-3, 1e-4])
def test_excitations_without_rests_move_at_every_rate(rig, kind, dt):
    """prbs, chirp and multisine open with the same rest as steps, then never rest: the input is
    zero only there (and, faded, at a chirp's or multisine's ends), within its level, and its
    power lies in the band (0.2 Hz up to 10 Hz or a tenth of the sample rate, at 100 Hz-10 kHz):
    what a record that is not steps and rests looks like."""
    t, u = synth.excitation(kind, rig, duration_s=8.0, sample_time_s=dt, seed=3)
    scale = synth.input_scale(rig)
    assert t[-1] == pytest.approx(8.0) and np.allclose(np.diff(t), dt)
    assert np.all(u[t < synth.FIRST_REST_S - 1e-9] == 0.0)
    inside = (t > synth.FIRST_REST_S + synth.FADE_S) & (t < t[-1] - synth.FADE_S)
    if kind == "prbs":
        assert np.allclose(np.abs(u[t >= synth.FIRST_REST_S - 1e-9]), synth.PRBS_LEVEL * scale)
        flips = np.flatnonzero(np.diff(u[inside]) != 0.0)
        assert np.all(np.diff(flips) * dt >= synth.PRBS_CLOCK_S - dt - 1e-9)   # only on the clock
        assert 0.3 < flips.size * synth.PRBS_CLOCK_S / np.ptp(t[inside]) < 0.7  # flips half the ticks
        return
    assert np.max(np.abs(u)) == pytest.approx(synth.SWEEP_LEVEL * scale, rel=0.02)
    assert np.mean(np.abs(u[inside]) < 1e-3 * scale) < 0.02, "no rest"
    f0, f1 = synth.sweep_band(dt)
    assert f1 == pytest.approx(min(10.0, 0.1 / dt))
    spectrum = np.abs(np.fft.rfft(u)) ** 2
    freq = np.fft.rfftfreq(u.size, dt)
    assert spectrum[(freq >= 0.5 * f0) & (freq <= 1.5 * f1)].sum() > 0.95 * spectrum.sum()


def test_cli_writes_a_sweep_with_its_band(tmp_path):
    out = tmp_path / "c.csv"
    res = CliRunner().invoke(main, ["synth", str(RIG), "--excitation", "chirp", "--duration", "3",
                                    "--sample-time", "0.01", "-o", str(out)])
    assert res.exit_code == 0, res.output
    assert read_measurement(out).duration_s == pytest.approx(3.0)
    exc = yaml.safe_load((tmp_path / "c.truth.yaml").read_text())["excitation"]
    assert exc["kind"] == "chirp" and exc["band_Hz"] == [0.2, 10.0] and exc["sample_time_s"] == 0.01


def test_profile_excitation_is_the_voltage_of_a_p_controller(rig):
    t, u = synth.excitation("profile:1", rig, duration_s=4.0)
    assert len(t) == 4001 and np.all(np.abs(u) <= rig.motor.max_voltage)
    assert np.all(u[t < 1.99] == 0.0)          # profile 1 dwells at 0 for 2 s: no error, no voltage
    assert np.max(np.abs(u[t > 2.0])) > 0.1    # then the step and the ramp ask for voltage


def test_file_excitation_is_read_and_checked(rig, tmp_path):
    f = tmp_path / "u.csv"
    f.write_text("time_s,voltage_V\n0,0\n0.5,3\n1.0,-3\n1.5,0\n")
    t, u = synth.excitation(str(f), rig)
    assert np.array_equal(t, [0, 0.5, 1.0, 1.5]) and np.array_equal(u, [0, 3, -3, 0])
    f.write_text("time_s,drive_torque_Nm\n0,0\n0.5,3\n")
    with pytest.raises(ValueError, match="drive_torque_Nm"):
        synth.excitation(str(f), rig)
    f.write_text("time_s,voltage_V\n0,0\n0.5,x\n")
    with pytest.raises(ValueError, match="'voltage_V'.*data row 2"):
        synth.excitation(str(f), rig)


# ------------------------------------------------------------------ synthesis

def test_record_reads_back_as_a_measurement(rig, record, tmp_path):
    m = synth.synthesize(rig, [], *record, seed=0)
    assert m.input_name == "voltage_V"
    assert list(m.signals) == ["motor_angle_deg", "load_angle_deg", "current_A"]
    path = write_measurement(m, tmp_path / "d.csv")
    back = read_measurement(path)
    assert np.allclose(back.time_s, m.time_s) and np.allclose(back.input, m.input)
    for k, v in m.signals.items():
        assert np.allclose(back.signals[k], v, rtol=1e-9, atol=1e-9)


def test_clean_record_equals_a_plain_open_loop_simulation(rig, record):
    t, u = record
    m = synth.synthesize(rig, [], t, u, noise=clean(rig))
    assert np.array_equal(m.input, u)
    run = simulate(rig, Controller("open"), Segments(t, u, np.zeros_like(u)), float(t[-1]),
                   SolverOptions(rtol=1e-6, max_step_s=1e-3, output_dt_s=1e-3))
    assert run.ok and len(run.time_s) == len(t)
    deg = 180.0 / math.pi
    assert np.allclose(m.signals["motor_angle_deg"], run.outputs[:, 2] * deg, rtol=0, atol=1e-6)
    assert np.allclose(m.signals["load_angle_deg"], run.outputs[:, 1] * deg, rtol=0, atol=1e-6)
    assert np.allclose(m.signals["current_A"], run.outputs[:, 4], rtol=0, atol=1e-9)
    # and the identify pipeline's replay of the record reproduces it: its rtol is 1e-5, so
    # impacts land a little differently; the current, which jumps at impacts, differs most
    sim = Replay(m, window_s=None).run(rig)
    for k, y in m.signals.items():
        assert np.max(np.abs(sim[k] - y)) < 2e-3 * np.ptp(y), k
        assert np.sqrt(np.mean((sim[k] - y) ** 2)) < 1e-4 * np.ptp(y), k


def test_moves_and_rests(rig, record):
    """The rig is well-behaved under steps: it moves, and is (nearly) still at the end of a rest."""
    t, u = record
    m = synth.synthesize(rig, [], t, u, noise=clean(rig))
    th = m.signals["load_angle_deg"]
    w = np.gradient(th, t)
    assert np.ptp(th) > 90.0
    ends = [b - 1 for a, b in runs_of(u == 0.0)[1:-1]]
    assert ends and np.all(np.abs(w[ends]) < 0.02 * np.max(np.abs(w)))


def test_hidden_bias_torque_changes_the_data(rig, record):
    base = synth.synthesize(rig, [], *record, noise=clean(rig))
    bias = synth.synthesize(rig, [AddedEffect("bias_torque", {"location": "load", "torque": 1.0})],
                            *record, noise=clean(rig))
    diff = bias.signals["load_angle_deg"] - base.signals["load_angle_deg"]
    assert np.max(np.abs(diff)) > 5.0
    assert np.array_equal(bias.input, base.input)


def test_hidden_sensor_delay_shifts_the_signal_by_the_delay(rig, record):
    base = synth.synthesize(rig, [], *record, noise=clean(rig))
    late = synth.synthesize(rig, [AddedEffect("sensor_delay", {"signal": "load_angle_deg", "delay": 0.02})],
                            *record, noise=clean(rig))
    k = 20  # samples of 1 ms
    y, yd = base.signals["load_angle_deg"], late.signals["load_angle_deg"]
    assert np.allclose(yd[k:], y[:-k], atol=1e-9)
    assert np.allclose(yd[:k], y[0])
    assert np.array_equal(late.signals["motor_angle_deg"], base.signals["motor_angle_deg"])


def test_hidden_encoder_quantization_puts_the_signal_on_its_grid(rig, record):
    counts = 1000
    m = synth.synthesize(rig, [AddedEffect("encoder_quantization",
                                           {"signal": "motor_angle_deg", "counts_per_rev": counts})],
                         *record, seed=3)
    q = 360.0 / counts
    y = m.signals["motor_angle_deg"]
    assert np.allclose(y / q, np.round(y / q), atol=1e-6), "whole counts: no analog noise added"
    assert len(np.unique(np.round(y / q))) > 100
    noisy = m.signals["load_angle_deg"]
    assert not np.allclose(noisy / q, np.round(noisy / q), atol=1e-6)  # the others carry noise


def test_noise_has_the_asked_size_and_depends_on_the_seed(rig, record):
    a = synth.synthesize(rig, [], *record, seed=7)
    b = synth.synthesize(rig, [], *record, seed=7)
    c = synth.synthesize(rig, [], *record, seed=8)
    truth = synth.synthesize(rig, [], *record, noise=clean(rig))
    for k in a.signals:
        assert np.array_equal(a.signals[k], b.signals[k])
        assert not np.array_equal(a.signals[k], c.signals[k])
    e = a.signals["load_angle_deg"] - truth.signals["load_angle_deg"]
    assert np.std(e) == pytest.approx(0.01, rel=0.05)
    e = a.signals["current_A"] - truth.signals["current_A"]
    assert np.std(e) == pytest.approx(0.005, rel=0.05)
    big = synth.synthesize(rig, [], *record, noise={"load_angle_deg": 0.1}, seed=7)
    assert np.std(big.signals["load_angle_deg"] - truth.signals["load_angle_deg"]) == pytest.approx(0.1, rel=0.05)


def test_ar1_noise_keeps_its_size_and_is_coloured(rig, record):
    truth = synth.synthesize(rig, [], *record, noise=clean(rig))
    a = synth.synthesize(rig, [], *record, seed=7, noise_ar1=0.9)
    e = a.signals["load_angle_deg"] - truth.signals["load_angle_deg"]
    assert np.std(e) == pytest.approx(0.01, rel=0.15)  # ~len/19 independent samples
    assert np.corrcoef(e[1:], e[:-1])[0, 1] == pytest.approx(0.9, abs=0.03)
    white = synth.synthesize(rig, [], *record, seed=7)
    w = white.signals["load_angle_deg"] - truth.signals["load_angle_deg"]
    assert abs(np.corrcoef(w[1:], w[:-1])[0, 1]) < 0.1


def test_synthesize_rejects_what_the_plant_cannot_measure(rig, record):
    with pytest.raises(synth.SynthError, match="load_position_mm"):
        synth.synthesize(rig, [], *record, signals=("motor_angle_deg", "load_position_mm"))
    with pytest.raises(synth.SynthError, match="sensor_delay acts on current_A"):
        synth.synthesize(rig, [AddedEffect("sensor_delay", {"signal": "current_A", "delay": 0.01})],
                         *record, signals=("motor_angle_deg",))


def test_translational_defaults():
    emps = load_plant(ROOT / "experiments" / "plants" / "emps_bare.yaml")
    assert synth.default_signals(emps) == ("motor_angle_deg", "load_position_mm")
    t, u = synth.excitation("steps", emps, duration_s=1.0)
    m = synth.synthesize(emps, [], t, u)
    assert m.input_name == "drive_force_N" and np.ptp(m.signals["load_position_mm"]) > 1.0


# ------------------------------------------------------------------ command line

def test_cli_writes_data_and_truth(tmp_path):
    out = tmp_path / "d.csv"
    args = ["synth", str(RIG), "--effect", "coulomb_friction location=load torque=0.5",
            "--effect", "encoder_quantization signal=motor_angle_deg counts_per_rev=2000",
            "--duration", "2", "--seed", "3", "-o", str(out)]
    res = CliRunner().invoke(main, args)
    assert res.exit_code == 0, res.output
    assert "wrote" in res.output and "coulomb_friction" in res.output
    m = read_measurement(out)
    assert m.duration_s == pytest.approx(2.0)
    truth = yaml.safe_load((tmp_path / "d.truth.yaml").read_text())
    assert truth["hidden_effects"] == [
        {"type": "coulomb_friction", "location": "load", "torque": 0.5},
        {"type": "encoder_quantization", "signal": "motor_angle_deg", "counts_per_rev": 2000}]
    assert truth["seed"] == 3 and truth["excitation"]["kind"] == "steps"
    assert truth["noise_std"]["motor_angle_deg"] == 0.0 and truth["noise_std"]["current_A"] == 0.005
    assert truth["plant"] == str(RIG)
    # same seed, same data
    again = tmp_path / "e.csv"
    assert CliRunner().invoke(main, args[:-1] + [str(again)]).exit_code == 0
    assert out.read_text() == again.read_text()


def test_cli_noise_ar1_is_written_to_the_truth(tmp_path):
    out = tmp_path / "c.csv"
    res = CliRunner().invoke(main, ["synth", str(RIG), "--duration", "1", "--noise-ar1", "0.8", "-o", str(out)])
    assert res.exit_code == 0, res.output
    truth = yaml.safe_load((tmp_path / "c.truth.yaml").read_text())
    assert truth["noise_ar1"] == 0.8 and "--noise-ar1 0.8" in truth["command"]
    bad = CliRunner().invoke(main, ["synth", str(RIG), "--noise-ar1", "1", "-o", str(out)])
    assert bad.exit_code == 2


def test_cli_mixed_excitation_is_written_with_its_pieces(tmp_path):
    out = tmp_path / "m.csv"
    res = CliRunner().invoke(main, ["synth", str(RIG), "--excitation", "mixed", "--duration", "15",
                                    "--seed", "2", "-o", str(out)])
    assert res.exit_code == 0, res.output
    m = read_measurement(out)
    assert m.duration_s == pytest.approx(15.0)
    u = synth.excitation("mixed", load_plant(RIG), duration_s=15.0, seed=2)[1]
    assert np.allclose(m.input, u, rtol=0, atol=1e-6)  # the CSV keeps 10 significant digits
    exc = yaml.safe_load((tmp_path / "m.truth.yaml").read_text())["excitation"]
    assert exc["kind"] == "mixed" and exc["seed"] == 2 and len(exc["segments"]) == len(synth.MIXED)


def test_cli_rejects_a_bad_effect_naming_the_key(tmp_path):
    out = tmp_path / "d.csv"

    def fails(*args):
        res = CliRunner().invoke(main, ["synth", str(RIG), *args, "-o", str(out)])
        assert res.exit_code == 2, res.output
        return " ".join(res.output.split())  # rich wraps long lines

    text = fails("--effect", "coulomb_friction location=load torqe=0.5")
    assert text.startswith("error:") and "coulomb_friction.torqe" in text and "'torque'" in text
    text = fails("--effect", "load_spring stiffness=-1 rest_angle_deg=0")
    assert "load_spring.stiffness" in text and "N m/rad" in text
    assert "key=value" in fails("--effect", "coulomb_friction torque")
    assert "not a known effect" in fails("--effect", "stiction torque=1")
    shaft = "shaft_compliance stiffness=50 damping=1e-4 pinion_inertia=3e-7"
    text = fails("--effect", shaft, "--effect", shaft)
    assert "shaft_compliance (#2): the plant already has a shaft" in text and "(#1)" not in text
    assert "--noise" in fails("--noise", "load_angle_deg=-1")
    assert list(tmp_path.iterdir()) == [], "nothing is written when anything fails"
