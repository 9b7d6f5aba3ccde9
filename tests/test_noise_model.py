"""The criterion that decides what pays counts a coloured residual's samples as ``n / tau``
independent ones (``scoring.noise_model``, ``scoring.bic_drop``, ``Policy.pays``), ``tau`` its
correlation time read by an autoregression of each signal's residual.

Against the truth of known processes, and on records whose noise is not what the fitted model
assumes (AR(1) noise the model takes as white, quantized encoders, a sensor's offset), from
gearbench's simulator and from the practice cases' independent one: a coloured null record pays
nothing by the criterion where the white BIC took a spring and a bias, and a real effect under
coloured or quantized sensors still pays.
"""
from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml
from scipy.signal import lfilter

from conftest import DATA, without_opening_rest
from gearbench import load_measurement
from gearbench.experiment.files import load_plant
from gearbench.identify.candidates import Candidate, fit_candidate
from gearbench.identify.fit import evaluate
from gearbench.identify.policy import Policy
from gearbench.identify.replay import Replay
from gearbench.identify.scoring import Scorer, bic_drop, noise_model, noise_share, read_as
from gearbench.measure.noise import difference_noise
from gearbench.measure.data import read_measurement
from gearbench.plant.effects import AddedEffect
from gearbench.synth import ar1, excitation, synthesize

from test_practice_cases import offsets, true_plant

RIG = Path(__file__).resolve().parents[1] / "experiments" / "plants" / "bench_rig.yaml"
N = 16_000


def test_white_residuals_take_order_0_and_count_every_sample():
    m = noise_model(np.random.default_rng(0).standard_normal(N))
    assert m.order == 0 and m.tau == 1.0 and m.n == N


@pytest.mark.parametrize("rho", [0.5, 0.9, 0.95])
def test_an_ar1_residual_takes_order_1_and_its_correlation_time(rho):
    """``tau = (1 + rho)/(1 - rho)`` for AR(1) (``synth.ar1``).  Yule-Walker's ``rho_hat`` has the
    standard error ``sqrt((1 - rho^2)/n)``, so ``tau``'s relative one is ``2 / sqrt(n (1 - rho^2))``
    (2.5 % at rho 0.95 over 64,000 samples); within 4 of them."""
    n = 4 * N
    for seed in range(3):
        m = noise_model(ar1(np.random.default_rng(seed).standard_normal(n), rho))
        tau = (1 + rho) / (1 - rho)
        assert m.order == 1
        assert abs(m.tau / tau - 1) < 4 * 2 / math.sqrt(n * (1 - rho ** 2)), (m.tau, tau)


def test_an_ar2_residual_takes_order_2_and_its_correlation_time():
    """``A(q) = 1 - 1.5 q^-1 + 0.7 q^-2``: ``tau = sigma2_e / (A(1)^2 r_0)``, its ``r_0`` from the
    process's own Yule-Walker equations."""
    a1, a2 = -1.5, 0.7
    e = np.random.default_rng(1).standard_normal(4 * N)
    m = noise_model(lfilter([1.0], [1.0, a1, a2], e))
    r0 = (1 + a2) / ((1 - a2) * ((1 + a2) ** 2 - a1 ** 2))
    assert m.order == 2 and m.tau == pytest.approx(1.0 / ((1 + a1 + a2) ** 2 * r0), rel=0.2)


def test_a_residual_predicted_to_rounding_stops_the_recursion():
    """A pure sinusoid is an exact AR(2): the recursion stops there instead of taking the log of 0."""
    m = noise_model(np.sin(0.01 * np.arange(N)))
    assert m.order >= 2 and 1.0 <= m.tau <= N


@pytest.mark.parametrize("rho", [0.0, 0.5, 0.9, 0.95])
def test_a_coloured_noise_reads_on_its_floor_as_read_as_says(rho):
    """``read_as`` against the floor rule itself: an AR(1) of unit variance read by the record's
    third differences (``measure.noise.difference_noise``, a robust scale) has the mean square
    ``read_as(tau)`` in those floors, within 5 % (the scale's sampling error is about 1 %)."""
    w = ar1(np.random.default_rng(4).standard_normal(4 * N), rho)
    tau = (1 + rho) / (1 - rho)
    assert float(np.mean(w ** 2)) / difference_noise(w) ** 2 == pytest.approx(read_as(tau, "differences"), rel=0.05)
    assert read_as(tau, "stated") == read_as(tau, "quantum") == 1.0


def test_a_misfit_above_what_the_noise_can_be_counts_as_independent_samples():
    """A residual 100x the mean square its correlation time allows is mostly misfit: 1 % of it
    carries the noise's correlation; at or below that mean square, all of it does."""
    allowed = read_as(39.0, "differences")
    assert noise_share(100 * allowed, 39.0, "differences") == pytest.approx(0.01)
    assert noise_share(allowed, 39.0, "differences") == noise_share(0.5, 39.0, "differences") == 1.0
    assert noise_share(4.0, 5.0, "stated") == 0.25


@pytest.fixture(scope="module")
def coloured_null():
    """16 s of the bench rig, nothing hidden, AR(1) noise of lag-1 correlation 0.95 on every signal
    (0.02 deg, 0.015 deg, 8 mA), its floors read from the record: the noise the fitted model
    assumes white."""
    rig = load_plant(RIG)
    t, u = excitation("mixed", rig, duration_s=16.0, seed=3)
    noise = {"motor_angle_deg": 0.02, "load_angle_deg": 0.015, "current_A": 0.008}
    return rig, synthesize(rig, [], t, u, noise=noise, seed=3, noise_ar1=0.95)


@pytest.mark.parametrize("effect,options", [("load_spring", {}), ("bias_torque", {"location": "load"})])
def test_on_coloured_null_noise_a_fitted_effect_does_not_pay(coloured_null, effect, options):
    """Given without its opening rest (``conftest.without_opening_rest``), the record's resets move
    the model by the noise, and the effect fitted to it lowers the white BIC by far more than 10
    (the defect: only the 3 % rule kept such fits out; measured 624 and 568 on 2026-12-07), and the
    BIC over ``n / tau`` samples by less than 10; ``tau`` is the AR(1) noise's ``(1 + rho)/(1 - rho)``
    = 39 samples within a factor 2 (the resets add some).  With its opening rest, where the resets
    know the noise, no model is moved and the fitted effect gains nothing by either BIC."""
    rig, record = coloured_null
    for data in (without_opening_rest(record), record):
        replay = Replay(data)
        scorer = Scorer(replay)
        before = evaluate(replay, scorer, rig)
        after = fit_candidate(replay, scorer, rig, Candidate(effect, options)).result
        assert bic_drop(scorer, before, after) < 10
        assert 39 / 2 < scorer.correlation_time(after) < 39 * 2
        assert not Policy().pays(scorer, before, after)
        if data is record:
            assert before.seams == after.seams == () and before.bic - after.bic < 10
        else:
            assert before.bic - after.bic > 10


def test_a_current_offset_under_quantized_sensors_still_pays_on_the_independent_record():
    """p08 (the independent simulator: 4096- and 2000-count encoders, the current read 10 mA high):
    its true plant with the offset against without it pays by the criterion, and the current's
    residual is white once it is in (the offset was that residual's colour)."""
    folder = DATA / "cases" / "p08"
    truth = yaml.safe_load((folder / "truth.yaml").read_text())
    plant = true_plant(truth, "p08")
    (signal, value), = offsets(truth).items()
    replay = Replay(read_measurement(folder / "data.csv"))
    scorer = Scorer(replay)
    without = evaluate(replay, scorer, plant)
    with_it = evaluate(replay, scorer, replace(plant, effects=plant.effects + (
        AddedEffect("sensor_offset", {"signal": signal, "offset": value}),)), 1)
    assert Policy().accepts(scorer, without, with_it)
    assert without.noise[signal].tau > 10 and with_it.noise[signal].tau < 2


def test_a_misfit_is_not_counted_as_coloured_noise():
    """3 s of ``bench_rig_hidden.csv`` (white noise, a friction the plant lacks): the fitted Coulomb
    friction still drifts (its residual's AR correlation time is hundreds of samples), but far above
    what a noise of that correlation could read on the floors, so its samples count as independent
    and the friction pays.  Counting the whole residual's correlation, it did not (15 independent
    samples in 10 s)."""
    rig = load_plant(RIG)
    replay = Replay(load_measurement(pd.read_csv(RIG.parents[1] / "data" / "bench_rig_hidden.csv").iloc[:3000]))
    scorer = Scorer(replay)
    before = evaluate(replay, scorer, rig)
    after = fit_candidate(replay, scorer, rig, Candidate("coulomb_friction", {"location": "load"})).result
    assert max(m.tau for m in after.noise.values()) > 100
    assert scorer.correlation_time(after) < 2
    assert Policy().accepts(scorer, before, after)
