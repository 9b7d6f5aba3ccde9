"""Controllers: what each law does to the motor-side angle, clear solver failures, and the
one table that names each kind in every report."""
import io
import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from gearbench import layout as L
from gearbench.control.controllers import KIND_NAMES, Controller, kind_name
from gearbench.experiment.files import load_experiment
from gearbench.report import tables, variants
from gearbench.report.stability import describe_controller
from gearbench.simulate import Segments, SolverOptions, failure_message, simulate

HOLD = Segments(t=np.array([0.0]), v=np.array([math.radians(10.0)]), s=np.array([0.0]))


def motor_side_deg(run):
    return np.degrees(run.outputs[:, L.O_MOTOR]) / 100.0


def test_p_settles_on_set_point_from_motor_side(plant):
    run = simulate(plant, Controller("p", kp=50), HOLD, 1.0)
    assert run.ok
    # a heavily damped load needs no torque at rest: no steady-state error on the motor side
    assert abs(motor_side_deg(run)[-1] - 10.0) < 1e-3
    # the output lags by half the clearance (it was pushed, then left on the driving flank)
    h = plant.gear.backlash_deg / 2
    assert abs(np.degrees(run.outputs[-1, L.O_LOAD]) - (10.0 - h)) < 0.01


def test_bang_bang_stops_inside_its_dead_band(plant):
    run = simulate(plant, Controller("bang_bang", band_deg=0.25), HOLD, 1.0)
    assert run.ok
    err = 10.0 - motor_side_deg(run)[-200:]
    assert np.all(np.abs(err) <= 0.125 + 0.05)  # half band, plus coasting after switch-off
    assert np.all(run.outputs[-50:, L.O_VOLTAGE] == 0.0)


def test_pid_with_filtered_derivative_tracks(plant):
    run = simulate(plant, Controller("pid", kp=50, ki=0.005, kd=0.002, derivative_filter_s=1e-3),
                   HOLD, 1.0)
    assert run.ok
    assert abs(motor_side_deg(run)[-1] - 10.0) < 1e-2


def test_set_point_shift_follows_thesis_equation_1(plant):
    """From rest the motor speed is >= 0, so the shift is added: the motor heads for
    r + s and lays the output onto the set point itself.  The engaged loop is
    overdamped here, so the speed decays to zero without changing sign: the shift
    never flips and nothing chatters (round-off alone must not flip it)."""
    h = plant.gear.backlash_deg / 2
    run = simulate(plant, Controller("p", kp=50, shift=True), HOLD, 1.0)
    assert abs(motor_side_deg(run)[-1] - (10.0 + h)) < 1e-3
    assert abs(np.degrees(run.outputs[-1, L.O_LOAD]) - 10.0) < 1e-3
    assert run.impacts == 1
    # after the first approach the output error is a fraction of the unshifted lag h
    plain = simulate(plant, Controller("p", kp=50), HOLD, 1.0)
    tail = slice(450, None)
    err = lambda r: np.abs(np.degrees(r.outputs[tail, L.O_SETPOINT] - r.outputs[tail, L.O_LOAD]))
    assert abs(err(plain).mean() - h) < 0.01
    assert err(run).mean() < h / 4


def test_voltage_never_exceeds_the_limit(plant):
    run = simulate(plant, Controller("pi", kp=5000, ki=1.0), HOLD, 0.5)
    assert np.max(np.abs(run.outputs[:, L.O_VOLTAGE])) <= plant.motor.max_voltage
    assert run.saturated_fraction > 0.0


def test_failed_run_says_which_where_and_why(plant):
    run = simulate(plant, Controller("p", kp=50), HOLD, 1.0, SolverOptions(max_steps=200),
                   label="tiny-budget")
    assert not run.ok
    msg = failure_message(run, plant.name)
    assert "tiny-budget" in msg and "t = " in msg and "likely cause" in msg
    assert 0.0 < run.stats[L.S_T_FAIL] < 1.0


# ---------------------------------------------------------------- controller names, written once

REPO = Path(__file__).resolve().parents[1]


def test_kind_name():
    assert [kind_name(k) for k in ("open", "bang_bang", "p", "pi", "pid")] == ["open", "bang-bang", "P", "PI", "PID"]
    assert kind_name("p", 50.0) == "P, Kp=50" and kind_name("pi", 0.5) == "PI, Kp=0.5"
    assert kind_name("bang_bang", float("nan")) == "bang-bang" and kind_name("p", None) == "P"
    assert kind_name("other") == "other"


@pytest.mark.parametrize("name", ["table1", "table1_translational", "compensators"])
def test_committed_markdown_tables_regenerate_from_their_runs(name):
    """The committed results/<name>.md is what the report writers make of results/<name>_runs.csv:
    the controller names there did not change."""
    exp = load_experiment(REPO / "experiments" / f"{name}.yaml")
    runs = pd.read_csv(REPO / "results" / f"{name}_runs.csv")
    if name == "table1":
        md = tables.table1_markdown(runs, f"{exp.name}: integrated absolute output error (deg s)",
                                    exp.description)
    elif name == "table1_translational":
        md = variants.translational_markdown(
            runs, f"{exp.name}: integrated absolute carriage position error (mm s)", exp.description)
    else:
        md = variants.compensator_markdown(
            runs, f"{exp.name}: integrated absolute output error (deg s) and voltage sign changes",
            exp.description)
    assert md == (REPO / "results" / f"{name}.md").read_text()


def test_every_report_names_controllers_from_the_one_table(monkeypatch):
    from rich.console import Console

    monkeypatch.setitem(KIND_NAMES, "p", "Prop")
    monkeypatch.setitem(KIND_NAMES, "bang_bang", "BB")
    t1 = pd.read_csv(REPO / "results" / "table1_runs.csv")
    md = tables.table1_markdown(t1, "t")
    assert "| 1 | BB |" in md and "| 1 | Prop, Kp=50 |" in md and "bang-bang" not in md
    out = io.StringIO()
    Console(file=out, width=200).print(tables.rich_table(t1, "t"))
    assert "Prop 50" in out.getvalue() and "BB" in out.getvalue()
    tr = pd.read_csv(REPO / "results" / "table1_translational_runs.csv")
    assert "| 1 | BB |" in variants.translational_markdown(tr, "t")
    co = pd.read_csv(REPO / "results" / "compensators_runs.csv")
    assert "| 1 | Prop, Kp=50 |" in variants.compensator_markdown(co, "t")
    assert describe_controller(SimpleNamespace(kind="p")) == "Prop"
    monkeypatch.undo()
    assert describe_controller(SimpleNamespace(kind="pi", ki=0.005)) == "PI, Ki = 0.005 1/s"
