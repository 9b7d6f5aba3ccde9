"""diagnose on data with a hidden effect: every effect of the library is found.

Each case (``studies.hidden_effects.CASES``) hides one effect (parameters and
noise unlike the defaults) in a 16 s record made by ``synthesize`` (stick-slip
friction, the default law) from the bench rig (not the thesis plant) under the
practice cases' mixed excitation (``synth.mixed``), every friction also at the
motor; it runs the whole
library's diagnosis (one rung; an effect tried only when asked for, ``Effect.on_request``, is
asked for) and checks the verdict names the hidden effect
and its place, its main parameter comes back within 15 %, the error after it
is within 1.2x the noise floor, and the explanation names the effect's
signature.  With nothing hidden, five plants with five noise seeds give no
verdict.  One diagnosis of a 16 s record takes 15-100 s on 2 cores (more with
nothing hidden, where every candidate fits in vain; the first run of a plant
also compiles its models): ``make test`` runs ``QUICK`` and ``QUICK_NULL``,
``make test-all`` (``--runslow``) every case; the durations measured are beside
them.

Coulomb friction with a bias torque on the same shaft (0.6 and 0.4 N m), which the
greedy ladder once took for a Stribeck curve and left at 55x the noise floor, is
resolved by the pairwise joint refits: ``tests/test_diagnose_search.py`` (slow).
"""
from __future__ import annotations

import re

import pytest

from gearbench.experiment.files import load_plant
from gearbench.identify.diagnose import diagnose
from gearbench.identify.evidence import SIGNATURES
from gearbench.identify.replay import Replay
from gearbench.synth import excitation, synthesize
from gearbench.plant.effects import REGISTRY, AddedEffect
from studies.hidden_effects import CASES, ERROR_TOL, NULL_CASES, PARAM_TOL, PLANTS, case, null_case

QUICK = {"coulomb_friction (motor)", "sensor_delay"}
"""The hidden-effect cases ``make test`` runs (a torque effect at the motor, a sensor effect): 31 and
26 s.  The other eleven are slow: 19-99 s each once compiled (760 s for backlash on the rigid rig the
first time, compiling its models), 7 min in all.  Measured on 2 shared cores with stick-slip friction
generating, each ``case`` timed in turn in one process."""
QUICK_NULL = {"bench_rig.yaml"}
"""The plant with nothing hidden that ``make test`` runs: 62-89 s.  The others are slow: bench_rig_rigid
680 s the first time (compiling its models), leadscrew_apparatus 108 s, emps_bare 43 s, the practice
case p01's nominal plant 91 s (all four with no verdict)."""
SHORT_CORRELATION = {"stribeck_friction (load)": 0.79, "stribeck_friction (motor)": 0.80,
                     "encoder_quantization": 0.83}
"""Cases whose explanation names the right signature but measures it below 0.9 on the 16 s stick-slip
records (measured 2026-11-25): Stribeck's curve against the sign of the speed alone, and the
quantisation's steps under the noise.  Known shortfalls of ``evidence.py``: marked xfail after every other
check has passed, so a regression in verdict, parameter or error still fails."""
TIED = {"lugre_friction (load)": "stick and breakaway 0.94, sign of the speed 0.94"}
"""Cases whose signature measures above 0.9 but ties another as the strongest (measured 2026-11-29): LuGre's
Stribeck speed, 0.5 rad/s at the load, is small beside the record's speeds, so its curve is the sign of the
speed on most samples.  Marked xfail after every other check has passed."""
STEPS_NOISE = {"motor_angle_deg": 0.02, "load_angle_deg": 0.015, "current_A": 0.008}


def steps_record(plant, hidden, seed):
    """3 s of open-loop voltage steps with ``hidden`` effects: the short record of the
    ladder's own tests (two rungs, pruning), which need no mixed excitation."""
    t, u = excitation("steps", plant, duration_s=3.0, seed=seed)
    return synthesize(plant, hidden, t, u, noise=STEPS_NOISE, seed=seed)


def _slow_unless(quick: bool):
    return () if quick else pytest.mark.slow


def test_every_effect_has_a_case_and_every_friction_one_at_the_motor():
    hidden = {(name, values.get("location")) for name, _, values, _ in CASES.values()}
    assert {name for name, _ in hidden} == set(REGISTRY)
    at_motor = {name for name, e in REGISTRY.items() if "motor" in e.options.get("location", ())}
    assert at_motor and {(name, "motor") for name in at_motor} <= hidden


def test_every_effect_declares_a_signature_the_explanations_know():
    assert {name: e.signature in SIGNATURES for name, e in REGISTRY.items()} == {n: True for n in REGISTRY}


@pytest.mark.parametrize("label", [pytest.param(c, marks=_slow_unless(c in QUICK)) for c in sorted(CASES)])
def test_hidden_effect_is_found(label):
    r = case(label)
    name, _, values, main = CASES[label]
    assert (r["verdict"], r["options"]) == (name, {k: v for k, v in values.items() if isinstance(v, str)}), \
        (r["verdict"], r["options"], r["runner_up"], r["reason"])
    assert r["fitted"] == pytest.approx(values[main], rel=PARAM_TOL), r["fitted_params"]
    assert r["error"] <= ERROR_TOL * r["noise_floor"], (r["error"], r["noise_floor"])
    # the explanation names this effect's signature and measures it on the residual
    text = r["explanation"]
    assert r["signature_named"], text
    corr = float(re.search(r"correlation (?:with it is )?(\d\.\d\d)", text).group(1))
    if label in SHORT_CORRELATION and corr < 0.9:
        pytest.xfail(f"{label}: signature correlation {corr:.2f} < 0.9 (known, {SHORT_CORRELATION[label]})")
    if name == "shaft_compliance":  # its residual is at the noise floor: nothing left to correlate,
        return                       # so no signature can be the strongest either (0.00, speed 0.01)
    assert corr >= 0.9, text
    if SIGNATURES[REGISTRY[name].signature][0] == "torque":
        if label in TIED and "the strongest of the" not in text:
            pytest.xfail(f"{label}: its signature ties another (known, {TIED[label]})")
        assert "the strongest of the" in text, text


@pytest.mark.parametrize("plant_file, seed", [pytest.param(p, s, marks=_slow_unless(p in QUICK_NULL))
                                              for p, s in NULL_CASES])
def test_no_hidden_effect_no_verdict(plant_file, seed):
    r = null_case(plant_file, seed)
    assert r["verdict"] is None, (r["best"], r["best_error"], r["best_bic_change"], r["reason"])
    assert "noise" in r["reason"], r["reason"]


def test_null_cases_are_five_plants_with_five_seeds():
    assert len({p for p, _ in NULL_CASES}) == len({s for _, s in NULL_CASES}) == len(NULL_CASES) >= 5


def test_two_hidden_effects_take_two_steps():
    plant = load_plant(PLANTS / "bench_rig.yaml")
    hidden = [AddedEffect("coulomb_friction", {"location": "load", "torque": 0.6}),
              AddedEffect("load_spring", {"stiffness": 3.0, "rest_angle_deg": -10.0})]
    d = diagnose(plant, Replay(steps_record(plant, hidden, seed=7)), max_steps=3)
    assert sorted(s.effect for s in d.ladder) == ["coulomb_friction", "load_spring"], d.to_json()["ladder"]
    assert d.ladder[1].error < d.ladder[0].error < d.baseline_error
    assert d.ladder[-1].error <= 1.5 * d.noise_floor


def test_leadscrew_carriage_friction_is_found():
    """The translational variant: the leadscrew apparatus with Coulomb friction at
    the carriage (a force, N), measured as carriage position in mm."""
    plant = load_plant(PLANTS / "leadscrew_apparatus.yaml")
    t, u = excitation("steps", plant, duration_s=3.0, seed=4)
    hidden = [AddedEffect("coulomb_friction", {"location": "carriage", "force": 30.0})]
    data = synthesize(plant, hidden, t, u, noise={"motor_angle_deg": 0.05, "load_position_mm": 0.002,
                                                 "current_A": 0.004}, seed=4)
    assert "load_position_mm" in data.signals
    d = diagnose(plant, Replay(data), max_steps=1, only=("coulomb_friction", "viscous_friction", "bias_torque"))
    assert d.verdict == "coulomb_friction" and d.ladder[0].options == {"location": "carriage"}
    assert d.ladder[0].params["force"] == pytest.approx(30.0, rel=0.2)
    assert d.unit == "mm" and d.ladder[0].error <= 1.5 * d.noise_floor


def test_json_candidates_carry_the_contract_keys_and_failures_say_why():
    from gearbench.identify.candidates import RANKING, Candidate, Tried, rank as _rank
    from gearbench.identify.results import Diagnosis
    from gearbench.identify.fit import FitResult

    plant = load_plant(PLANTS / "bench_rig.yaml")

    def ok(err, rss):
        return FitResult(plant, {}, err, rss, 1000, 1, True, "converged", 5)

    tried = _rank([Tried(Candidate("bias_torque", {}), ok(2.0, 900.0), {"torque": 0.1}, {"torque": 0.01}),
                   Tried(Candidate("sensor_delay", {"signal": "load_angle_deg"}), None,
                         note="could not be simulated: step budget exhausted"),
                   Tried(Candidate("load_spring", {}), ok(1.0, 400.0), {"stiffness": 2.0}, {"stiffness": 0.1})])
    base = ok(3.0, 1e4)
    j = Diagnosis(3.0, 0.01, "deg", "load_angle_deg", tried, None, [], "x", plant, base, plant, 1.0).to_json()
    assert j["ranking"] == RANKING and "BIC" in RANKING
    assert [c["effect"] for c in j["candidates"]] == ["load_spring", "bias_torque", "sensor_delay"]
    bics = [c["bic"] for c in j["candidates"] if c["bic"] is not None]
    assert bics == sorted(bics)
    for c in j["candidates"]:
        assert {"effect", "options", "params", "error", "bic", "status"} <= set(c)
    failed = j["candidates"][-1]
    assert failed["error"] is None and failed["bic"] is None and failed["status"] == "failed"
    assert "step budget" in failed["message"] and failed["options"] == {"signal": "load_angle_deg"}


def test_an_effect_that_no_longer_pays_is_taken_out():
    """Stepwise backwards: a record with viscous friction only, and a ladder that took Coulomb
    friction first and viscous friction second.  Refitted together the Coulomb torque has
    nothing left to explain, so ``_prune`` takes it out and keeps the viscous term."""
    from gearbench.identify.ladder import removals
    from gearbench.identify.policy import Policy
    from gearbench.identify.fit import Free, fit
    from gearbench.identify.scoring import Scorer

    plant = load_plant(PLANTS / "bench_rig.yaml")
    data = steps_record(plant, [AddedEffect("viscous_friction", {"location": "load", "coefficient": 0.05})],
                        seed=11)
    replay = Replay(data)
    scorer = Scorer(replay)
    both = plant.with_effects(AddedEffect("coulomb_friction", {"location": "load", "torque": 0.3}),
                              AddedEffect("viscous_friction", {"location": "load", "coefficient": 0.03}))
    res = fit(replay, both, Free.effect(both, 0) + Free.effect(both, 1), scorer)
    assert res.converged
    removed = removals(replay, scorer, Policy(), res, 0, ())
    assert [(e.name, e.values["location"]) for e, _, _ in removed] == [("coulomb_friction", "load")]
    gone, without, gain = removed[0]
    assert not Policy().accepts(scorer, without, res) and gain < 10.0
    assert [e.name for e in without.plant.effects] == ["viscous_friction"]
    assert without.plant.effects[0].values["coefficient"] == pytest.approx(0.05, rel=0.05)
    assert without.error <= 1.5 * scorer.noise_floor
    # effects that each pay stay: a record with both Coulomb friction and a spring
    hidden = [AddedEffect("coulomb_friction", {"location": "load", "torque": 0.6}),
              AddedEffect("load_spring", {"stiffness": 3.0, "rest_angle_deg": -10.0})]
    replay2 = Replay(steps_record(plant, hidden, seed=7))
    scorer2 = Scorer(replay2)
    two = plant.with_effects(*hidden)
    res2 = fit(replay2, two, Free.effect(two, 0) + Free.effect(two, 1), scorer2)
    assert res2.converged and removals(replay2, scorer2, Policy(), res2, 0, ()) == []
