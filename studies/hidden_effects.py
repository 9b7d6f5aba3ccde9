"""Every effect of the library hidden in a record, and what ``diagnose`` makes of it.

For each case: 16 s of the mixed open-loop excitation of the practice cases
(``synth.mixed``: steps both ways with pauses and direct reversals, low-level
steps, fast reversals, a slow sine period and a triangle ramp) on the bench rig
(a plant other than the thesis's) with one effect hidden (parameters and noise
unlike the defaults), made by ``synthesize`` (the plant's default friction law
generates), diagnosed over the whole library, one rung.  Every effect is hidden
once; an effect with a ``location`` that can be the motor (the frictions) is
hidden at the motor and at the load.  The table gives the verdict, the main
parameter against the truth, the error after the rung against the noise floor,
whether the explanation names the effect's signature, the runner-up and the
time.  Then "no hidden effect": five plants, each with its own noise seed, must
give no verdict.  ``tests/test_diagnose.py`` asserts the same cases.

    python -m studies.hidden_effects --results results
"""
from __future__ import annotations

import json
import time
from pathlib import Path

import click

from gearbench.experiment.files import load_plant
from gearbench.identify.diagnose import diagnose
from gearbench.identify.evidence import SIGNATURES
from gearbench.identify.replay import Replay
from gearbench.identify.synth import default_signals, excitation, synthesize
from gearbench.plant.effects import REGISTRY, AddedEffect
from gearbench.report.io import write_text_atomic

PLANTS = Path(__file__).resolve().parents[1] / "experiments" / "plants"
NOISE = {"motor_angle_deg": 0.02, "load_angle_deg": 0.015, "current_A": 0.008, "load_position_mm": 0.002}
"""Noise standard deviation of each signal a plant records, in its unit (unlike synth's defaults)."""
DURATION_S = 16.0
SEED = 3
PARAM_TOL = 0.15     # the main parameter comes back within 15 %
ERROR_TOL = 1.2      # the error after the rung is within 1.2x the noise floor

CASES = {  # label -> (effect, plant file, hidden values, main parameter)
    "backlash": ("backlash", "bench_rig_rigid.yaml", {"backlash_deg": 1.5}, "backlash_deg"),
    "coulomb_friction (load)": ("coulomb_friction", "bench_rig.yaml", {"location": "load", "torque": 0.6},
                                "torque"),
    "coulomb_friction (motor)": ("coulomb_friction", "bench_rig.yaml", {"location": "motor", "torque": 0.02},
                                 "torque"),
    "stribeck_friction (load)": ("stribeck_friction", "bench_rig.yaml",
                                 {"location": "load", "static_torque": 1.2, "coulomb_torque": 0.7,
                                  "stribeck_speed": 2.0}, "static_torque"),
    # the same curve seen from the rotor of the 20:1 gear: torques / 20, speed x 20
    "stribeck_friction (motor)": ("stribeck_friction", "bench_rig.yaml",
                                  {"location": "motor", "static_torque": 0.06, "coulomb_torque": 0.035,
                                   "stribeck_speed": 40.0}, "static_torque"),
    "viscous_friction (load)": ("viscous_friction", "bench_rig.yaml", {"location": "load", "coefficient": 0.05},
                                "coefficient"),
    "viscous_friction (motor)": ("viscous_friction", "bench_rig.yaml",
                                 {"location": "motor", "coefficient": 1.5e-4}, "coefficient"),
    "shaft_compliance": ("shaft_compliance", "bench_rig.yaml",
                         {"stiffness": 20.0, "damping": 2e-4, "pinion_inertia": 5e-6}, "stiffness"),
    "load_spring": ("load_spring", "bench_rig.yaml", {"stiffness": 1.5, "rest_angle_deg": 5.0}, "stiffness"),
    "bias_torque": ("bias_torque", "bench_rig.yaml", {"location": "load", "torque": -0.5}, "torque"),
    "amplifier_deadzone": ("amplifier_deadzone", "bench_rig.yaml", {"threshold": 1.5}, "threshold"),
    "sensor_delay": ("sensor_delay", "bench_rig.yaml", {"signal": "load_angle_deg", "delay": 0.008}, "delay"),
    "encoder_quantization": ("encoder_quantization", "bench_rig.yaml",
                             {"signal": "motor_angle_deg", "counts_per_rev": 2048}, "counts_per_rev"),
}

NULL_CASES = (  # plant file, seed: no effect hidden, each plant with its own noise
    ("bench_rig.yaml", 5),
    ("bench_rig_rigid.yaml", 6),
    ("leadscrew_apparatus.yaml", 7),
    ("thesis_gear.yaml", 8),
    ("emps_bare.yaml", 9),
)


def record(plant, hidden, seed=SEED, duration=DURATION_S):
    """A synthetic record of ``plant`` with ``hidden`` effects: the mixed open-loop
    excitation of ``duration`` s, noise NOISE on the plant's default signals."""
    t, u = excitation("mixed", plant, duration_s=duration, seed=seed)
    noise = {s: NOISE[s] for s in default_signals(plant)}
    return synthesize(plant, hidden, t, u, noise=noise, seed=seed)


def names_signature(effect: str, explanation: str) -> bool:
    """Whether ``explanation`` names ``effect``'s signature (``evidence.SIGNATURES``)."""
    words = SIGNATURES[REGISTRY[effect].signature][1]
    return f"its signature is {words}".lower() in explanation.lower()


def case(label: str, duration: float = DURATION_S, max_steps: int = 1) -> dict:
    """Hide ``CASES[label]``, diagnose, and report the first rung against the truth."""
    name, plant_file, values, main = CASES[label]
    plant = load_plant(PLANTS / plant_file)
    data = record(plant, [AddedEffect(name, values)], duration=duration)
    t0 = time.perf_counter()
    d = diagnose(plant, Replay(data), max_steps=max_steps)
    wall = time.perf_counter() - t0
    step = d.ladder[0] if d.ladder else None
    fitted = step.params.get(main) if step else None
    return {"case": label, "effect": name, "plant": plant_file, "truth": values, "duration_s": duration,
            "verdict": d.verdict, "options": step.options if step else None, "main_parameter": main,
            "fitted": fitted, "fitted_params": step.params if step else {},
            "error": step.error if step else d.baseline_error, "baseline_error": d.baseline_error,
            "noise_floor": d.noise_floor, "unit": d.unit,
            "signature_named": bool(step) and names_signature(name, step.explanation),
            "explanation": step.explanation if step else "",
            "runner_up": d.tried[1].candidate.label() if len(d.tried) > 1 else None,
            "runner_up_error": d.tried[1].result.error if len(d.tried) > 1 and d.tried[1].ok else None,
            "wall_s": wall, "reason": d.reason}


def passes(r: dict) -> bool:
    """The test's criteria: verdict and place, main parameter within PARAM_TOL, error within
    ERROR_TOL x the noise floor, the explanation names the signature."""
    place = {k: v for k, v in r["truth"].items() if isinstance(v, str)}
    return (r["verdict"] == r["effect"] and r["options"] == place and r["fitted"] is not None
            and abs(r["fitted"] / r["truth"][r["main_parameter"]] - 1.0) <= PARAM_TOL
            and r["error"] <= ERROR_TOL * r["noise_floor"] and r["signature_named"])


def null_case(plant_file: str, seed: int, duration: float = DURATION_S, max_steps: int = 1) -> dict:
    """No hidden effect on ``plant_file``: diagnose and report the verdict (None expected)."""
    plant = load_plant(PLANTS / plant_file)
    data = record(plant, [], seed=seed, duration=duration)
    t0 = time.perf_counter()
    d = diagnose(plant, Replay(data), max_steps=max_steps)
    wall = time.perf_counter() - t0
    best = d.tried[0] if d.tried and d.tried[0].ok else None
    return {"plant": plant_file, "seed": seed, "duration_s": duration, "verdict": d.verdict,
            "baseline_error": d.baseline_error, "noise_floor": d.noise_floor, "unit": d.unit,
            "best": best.candidate.label() if best else None,
            "best_error": best.result.error if best else None,
            "best_bic_change": best.result.bic - d.baseline.bic if best else None,
            "wall_s": wall, "reason": d.reason}


@click.command()
@click.option("--results", "results_dir", type=click.Path(file_okay=False, path_type=Path),
              default=Path("results"), show_default=True, help="Output folder.")
@click.option("--duration", type=float, default=DURATION_S, show_default=True, help="Record length, s.")
def main(results_dir: Path, duration: float) -> None:
    """Every effect of the library hidden in a record, and what diagnose makes of it;
    and records with nothing hidden on five plants.

    Writes RESULTS/hidden_effects.md and RESULTS/hidden_effects.json."""
    rows = []
    for label in CASES:
        r = case(label, duration)
        rows.append(r)
        click.echo(f"{label}: verdict {r['verdict']} {r['options']}, {r['main_parameter']} {r['fitted']} (truth "
                   f"{r['truth'][r['main_parameter']]}), error {r['error']:.4g} / noise {r['noise_floor']:.4g} "
                   f"{r['unit']}, signature named {r['signature_named']}, {r['wall_s']:.1f} s")
    nulls = []
    for plant_file, seed in NULL_CASES:
        r = null_case(plant_file, seed, duration)
        nulls.append(r)
        click.echo(f"nothing hidden, {plant_file} seed {seed}: verdict {r['verdict']}, {r['wall_s']:.1f} s")
    noise = ", ".join(f"{k} {v:g}" for k, v in NOISE.items())
    md = ["# Hidden effects: what diagnose finds", "",
          f"Each effect hidden in {duration:g} s of the mixed open-loop voltage excitation (`synth.mixed`: "
          f"steps both ways with pauses and direct reversals, low-level steps, fast reversals, a slow sine, "
          f"a triangle ramp) on the bench rig, noise {noise}, seed {SEED}; the whole library diagnosed, one "
          "rung (`python -m studies.hidden_effects`). Pass: verdict and place right, main parameter within "
          f"{PARAM_TOL:.0%}, error within {ERROR_TOL:g}x the noise floor, the explanation names the signature.", "",
          "| hidden | verdict | parameter | truth | fitted | error / noise floor | signature named | runner-up "
          "| pass | time (s) |",
          "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        truth = r["truth"][r["main_parameter"]]
        fitted = "—" if r["fitted"] is None else f"{r['fitted']:.4g}"
        verdict = f"{r['verdict']} ({', '.join(r['options'].values())})" if r["options"] else str(r["verdict"])
        md.append(f"| {r['case']} | {verdict} | {r['main_parameter']} | {truth:g} | {fitted} | "
                  f"{r['error'] / r['noise_floor']:.3g} | {'yes' if r['signature_named'] else 'no'} | "
                  f"{r['runner_up']} | {'yes' if passes(r) else '**no**'} | {r['wall_s']:.1f} |")
    md += ["", "## Nothing hidden", "",
           f"The same excitation and noise with no effect hidden; each plant its own seed. Verdict must be none.", "",
           "| plant | seed | verdict | error / noise floor | best candidate | its BIC change | time (s) |",
           "|---|---|---|---|---|---|---|"]
    for r in nulls:
        bic = "—" if r["best_bic_change"] is None else f"{r['best_bic_change']:+.1f}"
        md.append(f"| {r['plant']} | {r['seed']} | {r['verdict']} | {r['baseline_error'] / r['noise_floor']:.3g} | "
                  f"{r['best']} | {bic} | {r['wall_s']:.1f} |")
    write_text_atomic(results_dir / "hidden_effects.md", "\n".join(md) + "\n")
    write_text_atomic(results_dir / "hidden_effects.json",
                      json.dumps({"hidden": rows, "nothing_hidden": nulls}, indent=1, default=str) + "\n")


if __name__ == "__main__":
    main()
