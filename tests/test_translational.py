"""The translational variant: the leadscrew apparatus's top speed (thesis: about 0.176 in/s)."""
import json
from pathlib import Path

from click.testing import CliRunner

from gearbench.cli import main
from gearbench.experiment.files import load_experiment

REPO = Path(__file__).resolve().parents[1]


def _info(name):
    res = CliRunner().invoke(main, ["info", str(REPO / "experiments/plants" / name), "--json"])
    assert res.exit_code == 0, res.output
    return json.loads(res.output)


def test_leadscrew_top_speed_within_5_percent_of_thesis():
    info = _info("leadscrew_apparatus.yaml")
    assert abs(info["top_speed_in_s"] / 0.176 - 1.0) <= 0.05, info["top_speed_in_s"]


def test_leadscrew_friction_is_coulomb_and_sets_the_top_speed():
    """The gear system's friction is a Coulomb effect on the screw; info counts it:
    without it the same plant would run at 0.29 in/s, not the thesis's 0.176 in/s."""
    from dataclasses import replace

    from gearbench.experiment.files import load_plant
    from gearbench.plant.linear import plant_info
    plant = load_plant(REPO / "experiments/plants/leadscrew_apparatus.yaml")
    assert [(e.name, e.values["location"]) for e in plant.effects] == [("coulomb_friction", "load")]
    info = plant_info(plant)
    assert info["drag_torque_Nm"] == plant.effects[0].values["torque"] / plant.gear.ratio
    assert plant_info(replace(plant, effects=()))["top_speed_in_s"] > 1.5 * info["top_speed_in_s"]


def test_valve_has_20_degree_clearance_and_a_stem():
    info = _info("thesis_valve.yaml")
    assert info["clearance_deg"] == 20.0 and "top_speed_in_s" in info


def test_translational_experiment_loads_with_scaled_profiles():
    from gearbench.runner import load_profiles
    exp = load_experiment(REPO / "experiments/table1_translational.yaml")
    assert exp.plant.leadscrew is not None and exp.profile_scale == 19.0
    assert len(exp.runs()) == 30
    p1 = load_profiles(exp)["profile1"]
    assert max(p1.end_values()) == 50.0 * 19.0


def test_translational_table_has_mm_s_column(tmp_path):
    import yaml
    raw = yaml.safe_load((REPO / "experiments/table1_translational.yaml").read_text())
    raw.update(plant=str(REPO / "experiments/plants/leadscrew_apparatus.yaml"), profiles=["profile1"],
               controllers=[{"kind": "p", "kp": 50}], shift=False, duration_s=3.0)
    f = tmp_path / "t.yaml"
    f.write_text(yaml.safe_dump(raw))
    res = CliRunner().invoke(main, ["run", str(f), "--results", str(tmp_path / "r")])
    assert res.exit_code == 0, res.output
    head = (tmp_path / "r" / "table1_translational.csv").read_text().splitlines()[0]
    assert head == "profile,controller,kp,shift,iae_mm_s"
    md = (tmp_path / "r" / "table1_translational.md").read_text()
    assert "| IAE, no shift (mm s) | sign changes | impacts |" in md


def test_committed_translational_table_is_the_regenerated_one(tmp_path):
    """results/table1_translational_runs.csv is what the code computes now: the 30 runs
    regenerated (about 16 s on 2 cores), IAE to 1e-9 and the counts exactly."""
    import numpy as np
    import pandas as pd
    from gearbench.report.tables import records_frame
    from gearbench.report.variants import translational_frame
    from gearbench.runner import run_experiment
    exp = load_experiment(REPO / "experiments/table1_translational.yaml")
    now = translational_frame(records_frame(run_experiment(exp)), exp.plant)
    now.to_csv(tmp_path / "now.csv", index=False)
    now = pd.read_csv(tmp_path / "now.csv")
    old = pd.read_csv(REPO / "results/table1_translational_runs.csv")
    key = ["profile", "controller", "kp", "shift"]
    pd.testing.assert_frame_equal(now[key], old[key])  # the same runs in the same order
    np.testing.assert_allclose(now.iae_mm_s, old.iae_mm_s, rtol=1e-9)
    assert (now.impacts == old.impacts).all() and (now.switchings == old.switchings).all()
