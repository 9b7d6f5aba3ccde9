"""Plant and experiment files: valid files load, every kind of bad input is named."""
import copy
import pickle
from pathlib import Path

import pytest
import yaml

from gearbench.control.controllers import Controller
from gearbench.experiment import (ConfigError, load_experiment, load_plant,
                                  validate_experiment_dict, validate_plant_dict)
from gearbench.simulate import SolverOptions

SAMPLE = {
    "motor": {"resistance": 2.5, "inductance": 1.0e-3, "torque_constant": 0.02,
              "back_emf_constant": 0.02, "inertia": 1.0e-6, "damping": 1.0e-6,
              "max_voltage": 12.0},
    "gear": {"ratio": 100.0, "backlash_deg": 3.0, "mesh_stiffness": 2.4e7, "mesh_damping": 3.4},
    "load": {"inertia": 5.0e-5, "damping": 15.0},
}

EXPERIMENT = """\
description: Table I of the thesis
plant: plants/thesis_gear.yaml
duration_s: 10.0
solver: {method: rosenbrock23, rtol: 1.0e-6, max_step_s: 1.0e-3, output_dt_s: 1.0e-3}
profiles: [profile1, profile2, profile3]
controllers:
  - {kind: bang_bang, band_deg: 0.25}
  - {kind: p, kp: 50}
  - {kind: pi, kp: 50, ki: 0.005}
  - {kind: pid, kp: 50, ki: 0.005, kd: 0.001, derivative_filter_s: 0.001}
shift: [off, on]
shift_deg: 1.5
reference: thesis_table1.csv
initial_delta_deg: 0.5
"""


def sample(**changes):
    """A deep copy of SAMPLE with ``{"motor.resistance": value}`` style changes
    (value ``DELETE`` removes the key)."""
    d = copy.deepcopy(SAMPLE)
    for path, value in changes.items():
        *heads, last = path.split(".")
        node = d
        for h in heads:
            node = node.setdefault(h, {})
        if value is DELETE:
            del node[last]
        else:
            node[last] = value
    return d


DELETE = object()


def write(tmp_path, name, content):
    path = tmp_path / name
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(content if isinstance(content, str) else yaml.safe_dump(content))
    return path


def error_of(fn, *args):
    with pytest.raises(ConfigError) as info:
        fn(*args)
    return str(info.value)


# ------------------------------------------------------------------ plants

def test_valid_plant_file(tmp_path):
    plant = load_plant(write(tmp_path, "thesis_gear.yaml", SAMPLE))
    assert plant.name == "thesis_gear"
    assert plant.motor.resistance == 2.5 and plant.gear.ratio == 100.0
    assert plant.gear.contact_law == "dubowsky"
    assert plant.load.inertia == 5.0e-5
    assert plant.shaft is None and plant.leadscrew is None and plant.effects == ()


def test_plant_from_dict_relative_path_and_name(tmp_path):
    write(tmp_path, "sub/g.yaml", dict(SAMPLE, name="rig", description="a test rig"))
    assert load_plant("sub/g.yaml", base_dir=tmp_path).name == "rig"
    assert load_plant(SAMPLE).motor.inertia == 1.0e-6
    assert validate_plant_dict(SAMPLE) == []


def test_yaml_exponent_without_dot_is_a_number(tmp_path):
    text = yaml.safe_dump(SAMPLE).replace("0.001", "1e-3")
    assert "1e-3" in text
    assert load_plant(write(tmp_path, "p.yaml", text)).motor.inductance == 1e-3


def test_shaft_pinion_comes_out_of_motor_inertia():
    d = sample(**{"shaft.stiffness": 50.0, "shaft.damping": 1e-4, "shaft.pinion_inertia": 3e-7,
                  "gear.contact_law": "elasto_backlash"})
    plant = load_plant(d)
    assert plant.motor.inertia == pytest.approx(7e-7)
    assert plant.shaft.pinion_inertia == 3e-7
    assert plant.gear.contact_law == "elasto_backlash"


def test_leadscrew_damping_defaults_to_zero():
    plant = load_plant(sample(**{"leadscrew.lead_mm": 1.27, "leadscrew.mass": 0.5}))
    assert plant.leadscrew.damping == 0.0 and plant.leadscrew.lead_mm == 1.27


BAD_PLANTS = {
    "unknown key": ({"motor.resistence": 2.0}, ["motor.resistence", "resistance (ohm)", "did you mean"]),
    "unknown top key": ({"colour": "red"}, ["colour", "allowed", "motor"]),
    "missing key": ({"load.inertia": DELETE}, ["load.inertia is missing", "kg m^2"]),
    "missing section": ({"gear": DELETE}, ["gear is missing", "ratio", "backlash_deg (deg)"]),
    "string number": ({"motor.inductance": "abc"}, ["motor.inductance", "in H", "string"]),
    "bool number": ({"motor.torque_constant": True}, ["motor.torque_constant", "N m/A", "boolean"]),
    "negative inertia": ({"load.inertia": -5e-5}, ["load.inertia", "positive", "kg m^2", "-5e-05"]),
    "zero resistance": ({"motor.resistance": 0}, ["motor.resistance", "positive", "ohm"]),
    "negative damping": ({"gear.mesh_damping": -1.0}, ["gear.mesh_damping", ">= 0", "N m s/rad"]),
    "non-finite": ({"motor.max_voltage": float("inf")}, ["motor.max_voltage", "in V", "finite"]),
    "nan": ({"gear.backlash_deg": float("nan")}, ["gear.backlash_deg", "deg"]),
    "a clearance past the backlash effect's bound": ({"gear.backlash_deg": 1e308},
                                                     ["gear.backlash_deg must be a number >= 0 and <= 90 in deg"]),
    "bad contact law": ({"gear.contact_law": "hertz"}, ["gear.contact_law", "dubowsky, elasto_backlash"]),
    "section not mapping": ({"load": [1, 2]}, ["load must be a mapping", "inertia"]),
    "unknown effect": ({"effects": [{"type": "coulomb_frictoin", "torque": 0.1}]},
                       ["effects[0].type", "did you mean 'coulomb_friction'"]),
    "effect negative": ({"effects": [{"type": "coulomb_friction", "location": "motor", "torque": -0.1}]},
                        ["effects[0].torque", "N m"]),
    "effect missing": ({"effects": [{"type": "load_spring", "stiffness": 2.0}]},
                       ["effects[0].rest_angle_deg is missing", "deg"]),
    "effect location": ({"effects": [{"type": "viscous_friction", "location": "shaft", "coefficient": 1.0}]},
                        ["effects[0].location", "motor, load, carriage"]),
    "carriage needs leadscrew": ({"effects": [{"type": "bias_torque", "location": "carriage", "force": 1.0}]},
                                 ["effects[0].location", "leadscrew"]),
    "effect unknown key": ({"effects": [{"type": "bias_torque", "torqe": 1.0}]},
                           ["effects[0].torqe", "bias_torque parameter"]),
    "effects not list": ({"effects": "coulomb"}, ["effects must be a list"]),
    "pinion too heavy": ({"shaft.stiffness": 50.0, "shaft.damping": 0.0, "shaft.pinion_inertia": 2e-6},
                         ["shaft.pinion_inertia", "motor.inertia", "kg m^2"]),
    "leadscrew lead": ({"leadscrew.lead_mm": -1.0, "leadscrew.mass": 0.5}, ["leadscrew.lead_mm", "mm"]),
    "name not string": ({"name": 3}, ["name must be a non-empty string"]),
}


@pytest.mark.parametrize("case", list(BAD_PLANTS))
def test_bad_plant_is_named(tmp_path, case):
    changes, expected = BAD_PLANTS[case]
    path = write(tmp_path, "thesis_gear.yaml", sample(**changes))
    msg = error_of(load_plant, path)
    assert msg.startswith("thesis_gear.yaml: ")
    for text in expected:
        assert text in msg, (text, msg)


def test_all_problems_reported_at_once(tmp_path):
    d = sample(**{"motor.resistance": -2.0, "load.inertia": DELETE, "gear.oops": 1})
    with pytest.raises(ConfigError) as info:
        load_plant(write(tmp_path, "thesis_gear.yaml", d))
    err = info.value
    assert len(err.entries) == 3
    lines = str(err).splitlines()
    assert "thesis_gear.yaml: motor.resistance must be a positive number in ohm, got -2.0" in lines
    assert all(line.startswith("thesis_gear.yaml: ") for line in lines)
    assert pickle.loads(pickle.dumps(err)).entries == err.entries
    assert len(validate_plant_dict(d, "plant")) == 3
    assert all(p.startswith("plant.") for p in validate_plant_dict(d, "plant"))


SHAFT_EFFECT = {"type": "shaft_compliance", "stiffness": 50.0, "damping": 1e-4, "pinion_inertia": 3e-7}


def test_an_effect_that_cannot_sit_on_the_plant_is_named_alone(tmp_path):
    """A second shaft cannot sit on the plant; the effects after it are judged without it."""
    d = sample(effects=[SHAFT_EFFECT, SHAFT_EFFECT, {"type": "coulomb_friction", "location": "load", "torque": 0.1}])
    with pytest.raises(ConfigError) as info:
        load_plant(write(tmp_path, "thesis_gear.yaml", d))
    assert info.value.entries == (("thesis_gear.yaml", "effects[1] (shaft_compliance): the plant already has a shaft"),)


def test_effect_entries_are_checked_by_the_plant_files_check(tmp_path):
    from gearbench.experiment.files import check_effects_on
    plant = load_plant(SAMPLE)
    items = [SHAFT_EFFECT, {"type": "bias_torque", "torqe": 1.0}, SHAFT_EFFECT,
             {"type": "coulomb_friction", "location": "load", "torque": 0.1}]
    problems: list[str] = []
    found = check_effects_on(plant, items, ["a", "b", "c", "d"], problems)
    assert [e.name for e in found] == ["shaft_compliance", "coulomb_friction"]
    assert problems[0].startswith("b.torqe is not a bias_torque parameter")
    assert all(p.startswith("b.") for p in problems[:-1]) and problems[-1] == "c: the plant already has a shaft"
    assert load_plant(sample(effects=[SHAFT_EFFECT, items[3]])).effects == found


def test_yaml_syntax_error_names_line(tmp_path):
    path = write(tmp_path, "broken.yaml", "motor:\n  resistance: 2.5\n  inductance: [1\ngear: {\n")
    msg = error_of(load_plant, path)
    assert msg.startswith("broken.yaml: YAML syntax error at line ")


def test_duplicate_key_names_line(tmp_path):
    text = yaml.safe_dump(SAMPLE) + "load:\n  inertia: 1.0\n  damping: 0.0\n"
    msg = error_of(load_plant, write(tmp_path, "dup.yaml", text))
    assert "dup.yaml" in msg and "'load' appears twice" in msg and "line" in msg


def test_missing_empty_and_non_mapping_files(tmp_path):
    assert "file not found" in error_of(load_plant, tmp_path / "nope.yaml")
    assert "empty" in error_of(load_plant, write(tmp_path, "empty.yaml", "# nothing\n"))
    assert "must be a mapping" in error_of(load_plant, write(tmp_path, "list.yaml", "- 1\n- 2\n"))


# ------------------------------------------------------------- experiments

@pytest.fixture
def table1(tmp_path):
    write(tmp_path, "plants/thesis_gear.yaml", SAMPLE)
    write(tmp_path, "thesis_table1.csv", "controller,iae\n")
    return write(tmp_path, "table1.yaml", EXPERIMENT)


def test_valid_experiment(table1, tmp_path):
    exp = load_experiment(table1)
    assert exp.name == "table1" and exp.description == "Table I of the thesis"
    assert exp.plant.name == "thesis_gear"
    assert exp.plant_path == str((tmp_path / "plants/thesis_gear.yaml").resolve())
    assert exp.duration_s == 10.0
    assert exp.solver == SolverOptions("rosenbrock23", 1e-6, 1e-3, output_dt_s=1e-3)
    assert exp.profiles == ("profile1", "profile2", "profile3")
    assert exp.controllers == (Controller("bang_bang", band_deg=0.25), Controller("p", kp=50.0),
                               Controller("pi", kp=50.0, ki=0.005),
                               Controller("pid", kp=50.0, ki=0.005, kd=0.001,
                                          derivative_filter_s=0.001))
    assert exp.shifts == (False, True)
    assert exp.shift_deg == 1.5
    assert exp.reference == (tmp_path / "thesis_table1.csv").resolve()
    assert exp.initial_delta_deg == 0.5
    assert exp.base_dir == tmp_path.resolve()

    runs = exp.runs()
    assert len(runs) == 3 * 4 * 2
    assert [(p, c.kind, c.shift) for p, c in runs[:3]] == [
        ("profile1", "bang_bang", False), ("profile1", "bang_bang", True), ("profile1", "p", False)]
    assert runs[8][0] == "profile2"
    assert all(c.shift_deg == 1.5 for _, c in runs)


def test_minimal_inline_experiment(tmp_path):
    text = yaml.safe_dump({"plant": SAMPLE, "duration_s": 2, "profiles": "profile1",
                           "controllers": {"kind": "p", "kp": 5}, "shift": True})
    exp = load_experiment(write(tmp_path, "quick.yaml", text))
    assert exp.plant.name == "quick" and exp.plant_path is None
    assert exp.solver == SolverOptions() and exp.shift_deg is None and exp.reference is None
    assert exp.shifts == (True,) and exp.profiles == ("profile1",)
    assert exp.runs() == [("profile1", Controller("p", kp=5.0, shift=True))]
    assert validate_experiment_dict(yaml.safe_load(text)) == []


def edit(text, old, new):
    assert old in text
    return text.replace(old, new)


BAD_EXPERIMENTS = {
    "wrong kind key": (("{kind: bang_bang, band_deg: 0.25}", "{kind: bang_bang, kp: 50}"),
                       ["controllers[0].kp is not a bang_bang setting", "band_deg (deg)"]),
    "unknown kind": (("{kind: p, kp: 50}", "{kind: lqr, kp: 50}"),
                     ["controllers[1].kind must be one of bang_bang, p, pi, pid", "'lqr'"]),
    "missing gain": (("{kind: pi, kp: 50, ki: 0.005}", "{kind: pi, kp: 50}"),
                     ["controllers[2].ki is missing", "1/s"]),
    "negative gain": (("{kind: p, kp: 50}", "{kind: p, kp: -50}"), ["controllers[1].kp", "V/deg"]),
    "bad kd": (("kd: 0.001", "kd: fast"), ["controllers[3].kd", "in s", "'fast'"]),
    "shift_deg range": (("shift_deg: 1.5", "shift_deg: 4.0"), ["shift_deg", "3 deg", "4.0"]),
    "shift_deg negative": (("shift_deg: 1.5", "shift_deg: -1"), ["shift_deg", ">= 0 in deg"]),
    "initial delta range": (("initial_delta_deg: 0.5", "initial_delta_deg: -1.6"),
                            ["initial_delta_deg", "+-1.5 deg", "backlash_deg"]),
    "duration": (("duration_s: 10.0", "duration_s: 0"), ["duration_s", "positive number in s"]),
    "missing duration": (("duration_s: 10.0\n", ""), ["duration_s is missing", "in s"]),
    "solver method": (("method: rosenbrock23", "method: euler"), ["solver.method", "rosenbrock23"]),
    "solver rtol": (("rtol: 1.0e-6", "rtol: 2"), ["solver.rtol", "< 1", "dimensionless"]),
    "solver key": (("rtol: 1.0e-6", "atol: 1.0e-6"), ["solver.atol is not a solver setting", "rtol"]),
    "shift type": (("shift: [off, on]", "shift: [off, 2]"), ["shift[1] must be a boolean"]),
    "profiles type": (("profiles: [profile1, profile2, profile3]", "profiles: [1, profile2]"),
                      ["profiles[0] must be a profile name or path"]),
    "unknown top key": (("shift_deg: 1.5", "shift_degs: 1.5"), ["shift_degs is not an experiment key",
                                                                "shift_deg (deg)"]),
    "reference missing": (("reference: thesis_table1.csv", "reference: nope.csv"),
                          ["reference must be an existing file", "nope.csv"]),
    "plant file missing": (("plants/thesis_gear.yaml", "plants/other.yaml"),
                           ["table1.yaml: plant must name an existing plant file", "plants/other.yaml"]),
}


@pytest.mark.parametrize("case", list(BAD_EXPERIMENTS))
def test_bad_experiment_is_named(tmp_path, table1, case):
    (old, new), expected = BAD_EXPERIMENTS[case]
    path = write(tmp_path, "table1.yaml", edit(EXPERIMENT, old, new))
    msg = error_of(load_experiment, path)
    for text in expected:
        assert text in msg, (text, msg)


def test_experiment_and_plant_problems_together(tmp_path, table1):
    write(tmp_path, "plants/thesis_gear.yaml", sample(**{"motor.resistance": 0.0}))
    path = write(tmp_path, "table1.yaml", edit(EXPERIMENT, "{kind: p, kp: 50}", "{kind: p}"))
    lines = error_of(load_experiment, path).splitlines()
    assert "table1.yaml: controllers[1].kp is missing: expected a positive number in V/deg" in lines
    assert ("plants/thesis_gear.yaml: motor.resistance must be a positive number in ohm, got 0.0"
            in lines)


def test_inline_plant_problems_carry_plant_prefix(tmp_path):
    raw = {"plant": sample(**{"load.inertia": -1.0}), "duration_s": 1.0, "profiles": ["p1"],
           "controllers": [{"kind": "p", "kp": 5}]}
    msg = error_of(load_experiment, write(tmp_path, "inline.yaml", raw))
    assert msg == "inline.yaml: plant.load.inertia must be a positive number in kg m^2, got -1.0"


def test_experiment_yaml_syntax_error(tmp_path):
    path = write(tmp_path, "bad.yaml", "duration_s: 10\ncontrollers:\n  - {kind: p, kp: 50\n")
    assert error_of(load_experiment, path).startswith("bad.yaml: YAML syntax error at line")


# ---------------------------------------------------- shift_deg against the resolved plant

RIGID = {"motor": SAMPLE["motor"], "gear": {"ratio": 100.0, "rigid": True}, "load": SAMPLE["load"]}
ZERO_CLEARANCE = dict(SAMPLE, gear=dict(SAMPLE["gear"], backlash_deg=0.0))


@pytest.mark.parametrize("base", [RIGID, ZERO_CLEARANCE], ids=["rigid", "mesh without clearance"])
@pytest.mark.parametrize("shift_deg, ok", [(1.0, True), (2.0, True), (2.5, False)])
def test_shift_deg_is_checked_against_the_clearance_of_a_backlash_effect(tmp_path, base, shift_deg, ok):
    """The rule: 0 <= shift_deg <= the clearance, here 2 deg from the backlash effect
    (gear.backlash_deg is 0 or absent)."""
    write(tmp_path, "plants/p.yaml", dict(base, effects=[{"type": "backlash", "backlash_deg": 2.0}]))
    text = edit(edit(EXPERIMENT, "plants/thesis_gear.yaml", "plants/p.yaml"), "shift_deg: 1.5",
                f"shift_deg: {shift_deg}")
    text = edit(edit(text, "reference: thesis_table1.csv\n", ""), "initial_delta_deg: 0.5", "initial_delta_deg: 0")
    path = write(tmp_path, "table1.yaml", text)
    if ok:
        exp = load_experiment(path)
        assert exp.shift_deg == shift_deg and exp.plant.gear.backlash_deg == 0.0
        assert exp.plant.resolved().gear.backlash_deg == 2.0
    else:
        msg = error_of(load_experiment, path)
        assert "shift_deg must lie between 0 and the clearance" in msg and "= 2 deg, got 2.5" in msg


def test_a_compensator_whose_gain_overflows_is_named(tmp_path):
    """The feedforward compensators pack gains from the plant (Kff = N (ke + R b/kt)): a resistance
    of 1e308 ohm is a valid number but makes them infinite (found by tests/test_fuzz.py on
    experiments/compensators.yaml); the controller and the compensators are named before solving."""
    root = Path(__file__).resolve().parents[1] / "experiments"
    plant = yaml.safe_load((root / "plants" / "thesis_gear.yaml").read_text())
    plant["motor"]["resistance"] = 1e308
    exp = yaml.safe_load((root / "compensators.yaml").read_text())
    exp["plant"] = plant
    msg = error_of(load_experiment, write(tmp_path, "compensators.yaml", exp))
    assert "controllers[0] with compensator direction_feedforward, damped_feedforward: its values are too extreme" \
        in msg, msg
