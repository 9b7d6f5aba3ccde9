"""compare, diagnose and fit from the command line, on short synthetic records."""
from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from gearbench.cli import main
from gearbench.experiment.files import load_plant
from gearbench.synth import excitation, synthesize
from gearbench.measure.data import write_measurement
from gearbench.plant.effects import AddedEffect

PLANTS = Path(__file__).resolve().parents[1] / "experiments" / "plants"
RIG = PLANTS / "bench_rig.yaml"


@pytest.fixture(scope="module")
def record(tmp_path_factory):
    """3 s of the bench rig with a hidden load-side Coulomb friction of 0.8 N m."""
    plant = load_plant(RIG)
    t, u = excitation("steps", plant, duration_s=3.0, seed=2)
    data = synthesize(plant, [AddedEffect("coulomb_friction", {"location": "load", "torque": 0.8})], t, u,
                      seed=2)
    path = tmp_path_factory.mktemp("rec") / "rig.csv"
    write_measurement(data, path)
    return path


def invoke(*args):
    return CliRunner().invoke(main, [str(a) for a in args], catch_exceptions=False)


def test_compare_reports_signals_phases_and_figures(record, tmp_path):
    r = invoke("compare", RIG, record, "--results", tmp_path, "--json")
    assert r.exit_code == 0, r.output
    out = json.loads(r.output)
    names = {s["signal"] for s in out["signals"]}
    assert names == {"motor_angle_deg", "load_angle_deg", "current_A"}
    assert all(s["ratio_to_noise"] > 5 for s in out["signals"] if s["signal"] != "current_A")
    assert set(out["phases"]) <= {"standstill", "steady motion", "direction reversal", "acceleration"}
    assert sum(p["error_share"] for p in out["phases"].values()) == pytest.approx(1.0)
    folder = tmp_path / "compare_bench_rig_rig"
    assert (folder / "load_angle_deg.png").stat().st_size > 10_000
    assert (folder / "load_angle_deg_residual_vs_motion.png").exists()


def test_diagnose_json_has_the_spec_keys(record, tmp_path):
    r = invoke("diagnose", RIG, record, "--only", "coulomb_friction,viscous_friction,bias_torque",
               "--max-steps", "2", "--results", tmp_path, "--json")
    assert r.exit_code == 0, r.output
    out = json.loads(r.output)
    assert {"baseline_error", "noise_floor", "candidates", "verdict", "ladder"} <= set(out)
    assert out["not_tried"] == {}  # the three of --only can all act on the rig
    assert out["verdict"] == "coulomb_friction"
    assert out["candidates"][0]["effect"] == "coulomb_friction"
    assert out["candidates"][0]["params"]["torque"] == pytest.approx(0.8, rel=0.05)
    errs = [c["error"] for c in out["candidates"] if c["error"] is not None]
    assert out["ladder"][0]["error"] < out["baseline_error"] and errs[0] == min(errs)
    assert (tmp_path / "diagnose_bench_rig_rig" / "ladder.png").exists()
    # standard errors per candidate and rung; the pairs of estimates (calibrated plant values
    # included) correlated beyond 0.9 listed by full name
    assert out["candidates"][0]["stderr"]["torque"] > 0
    for entry in out["candidates"][0]["correlations"] + out["ladder"][0]["correlations"]:
        assert set(entry) == {"a", "b", "rho"} and abs(entry["rho"]) > 0.9 and entry["a"] != entry["b"]
    assert out["ladder"][0]["stderr"]


def test_fit_writes_a_plant_that_loads_and_fits_better(record, tmp_path):
    new = tmp_path / "fitted.yaml"
    r = invoke("fit", RIG, record, "--effect", "coulomb_friction location=load", "-o", new)
    assert r.exit_code == 0, r.output
    plant = load_plant(new)
    (e,) = plant.effects
    assert e.name == "coulomb_friction" and e.values["torque"] == pytest.approx(0.8, rel=0.05)
    assert "standard error" in new.read_text()
    r2 = invoke("compare", new, record, "--results", tmp_path, "--json")
    load = next(s for s in json.loads(r2.output)["signals"] if s["signal"] == "load_angle_deg")
    assert load["ratio_to_noise"] < 1.5


def test_fit_that_does_not_converge_writes_nothing(record, tmp_path):
    new = tmp_path / "never.yaml"
    r = invoke("fit", RIG, record, "--effect", "coulomb_friction location=load torque=0.01",
               "--max-evals", "1", "-o", new)
    assert r.exit_code == 1
    assert "did not converge" in r.output and "nothing written" in r.output
    assert not new.exists()


@pytest.mark.parametrize("args, text", [
    (["--effect", "coulomb_frictoin"], "unknown effect"),
    (["--effect", "coulomb_friction location=shaft"], "location"),
    (["--free", "load.colour", "--effect", "bias_torque"], "load.colour"),
])
def test_fit_bad_input_names_the_fault(record, tmp_path, args, text):
    r = CliRunner().invoke(main, ["fit", str(RIG), str(record), *args, "-o", str(tmp_path / "x.yaml")])
    assert r.exit_code == 2 and text in r.output, r.output
    assert not (tmp_path / "x.yaml").exists()


def test_bad_measurement_file_is_named_before_solving(tmp_path):
    bad = tmp_path / "bad.csv"
    bad.write_text("time_s,voltage_V,load_angle_deg\n0,1,0\n0.001,1,nan\n")
    r = CliRunner().invoke(main, ["compare", str(RIG), str(bad)])
    assert r.exit_code == 2 and "load_angle_deg" in r.output and "row 2" in r.output, r.output
    wrong = tmp_path / "force.csv"
    wrong.write_text("time_s,drive_force_N,load_angle_deg\n0,1,0\n0.001,1,0\n")
    r = CliRunner().invoke(main, ["diagnose", str(RIG), str(wrong)])
    assert r.exit_code == 2 and "drive: force" in r.output, r.output
