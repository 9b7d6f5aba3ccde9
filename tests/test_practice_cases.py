"""The practice cases (data/cases/, an independent event-driven simulator with the truth beside
each record) are in the repository and read by gearbench's own loaders: every file is there,
loads, and says what data/cases/README.md says it does; the true plant replays every record to
its noise, p05-p13's real sensors (coloured noise, no load angle, 250 Hz, quantized encoders, an
offset) and other plants and excitations too; diagnose on excerpts of p02 (a spring and a dry
friction), p04 (datasheet values off and a spring), p05 (coloured noise), p06 (p02's effects
without the load angle), p09 (a backlash seen from the motor side only) and p13 (null, quantized,
an offset) takes what is there and nothing more; and (slow) what diagnose makes of p01-p04 is
the truth."""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
import yaml

from conftest import DATA
from gearbench.experiment.files import load_plant, plant_from_dict
from gearbench.identify.compare import comparison
from gearbench.identify.fit import evaluate
from gearbench.identify.refit import refit
from gearbench.identify.replay import Replay, stated_noise
from gearbench.identify.scoring import Scorer
from gearbench.measure.data import from_arrays, read_measurement
from gearbench.plant.effects import AddedEffect

CASES = ("p01", "p02", "p03", "p04")
EXPECTED = {"p01": "stribeck_friction", "p02": "coulomb_friction", "p03": "backlash", "p04": "load_spring"}


def true_plant(truth: dict, case: str):
    """The truth file's plant as a gearbench plant: its effects are written ``{effect, params}``
    with SI parameters (``rest_angle`` in rad), a plant file's as ``{type, ...}`` (``rest_angle_deg``)."""
    raw = dict(truth["true_plant"])
    effects = []
    for e in raw.get("effects", []):
        params = dict(e["params"])
        if "rest_angle" in params:
            params["rest_angle_deg"] = math.degrees(params.pop("rest_angle"))
        effects.append({"type": e["effect"], **params})
    raw["effects"] = effects
    return plant_from_dict(raw, name=f"{case} truth")


@pytest.mark.parametrize("case", CASES)
def test_case_loads(case):
    folder = DATA / "cases" / case
    nominal = load_plant(folder / "nominal.yaml")
    truth = yaml.safe_load((folder / "truth.yaml").read_text())
    truth_plant = true_plant(truth, case)
    record = read_measurement(folder / "data.csv")

    assert nominal.effects == ()
    assert truth["case"] == case
    assert EXPECTED[case] in {e["effect"] for e in truth["hidden_effects"]}
    assert {e.name for e in truth_plant.effects} <= {e["effect"] for e in truth["hidden_effects"]}
    # 1 kHz, about 16 s, the SPEC's open-loop columns
    dt = np.diff(record.time_s)
    assert np.allclose(dt, 1e-3, atol=1e-9)
    assert 15.0 < record.time_s[-1] < 20.0
    assert set(record.signals) == {"motor_angle_deg", "load_angle_deg", "current_A"}
    # the nominal plant is the true one but for the hidden effect (and, in p04, the datasheet errors)
    assert nominal.gear.ratio == truth_plant.gear.ratio
    off = truth.get("datasheet_errors") or {}
    assert bool(off) == (case == "p04")
    for key, pair in off.items():
        part, field = key.split(".")
        assert getattr(getattr(nominal, part), field) == pytest.approx(pair["nominal"])
        assert getattr(getattr(truth_plant, part), field) == pytest.approx(pair["true"])
        assert pair["nominal"] != pytest.approx(pair["true"], rel=0.01)


@pytest.mark.parametrize("case", CASES)
def test_the_true_plant_replays_the_independent_record_to_its_noise(case):
    """Each case's true plant needs nothing gearbench lacks (an impact-pair backlash,
    stick-slip friction), so gearbench's replay of it, re-initialised every second as
    ``compare`` does, matches the independent event-driven simulator down to the record's
    noise on every channel.  (Before, the replay measured its drift on the difference of the
    two trajectories, a reset mid-crossing of the clearance moved p03's right model by
    0.35 deg: 38x the noise; and before friction stuck by events, p01's true Stribeck
    friction, regularized, left the motor angle at 2.56x its noise.)"""
    truth = yaml.safe_load((DATA / "cases" / case / "truth.yaml").read_text())
    plant = true_plant(truth, case)
    replay = Replay(read_measurement(DATA / "cases" / case / "data.csv"), window_s=1.0)
    rows = {r["signal"]: r for r in comparison(replay, plant)["signals"]}
    for name, sigma in truth["noise_sigma"].items():
        assert rows[name]["noise_floor"] == pytest.approx(sigma, rel=0.1)
        assert rows[name]["ratio_to_noise"] < 1.05, (name, rows[name])
    # and without the hidden effects (the nominal plant) it does not: the missing effect shows
    nominal = comparison(replay, load_plant(DATA / "cases" / case / "nominal.yaml"))["signals"]
    assert max(r["ratio_to_noise"] for r in nominal) > 20


def test_regularized_friction_does_not_replay_true_stick_slip():
    """p01's Stribeck friction at the load with the tanh law (model: regularized): the
    stuck output shaft creeps, and the motor angle misses by 2.56x its noise (measured
    2026-11-25), where the event-driven law is at 0.96x."""
    truth = yaml.safe_load((DATA / "cases" / "p01" / "truth.yaml").read_text())
    plant = true_plant(truth, "p01")
    smooth = replace(plant, effects=tuple(AddedEffect(e.name, {**e.values, "model": "regularized"})
                                          for e in plant.effects))
    replay = Replay(read_measurement(DATA / "cases" / "p01" / "data.csv"), window_s=1.0)
    rows = {r["signal"]: r["ratio_to_noise"] for r in comparison(replay, smooth)["signals"]}
    assert rows["motor_angle_deg"] > 2.0, rows


def hidden_in_gearbench_keys(truth: dict) -> dict[str, dict]:
    """The truth file's hidden effects by name, with gearbench's parameter keys: a hidden
    clearance as ``backlash_deg``, a rest angle in degrees."""
    out = {}
    for e in truth["hidden_effects"]:
        params = dict(e["params"])
        if e["effect"] == "backlash":
            params = {"backlash_deg": params["clearance_deg"]}
        if "rest_angle" in params:
            params["rest_angle_deg"] = math.degrees(params.pop("rest_angle"))
        out[e["effect"]] = params
    return out


REST_ANGLE_TOL_DEG = 1.0
"""A rest angle whose truth is 0 has no relative tolerance: 1 deg, under 0.3 % of the load's
travel in p02 (hundreds of degrees)."""


@pytest.mark.slow
@pytest.mark.parametrize("case", ("p01", "p02", "p03", "p04"))
def test_diagnose_finds_the_hidden_effects(case):
    """diagnose over the whole library on the practice case: the verdict is the expected one,
    the final model holds every hidden effect with each parameter within 15 % of the truth, and
    the ladder ends within 1.2x the noise floor.  p01 and p02 are true stick-slip records: they
    pass with the event-driven stick-slip friction (and passed with the regularised law before
    it).  p04's plant file has datasheet values 5-10 % off (``datasheet_errors``): diagnose
    calibrates them, each within 5 % of the truth.  (2 cores, stick-slip: p01 86 s, p02 122 s,
    p03 624 s before calibration; p04 414 s with it, loaded)"""
    from gearbench.identify.diagnose import diagnose

    folder = DATA / "cases" / case
    truth = yaml.safe_load((folder / "truth.yaml").read_text())
    d = diagnose(load_plant(folder / "nominal.yaml"), Replay(read_measurement(folder / "data.csv")))
    expected = truth["expected_verdict"]
    assert d.verdict in (expected if isinstance(expected, list) else [expected]), (d.reason, d.to_json()["ladder"])
    final = {e.name: e.values for e in d.plant.effects}
    hidden = hidden_in_gearbench_keys(truth)
    assert set(final) == set(hidden), (final, d.to_json()["ladder"])
    for name, params in hidden.items():
        for key, value in params.items():
            if key == "location":
                assert final[name][key] == value, (name, final[name])
            elif value == 0.0:
                assert final[name][key] == pytest.approx(0.0, abs=REST_ANGLE_TOL_DEG), (name, key, final[name])
            else:
                assert final[name][key] == pytest.approx(value, rel=0.15), (name, key, final[name])
    assert d.ladder[-1].error <= 1.2 * d.noise_floor, (d.ladder[-1].error, d.noise_floor)
    for path, values in truth.get("datasheet_errors", {}).items():
        section, key = path.split(".")
        got = getattr(getattr(d.plant, section), key)
        assert got == pytest.approx(values["true"], rel=0.05), (path, got, values, d.to_json()["calibration"])


def excerpt(case: str, seconds: float):
    """The first ``seconds`` of a practice record, as a DataFrame (what a user would pass)."""
    import pandas as pd
    df = pd.read_csv(DATA / "cases" / case / "data.csv")
    return df[df["time_s"] < seconds]


def test_diagnose_takes_only_the_friction_under_independent_coloured_noise():
    """p05's first 6 s (the independent simulator: Stribeck friction at the load, true stick-slip,
    AR(1) noise of lag-1 correlation 0.95 on both angles, read from the record), among the dry
    frictions and a bias: the ladder takes the Stribeck friction at the load and nothing after it,
    the coloured noise paying no second rung, each value within 4 standard errors of the truth
    (measured 2026-11-29: within 0.6 of them, 14 s)."""
    import gearbench as gb
    truth = yaml.safe_load((DATA / "cases" / "p05" / "truth.yaml").read_text())
    d = gb.diagnose(DATA / "cases" / "p05" / "nominal.yaml", excerpt("p05", 6.0),
                    only=("stribeck_friction", "coulomb_friction", "bias_torque")).diagnosis
    assert [(s.effect, s.options) for s in d.ladder] == [("stribeck_friction", {"location": "load"})], d.reason
    step, (hidden,) = d.ladder[0], truth["hidden_effects"]
    for key in ("static_torque", "coulomb_torque", "stribeck_speed"):
        assert abs(step.params[key] - hidden["params"][key]) <= 4 * step.stderr[key], (key, step.params, step.stderr)


def test_diagnose_finds_a_backlash_seen_from_the_motor_side_only():
    """p09's first 6 s (the independent simulator: a 2 deg clearance the nominal plant leaves out,
    no load angle, the motor angle on a 4096-count encoder), among the clearance, a dry friction
    and a spring: the ladder takes exactly the backlash, within 4 standard errors of the truth,
    and ends at the noise floors (measured 2026-11-29: 1.99974 +- 0.00022 deg, 8 s beside other
    work)."""
    import gearbench as gb
    truth = yaml.safe_load((DATA / "cases" / "p09" / "truth.yaml").read_text())
    d = gb.diagnose(DATA / "cases" / "p09" / "nominal.yaml", excerpt("p09", 6.0),
                    only=("backlash", "coulomb_friction", "load_spring")).diagnosis
    assert [s.effect for s in d.ladder] == ["backlash"], d.reason
    assert d.stopped == "noise floor"
    step, (hidden,) = d.ladder[0], truth["hidden_effects"]
    assert abs(step.params["backlash_deg"] - hidden["params"]["clearance_deg"]) <= 4 * step.stderr["backlash_deg"]


def test_diagnose_keeps_a_null_record_under_real_sensors_null():
    """p13's first 6 s (the independent simulator, nothing hidden: a 2048-count motor encoder and
    a 4000-count load encoder, both rounded, the current read 8 mA low): over the whole library
    the ladder takes only the current sensor's offset, within 4 standard errors of the sensor's
    -8 mA, and ends at the noise floors (measured 2026-11-29: -7.961 mA +- 0.050, 11 s).  The offset
    reaches the floors with one value, so no calibration of the datasheet values could rank above it,
    and none is tried (``refit.out_of_reach``): each value says why."""
    import gearbench as gb
    truth = yaml.safe_load((DATA / "cases" / "p13" / "truth.yaml").read_text())
    data = excerpt("p13", 6.0)
    d = gb.diagnose(DATA / "cases" / "p13" / "nominal.yaml", data).diagnosis
    assert [(s.effect, s.options) for s in d.ladder] == [("sensor_offset", {"signal": "current_A"})], d.reason
    assert d.stopped == "noise floor"
    step = d.ladder[0]
    assert abs(step.params["offset"] - truth["noise_model"]["current_A"]["offset"]) <= 4 * step.stderr["offset"]
    # at 1 kHz the floors read from the record are the noise's: none is above what the model leaves
    assert not any(f["over_read"] for f in d.to_json()["noise_floors"].values()) and "upper bound" not in d.reason
    assert "calibration" not in {s["stage"] for s in d.timing["stages"]}
    kept = [row for row in d.to_json()["calibration"].values() if row["status"] != "held"]
    assert kept and all(row["status"] == "file value" and "so it was not tried" in row["message"] for row in kept)


def final_model_fit(d, data):
    """The diagnosis' final model refitted from where it ended (its effects' parameters free): the
    values with their standard errors, as ``gearbench fit`` would give them."""
    import gearbench as gb
    from gearbench.identify.fit import fit
    from gearbench.identify.refit import frees_of
    from gearbench.identify.scoring import Scorer
    replay = Replay(gb.load_measurement(data))
    return fit(replay, d.plant, frees_of(replay, d.plant, (), range(len(d.plant.effects))), Scorer(replay))


def test_diagnose_finds_a_spring_and_a_dry_friction_together():
    """p02's first 6 s (the independent simulator: a load spring 0.8 N m/rad at rest angle 0 and a
    Coulomb friction 0.05 N m at the load, true stick-slip), among the spring, the friction and a
    bias (which a spring's rest angle trades off with): the ladder takes the spring and the friction,
    ends at the noise floors, and the final model refitted holds each value within 4 standard
    errors of the truth (measured 2026-11-29: 0.8000002 +- 0.0000003, rest angle 0.000006 +- 0.000034
    deg, 0.0500004 +- 0.0000011 N m; 7 s)."""
    import gearbench as gb
    truth = yaml.safe_load((DATA / "cases" / "p02" / "truth.yaml").read_text())
    data = excerpt("p02", 6.0)
    d = gb.diagnose(DATA / "cases" / "p02" / "nominal.yaml", data,
                    only=("load_spring", "bias_torque", "coulomb_friction")).diagnosis
    assert sorted((s.effect, s.action) for s in d.ladder) == [("coulomb_friction", "add"), ("load_spring", "add")], d.reason
    assert d.stopped == "noise floor"
    final = final_model_fit(d, data)
    assert final.converged
    hidden = hidden_in_gearbench_keys(truth)
    index = {e.name: i for i, e in enumerate(d.plant.effects)}
    assert d.plant.effects[index["coulomb_friction"]].values["location"] == "load"
    for name, params in hidden.items():
        for key, value in params.items():
            if key == "location":
                continue
            got = final.params[f"effects[{index[name]}].{key}"]
            assert abs(got.value - value) <= 4 * got.stderr, (name, key, got)


def test_diagnose_finds_a_spring_and_a_dry_friction_without_the_load_angle():
    """p06's first 10 s (the independent simulator: p02's spring and Coulomb friction at the load,
    the load angle not recorded: the motor angle and the current alone), among the spring, the
    friction and a bias: the ladder takes the spring and the friction at the load, ends at the
    noise floors, and the final model refitted holds each value within 4 standard errors of the
    truth (measured 2026-11-29: 0.8000004 +- 0.0000002, rest angle 0.00002 +- 0.00002 deg,
    0.0500004 +- 0.0000009 N m; 16 s).  Its first 6 s were not enough: three Coulomb frictions and
    the load's at a fifth of the truth."""
    import gearbench as gb
    truth = yaml.safe_load((DATA / "cases" / "p06" / "truth.yaml").read_text())
    data = excerpt("p06", 10.0)
    assert "load_angle_deg" not in data.columns
    d = gb.diagnose(DATA / "cases" / "p06" / "nominal.yaml", data,
                    only=("load_spring", "bias_torque", "coulomb_friction")).diagnosis
    assert [(s.effect, s.action) for s in d.ladder] == [("load_spring", "add"), ("coulomb_friction", "add")], d.reason
    assert d.ladder[1].options == {"location": "load"} and d.stopped == "noise floor"
    final = final_model_fit(d, data)
    assert final.converged
    for name, params in hidden_in_gearbench_keys(truth).items():
        i = [e.name for e in d.plant.effects].index(name)
        for key, value in params.items():
            if key != "location":
                got = final.params[f"effects[{i}].{key}"]
                assert abs(got.value - value) <= 4 * got.stderr, (name, key, got)


@pytest.fixture(scope="module")
def p04_excerpt():
    """p04's first 10 s (the independent simulator: a load spring 0.6 N m/rad, and a plant file whose
    resistance is 10 % high, motor constant 5 % low and load inertia 8 % low), diagnosed among the
    spring, a bias and a dry friction: (truth, record, diagnosis)."""
    import gearbench as gb
    truth = yaml.safe_load((DATA / "cases" / "p04" / "truth.yaml").read_text())
    data = excerpt("p04", 10.0)
    d = gb.diagnose(DATA / "cases" / "p04" / "nominal.yaml", data,
                    only=("load_spring", "bias_torque", "coulomb_friction")).diagnosis
    return truth, data, d


def test_diagnose_calibrates_datasheet_values_and_prunes_what_they_explained(p04_excerpt):
    """On p04's excerpt the ladder takes the spring, then a Coulomb friction that stands in for the
    datasheet errors, calibrates the six datasheet values and takes the friction out (issue 37,
    part 7): the final model is the spring alone, within 15 % of the truth, each datasheet value
    within 5 % of the truth (the bars of the slow whole-record test), at the noise floors and within
    1.2x the record's noise (measured 2026-11-29: the spring 0.600033, resistance 1.09995 for
    1.1, motor constant 0.0430005 for 0.043, load inertia 0.00120003 for 0.0012; 21 s)."""
    truth, _, d = p04_excerpt
    assert [(s.effect, s.action) for s in d.ladder] == [
        ("load_spring", "add"), ("coulomb_friction", "add"), ("coulomb_friction", "remove")], d.reason
    assert d.calibration_step is not None and d.stopped == "noise floor"
    assert [e.name for e in d.plant.effects] == ["load_spring"]
    assert d.plant.effects[0].values["stiffness"] == pytest.approx(0.6, rel=0.15)
    assert d.plant.effects[0].values["rest_angle_deg"] == pytest.approx(0.0, abs=REST_ANGLE_TOL_DEG)
    for path, values in truth["datasheet_errors"].items():
        section, key = path.split(".")
        assert getattr(getattr(d.plant, section), key) == pytest.approx(values["true"], rel=0.05), path
    sigma = truth["noise_sigma"][d.signal]  # white noise: p01-p04 give its standard deviation
    assert d.ladder[-1].error <= 1.2 * sigma, (d.ladder[-1].error, sigma)


def test_each_calibrated_value_and_the_spring_lie_within_four_standard_errors_of_the_truth(p04_excerpt):
    """On p04's excerpt: each of the six datasheet values the diagnosis calibrated, and the spring
    refitted beside them, within 4 of their standard errors of the truth.  These estimates trade off
    (correlations near 1), and their errors are taken with steps of a standard error
    (``fit._sharp_jacobian``): with the fit's own 0.1 % steps the resistance was 4.9 and the spring
    5.6 standard errors away (measured 2026-11-29, before; now 2.0 and 2.3)."""
    from gearbench.identify import calibration
    from gearbench.identify.fit import Free, fit, param_value
    from gearbench.identify.refit import frees_of
    from gearbench.identify.scoring import Scorer
    import gearbench as gb
    truth, data, d = p04_excerpt
    true = true_plant(truth, "p04")
    for label, row in d.calibration.items():
        path = label.split(" ~ ")[0]
        want = param_value(true, Free.plant(true, path))
        assert row["status"] == "calibrated" and abs(row["value"] - want) <= 4 * row["stderr"], (label, row, want)
    replay = Replay(gb.load_measurement(data))
    scorer = Scorer(replay)
    joint = fit(replay, d.plant, frees_of(replay, d.plant, calibration.plan(d.plant, replay, scorer).frees, [0]), scorer)
    got = joint.params["effects[0].stiffness"]
    assert joint.converged and abs(got.value - 0.6) <= 4 * got.stderr, got


REAL_SENSOR_CASES = ("p05", "p06", "p07", "p08", "p09", "p10", "p11", "p12", "p13")
"""The practice cases with a real rig's sensors (coloured noise, no load angle, 250 Hz, quantized
encoders, a current offset) and, from p10, their own plants and excitations."""


def offsets(truth: dict) -> dict[str, float]:
    """A sensor's constant offset per column: ``realism.offset`` (p05-p09) or ``noise_model``'s."""
    out = dict((truth.get("realism") or {}).get("offset") or {})
    out.update({k: m["offset"] for k, m in (truth.get("noise_model") or {}).items() if "offset" in m})
    return out


def replay_of_the_truth(case: str, window_s: float) -> tuple[dict, dict[str, float]]:
    """The truth file and, per recorded column, the RMS residual of the true plant (with the record's
    sensor offsets as ``sensor_offset`` effects) over the column's true noise."""
    folder = DATA / "cases" / case
    truth = yaml.safe_load((folder / "truth.yaml").read_text())
    record = read_measurement(folder / "data.csv")
    plant = true_plant(truth, case)
    plant = replace(plant, effects=plant.effects + tuple(
        AddedEffect("sensor_offset", {"signal": k, "offset": v}) for k, v in offsets(truth).items()))
    rows = {r["signal"]: r for r in comparison(Replay(record, window_s=window_s), plant)["signals"]}
    return truth, {name: rows[name]["rms_error"] / truth["true_noise"][name] for name in rows}


@pytest.mark.parametrize("case", REAL_SENSOR_CASES)
def test_the_true_plant_replays_each_real_sensor_record_to_its_true_noise(case):
    """gearbench's simulator against the independent one under a real rig's sensors, rates and
    excitations: the true plant, replayed open loop over the whole record (no re-initialisation,
    the voltage held at the record's rate: 250 Hz in p07 and p12), leaves on every recorded
    column a residual at the record's true noise, the RMS of everything that is noise there
    (coloured, quantized: the model is not quantized, so the rounding is in the residual as
    ``true_noise`` counts it).  Measured 0.98-1.02 on every column of p05-p13.  The records'
    columns are the ones the truth lists."""
    truth, ratios = replay_of_the_truth(case, window_s=0.0)
    assert set(ratios) == set(truth["true_noise"]) - {"current_A (mean, the offset)"}
    assert all(0.95 < r < 1.05 for r in ratios.values()), ratios


@pytest.mark.parametrize("case", REAL_SENSOR_CASES)
def test_window_resets_keep_the_true_plant_at_its_noise(case):
    """Re-initialised every second, the true plant still leaves every column at its true noise: the
    resets move no right model, white noise or coloured.  Until 2026-12-07 a strict xfail on p10
    (AR(1) angle noise, lag-1 correlation 0.9): its one reset, at 10.525 s, was false and left the
    motor angle at 1.59x its true noise (the per-second RMS 0.08-0.12 deg after t = 10 s, against
    0.04 before), because the reset's test (``Replay._reset_angles``: a straight line through the
    last 21 samples' difference, moved past 5 of its standard errors) took the standard error from
    those 21 samples, which cannot see a correlation of 0.9; widening it by the previous window's
    whole residual fixed p10 but lost the hidden shaft compliance of ``studies.hidden_effects``.
    The test now also takes the error such a line has through the noise of the record's opening
    rest, which does not move with the model."""
    _, ratios = replay_of_the_truth(case, window_s=1.0)
    assert all(r < 1.05 for r in ratios.values()), ratios


def test_a_record_without_its_opening_rest_needs_the_noise_stated():
    """p10 cut where its input first leaves zero: no opening rest to read the noise's colour from,
    so the reset test has the 21 samples' scatter alone and the noise moves the true plant (6
    false resets, the motor angle at 1.45x its true noise, 2026-12-07); with the cut-off rest given
    as the record at rest (``--noise-from``), its noise's standard deviation is the test's least
    error, and the true plant is left at its noise."""
    folder = DATA / "cases" / "p10"
    truth = yaml.safe_load((folder / "truth.yaml").read_text())
    record = read_measurement(folder / "data.csv")
    plant = true_plant(truth, "p10")
    k = Replay(record).opening_rest()

    def part(s: slice, name: str):
        return from_arrays(record.time_s[s], record.input_name, record.input[s],
                           {n: v[s] for n, v in record.signals.items()}, source=name)

    moving, rest = part(slice(k - 1, None), "p10 from its last sample at rest"), part(slice(0, k), "p10's opening rest")
    for replay, moved in ((Replay(moving), True), (Replay(moving, noise_std=stated_noise(moving, False, None, rest)), False)):
        assert replay.opening_rest() == 1
        run = replay.run(plant)
        ratio = max(r["rms_error"] / truth["true_noise"][r["signal"]] for r in comparison(replay, plant, run)["signals"])
        assert (len(run.seams) >= 3 and ratio > 1.2) if moved else (run.seams == () and ratio < 1.05), (run.seams, ratio)


def test_the_simplifications_refit_on_coloured_noise_lands_on_the_truth():
    """p10 (coloured noise, a Coulomb friction of 0.03 N m at the load): diagnose simplifies a
    Stribeck law to Coulomb friction by refitting the latter from the former's sliding level
    (``Effect.simpler``).  From the law p10's diagnosis ended with on 2026-12-02, the Coulomb
    friction wins on BIC, with no window reset, and its standard error covers the truth.
    Until 2026-12-07 that refit's least squares ended with a reset at a false seam (10.525 s, the
    one ``test_window_resets_keep_the_true_plant_at_its_noise`` no longer sees), worse than its
    start (RSS 622,479 against 589,543; ``fit._rounds`` then kept the start, ``test_secant.py``)
    and 21 standard errors (1.7e-7 N m) from the truth; now RSS 454,768, 1.8 of 8.5e-8 away."""
    folder = DATA / "cases" / "p10"
    truth = yaml.safe_load((folder / "truth.yaml").read_text())["hidden_effects"][0]["params"]["torque"]
    plant = load_plant(folder / "nominal.yaml")
    replay = Replay(read_measurement(folder / "data.csv"))
    scorer = Scorer(replay)
    law = AddedEffect("stribeck_friction", {"location": "load", "static_torque": 0.039843129494210164,
                                            "coulomb_torque": 0.029996428833628415,
                                            "stribeck_speed": 0.00021926658881757778})
    stribeck = evaluate(replay, scorer, plant.with_effects(law))
    coulomb = plant.with_effects(AddedEffect(*law.effect.simpler(law.values)))
    start = evaluate(replay, scorer, coulomb)
    got = refit(replay, scorer, coulomb, (), (0,))
    assert got.converged and got.rss <= start.rss and got.seams == (), (got.message, got.seams)
    assert got.bic < replace(stribeck, k=3).bic
    torque = got.params["effects[0].torque"]
    assert abs(torque.value - truth) <= 3.0 * torque.stderr, torque


def test_a_fit_of_an_absent_friction_stops_at_its_floor_above_the_chatter():
    """p03 (the independent simulator: a clearance hidden, no friction; the whole 16 s) fitted with
    a Coulomb friction at the load: the level walks down to the fit's floor, 1e-3 of the location's
    typical torque (``location.stick_slip_floor``), and stops there.  Below the floor the replay
    chatters at its tolerance (rtol 1e-6): a body at rest sticks and breaks away at every turn of
    its speed, so a replay at a tenth of the floor locates several times the events it does at the
    floor (measured 2026-11-29: 14,096 events at a tenth of the floor, 856 at it, 935 at ten times
    it; the fit ends at the floor in 15 replays and 4 s).  That chatter is the tolerance's, which
    is what the floor is for: at rtol 1e-7, 1e-8 and 1e-9 a tenth of the floor locates 709, 803
    and 1,302 events (2026-12-03).  How the counts at the floor and at ten times it compare is not
    asserted: it moves with the step sequence (rtol 1e-6 to 1e-9: 856, 696, 971, 2,212 at the
    floor against 935, 1,344, 1,645, 1,770 at ten times it).  On its first 4 or 8 s the fit stops
    on its cost's tolerance at 2.1 and 1.4 times the floor."""
    import gearbench as gb
    from gearbench.identify.candidates import fit_effect
    from gearbench.plant.effects.location import stick_slip_floor
    plant = load_plant(DATA / "cases" / "p03" / "nominal.yaml")
    replay = Replay(gb.load_measurement(DATA / "cases" / "p03" / "data.csv"))
    floor = stick_slip_floor(plant, {"location": "load"})

    def events(level):
        return replay.run(plant.with_effects(AddedEffect("coulomb_friction",
                                                         {"location": "load", "torque": level}))).events

    assert events(0.1 * floor) > 3 * events(floor)
    (tried,) = fit_effect(plant, replay, "coulomb_friction", {"location": "load"})
    assert tried.result.converged
    assert tried.params["torque"] == pytest.approx(floor, rel=1e-6)


def test_a_multistart_ends_at_the_first_fit_that_reaches_the_noise_floors(monkeypatch):
    """p01 (the independent simulator: Stribeck friction at the load; the whole 16 s) fitted with
    that friction: the scan's best start explains the record down to its noise floors, so the
    second start is not fitted (``refit.AT_FLOORS``; before, it took 79 least-squares residuals
    to end 0.003 lower in an RSS of 46,117, measured 2026-11-30), and the values lie within four
    standard errors of the truth."""
    import gearbench as gb
    from gearbench.identify import candidates as C
    from gearbench.identify.candidates import fit_effect
    from gearbench.identify.refit import AT_FLOORS
    plant = load_plant(DATA / "cases" / "p01" / "nominal.yaml")
    replay = Replay(gb.load_measurement(DATA / "cases" / "p01" / "data.csv"))
    fitted, ends = C.fit, []

    def counted(*args, **kwargs):
        ends.append(fitted(*args, **kwargs))
        return ends[-1]
    monkeypatch.setattr(C, "fit", counted)
    (tried,) = fit_effect(plant, replay, "stribeck_friction", {"location": "load"})
    assert len(ends) == 1 and ends[0].weighted_rms <= AT_FLOORS, [e.weighted_rms for e in ends]
    truth = yaml.safe_load((DATA / "cases" / "p01" / "truth.yaml").read_text())
    hidden = hidden_in_gearbench_keys(truth)["stribeck_friction"]
    for key in ("static_torque", "coulomb_torque", "stribeck_speed"):
        se = tried.result.params[f"effects[0].{key}"].stderr
        assert abs(tried.params[key] - hidden[key]) < 4 * se, (key, tried.params[key], se, hidden[key])
