"""The noise floor of a quantized signal (``measure.noise.noise_estimate``), against its known truth.

An encoder of 4096 counts per revolution rounds an angle to ``q = 360/4096`` deg; the rounding error
of a moving angle is uniform with standard deviation ``q/√12`` (Widrow), and noise ``σ_n`` before the
rounding adds to it: ``√(q²/12 + σ_n²)``.  The truths the tests assert are these, and ``σ`` itself for
white noise: never a number read from an output.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from gearbench.experiment.files import load_plant
from gearbench.identify.compare import comparison
from gearbench.identify.replay import Replay
from gearbench.identify.results import noise as noise_entries
from gearbench.identify.scoring import Scorer
from gearbench.measure.noise import RULES, noise_estimate, noise_floor
from gearbench.plant.effects import AddedEffect
from gearbench.synth import excitation, synthesize

Q = 360.0 / 4096                 # deg: one count of a 4096-count encoder
ROUNDING = Q / math.sqrt(12.0)   # deg: the standard deviation of a moving angle's rounding error
DT = 1e-3
T = np.arange(0.0, 10.0, DT)
RIG = Path(__file__).resolve().parents[1] / "experiments" / "plants" / "bench_rig.yaml"


def motion(peak_counts_per_sample: float) -> np.ndarray:
    """A sine-ish motion (two sines, 0.5 and 1.3 Hz) whose speed peaks near the given counts per sample, deg."""
    a = peak_counts_per_sample * Q / (2 * np.pi * 0.5 * DT) / 1.4
    return a * np.sin(2 * np.pi * 0.5 * T + 0.3) + 0.4 * a * np.sin(2 * np.pi * 1.3 * T + 1.1)


def rounded(y: np.ndarray) -> np.ndarray:
    return Q * np.round(y / Q)


@pytest.mark.parametrize("peak", [0.05, 2.0, 5.0, 20.0, 200.0])
def test_a_quantized_motion_has_the_rounding_floor(peak):
    """From a creep of 0.05 counts per sample to 200 (the bench rig's motor runs at up to ~380)."""
    y = rounded(motion(peak))
    est = noise_estimate(y)
    assert est.quantum == pytest.approx(Q, rel=1e-9)
    assert est.floor == pytest.approx(ROUNDING, rel=0.10)
    assert est.rule in ("quantum", "quantized differences")
    # the truth this record has: its rounding error's RMS
    assert float(np.std(y - motion(peak))) == pytest.approx(ROUNDING, rel=0.10)


def test_the_old_median_read_a_moving_encoder_15_percent_high():
    """What the rule replaces: the median absolute deviation of whole counts is one count here, and
    ``1.4826 q / √20 = 1.148 q/√12`` whatever the signal does."""
    from gearbench.measure.noise import difference_noise
    y = rounded(motion(20.0))
    assert difference_noise(y) == pytest.approx(1.4826 * Q / math.sqrt(20), rel=1e-9)
    assert abs(noise_floor(y) / ROUNDING - 1) < 0.10 < abs(difference_noise(y) / ROUNDING - 1)


def test_a_creeping_encoder_reads_at_most_17_percent_high():
    """The documented limit: at 0.5 counts per sample the rounding error is periodic near the Nyquist
    frequency, where the third difference weighs most."""
    y = rounded(motion(0.5))
    assert ROUNDING <= noise_floor(y) <= 1.2 * ROUNDING


@pytest.mark.parametrize("sigma", [1e-3, 1e-2, 0.3])
def test_white_noise_has_its_sigma(sigma):
    rng = np.random.default_rng(7)
    y = motion(20.0) + rng.normal(0.0, sigma, T.size)
    est = noise_estimate(y)
    assert est.rule == "differences" and est.quantum is None
    assert est.floor == pytest.approx(sigma, rel=0.10)


@pytest.mark.parametrize("sigma_counts", [0.1, 0.5, 1.0, 3.0])
@pytest.mark.parametrize("peak", [0.05, 20.0])
def test_noise_before_the_rounding_adds_to_the_quantum(sigma_counts, peak):
    """Noise and rounding: ``√(q²/12 + σ_n²)``, the RMS of a right model's residual; the rule says
    which part the floor came from (the quantum while the noise is far below a count)."""
    rng = np.random.default_rng(11)
    s = motion(peak)
    y = rounded(s + rng.normal(0.0, sigma_counts * Q, T.size))
    truth = math.sqrt(ROUNDING ** 2 + (sigma_counts * Q) ** 2)
    est = noise_estimate(y)
    assert est.floor == pytest.approx(truth, rel=0.10)
    assert float(np.std(y - s)) == pytest.approx(truth, rel=0.05)
    assert est.floor >= ROUNDING
    assert est.rule == ("quantized differences" if sigma_counts >= 0.5 else est.rule)


def test_a_given_quantum_raises_a_white_floor():
    rng = np.random.default_rng(3)
    y = motion(20.0) + rng.normal(0.0, 1e-4, T.size)
    est = noise_estimate(y, quantum=0.01)
    assert est.floor == pytest.approx(0.01 / math.sqrt(12)) and est.rule == "quantum"
    with pytest.raises(ValueError, match="positive"):
        noise_estimate(y, quantum=-1.0)


def test_each_rule_is_described():
    y = rounded(motion(20.0))
    est = noise_estimate(y)
    assert est.rule in RULES and "q = " in est.description


def test_replay_reports_the_rule_per_signal():
    """A bench rig record with its motor angle on a 4096-count encoder: compare's rows and diagnose's
    ``noise_floors`` say the motor angle's floor is the quantum, the others' white differences, a
    stated one ``stated``."""
    plant = load_plant(RIG)
    t, u = excitation("steps", plant, duration_s=3.0, seed=2)
    enc = AddedEffect("encoder_quantization", {"signal": "motor_angle_deg", "counts_per_rev": 4096})
    data = synthesize(plant, [enc], t, u, seed=2)
    replay = Replay(data, noise_std={"load_angle_deg": 0.01})
    # the rounding error's own differences read 1-3 % above q/sqrt(12) on the moving rig: either rule
    quantized = ("quantum", "quantized differences")
    assert replay.noise_rule("motor_angle_deg") in quantized
    assert replay.noise_floor("motor_angle_deg") == pytest.approx(ROUNDING, rel=0.10)
    assert replay.noise_rule("current_A") == "differences"
    assert replay.noise_rule("load_angle_deg") == "stated"
    entries = noise_entries(replay, Scorer(replay))
    rules = {n: e["rule"] for n, e in entries.items()}
    assert rules["motor_angle_deg"] in quantized
    assert rules == {**rules, "load_angle_deg": "stated", "current_A": "differences"} and len(rules) == 3
    rows = {r["signal"]: r for r in comparison(replay, plant, lags=None)["signals"]}
    assert rows["motor_angle_deg"]["noise_rule"] in quantized
    # the rig without its encoder leaves exactly the rounding error in the motor angle: at the floor
    assert rows["motor_angle_deg"]["ratio_to_noise"] == pytest.approx(1.0, abs=0.15)
