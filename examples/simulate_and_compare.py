"""gearbench from Python: simulate a Table I cell, then hold a model against a record.

    python examples/simulate_and_compare.py [OUTPUT_FOLDER]

Writes run.png, run.csv, compare.png, fitted_compare.png and fitted_plant.yaml into OUTPUT_FOLDER
(default: example_output/).  Run from anywhere; the plant and data files are
taken from the repository this script sits in.
"""
import sys
from pathlib import Path

import gearbench as gb

REPO = Path(__file__).resolve().parent.parent
out = Path(sys.argv[1] if len(sys.argv) > 1 else "example_output")
out.mkdir(parents=True, exist_ok=True)

# 1. A plant file, a controller (gains in V/deg, as in the experiment files), a profile.
plant = gb.load_plant(REPO / "experiments/plants/thesis_gear.yaml")
for shift in (False, True):
    run = gb.simulate(plant, gb.Controller("p", kp=50, shift=shift), "profile1", solver={"rtol": 1e-7})
    print(f"profile1, P Kp=50, shift {'on ' if shift else 'off'}: IAE {run.iae_deg_s:.3f} deg s, "
          f"{run.scores['impacts']} impacts")
run.plot().savefig(out / "run.png", dpi=80)
run.to_pandas().to_csv(out / "run.csv", index=False)

# 2. A set point of your own, in degrees: rest, a 20 deg/s ramp to 20 deg, hold.
mine = gb.setpoint([0.0, 0.5, 1.5], [0.0, 0.0, 20.0], [0.0, 20.0, 0.0], duration_s=3.0, name="ramp")
run = gb.simulate(plant, {"kind": "pi", "kp": 200, "ki": 0.005}, mine)
print(f"ramp, PI Kp=200: IAE {run.iae_deg_s:.4f} deg s; output at 3 s: {run['load_angle_deg'][-1]:.3f} deg")

# 3. The model against a measured record, and the two effects it misses, fitted
#    (the tutorial, docs/tutorial.md: the record hides a load spring and Coulomb friction).
rig, record = REPO / "experiments/plants/bench_rig.yaml", REPO / "experiments/data/bench_rig_hidden.csv"
before = gb.compare(rig, record)
print(before.to_pandas()[["unit", "rms_error", "noise_floor", "ratio_to_noise"]].to_string())
before.plot().savefig(out / "compare.png", dpi=80)
spring = gb.fit(rig, record, "load_spring")
both = gb.fit(spring.plant, record, "coulomb_friction", options={"location": "load"}, refit=True)
print(both.to_pandas().to_string())
after = gb.compare(both.plant, record)
after.plot().savefig(out / "fitted_compare.png", dpi=80)
p = after.primary
print(f"{p}: RMS error {before.to_pandas().loc[p, 'rms_error']:.4g} -> {after.to_pandas().loc[p, 'rms_error']:.4g} "
      f"{both.unit} ({after.to_pandas().loc[p, 'ratio_to_noise']:.3g}x its noise floor)")
(out / "fitted_plant.yaml").write_text(both.to_yaml())
