"""Coloured measurement noise, and the noise a user states (``Replay(noise_std=...)``, ``--noise``).

The noise floor read from a record (third differences) assumes white noise: an AR(1) noise
of lag-1 correlation 0.9 shows there at a quarter of its level, and a window's reset, which
tests the model's drift against the straight line's own (white) standard error, moves a right
model on that noise.  A stated noise is the floor, and the least drift a reset acts on.
"""
from __future__ import annotations

from pathlib import Path

import json

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

import gearbench as gb
from gearbench.cli import main
from gearbench.experiment.files import ConfigError, load_plant
from gearbench.identify.compare import comparison
from gearbench.identify.diagnose import diagnose
from gearbench.identify.explain import not_driven as _not_driven
from gearbench.identify.fit import evaluate
from gearbench.identify.scoring import Scorer, objective_signals
from gearbench.identify.replay import Replay, ReplayError, noise_at_rest
from gearbench.identify.residuals import residual_test
from gearbench.synth import excitation, synthesize
from gearbench.measure.noise import rest_noise
from gearbench.plant.effects import AddedEffect
from gearbench.simulate import SolverOptions
from conftest import without_opening_rest

ROOT = Path(__file__).resolve().parents[1]
RIG = ROOT / "experiments" / "plants" / "bench_rig.yaml"
HIDDEN = ROOT / "experiments" / "data" / "bench_rig_hidden.csv"
NOISE = {"motor_angle_deg": 0.02, "load_angle_deg": 0.015, "current_A": 0.008}


@pytest.fixture(scope="module")
def rig():
    return load_plant(RIG)


def coloured(plant, seed, hidden=(), duration_s=8.0, options=None):
    t, u = excitation("mixed", plant, duration_s=duration_s, seed=seed)
    return synthesize(plant, list(hidden), t, u, noise=NOISE, seed=seed, noise_ar1=0.9, options=options)


def at_rest(plant, seed=5, duration_s=10.0):
    """The rig standing still (no voltage) for ``duration_s``, the same AR(1) noise: what a user
    records to measure the noise."""
    t = np.arange(0.0, duration_s, 1e-3)
    return synthesize(plant, [], t, np.zeros_like(t), noise=NOISE, seed=seed, noise_ar1=0.9)


def rms_ratio(replay, plant, name):
    """The RMS of column ``name``'s residual over its noise, and the times the run reset at."""
    sim = replay.run(plant)
    r = replay.residuals(sim)[name]
    return float(np.sqrt(np.mean(r ** 2))) / NOISE[name], sim.reinitialised_s


def test_a_stated_noise_is_the_floor_and_the_weight(rig):
    data = gb.load_measurement(HIDDEN)
    replay = Replay(data, noise_std={"load_angle_deg": 0.05})
    scorer = Scorer(replay)
    assert scorer.floors["load_angle_deg"] == 0.05
    assert scorer.floors["current_A"] == Replay(data).noise_floor("current_A")   # the others: read
    rows = {r["signal"]: r for r in comparison(replay, rig, lags=None)["signals"]}
    assert rows["load_angle_deg"]["noise_floor"] == 0.05
    assert rows["load_angle_deg"]["ratio_to_noise"] == pytest.approx(rows["load_angle_deg"]["rms_error"] / 0.05)


def test_the_floors_come_in_the_compared_columns_order():
    """Every per-signal text and sum runs over ``Scorer.floors``: their order is the record's
    compared columns', the primary after them where it is not one (a set's order would change
    with the process's string-hash seed, and with it ``noise`` in ``diagnose --json``)."""
    replay = Replay(gb.load_measurement(HIDDEN))
    assert list(Scorer(replay).floors) == objective_signals(replay) == list(replay.data.signals)
    assert len(replay.data.signals) >= 3


def test_the_noise_of_a_record_at_rest_is_its_spread(rig):
    """10 s at rest with AR(1) noise (lag-1 correlation 0.9): each column's standard deviation there
    is its noise within 5 %, where the third differences read a quarter of it."""
    rest = at_rest(rig)
    got = noise_at_rest(rest, ["motor_angle_deg", "load_angle_deg", "current_A", "speed"])
    assert set(got) == set(NOISE)
    for name, std in NOISE.items():
        assert got[name] == pytest.approx(std, rel=0.05)
        assert Replay(rest).noise_floor(name) < 0.35 * std
    # an encoder at rest: at least a count's q/sqrt(12); one that never toggles cannot say
    counts = 0.01 * np.r_[np.zeros(50), np.ones(40), 2 * np.ones(10)]
    assert rest_noise(counts) >= 0.01 / np.sqrt(12)
    with pytest.raises(ValueError, match="motor_angle_deg does not vary at all"):
        rest_noise(np.full(100, 3.0), "motor_angle_deg")
    with pytest.raises(ReplayError, match="none of the compared columns"):
        noise_at_rest(rest, ["motor_position_mm"])


def test_coloured_noise_no_longer_moves_a_right_model(rig):
    """Six 8 s records of the true plant with AR(1) noise (lag-1 correlation 0.9), read from the
    record or stated: no reset, and the motor angle at its noise.  Read from the record's opening
    rest (``Replay.opening_rest``) since 2026-12-07; a record without one (its input not starting at
    zero) is still moved by the noise, as every record was before (18 of 39 window seams, the motor
    angle's error 1.20-1.63x the noise, measured 2026-11-26): that defect is what a stated noise
    removes."""
    moved, worst = 0, 0.0
    for seed in range(6):
        m = coloured(rig, seed)
        for replay in (Replay(m), Replay(m, noise_std=NOISE)):
            ratio, seams = rms_ratio(replay, rig, "motor_angle_deg")
            assert ratio < 1.05 and seams == ()
        ratio, read = rms_ratio(Replay(without_opening_rest(m)), rig, "motor_angle_deg")
        worst = max(worst, ratio)
        moved += len(read)
    assert moved >= 10 and worst > 1.15


def test_a_stated_noise_still_resets_a_model_that_drifts(rig):
    """Coulomb friction (0.5 N m) the plant lacks: the model drifts by degrees a window, and the
    stated noise resets it at the same seams as the noise read from the record."""
    hidden = AddedEffect("coulomb_friction", {"location": "load", "torque": 0.5})
    t, u = excitation("mixed", rig, duration_s=8.0, seed=0)
    m = synthesize(rig, [hidden], t, u, noise=NOISE, seed=0)
    read = Replay(m).run(rig).reinitialised_s
    stated = Replay(m, noise_std=NOISE).run(rig).reinitialised_s
    assert len(read) >= 5 and stated == read


def test_an_effect_that_pays_only_by_moving_the_resets_does_not_pay(rig):
    """``Policy.accepts`` scores both models at the same window seams.  On 16 s of the rig with AR(1)
    noise read from the record, the friction the ladder took from 401d868 to f1114f2 (Stribeck at
    the motor, 4.7e-7 N m) pays by the BIC and the 3 % rule only by moving the resets (8 seams to
    10); the Coulomb friction hidden in a record pays at every seams (its own 0 against the
    model's 5 or more).  Since 2026-12-07 the reset test reads the noise from the record's opening
    rest and moves neither model there, so the record is given without one (the resets of a
    record cut from a running machine)."""
    from gearbench.identify.policy import Policy
    m = coloured(rig, 11, duration_s=16.0, options=SolverOptions(rtol=1e-9, max_step_s=1e-3))
    scorer = Scorer(Replay(without_opening_rest(m)))
    stribeck = rig.with_effects(AddedEffect("stribeck_friction", {
        "location": "motor", "static_torque": 4.65185e-07, "coulomb_torque": 1.2e-15, "stribeck_speed": 80.2824}))
    right, wrong = evaluate(scorer.replay, scorer, rig), evaluate(scorer.replay, scorer, stribeck, 3)
    assert len(right.seams) == 8 and len(wrong.seams) == 10
    assert Policy().pays(scorer, right, wrong) and not Policy().accepts(scorer, right, wrong)
    hidden = AddedEffect("coulomb_friction", {"location": "load", "torque": 0.5})
    t, u = excitation("mixed", rig, duration_s=8.0, seed=0)
    scorer = Scorer(Replay(synthesize(rig, [hidden], t, u, noise=NOISE, seed=0)))
    without, found = evaluate(scorer.replay, scorer, rig), evaluate(scorer.replay, scorer, rig.with_effects(hidden), 1)
    assert len(without.seams) >= 5 and found.seams != without.seams
    assert Policy().accepts(scorer, without, found)


@pytest.mark.parametrize("noise,words", [
    ({"bogus": 1.0}, ["'bogus'", "not a compared column", "motor_angle_deg, load_angle_deg, current_A"]),
    ({"load_angle_deg": 0.0}, ["noise_std['load_angle_deg']", "> 0 in deg", "0.0"]),
    ({"current_A": -1.0}, ["noise_std['current_A']", "> 0 in A"]),
    ({"current_A": float("nan")}, ["noise_std['current_A']", "> 0 in A"]),
    ({"current_A": True}, ["noise_std['current_A']", "True"]),
    ([0.01], ["must be a dict"]),
])
def test_a_bad_stated_noise_names_the_column_and_unit(noise, words):
    data = gb.load_measurement(HIDDEN)
    with pytest.raises(ReplayError) as err:
        Replay(data, noise_std=noise)
    for w in words:
        assert w in str(err.value)


def test_the_api_and_the_cli_take_the_noise(tmp_path):
    c = gb.compare(RIG, HIDDEN, noise_std={"load_angle_deg": 0.05})
    assert c.to_pandas().loc["load_angle_deg", "noise_floor"] == 0.05
    with pytest.raises(ConfigError, match="noise_std must be a mapping"):
        gb.compare(RIG, HIDDEN, noise_std=[0.05])
    run = CliRunner().invoke(main, ["compare", str(RIG), str(HIDDEN), "--noise", "all=0.04", "--noise",
                                    "current_A=0.002", "--json", "--results", str(tmp_path)])
    assert run.exit_code == 0, run.output
    floors = {r["signal"]: r["noise_floor"] for r in json.loads(run.stdout)["signals"]}
    assert floors == {"motor_angle_deg": 0.04, "load_angle_deg": 0.04, "current_A": 0.002}
    rest = tmp_path / "rest.csv"
    m = at_rest(load_plant(RIG))
    pd.DataFrame({"time_s": m.time_s, "voltage_V": m.input, **m.signals}).to_csv(rest, index=False)
    run = CliRunner().invoke(main, ["compare", str(RIG), str(HIDDEN), "--noise-from", str(rest), "--noise",
                                    "current_A=0.002", "--json", "--results", str(tmp_path)])
    assert run.exit_code == 0, run.output
    floors = {r["signal"]: r["noise_floor"] for r in json.loads(run.stdout)["signals"]}
    assert floors["current_A"] == 0.002          # --noise wins
    assert floors["load_angle_deg"] == pytest.approx(NOISE["load_angle_deg"], rel=0.05)
    for bad, said in (("load_angle_deg=0", "standard deviation > 0"), ("load_angle_deg", "SIGNAL=STD"),
                      ("speed=1", "'speed' is not a compared column")):
        run = CliRunner().invoke(main, ["diagnose", str(RIG), str(HIDDEN), "--noise", bad, "--json"])
        assert run.exit_code == 2 and said in run.output, run.output


def _tests(independent: dict[str, bool]):
    """Residual tests of made-up residuals: a correlated one copies the input."""
    rng = np.random.default_rng(0)
    u = np.repeat(rng.choice([-1.0, 1.0], 40), 50)
    e = np.convolve(rng.standard_normal(u.size), np.ones(10) / 10, "same")
    return {n: residual_test(e + (0 if ok else 0.5 * u), u, n, "voltage_V") for n, ok in independent.items()}


def test_a_residual_the_input_does_not_drive_is_not_called_missing_physics():
    reason = "no candidate explains the residual: ...; the missing physics is not in the library"
    data = gb.load_measurement(HIDDEN)
    said = _not_driven(reason, _tests({"load_angle_deg": True, "current_A": True}), Replay(data))
    assert "not in the library" not in said
    assert "independent of the input voltage_V on every signal but not white" in said and "--noise" in said
    stated = Replay(data, noise_std={"load_angle_deg": 0.01, "current_A": 0.01})
    assert "noise larger than stated" in _not_driven(reason, _tests({"load_angle_deg": True, "current_A": True}),
                                                     stated)
    # one column the input drives: the reason stands
    assert _not_driven(reason, _tests({"load_angle_deg": True, "current_A": False}), Replay(data)) == reason


@pytest.mark.slow
@pytest.mark.parametrize("case", ["nothing hidden", "coulomb friction"])
def test_diagnose_with_coloured_noise_measured_at_rest(rig, case):
    """16 s of the bench rig, made at rtol 1e-9, AR(1) noise (lag-1 correlation 0.9), the noise
    stated as a user would measure it: its spread in 10 s of the rig at rest.  Measured
    2026-11-26 (2 cores): nothing hidden, verdict null at the noise floor (0.996x, 33 s); Coulomb
    friction hidden, found at 0.5000 N m and the ladder at the noise floor (26 s).  Read from the record instead, the floors are a quarter of the noise: nothing
    hidden ended 'nothing pays' at 3.58x, and with the friction hidden it took 132 s to end at 3.59x."""
    hidden = [AddedEffect("coulomb_friction", {"location": "load", "torque": 0.5})] if case != "nothing hidden" else []
    m = coloured(rig, 11, hidden, duration_s=16.0, options=SolverOptions(rtol=1e-9, max_step_s=1e-3))
    d = diagnose(rig, Replay(m, noise_std=noise_at_rest(at_rest(rig), list(NOISE))))
    j = d.to_json()
    assert d.stopped == "noise floor", (d.reason, j["ladder"])
    assert all(v["stated"] for v in j["noise_floors"].values())
    if not hidden:
        assert d.verdict is None and j["ladder"] == []
    else:
        assert d.verdict == "coulomb_friction" and [s["effect"] for s in j["ladder"]] == ["coulomb_friction"]
        assert j["ladder"][0]["params"]["torque"] == pytest.approx(0.5, rel=0.02)


@pytest.mark.slow
def test_diagnose_with_coloured_noise_read_from_the_record_says_what_is_left(rig):
    """The same record, nothing hidden, the noise not stated: the floors are a quarter of the noise,
    nothing pays at 3.6x, and the reason says the residual is not driven by the input instead of
    'the missing physics is not in the library' (measured 2026-11-26 on this record, 30 s).  On
    other seeds the resets' moves make the motor angle's residual correlate with the input, and
    the reason stays (issue 17).

    The resets fire on that noise, and an effect can pay by moving them: a Stribeck friction of
    4.7e-7 N m at the motor (1e-5 of its typical 0.048) moved them from 8 window seams to 10 and
    the weighted RMS from 3.579 to 3.470 (3.04 %, past the 3 % rule; taken from 401d868 to
    f1114f2).  With the resets at the same seams it does not pay (3.669 at the right model's, the
    right model 3.502 at its own), and ``Policy.accepts`` now asks that (2026-11-28, 36 s).  Since a
    fit ends no worse than its start by the replay's own resets (``fit._rounds``, bab4078) that
    friction no longer ends at a false seam; the best candidate is a bias of -1.1e-6 N m, which pays
    by no resets (BIC change -51.5 counting the residual's correlation, weighted RMS 3.579 -> 3.521;
    2026-12-02, 37 s), and the reason gives its numbers (what the reason says of a candidate that
    pays only by its resets: ``test_a_candidate_that_pays_only_by_its_resets_is_said_so``).  Since
    2026-12-07 the resets read the noise from the record's opening rest and do not fire on it."""
    m = coloured(rig, 11, duration_s=16.0, options=SolverOptions(rtol=1e-9, max_step_s=1e-3))
    d = diagnose(rig, Replay(m))
    assert d.verdict is None and d.stopped == "nothing pays"
    assert "would take the error to" in d.reason and "BIC change" in d.reason
    assert "not driven by the input" in d.reason and "not in the library" not in d.reason
    assert all(t["input_independent"] and not t["white"] for t in d.to_json()["residual_tests"].values())


def test_a_candidate_that_pays_only_by_its_resets_is_said_so(monkeypatch):
    """``explain.seams_text``: a candidate that pays by its own window resets (``Policy.pays``) but
    not with the model's (``Policy.accepts``) is said to pay only by where the replay resets the
    angles, with both models scored at each other's seams; one that does not pay by its own says
    nothing."""
    from types import SimpleNamespace
    from gearbench.identify import explain
    current = SimpleNamespace(seams=(0, 1000), weighted_rms=3.579)
    new = SimpleNamespace(seams=(0, 1000, 2000, 3000), weighted_rms=3.470)
    rescored = {id(new): SimpleNamespace(weighted_rms=3.669), id(current): SimpleNamespace(weighted_rms=3.502)}
    monkeypatch.setattr(explain, "at_seams", lambda scorer, res, seams: rescored[id(res)])
    for pays in (True, False):
        ctx = SimpleNamespace(scorer=None, policy=SimpleNamespace(pays=lambda scorer, a, b: pays))
        text = explain.seams_text(ctx, current, new)
        if pays:
            assert "pay only by where the replay resets the angles (at 4 window seams against the model's 2)" in text
            assert "the model's give it 3.669x against 3.579x, and its own give the model 3.502x against 3.47x" in text
        else:
            assert text == ""
