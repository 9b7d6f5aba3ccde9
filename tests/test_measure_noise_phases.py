"""Noise floor, quantum detection and motion phases on synthetic signals of known truth."""
from __future__ import annotations

import numpy as np
import pytest

from scipy.signal import lfilter

from gearbench.measure.noise import detect_quantum, difference_noise, line_end_noise, noise_floor
from gearbench.measure.phases import PHASES, classify_phases, error_shares, phase_codes

T = np.arange(0.0, 10.0, 1e-3)
SINE = 5.0 * np.sin(2 * np.pi * 0.3 * T)


@pytest.mark.parametrize("sigma", [1e-3, 1e-2, 0.3])
def test_noise_floor_of_sine_plus_white_noise(sigma):
    rng = np.random.default_rng(42)
    y = SINE + rng.normal(0.0, sigma, T.size)
    assert noise_floor(y) == pytest.approx(sigma, rel=0.15)


def test_noise_floor_ignores_a_few_steps():
    rng = np.random.default_rng(1)
    y = SINE + rng.normal(0.0, 0.01, T.size)
    y[2000:] += 3.0                      # an impact / slip
    y[7000:7003] += 1.0                  # a short spike
    assert noise_floor(y) == pytest.approx(0.01, rel=0.15)


def test_noise_floor_of_smooth_signal_is_tiny():
    assert noise_floor(SINE) < 1e-6 * np.ptp(SINE)
    assert detect_quantum(SINE) is None


def test_quantised_ramp():
    q = 0.01
    y = np.round(np.linspace(0.0, 3.0, 4000) / q) * q
    assert detect_quantum(y) == pytest.approx(q, rel=1e-12)
    assert noise_floor(y) == pytest.approx(q / np.sqrt(12), rel=1e-9)
    # the difference estimator alone sees almost nothing of a creeping grid
    assert difference_noise(y) < q / np.sqrt(12)


def test_quantum_with_skipped_levels_and_offset():
    q = 2 * np.pi / 50000                # encoder counts, rad
    counts = np.array([0, 2, 5, 9, 12, 30, 31, 28])
    assert detect_quantum(0.25 + counts * q) == pytest.approx(q, rel=1e-9)


def test_given_quantum_sets_the_floor():
    rng = np.random.default_rng(3)
    y = SINE + rng.normal(0.0, 1e-4, T.size)
    assert noise_floor(y, quantum=0.01) == pytest.approx(0.01 / np.sqrt(12))
    assert noise_floor(y, quantum=1e-6) == pytest.approx(1e-4, rel=0.15)


def test_noisy_signal_has_no_quantum():
    rng = np.random.default_rng(4)
    assert detect_quantum(SINE + rng.normal(0, 0.1, T.size)) is None
    assert detect_quantum([1.0, 1.0, 2.0]) is None         # two levels prove nothing


def test_noise_floor_needs_samples():
    with pytest.raises(ValueError, match="at least"):
        noise_floor([1.0, 2.0, 3.0])


def _lines_at_the_next_sample(e, m: int, every: int) -> np.ndarray:
    """Least-squares lines through ``m`` samples of ``e`` starting every ``every`` samples, each
    evaluated at the sample after its last: what a window's reset test extrapolates."""
    j = np.arange(m, dtype=float)
    starts = np.arange(0, e.size - m, every)
    coef = np.polynomial.polynomial.polyfit(j, e[starts[:, None] + np.arange(m)].T, 1)
    return coef[0] + coef[1] * m


@pytest.mark.parametrize("phi", [0.0, 0.5, 0.9])
def test_line_end_noise_is_the_spread_of_lines_fitted_to_such_noise(phi):
    """Read from one stretch of AR(1) noise (lag-1 correlation ``phi``), the standard deviation of a
    21-sample line's value at the next sample is the spread of such lines fitted to another,
    independent stretch (5,000 lines, far enough apart to be independent: 1 % standard error), and
    for white noise the textbook ``sigma sqrt(1/m + (m - mean)^2 / Sxx)``, 0.45 sigma."""
    rng = np.random.default_rng(7)
    m, sigma = 21, 0.04
    scale = sigma * np.sqrt(1.0 - phi ** 2)  # marginal standard deviation sigma
    rest = lfilter([scale], [1.0, -phi], rng.normal(size=2000))
    other = lfilter([scale], [1.0, -phi], rng.normal(size=5000 * 120))
    got = line_end_noise(rest, m)
    assert got == pytest.approx(np.std(_lines_at_the_next_sample(other, m, 120)), rel=0.1)
    if phi == 0.0:
        j = np.arange(m)
        textbook = sigma * np.sqrt(1.0 / m + (m - j.mean()) ** 2 / np.sum((j - j.mean()) ** 2))
        assert got == pytest.approx(textbook, rel=0.1)
        assert textbook == pytest.approx(0.45 * sigma, rel=0.01)


def test_line_end_noise_needs_a_still_rest_of_five_lines_and_a_toggling_signal():
    """Too short, a constant, or motion (a drive the record does not show, a swing): no noise read."""
    rng = np.random.default_rng(8)
    assert line_end_noise(rng.normal(size=104), 21) == 0.0
    assert line_end_noise(rng.normal(size=105), 21) > 0.0
    assert line_end_noise(np.full(500, 0.25), 21) == 0.0   # an encoder at rest that does not toggle
    t = np.arange(500) * 1e-3
    noise = 0.01 * rng.normal(size=t.size)
    assert line_end_noise(1.5 * t ** 2 + noise, 21) == 0.0                       # accelerating
    assert line_end_noise(0.1 * np.sin(2 * np.pi * 2.0 * t) + noise, 21) == 0.0  # swinging at 2 Hz


# ---------------------------------------------------------------------------
# Phases
# ---------------------------------------------------------------------------

def trapezoid(dwell_s: float = 0.0):
    """Rest 1 s; up to +10/s in 0.5 s; cruise 2 s; down to 0 in 0.5 s (at t = 4), an
    optional dwell; down to −10/s in 0.5 s; cruise 2 s; back to 0 in 0.5 s; rest 1.5 s."""
    knots_t = np.array([0, 1, 1.5, 3.5, 4.0, 4.0 + dwell_s, 4.5 + dwell_s, 6.5 + dwell_s, 7.0 + dwell_s,
                        8.5 + dwell_s])
    knots_v = np.array([0, 0, 10, 10, 0, 0, -10, -10, 0, 0])
    t = np.arange(0.0, knots_t[-1], 1e-3)
    v = np.interp(t, knots_t, knots_v)
    y = np.concatenate(([0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(t))))
    return t, y, v


def labels_at(t, labels, times):
    return [labels[np.searchsorted(t, x)] for x in times]


@pytest.mark.parametrize("noise", [0.0, 0.01])
def test_trapezoid_phases_where_expected(noise):
    t, y, _ = trapezoid()
    rng = np.random.default_rng(7)
    labels = classify_phases(t, y + rng.normal(0, noise, t.size))
    assert set(labels) == set(PHASES)
    expected = {0.5: "standstill", 1.25: "acceleration", 2.5: "steady motion", 3.7: "acceleration",
                4.0: "direction reversal", 4.3: "acceleration", 5.5: "steady motion", 6.75: "acceleration",
                7.5: "standstill", 8.45: "standstill"}
    assert labels_at(t, labels, expected) == list(expected.values())
    # the reversal is one window around t = 4, nowhere else
    rev = t[labels == "direction reversal"]
    assert 3.8 < rev.min() < 4.0 < rev.max() < 4.2
    assert np.all(np.diff(rev) < 2e-3)


def test_short_stop_is_a_reversal_long_stop_is_not():
    t, y, v = trapezoid(dwell_s=0.05)
    labels = classify_phases(t, y, speed=v)
    assert labels_at(t, labels, [4.025]) == ["direction reversal"]
    t, y, v = trapezoid(dwell_s=1.0)
    labels = classify_phases(t, y, speed=v)
    assert "direction reversal" not in set(labels)
    assert labels_at(t, labels, [4.5]) == ["standstill"]


def test_thresholds_can_be_given():
    t, y, v = trapezoid()
    labels = classify_phases(t, y, speed=v, standstill_speed=11.0)
    assert set(labels) == {"standstill"}
    wide = classify_phases(t, y, speed=v, reversal_window_s=0.6)
    assert np.sum(wide == "direction reversal") > 2 * np.sum(classify_phases(t, y, speed=v) == "direction reversal")


def test_still_record_is_all_standstill():
    t = np.arange(0.0, 1.0, 1e-3)
    assert set(classify_phases(t, np.zeros_like(t))) == {"standstill"}


def test_error_shares():
    labels = np.array(["standstill"] * 3 + ["acceleration"] * 1)
    residual = np.array([1.0, 1.0, 1.0, 3.0])
    shares = error_shares(labels, residual)
    assert set(shares) == set(PHASES)
    assert shares["standstill"] == pytest.approx({"time_share": 0.75, "error_share": 0.25, "rms": 1.0})
    assert shares["acceleration"] == pytest.approx({"time_share": 0.25, "error_share": 0.75, "rms": 3.0})
    assert shares["steady motion"] == {"time_share": 0.0, "error_share": 0.0, "rms": 0.0}
    weighted = error_shares(phase_codes(labels), residual, dt=np.array([1.0, 1.0, 1.0, 3.0]))
    assert weighted["acceleration"]["time_share"] == pytest.approx(0.5)
    assert weighted["acceleration"]["error_share"] == pytest.approx(27 / 30)
    assert sum(s["error_share"] for s in weighted.values()) == pytest.approx(1.0)


def test_error_shares_of_a_perfect_model():
    shares = error_shares(["standstill", "standstill"], [0.0, 0.0], dt=0.1)
    assert shares["standstill"] == {"time_share": 1.0, "error_share": 0.0, "rms": 0.0}
