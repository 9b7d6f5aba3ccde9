"""Diagnose with a plant file whose datasheet values are off, on records that break the inverse crime.

The records are made by the true plant (its friction stick-slip, as diagnose's own
model) at a solver tolerance a thousand times tighter than the fits use (rtol 1e-9
against 1e-6), 16 s of the mixed excitation the practice cases use; the plant file
handed to diagnose has its resistance, motor constant and inertias 5-20 % off.  A
parameter being off must not be taken for a missing effect (verdict null, the
calibration recovers the truth), and a missing effect must still be found, with the
ladder ending within 1.2x the noise floor.  Practice case p04 (an independent
simulator) is the same test on data gearbench did not make
(``tests/test_practice_cases.py``).
"""
from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import pytest

from gearbench.experiment.files import load_plant
from gearbench.identify.diagnose import diagnose
from gearbench.identify.replay import Replay
from gearbench.synth import default_signals, excitation, synthesize
from gearbench.plant.effects import AddedEffect
from gearbench.simulate import SolverOptions

ROOT = Path(__file__).resolve().parents[1]
RIG = ROOT / "experiments" / "plants" / "bench_rig.yaml"
NOISE = {"motor_angle_deg": 0.02, "load_angle_deg": 0.015, "current_A": 0.008}
TIGHT = SolverOptions(rtol=1e-9, max_step_s=1e-3)

OFF = {  # name -> {path: file value / true value}
    "p04-like": {"motor.resistance": 1.10, "motor.torque_constant": 0.95, "motor.back_emf_constant": 0.95,
                 "load.inertia": 0.92},
    "other way": {"motor.resistance": 0.85, "motor.torque_constant": 1.10, "motor.back_emf_constant": 1.10,
                  "motor.inertia": 1.15, "load.inertia": 1.18},
}


def datasheet(truth, factors: dict):
    """``truth`` with each value of ``factors`` multiplied: the plant file a user would write."""
    plant = truth
    for path, f in factors.items():
        section, key = path.split(".")
        comp = getattr(plant, section)
        plant = replace(plant, **{section: replace(comp, **{key: f * getattr(comp, key)})})
    return plant


def record(truth, hidden=(), seed=11):
    t, u = excitation("mixed", truth, duration_s=16.0, seed=seed)
    noise = {s: NOISE[s] for s in default_signals(truth)}
    return synthesize(truth, list(hidden), t, u, noise=noise, seed=seed, options=TIGHT)


def calibration_misses(d, truth, factors) -> tuple[list, list]:
    """The values the file had off that did not come back within 2 % of the truth (the fit moves
    them by 5-20 %), and those that did but not within 3 of their standard errors."""
    cal = d.to_json()["calibration"]
    off, overconfident = [], []
    for path in factors:
        section, key = path.split(".")
        true = getattr(getattr(truth, section), key)
        got = getattr(getattr(d.plant, section), key)
        # the motor constant is calibrated as one: "motor.torque_constant ~ back_emf_constant"
        row = next((v for k, v in cal.items() if k == path or k.startswith(path + " ")), None) or {}
        se = row.get("stderr") or 0.0
        if abs(got / true - 1) > 0.02:
            off.append((path, got, true, se))
        elif se and abs(got - true) > 3 * se:
            overconfident.append((path, got, true, se))
    return off, overconfident


@pytest.mark.parametrize("case", [pytest.param("p04-like"), pytest.param("other way", marks=pytest.mark.slow)])
def test_datasheet_values_off_and_nothing_missing_give_no_verdict(case):
    """Verdict null at the noise floor, every value the file had off back within 2 % of the truth and
    within 3 of its standard errors.  Until the fits held the replay's resets (``fit``), p04-like's
    calibration ended in a false minimum at 5.0x the noise floors (resistance 3.19 ohm for 3.0), and
    other way's values, within 0.5 %, lay 50-500 standard errors from the truth.  (2 cores,
    2026-11-26: p04-like 32 s, other way 40 s.)"""
    truth = load_plant(RIG)
    d = diagnose(datasheet(truth, OFF[case]), Replay(record(truth)), max_steps=2)
    assert d.verdict is None, (d.reason, d.to_json()["ladder"])
    off, overconfident = calibration_misses(d, truth, OFF[case])
    assert d.stopped == "noise floor" and not off and not overconfident, (d.reason, off, overconfident)


@pytest.mark.slow
def test_datasheet_values_off_and_an_effect_missing():
    """Coulomb friction (0.5 N m) hidden at the load of the bench rig whose file has p04's
    datasheet errors: found, its torque within 2 %, the ladder within 1.2x the noise floor,
    the datasheet values calibrated back within 2 % and 3 standard errors (112 s on 2 cores,
    2026-11-26).  Until the fits held the replay's resets, the friction was found at 0.466 N m and
    a shaft compliance stayed in the final model."""
    truth = load_plant(RIG)
    hidden = AddedEffect("coulomb_friction", {"location": "load", "torque": 0.5})
    d = diagnose(datasheet(truth, OFF["p04-like"]), Replay(record(truth, [hidden])), max_steps=3)
    assert d.verdict == "coulomb_friction", (d.reason, d.to_json()["ladder"])
    final = {e.name: e.values for e in d.plant.effects}
    assert set(final) == {"coulomb_friction"}, d.to_json()["ladder"]
    assert final["coulomb_friction"]["torque"] == pytest.approx(0.5, rel=0.02)
    assert d.ladder[-1].error <= 1.2 * d.noise_floor
    assert d.stopped == "noise floor", d.reason  # every signal, not only the load angle (0.994x, 2026-12-07)
    assert calibration_misses(d, truth, OFF["p04-like"]) == ([], [])


HIDDEN = AddedEffect("coulomb_friction", {"location": "load", "torque": 0.5})


@pytest.fixture(scope="module")
def calibrated():
    """The 16 s record with Coulomb friction at the load, and ``gearbench fit --calibrate``'s fit of
    it from p04's datasheet errors at the default rtol 1e-6."""
    import gearbench as gb
    truth = load_plant(RIG)
    m = record(truth, [HIDDEN])
    return m, gb.fit(datasheet(truth, OFF["p04-like"]), m, "coulomb_friction", options={"location": "load"},
                     calibrate=True)


def test_fit_calibrate_brings_back_the_effect_and_the_datasheet_values(calibrated):
    """``gearbench fit --calibrate`` (``gearbench.fit(..., calibrate=True)``): Coulomb friction at
    the load fitted beside the datasheet values of p04's errors, on the same 16 s record as above:
    the friction within 2 %, each value the file had off back within 2 % and 3 standard errors,
    the load angle's error at its noise (0.0149 deg for 0.015; 34 s on 2 cores, 2026-11-27)."""
    truth = load_plant(RIG)
    f = calibrated[1]
    assert f.values["effects[0].torque"] == pytest.approx(0.5, rel=0.02), f.values
    for path in ("motor.resistance", "motor.torque_constant", "load.inertia"):
        section, key = path.split(".")
        true = getattr(getattr(truth, section), key)
        assert f.values[path] == pytest.approx(true, rel=0.02), (path, f.values)
        assert abs(f.values[path] - true) <= 3 * f.stderr[path], (path, f.values[path], f.stderr[path])
    assert f.plant.motor.back_emf_constant == pytest.approx(truth.motor.back_emf_constant, rel=0.02)
    assert f.error_after <= 1.2 * NOISE["load_angle_deg"], f.error_after
    line = next(ln for ln in f.to_yaml().splitlines() if ln.strip().startswith("resistance:"))
    assert "fitted, standard error" in line and "ohm" in line, line  # the plant fit -o writes


def test_the_solvers_numerical_error_is_taken_out_of_the_fit(calibrated):
    """``identify.numerics.refine``: on that long, quiet record the replay's tolerance (rtol 1e-6)
    leaves the fitted values more than 0.3 of their standard errors from the least squares at rtol
    1e-8 (up to 1.8, the motor damping; the torque constant 1.4; 2026-12-03), so ``gearbench.fit``
    finishes the fit there.  Finished, every value is within 0.5 standard errors of the same fit
    run at rtol 1e-8 from the start (0.24 at most when written; left, up to 1.9), whose own shift
    is below 0.3 and left."""
    import gearbench as gb
    m, loose = calibrated
    se = loose.stderr
    assert max(abs(v) / se[n] for n, v in loose.numerical.items()) > 0.3, loose.numerical
    assert loose.refined and "finished at rtol 1e-08" in loose.message, loose.message
    tight = gb.fit(datasheet(load_plant(RIG), OFF["p04-like"]), m, "coulomb_friction",
                   options={"location": "load"}, calibrate=True, rtol=1e-8)
    assert not tight.refined and all(abs(v) <= 0.3 * tight.stderr[n] for n, v in tight.numerical.items())
    off = {n: (loose.values[n] - tight.values[n]) / se[n] for n in se}
    assert all(abs(z) <= 0.5 for z in off.values()), off
    kept = {n: (loose.values[n] - loose.numerical[n] - tight.values[n]) / se[n] for n in se}
    assert max(map(abs, kept.values())) > max(map(abs, off.values())), (kept, off)  # it was worse left in


def test_fit_calibrate_on_8_s():
    """``fit --calibrate`` on 8 s of that record: the load angle ends at 1.01x its noise, the
    friction 0.4958 N m for 0.5 (8 s on 2 cores, 2026-11-28; the README had 3.2x from
    2026-11-27, before the fits' later changes).  Not at the truth: the resistance 3.034 ohm (3.0)
    and the load inertia 0.005956 kg m^2 (0.006) sit 5-6 standard errors off, the load damping at
    its bound, 0.0024 for 0.003; fitted again from the best points of a scan of the tolerance box,
    as diagnose's calibration is, it ends at the same values."""
    import gearbench as gb
    truth = load_plant(RIG)
    hidden = AddedEffect("coulomb_friction", {"location": "load", "torque": 0.5})
    t, u = excitation("mixed", truth, duration_s=8.0, seed=11)
    m = synthesize(truth, [hidden], t, u, noise={s: NOISE[s] for s in default_signals(truth)}, seed=11,
                   options=TIGHT)
    f = gb.fit(datasheet(truth, OFF["p04-like"]), m, "coulomb_friction", options={"location": "load"},
               calibrate=True)
    assert f.error_after <= 1.2 * NOISE["load_angle_deg"], f.error_after
    assert f.values["effects[0].torque"] == pytest.approx(0.5, rel=0.02)
    for path in ("motor.resistance", "load.inertia"):
        section, key = path.split(".")
        assert f.values[path] == pytest.approx(getattr(getattr(truth, section), key), rel=0.02), (path, f.values)


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason="the ladder ends outside the truth's stick-slip notch since 330e464 "
                   "(weighted RMS 2.10x the floors, the truth 1.17x; resistance +6.4, load inertia -4.7 SE)")
def test_datasheet_values_off_and_an_effect_missing_on_8_s():
    """``test_datasheet_values_off_and_an_effect_missing`` on 8 s of the same excitation.  The
    stick-slip at the load makes the calibration's residual jump between branches (on the first
    second of this record, with the load inertia held and the rest refitted: 11.0x the noise
    floors at 0.0054, 3.2x at 0.0056, 0.98x at the truth's 0.006), and from p04's values the fit
    took the wrong branch: the ladder ended at 143x the noise floor, load inertia 0.00539 for
    0.006 (2026-11-27).  A calibration that pays but stops short of the noise is now fitted again
    from the best points of a scan of the tolerance box (``ladder.calibrate``): the ladder
    takes Coulomb friction with a load spring as a pair, the calibration, and takes the spring
    out, at 0.988x the noise floors, every value within 0.2 % (157 s on 2 cores, 2026-11-28).

    A strict xfail since 2026-12-07: with the step cap of ``solver/integrate.py`` (330e464; its
    parent passes) the same ladder ends "nothing pays" after the spring's removal at a weighted
    RMS of 2.10x the noise floors, the load angle's error at 1.02x its floor, resistance 3.0396
    ohm (+6.4 standard errors) and load inertia 0.005936 kg m^2 (-4.7).  The truth scores a
    weighted RSS of 32,769 (1.17x) under that model's replay against its 107,541; moved to the truth one
    value at a time, from either end, the RSS is 3e7 to 3e9: the truth's branch is a notch no
    single value's step reaches, and the path before the cap had reached it by a detour (a
    viscous friction added and taken out again, 0.988x).  The calibration's scan of the tolerance
    box (six fits in its stage) does not reach it either."""
    truth = load_plant(RIG)
    hidden = AddedEffect("coulomb_friction", {"location": "load", "torque": 0.5})
    t, u = excitation("mixed", truth, duration_s=8.0, seed=11)
    noise = {s: NOISE[s] for s in default_signals(truth)}
    m = synthesize(truth, [hidden], t, u, noise=noise, seed=11, options=TIGHT)
    d = diagnose(datasheet(truth, OFF["p04-like"]), Replay(m), max_steps=3)
    assert d.verdict == "coulomb_friction" and d.ladder[-1].error <= 1.2 * d.noise_floor
    assert d.stopped == "noise floor", d.reason  # every signal: the load angle alone passed at 2.10x
    assert calibration_misses(d, truth, OFF["p04-like"]) == ([], [])
