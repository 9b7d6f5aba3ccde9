"""The public Python API (``gearbench.__all__``, ``gearbench/api.py``): names,
docstrings and their doctests, argument checks, results, and agreement with
the runner and the CLI."""
from __future__ import annotations

import doctest
import inspect
import json
import math
import os
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from numpydoc.docscrape import ClassDoc, FunctionDoc

import gearbench as gb

REPO = Path(__file__).resolve().parent.parent
THESIS = REPO / "experiments/plants/thesis_gear.yaml"
RIG = REPO / "experiments/plants/bench_rig.yaml"
HIDDEN = REPO / "experiments/data/bench_rig_hidden.csv"


@pytest.fixture
def in_repo(monkeypatch):
    """Doctests and examples use paths relative to the repository, as a user there would."""
    monkeypatch.chdir(REPO)


# ------------------------------------------------------------------ names

def test_import_is_cheap_and_every_name_resolves():
    code = ("import sys, gearbench; heavy = [m for m in ('numba', 'pandas', 'matplotlib', 'scipy') "
            "if m in sys.modules]; print(heavy); [getattr(gearbench, n) for n in gearbench.__all__]")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         env={**os.environ, "PYTHONPATH": str(REPO)})
    assert out.stdout.strip() == "[]"
    assert set(gb.__all__) <= set(dir(gb))
    with pytest.raises(AttributeError, match="no attribute 'simulat'"):
        gb.simulat


def test_simulate_is_the_api_function_and_the_module_still_imports():
    import gearbench.simulate  # noqa: F401 - importing the submodule must not hide the function
    from gearbench.simulate import Segments, simulate as internal
    assert gb.simulate.__module__ == "gearbench.api"
    assert internal.__module__ == "gearbench.simulate" and gb.Segments is Segments
    assert sys.modules["gearbench.simulate"].simulate is internal


# ------------------------------------------------------------- docstrings

def _public():
    """Public callables that a user calls (exceptions are raised, not called)."""
    out = []
    for name in gb.__all__:
        obj = getattr(gb, name)
        if inspect.isclass(obj) and issubclass(obj, BaseException):
            continue
        out.append((name, obj))
    return out


def _documented(obj) -> set[str]:
    doc = ClassDoc(obj) if inspect.isclass(obj) else FunctionDoc(obj)
    names = set()
    for p in doc["Parameters"]:
        names.update(n.strip().lstrip("*") for n in p.name.split(","))
    return names


def _undocumented(obj) -> tuple[set[str], set[str]]:
    """(parameters missing from the docstring, documented names that are not parameters)."""
    params = {n for n, p in inspect.signature(obj).parameters.items()
              if n != "self" and p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD)}
    doc = _documented(obj)
    return params - doc, doc - params


@pytest.mark.parametrize("name", [n for n, _ in _public()])
def test_every_parameter_is_documented(name):
    missing, stale = _undocumented(getattr(gb, name))
    assert not missing, f"gearbench.{name}: parameters not in its docstring's Parameters section: {missing}"
    assert not stale, f"gearbench.{name}: documented parameters it does not have: {stale}"


def test_the_parameter_check_catches_an_undocumented_argument():
    def documented(a, b=1):
        """Do it.

        Parameters
        ----------
        a : int
            The first.
        """
    assert _undocumented(documented) == ({"b"}, set())


@pytest.mark.parametrize("name", [n for n, _ in _public()])
def test_examples_run_as_doctests(name, in_repo):
    obj = getattr(gb, name)
    doc = ClassDoc(obj) if inspect.isclass(obj) else FunctionDoc(obj)
    assert doc["Examples"], f"gearbench.{name} has no Examples section"
    tests = [t for t in doctest.DocTestFinder(recurse=False).find(obj, name) if t.examples]
    assert tests, f"gearbench.{name}: its Examples hold no >>> example"
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    for t in tests:
        runner.run(t)
    assert runner.failures == 0, f"gearbench.{name}: {runner.failures} failing example(s) (output above)"


def test_api_module_docstring_example(in_repo):
    import gearbench.api
    (test,) = doctest.DocTestFinder(recurse=False).find(gearbench.api)
    runner = doctest.DocTestRunner()
    runner.run(test)
    assert test.examples and runner.failures == 0


# ------------------------------------------------------ argument checks

@pytest.mark.parametrize("kwargs, message", [
    (dict(kind="p", kp=-5), "Controller: kp must be a positive number in V/deg, got -5"),
    (dict(kind="pd"), "kind must be one of open, bang_bang, p, pi, pid (a string), got the string 'pd'"),
    (dict(kind=["p"]), "kind must be one of open, bang_bang, p, pi, pid (a string), got a list"),
    (dict(kind="p"), "kp must be a positive number in V/deg, got 0.0"),
    (dict(kind="pi", kp=50, ki=-1), "ki must be a number >= 0 in 1/s, got -1"),
    (dict(kind="pid", kp=50, kd=0.1, derivative_filter_s=0), "derivative_filter_s must be a positive number in s"),
    (dict(kind="p", kp=math.nan), "kp must be a positive number in V/deg, got nan (not a finite number)"),
    (dict(kind="p", kp=True), "kp must be a positive number in V/deg, got the boolean true"),
    (dict(kind="p", kp=50, ki=0.1), "ki does not apply to a p controller (it reads kp)"),
    (dict(kind="bang_bang", band_deg=-1), "band_deg must be a positive number in deg"),
    (dict(kind="p", kp=50, shift_deg=-1), "shift_deg must be a number >= 0 in deg"),
    (dict(kind="p", kp=50, compensator="bogus"), "compensator must be one of none, thesis_shift"),
    (dict(kind="open", shift=True), "shift and compensator do not apply to an open controller"),
])
def test_controller_names_the_setting_and_its_unit(kwargs, message):
    with pytest.raises(gb.ConfigError) as err:
        gb.Controller(**kwargs)
    assert message in str(err.value)


def test_every_controller_setting_has_a_unit_and_a_kind_that_reads_it():
    from dataclasses import fields
    from gearbench.control.controllers import SETTING_UNITS, SETTINGS
    assert {f.name for f in fields(gb.Controller)} == set(SETTING_UNITS) | {"kind", "shift", "shift_deg",
                                                                             "compensator"}
    assert set().union(*SETTINGS.values()) == set(SETTING_UNITS)


def test_controller_reports_every_problem_at_once():
    with pytest.raises(gb.ConfigError) as err:
        gb.Controller("pid", kp=-1, ki=-1, kd=-1)
    assert [p.split(" ")[0] for p in err.value.problems] == ["kp", "ki", "kd"]


@pytest.mark.parametrize("args, message", [
    (([0.0, 1.0], [0.0], [0.0, 0.0]), "v has 1 values, t has 2: one per segment"),
    (([0.0, 1.0], [0.0, 0.0], [0.0, 0.0], [0.0]), "d has 1 values, t has 2"),
    (([0.0, 2.0, 1.0], [0.0] * 3, [0.0] * 3), "t must increase strictly (s): t[2] = 1 s comes after t[1] = 2 s"),
    (([0.0, 1.0, 1.0], [0.0] * 3, [0.0] * 3), "t must increase strictly"),
    (([0.5, 1.0], [0.0] * 2, [0.0] * 2), "t[0] must be 0 s"),
    (([0.0, 1.0], [0.0, math.nan], [0.0, 0.0]), "v[1] is nan: every value must be a finite number in rad, or V"),
    (([0.0], [0.0], [math.inf]), "s[0] is inf"),
    (([], [], []), "t must be a non-empty one-dimensional array in s"),
    ((["a"], [0.0], [0.0]), "t must be a one-dimensional array of numbers in s"),
])
def test_segments_are_checked_when_made(args, message):
    with pytest.raises(gb.ConfigError) as err:
        gb.Segments(*args)
    assert message in str(err.value)


def test_a_nan_voltage_is_refused_not_run_as_zero():
    plant = gb.load_plant(THESIS)
    with pytest.raises(gb.ConfigError, match=r"v\[0\] is nan"):
        gb.simulate(plant, gb.Controller("open"), gb.Segments([0.0], [math.nan], [0.0]), 0.1)


@pytest.mark.parametrize("kwargs, message", [
    (dict(duration_s=-1.0), "simulate: duration_s must be a positive number in s, got -1.0"),
    (dict(duration_s=math.nan), "duration_s must be a positive number in s, got nan"),
    (dict(duration_s=4e-4), "solver.output_dt_s must be at most duration_s (0.0004 s), got 0.001"),
    (dict(duration_s=1e5), "duration_s = 100000 s sampled every solver.output_dt_s = 0.001 s is 1e+08 samples"),
    (dict(initial_delta_deg=5.0), "initial_delta_deg must lie within +-1.6 deg"),
    (dict(solver={"rtol": 2.0}), "solver.rtol must be a number > 0 and < 1"),
    (dict(solver={"rtoll": 1e-6}), "solver.rtoll is not a solver setting (did you mean 'rtol'?)"),
    (dict(solver={"method": "euler"}), "solver.method must be one of rosenbrock23"),
    (dict(controller={"kind": "p", "kpp": 5}), "controller.kpp is not a controller setting (did you mean 'kp'?)"),
    (dict(controller="p"), "controller must be a Controller or a mapping"),
    (dict(controller=gb.Controller("p", kp=50, shift_deg=4.0)),
     "controller.shift_deg must lie between 0 and the clearance gear.backlash_deg = 3.2 deg, got 4.0"),
    (dict(setpoint=42), "setpoint must be a Profile, a profile name or file, or Segments, got 42"),
    (dict(setpoint=gb.Segments([0.0], [0.0], [0.0])), "duration_s is needed with Segments (s)"),
    (dict(controller=gb.Controller("open")), "an open controller is driven by its input itself"),
    (dict(plant=3), "plant must be a Plant, a plant file path or a plant mapping, got 3"),
])
def test_simulate_names_the_argument_and_its_unit(kwargs, message):
    args = dict(plant=THESIS, controller=gb.Controller("p", kp=50), setpoint="profile1")
    args.update(kwargs)
    with pytest.raises(gb.ConfigError) as err:
        gb.simulate(args.pop("plant"), args.pop("controller"), args.pop("setpoint"), **args)
    assert message in str(err.value)


def test_the_internal_simulate_checks_its_arguments_too():
    from gearbench.simulate import SolverOptions, simulate
    plant = gb.load_plant(THESIS)
    with pytest.raises(gb.ConfigError, match=r"simulate: t_end must be a positive number in s, got 0"):
        simulate(plant, gb.Controller("p", kp=50), gb.Segments([0.0], [0.0], [0.0]), 0)
    with pytest.raises(gb.ConfigError, match=r"options.max_step_s must be a positive number in s"):
        simulate(plant, gb.Controller("p", kp=50), gb.Segments([0.0], [0.0], [0.0]), 1.0,
                 SolverOptions(max_step_s=-1.0))
    with pytest.raises(gb.ConfigError, match=r"t_end = 1e\+06 s sampled every options.output_dt_s = 0.001 s"):
        simulate(plant, gb.Controller("p", kp=50), gb.Segments([0.0], [0.0], [0.0]), 1e6)


@pytest.mark.parametrize("args, kwargs, message", [
    (([0.0, 1.0], [0.0, 5.0]), dict(duration_s=1.0), "the last segment starts at 1 s, at or after duration_s"),
    (([1.0, 2.0], [0.0, 5.0]), {}, "start_s[0] must be 0 s"),
    (([0.0, 1.0], [0.0]), {}, "value_deg has 1 values, start_s has 2"),
    (([0.0, 1.0], [0.0, math.nan]), {}, "value_deg[1] must be a finite number in deg"),
    (([0.0, 1.0], [0.0, 1.0], [0.0, 1.0]), dict(duration_s=0), "duration_s must be a positive number in s"),
])
def test_setpoint_names_the_argument_and_its_unit(args, kwargs, message):
    with pytest.raises(gb.ConfigError) as err:
        gb.setpoint(*args, **kwargs)
    assert message in str(err.value)


def test_a_failed_run_raises_by_default_and_reports_when_asked():
    plant = gb.load_plant(THESIS)
    ctrl = gb.Controller("bang_bang")
    solver = {"max_steps": 50}
    with pytest.raises(gb.SolverError, match="step budget exhausted"):
        gb.simulate(plant, ctrl, "profile1", 1.0, solver=solver)
    run = gb.simulate(plant, ctrl, "profile1", 1.0, solver=solver, raise_on_failure=False)
    assert not run.ok and run.status == "step budget exhausted" and "failed at t =" in run.message
    # where the budget went: 51 steps and no switch is not a chattering switch
    assert "51 steps, 0 rejected, and 0 mode switches: a fast motion or a long run" in run.message
    assert run.to_dict()["status"] == "step budget exhausted"


# -------------------------------------------------------------- results

def test_api_equals_the_runner_for_a_table1_cell():
    """One Table I cell (profile 1, P Kp=50, with the shift) through the API and
    through the runner that ``gearbench run`` uses: the same IAE."""
    from gearbench.runner import run_experiment
    exp = gb.load_experiment(REPO / "experiments/table1.yaml")
    cell = replace(exp, profiles=("profile1",), controllers=(gb.Controller("p", kp=50.0),), shifts=(True,))
    (record,) = run_experiment(cell, workers=1, keep_traces=False)
    run = gb.simulate(exp.plant, gb.Controller("p", kp=50.0, shift=True), "profile1", solver=exp.solver)
    assert run.ok
    assert run.iae_deg_s == pytest.approx(record.result.iae_deg_s, rel=1e-9)
    assert run.scores["impacts"] == record.result.impacts
    assert round(run.iae_deg_s, 2) == 2.16  # Table I (docs/thesis.md)


def test_run_experiment_wraps_every_run():
    exp = gb.load_experiment(REPO / "experiments/table1.yaml")
    small = replace(exp, profiles=("profile1",), controllers=exp.controllers[:2], shifts=(False,), duration_s=1.0)
    runs = gb.run_experiment(small, traces=False)
    assert [(r.profile, r.controller.kind) for r in runs] == [("profile1", "bang_bang"), ("profile1", "p")]
    with pytest.raises(gb.ConfigError, match="workers must be a positive integer in processes"):
        gb.run_experiment(small, workers=0)


def test_signals_and_to_pandas_carry_their_units():
    plant = gb.load_plant(THESIS)
    run = gb.simulate(plant, gb.Controller("p", kp=50), "profile1", duration_s=3.0)
    df = run.to_pandas()
    assert list(df.columns) == ["time_s", "voltage_V", "motor_angle_deg", "load_angle_deg", "current_A",
                                "setpoint_deg", "error_deg", "motor_speed_deg_per_s", "load_speed_deg_per_s",
                                "mesh_torque_Nm", "mesh_deflection_deg"]
    assert df.attrs["units"]["motor_speed_deg_per_s"] == "deg/s" and df.attrs["units"]["voltage_V"] == "V"
    assert len(df) == 3001 and df["time_s"].iloc[-1] == pytest.approx(3.0)
    o = run.result.outputs
    # degrees at the edge, SI inside: the same samples, converted
    np.testing.assert_allclose(df["load_angle_deg"], np.degrees(o[:, 1]))
    # the sample at a step's instant holds the value before it; the profile is right-continuous
    off_steps = ~np.isin(df["time_s"], [t for t, _ in gb.load_profile("profile1").steps()])
    np.testing.assert_allclose(df["setpoint_deg"][off_steps],
                               gb.load_profile("profile1")(df["time_s"][off_steps]), atol=1e-9)
    np.testing.assert_allclose(df["error_deg"], df["setpoint_deg"] - df["load_angle_deg"])
    assert np.abs(df["voltage_V"]).max() <= plant.motor.max_voltage + 1e-9
    assert json.loads(json.dumps(run.to_dict()))["iae_deg_s"] == pytest.approx(run.iae_deg_s)
    with pytest.raises(KeyError, match="no signal 'load_angle'"):
        run["load_angle"]


def test_a_leadscrew_run_has_carriage_millimetres():
    run = gb.simulate(REPO / "experiments/plants/leadscrew_apparatus.yaml", gb.Controller("p", kp=5),
                      gb.setpoint([0.0, 0.1], [0.0, 10.0], duration_s=0.5))
    lead_mm = gb.load_plant(REPO / "experiments/plants/leadscrew_apparatus.yaml").leadscrew.lead_mm
    assert run.units["load_position_mm"] == "mm" and run.units["setpoint_mm"] == "mm"
    np.testing.assert_allclose(run["load_position_mm"], run["load_angle_deg"] / 360.0 * lead_mm)
    assert run.scores["iae_mm_s"] == pytest.approx(run.iae_deg_s / 360.0 * lead_mm)


def test_a_force_driven_run_names_its_input():
    seg = gb.Segments([0.0, 0.05], [10.0, 0.0], [0.0, 0.0])  # 10 N for 50 ms
    run = gb.simulate(REPO / "experiments/plants/emps_bare.yaml", gb.Controller("open"), seg, 0.1)
    assert "drive_force_N" in run.signals and "voltage_V" not in run.signals and "current_A" not in run.signals
    assert run["drive_force_N"][10] == pytest.approx(10.0) and run["load_position_mm"][-1] > 0


def test_plot_returns_a_figure_and_leaves_pyplot_alone(tmp_path):
    import matplotlib
    from matplotlib.figure import Figure
    backend = matplotlib.get_backend()
    run = gb.simulate(THESIS, gb.Controller("p", kp=50), "profile1", duration_s=3.0)
    fig = run.plot()
    assert isinstance(fig, Figure) and len(fig.axes) == 4  # angles, error, voltage (+ current on its right)
    assert fig.axes[0].get_title() == "thesis_gear: profile1, p Kp=50 V/deg, none"
    np.testing.assert_array_equal(fig.axes[0].lines[2].get_ydata(), run["load_angle_deg"])
    assert matplotlib.get_backend() == backend
    fig.savefig(tmp_path / "run.png")
    assert (tmp_path / "run.png").stat().st_size > 10_000


def test_compare_matches_the_cli_json(tmp_path):
    from click.testing import CliRunner
    from gearbench.cli import main
    c = gb.compare(RIG, HIDDEN)
    out = CliRunner().invoke(main, ["compare", str(RIG), str(HIDDEN), "--json", "--results", str(tmp_path)])
    assert out.exit_code == 0, out.output
    cli = json.loads(out.stdout)
    mine = json.loads(json.dumps(c.to_dict()))
    for key in ("signals", "primary", "phases", "closed_loop"):
        assert mine[key] == cli[key]
    df = c.to_pandas()
    assert list(df.index) == ["motor_angle_deg", "load_angle_deg", "current_A"]
    assert df.loc["current_A", "unit"] == "A"
    fig = c.plot("current_A")
    assert fig.axes and fig.axes[0].get_title().startswith("bench_rig.yaml vs bench_rig_hidden.csv")
    with pytest.raises(KeyError, match="no compared signal"):
        c.plot("voltage_V")


def test_compare_accepts_a_dataframe_and_checks_it():
    frame = pd.read_csv(HIDDEN).iloc[:3000]
    c = gb.compare(RIG, frame)
    assert c.time_s.size == 3000 and c.data.source == "<DataFrame>"
    with pytest.raises(gb.MeasurementError, match="decreasing time"):
        gb.compare(RIG, frame.iloc[::-1])
    with pytest.raises(gb.ConfigError, match="window_s must be a number >= 0 in s"):
        gb.compare(RIG, frame, window_s=-1)
    with pytest.raises(gb.ConfigError, match="controller must be None"):
        gb.compare(RIG, frame, controller=3)


def test_diagnose_wraps_the_ladder():
    d = gb.diagnose(RIG, pd.read_csv(HIDDEN).iloc[:3000], only=("coulomb_friction",), max_steps=1)
    assert d.verdict == "coulomb_friction" and d.plant.effects[0].name == "coulomb_friction"
    j = json.loads(json.dumps(d.to_dict()))
    assert j["verdict"] == "coulomb_friction" and j["error_unit"] == "deg"
    table = d.to_pandas()
    assert table["effect"].iloc[0] == "coulomb_friction" and table["error"].iloc[0] < d.baseline_error
    with pytest.raises(gb.ConfigError, match="only: unknown effect 'friction'"):
        gb.diagnose(RIG, HIDDEN, only=("friction",))
    with pytest.raises(gb.ConfigError, match="max_steps must be a positive integer"):
        gb.diagnose(RIG, HIDDEN, max_steps=0)


def test_fit_gives_a_plant_that_loads_back():
    import yaml
    f = gb.fit(RIG, HIDDEN, "coulomb_friction", options={"location": "load"})
    assert f.effect == "coulomb_friction (load)" and f.error_after < 0.5 * f.error_before
    assert set(f.to_pandas().index) == {"effects[0].torque"}
    again = gb.load_plant(yaml.safe_load(f.to_yaml()))
    assert again.effects[0].values["torque"] == pytest.approx(f.values["effects[0].torque"], rel=1e-6)
    with pytest.raises(gb.ConfigError, match="fit: effect: unknown effect 'coulomb'"):
        gb.fit(RIG, HIDDEN, "coulomb")
    with pytest.raises(gb.ConfigError, match="cannot be added here"):
        gb.fit(RIG, HIDDEN, "coulomb_friction", options={"location": "nowhere"})
    with pytest.raises(gb.ConfigError, match=r"effect coulomb_friction \(load\): 'torq' is not one of its "
                                             r"parameters; they are torque \(N m"):
        gb.fit(RIG, HIDDEN, "coulomb_friction", options={"location": "load"}, start={"torq": 1.0})


def test_the_example_runs(tmp_path):
    out = subprocess.run([sys.executable, str(REPO / "examples/simulate_and_compare.py"), str(tmp_path)],
                         capture_output=True, text=True, cwd=tmp_path,
                         env={**os.environ, "PYTHONPATH": str(REPO), "MPLBACKEND": "Agg"})
    assert out.returncode == 0, out.stderr
    assert "IAE" in out.stdout
    for name in ("run.png", "run.csv", "compare.png"):
        assert (tmp_path / name).stat().st_size > 1000


# ------------------------------------------------- any input: a named error

from hypothesis import given, settings, strategies as st  # noqa: E402

_ANY = st.one_of(st.none(), st.booleans(), st.integers(-10**6, 10**6), st.floats(allow_nan=True),
                 st.text(max_size=5), st.lists(st.floats(), max_size=3), st.dictionaries(st.text(max_size=3),
                                                                                          st.integers(), max_size=2))
_KINDS = st.one_of(st.sampled_from(["open", "bang_bang", "p", "pi", "pid", "pd", ""]), _ANY)
_SETTINGS = st.dictionaries(st.sampled_from(["kp", "ki", "kd", "derivative_filter_s", "band_deg", "shift",
                                             "shift_deg", "compensator"]),
                            st.one_of(st.floats(-1e3, 1e3), _ANY, st.sampled_from(["none", "thesis_shift"])),
                            max_size=4)


@settings(max_examples=150, deadline=None)
@given(kind=_KINDS, kw=_SETTINGS)
def test_controller_gives_a_controller_or_a_named_error(kind, kw):
    try:
        c = gb.Controller(kind, **kw)
    except gb.ConfigError as exc:
        assert str(exc).startswith("Controller: ")
        return
    assert c.problems() == [] and c.kind in ("open", "bang_bang", "p", "pi", "pid")


_ARRAY = st.one_of(st.lists(st.floats(-10, 10), min_size=0, max_size=4),
                   st.lists(st.floats(allow_nan=True, allow_infinity=True), max_size=4), _ANY)


@settings(max_examples=150, deadline=None)
@given(t=_ARRAY, v=_ARRAY, s=_ARRAY, d=st.one_of(st.none(), _ARRAY))
def test_segments_give_segments_or_a_named_error(t, v, s, d):
    try:
        seg = gb.Segments(t, v, s, d)
    except gb.ConfigError as exc:
        assert str(exc).startswith("Segments: ")
        return
    assert seg.t[0] == 0.0 and np.all(np.diff(seg.t) > 0) and len(seg.v) == len(seg.s) == len(seg.t)
    assert np.all(np.isfinite(seg.v)) and np.all(np.isfinite(seg.s))


@settings(max_examples=60, deadline=None)
@given(duration=st.one_of(st.floats(-1, 0.05), st.sampled_from([math.nan, math.inf, 1e9, None, True, "1", [1.0]])), delta=st.one_of(st.floats(-5, 5), _ANY),
       solver=st.one_of(st.none(), st.dictionaries(st.sampled_from(["rtol", "method", "max_step_s", "bogus"]),
                                                   st.one_of(st.floats(-1, 1), _ANY), max_size=2)))
def test_simulate_runs_or_names_the_argument(duration, delta, solver):
    """Short runs (at most 0.05 s, or the profile's 10 s): a valid call finishes, a bad one is a ConfigError."""
    try:
        run = gb.simulate(THESIS, gb.Controller("p", kp=50), "profile1", duration, solver=solver,
                          initial_delta_deg=delta)
    except gb.ConfigError as exc:
        assert str(exc).startswith(("simulate: ", "<config>"))
        return
    assert run.ok and run.time_s[-1] == pytest.approx(10.0 if duration is None else duration)  # None: the profile's
