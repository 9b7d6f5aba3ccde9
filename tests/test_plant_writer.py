"""``gearbench fit -o`` edits the user's plant file: comments, key order, number formats and
the description stay; fitted values change in place with their standard errors as comments."""
from __future__ import annotations

import re
from dataclasses import replace
from pathlib import Path

import pytest
from click.testing import CliRunner

from gearbench.cli import main
from gearbench.experiment.files import load_plant
from gearbench.experiment.writer import plant_to_dict, update_plant_yaml
from gearbench.synth import excitation, synthesize
from gearbench.measure.data import write_measurement
from gearbench.plant.effects import AddedEffect

PLANTS = Path(__file__).resolve().parents[1] / "experiments" / "plants"
RIG = PLANTS / "bench_rig.yaml"
SCREW = PLANTS / "leadscrew_apparatus.yaml"


def comments(text: str) -> list[str]:
    """Every comment of a file, without the spacing around it."""
    return [c.strip() for c in re.findall(r"#[^\n]*", text)]


def top_keys(text: str) -> list[str]:
    return re.findall(r"^(\w+):", text, re.M)


def reload(tmp_path, text: str):
    path = tmp_path / "new.yaml"
    path.write_text(text)
    return load_plant(path)


def test_an_added_effect_keeps_every_comment_and_the_description(tmp_path):
    text = RIG.read_text()
    old = load_plant(RIG)
    new = old.with_effects(AddedEffect("coulomb_friction", {"location": "load", "torque": 0.9612345}))
    out = update_plant_yaml(text, old, new, {"effects[0].torque": 0.0123}, "bench_rig + friction\nerror 3 -> 0.01")
    assert out.startswith("# bench_rig + friction\n# error 3 -> 0.01\n# A small lab gearmotor rig")
    # the header's two, every one of the file's, the fitted value's
    assert comments(out)[2:-1] == comments(text)
    assert comments(out)[-1] == "# fitted, standard error 0.0123"
    assert top_keys(out) == top_keys(text)
    assert "Lab rig for practice and tests" in out and "mesh_stiffness: 3.0e5" in out
    assert re.search(r"torque: 0.9612345 +# fitted, standard error 0.0123\n", out)
    again = reload(tmp_path, out)
    assert again == new


def test_a_refitted_value_keeps_the_old_comment_below_and_says_what_it_was(tmp_path):
    text = SCREW.read_text()
    old = load_plant(SCREW)
    e = old.effects[0]
    new = replace(old, effects=(AddedEffect(e.name, {**e.values, "torque": 1.3}),),
                  leadscrew=replace(old.leadscrew, mass=2.5))
    out = update_plant_yaml(text, old, new, {"effects[0].torque": 0.02, "leadscrew.mass": 0.1})
    assert "  mass: 2.5                # fitted, standard error 0.1 (was 2.0)\n" \
           "                           # kg: carriage and slide\n" in out
    assert "    torque: 1.3            # fitted, standard error 0.02 (was 1.15)\n" \
           "                           # N m: nine tenths of the 1.2775 N m drag" in out
    assert "  - type: coulomb_friction # the gear system's sliding friction" in out  # its list indent too
    assert set(comments(text)) <= set(comments(out))
    assert reload(tmp_path, out) == new

    # fitted again: the note is replaced, not stacked; the user's comment stays once
    newer = replace(new, leadscrew=replace(new.leadscrew, mass=2.6))
    again = update_plant_yaml(out, new, newer, {"leadscrew.mass": 0.05})
    assert "mass: 2.6                # fitted, standard error 0.05 (was 2.5)\n" in again
    assert again.count("# kg: carriage and slide") == 1 and again.count("fitted, standard error") == 2
    assert reload(tmp_path, again) == newer


def test_defaults_the_file_leaves_out_stay_out(tmp_path):
    text = RIG.read_text()
    old = load_plant(RIG)
    new = replace(old, load=replace(old.load, damping=4.5e-3))
    out = update_plant_yaml(text, old, new, {"load.damping": 1e-4})
    assert "contact_law" not in out and "drive" not in top_keys(out)
    assert reload(tmp_path, out) == new


def test_a_shaft_plant_motor_inertia_round_trips(tmp_path):
    path = PLANTS / "thesis_gear_shaft.yaml"
    old = load_plant(path)
    new = replace(old, motor=replace(old.motor, inertia=old.motor.inertia * 1.1))
    out = update_plant_yaml(path.read_text(), old, new, {"motor.inertia": 1e-8})
    again = reload(tmp_path, out)
    assert again.motor_inertia_total == pytest.approx(new.motor_inertia_total, rel=1e-12)
    assert "fitted, standard error 1e-08" in out


def test_what_the_editor_cannot_do_is_written_afresh_and_said(tmp_path):
    old = load_plant(SCREW)
    new = replace(old, effects=(AddedEffect("viscous_friction", {"location": "load", "coefficient": 0.1}),))
    out = update_plant_yaml(SCREW.read_text(), old, new, {}, "header")
    assert out.startswith("# header\n# the original file's comments could not be kept")
    assert plant_to_dict(reload(tmp_path, out)) == plant_to_dict(new)


@pytest.fixture(scope="module")
def record(tmp_path_factory):
    """2 s of the bench rig with a hidden load-side Coulomb friction of 0.8 N m."""
    plant = load_plant(RIG)
    t, u = excitation("steps", plant, duration_s=2.0, seed=3)
    data = synthesize(plant, [AddedEffect("coulomb_friction", {"location": "load", "torque": 0.8})], t, u, seed=3)
    path = tmp_path_factory.mktemp("rec") / "rig.csv"
    write_measurement(data, path)
    return path


def test_fit_output_keeps_the_plant_files_comments(record, tmp_path):
    out = tmp_path / "fitted.yaml"
    r = CliRunner().invoke(main, ["fit", str(RIG), str(record), "--effect", "coulomb_friction location=load",
                                  "-o", str(out)])
    assert r.exit_code == 0, r.output
    text = out.read_text()
    assert comments(text)[2:-1] == comments(RIG.read_text())
    assert text.startswith("# bench_rig + coulomb_friction")
    assert "description: >\n  Lab rig for practice and tests" in text
    (e,) = load_plant(out).effects
    assert e.values["torque"] == pytest.approx(0.8, rel=0.05)
    assert re.search(r"\n  torque: [0-9.]+ +# fitted, standard error [0-9.e-]+ N m\n", text)


def test_the_standard_error_carries_its_unit_and_the_file_still_loads(tmp_path):
    text = RIG.read_text()
    old = load_plant(RIG)
    new = old.with_effects(AddedEffect("coulomb_friction", {"location": "load", "torque": 0.5}))
    out = update_plant_yaml(text, old, new, {"effects[0].torque": 0.0123}, "h", {"effects[0].torque": "N m"})
    assert re.search(r"torque: 0.5 +# fitted, standard error 0.0123 N m\n", out)
    assert plant_to_dict(reload(tmp_path, out)) == plant_to_dict(new)
