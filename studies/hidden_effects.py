"""Every effect of the library hidden in a record, and what ``diagnose`` makes of it.

For each effect: 3 s of open-loop voltage steps on the bench rig (a plant other
than the thesis's) with that effect hidden (parameters and noise unlike the
defaults), diagnosed over the whole library; the table gives the verdict, the
main parameter against the truth, the error after adding it against the noise
floor, and the time.  ``tests/test_diagnose.py`` asserts the same cases.

    python -m studies.hidden_effects --results results
"""
from __future__ import annotations

import json
import time
from pathlib import Path

import click

from gearbench.experiment.files import load_plant
from gearbench.identify.diagnose import diagnose
from gearbench.identify.replay import Replay
from gearbench.identify.synth import excitation, synthesize
from gearbench.plant.effects import AddedEffect
from gearbench.report.io import write_text_atomic

PLANTS = Path(__file__).resolve().parents[1] / "experiments" / "plants"
NOISE = {"motor_angle_deg": 0.02, "load_angle_deg": 0.015, "current_A": 0.008}
DURATION_S = 3.0
SEED = 3

HIDDEN = {  # effect -> (plant file, hidden values, main parameter)
    "backlash": ("bench_rig_rigid.yaml", {"backlash_deg": 1.5}, "backlash_deg"),
    "coulomb_friction": ("bench_rig.yaml", {"location": "motor", "torque": 0.02}, "torque"),
    "stribeck_friction": ("bench_rig.yaml", {"location": "load", "static_torque": 1.2, "coulomb_torque": 0.7,
                                             "stribeck_speed": 2.0}, "static_torque"),
    "viscous_friction": ("bench_rig.yaml", {"location": "load", "coefficient": 0.05}, "coefficient"),
    "shaft_compliance": ("bench_rig.yaml", {"stiffness": 20.0, "damping": 2e-4, "pinion_inertia": 5e-6},
                         "stiffness"),
    "load_spring": ("bench_rig.yaml", {"stiffness": 1.5, "rest_angle_deg": 5.0}, "stiffness"),
    "bias_torque": ("bench_rig.yaml", {"torque": -0.5}, "torque"),
    "amplifier_deadzone": ("bench_rig.yaml", {"threshold": 1.5}, "threshold"),
    "sensor_delay": ("bench_rig.yaml", {"signal": "load_angle_deg", "delay": 0.008}, "delay"),
    "encoder_quantization": ("bench_rig.yaml", {"signal": "motor_angle_deg", "counts_per_rev": 2048},
                             "counts_per_rev"),
}


def record(plant, hidden, seed=SEED, duration=DURATION_S):
    """A synthetic record of ``plant`` with ``hidden`` effects: open-loop voltage steps, noise NOISE."""
    t, u = excitation("steps", plant, duration_s=duration, seed=seed)
    return synthesize(plant, hidden, t, u, noise=NOISE, seed=seed)


def case(name: str) -> dict:
    """Hide ``name``, diagnose, and report (one rung: the verdict)."""
    plant_file, values, main = HIDDEN[name]
    plant = load_plant(PLANTS / plant_file)
    data = record(plant, [AddedEffect(name, values)])
    t0 = time.perf_counter()
    d = diagnose(plant, Replay(data), max_steps=1)
    wall = time.perf_counter() - t0
    step = d.ladder[0] if d.ladder else None
    return {"effect": name, "plant": plant_file, "truth": values, "verdict": d.verdict,
            "main_parameter": main, "fitted": step.params.get(main) if step else None,
            "fitted_params": step.params if step else {}, "error": step.error if step else d.baseline_error,
            "baseline_error": d.baseline_error, "noise_floor": d.noise_floor, "unit": d.unit,
            "runner_up": d.tried[1].candidate.label() if len(d.tried) > 1 else None, "wall_s": wall,
            "reason": d.reason}


@click.command()
@click.option("--results", "results_dir", type=click.Path(file_okay=False, path_type=Path),
              default=Path("results"), show_default=True, help="Output folder.")
def main(results_dir: Path) -> None:
    """Every effect of the library hidden in a record, and what diagnose makes of it.

    Writes RESULTS/hidden_effects.md and RESULTS/hidden_effects.json."""
    rows = []
    for name in HIDDEN:
        r = case(name)
        rows.append(r)
        click.echo(f"{name}: verdict {r['verdict']}, {r['main_parameter']} {r['fitted']} (truth "
              f"{r['truth'][r['main_parameter']]}), error {r['error']:.4g} / noise {r['noise_floor']:.4g} "
              f"{r['unit']}, {r['wall_s']:.1f} s")
    md = ["# Hidden effects: what diagnose finds", "",
          f"Each effect hidden in {DURATION_S:g} s of open-loop voltage steps on the bench rig, noise "
          + ", ".join(f"{k} {v:g}" for k, v in NOISE.items()) + f", seed {SEED}; the whole library "
          "diagnosed (`python -m studies.hidden_effects`).", "",
          "| hidden | verdict | parameter | truth | fitted | error / noise floor | runner-up | time (s) |",
          "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        truth = r["truth"][r["main_parameter"]]
        fitted = "—" if r["fitted"] is None else f"{r['fitted']:.4g}"
        md.append(f"| {r['effect']} | {r['verdict']} | {r['main_parameter']} | {truth:g} | {fitted} | "
                  f"{r['error'] / r['noise_floor']:.3g} | {r['runner_up']} | {r['wall_s']:.1f} |")
    write_text_atomic(results_dir / "hidden_effects.md", "\n".join(md) + "\n")
    write_text_atomic(results_dir / "hidden_effects.json", json.dumps(rows, indent=1, default=str) + "\n")


if __name__ == "__main__":
    main()
