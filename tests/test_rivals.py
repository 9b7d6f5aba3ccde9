"""What a record cannot tell apart, said instead of guessed (issue 37, part 3): a viscous friction
``b`` at the motor acts on a rigid train exactly as ``N^2 b`` at the load, so a record of the rig with
no clearance cannot say where it is, and diagnose names the other place as the rung's rival with
the coefficient that equivalence gives; with a 1 deg clearance between them the places differ and
no rival is named."""
from __future__ import annotations

import json

import pytest
from click.testing import CliRunner

from conftest import DATA
from gearbench.cli import main
from gearbench.experiment.files import load_plant

PLANTS = DATA.parent / "experiments" / "plants"
TRUE_B = 0.05  # N m s/rad at the load


def ladder(plant_file: str, tmp_path):
    data = tmp_path / "viscous.csv"
    r = CliRunner().invoke(main, ["synth", str(PLANTS / plant_file), "--effect",
                                  f"viscous_friction location=load coefficient={TRUE_B}", "--excitation", "steps",
                                  "--duration", "3", "--seed", "4", "-o", str(data)])
    assert r.exit_code == 0, r.output
    r = CliRunner().invoke(main, ["diagnose", str(PLANTS / plant_file), str(data), "--only", "viscous_friction",
                                  "--no-calibrate", "--json", "--results", str(tmp_path)])
    assert r.exit_code == 0, r.output
    return json.loads(r.output)["ladder"]


def test_a_rigid_train_cannot_tell_the_motor_from_the_load(tmp_path):
    steps = ladder("bench_rig_rigid.yaml", tmp_path)
    n = load_plant(PLANTS / "bench_rig_rigid.yaml").gear.ratio
    (step,) = steps
    rival, = step["rivals"]
    places = {step["options"]["location"], rival["options"]["location"]}
    assert places == {"motor", "load"} and rival["effect"] == "viscous_friction"
    at = {step["options"]["location"]: step["params"]["coefficient"],
          rival["options"]["location"]: rival["params"]["coefficient"]}
    assert at["load"] == pytest.approx(TRUE_B, rel=1e-3)
    assert at["motor"] * n * n == pytest.approx(at["load"], rel=0.01)  # b at the motor is N^2 b at the load
    assert 0 <= rival["bic_difference"] < 10
    assert "does not tell it apart from viscous_friction" in step["explanation"]


def test_a_clearance_between_them_tells_the_places_apart(tmp_path):
    (step,) = ladder("bench_rig.yaml", tmp_path)
    assert step["options"] == {"location": "load"} and step["rivals"] == []
    assert "does not tell it apart" not in step["explanation"]
