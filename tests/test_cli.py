"""The command line: info, run (tables, plots, traces), and clear errors on bad files."""
import json
from pathlib import Path

import pandas as pd
from click.testing import CliRunner

from gearbench.cli import main

REPO = Path(__file__).resolve().parents[1]
PLANT = REPO / "experiments" / "plants" / "thesis_gear.yaml"


def test_info_json_has_the_derived_figures():
    res = CliRunner().invoke(main, ["info", str(PLANT), "--json"])
    assert res.exit_code == 0, res.output
    data = json.loads(res.output)
    assert 100e3 < data["mesh_frequency_hz"] < 120e3  # the thesis's ~110 kHz
    assert data["shaft_frequency_hz"] is None
    assert "top_speed_in_s" not in data
    for key in ("electrical_time_constant_s", "mechanical_time_constant_s", "stall_torque_Nm",
                "no_load_speed_rad_s"):
        assert data[key] > 0


def short_experiment(tmp_path: Path) -> Path:
    exp = tmp_path / "mini.yaml"
    exp.write_text(f"""
name: mini
plant: {PLANT}
duration_s: 1.0
profiles: [profile1]
controllers:
  - {{kind: bang_bang, band_deg: 0.25}}
  - {{kind: p, kp: 50}}
shift: [off, on]
reference: {REPO / 'experiments' / 'thesis_table1.csv'}
""")
    return exp


def test_run_writes_table_plots_and_traces(tmp_path):
    exp = short_experiment(tmp_path)
    out = tmp_path / "results"
    res = CliRunner().invoke(main, ["run", str(exp), "--results", str(out), "--plot", "--traces"])
    assert res.exit_code == 0, res.output
    table = pd.read_csv(out / "mini.csv")
    assert list(table.columns) == ["profile", "controller", "kp", "shift", "iae_deg_s",
                                   "thesis_iae_deg_s", "ratio"]
    assert len(table) == 4
    assert (out / "mini.md").read_text().count("\n| 1 |") == 2
    pngs = sorted((out / "mini" / "plots").glob("*.png"))
    assert len(pngs) == 4
    traces = sorted((out / "mini" / "traces").glob("*.csv"))
    assert len(traces) == 4
    trace = pd.read_csv(traces[0])
    assert {"time_s", "voltage_V", "motor_angle_deg", "load_angle_deg", "current_A",
            "setpoint_deg"} <= set(trace.columns)
    assert trace["time_s"].is_monotonic_increasing and trace.notna().all().all()


def test_run_rejects_bad_experiment_before_solving(tmp_path):
    exp = tmp_path / "bad.yaml"
    exp.write_text(f"""
plant: {PLANT}
duration_s: -1
profiles: [profile1]
controllers: [{{kind: p, kp: 50, band_deg: 1}}]
""")
    res = CliRunner().invoke(main, ["run", str(exp), "--results", str(tmp_path / "r")])
    assert res.exit_code == 2
    assert "duration_s" in res.output and "controllers[0]" in res.output
    assert not (tmp_path / "r").exists()


def test_info_rejects_unphysical_plant(tmp_path):
    bad = tmp_path / "bad_plant.yaml"
    bad.write_text(PLANT.read_text().replace("resistance: 2.5", "resistance: 0.0"))
    res = CliRunner().invoke(main, ["info", str(bad)])
    assert res.exit_code == 2
    assert "motor.resistance" in res.output and "ohm" in res.output
