"""Measurement files (SPEC section 3): good files round-trip, bad ones are rejected with
a message that names the column or the row."""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings, strategies as st

from gearbench.measure.data import (
    INPUT_COLUMNS, SETPOINT_COLUMNS, SIGNAL_COLUMNS, Measurement, MeasurementError, from_arrays,
    read_measurement, write_measurement,
)

GOOD = """time_s,voltage_V,motor_angle_deg,load_angle_deg
0.0,0.0,0.0,0.0
0.1,1.5,2.0,0.1
0.2,1.5,4.0,0.3
0.3,-2.0,5.0,0.4
"""


def write(tmp_path, text: str, name: str = "m.csv"):
    path = tmp_path / name
    path.write_text(text)
    return path


def rejected(tmp_path, text: str) -> str:
    with pytest.raises(MeasurementError) as info:
        read_measurement(write(tmp_path, text))
    return str(info.value)


def test_good_file_reads(tmp_path):
    m = read_measurement(write(tmp_path, GOOD))
    assert m.input_name == "voltage_V"
    np.testing.assert_array_equal(m.input, [0.0, 1.5, 1.5, -2.0])
    assert list(m.signals) == ["motor_angle_deg", "load_angle_deg"]
    assert m.setpoint is None and m.setpoint_name is None and m.disturbance_V is None
    assert m.duration_s == pytest.approx(0.3)
    assert m.sample_time_s == pytest.approx(0.1)
    assert m.signal_unit("load_angle_deg") == "deg"
    assert m.signal_unit("motor_position_mm") == "mm"
    assert m.input_unit == "V"
    assert m.source.endswith("m.csv")


def test_column_sets():
    assert INPUT_COLUMNS == ("voltage_V", "drive_torque_Nm", "drive_force_N")
    assert SIGNAL_COLUMNS == {"motor_angle_deg": "deg", "load_angle_deg": "deg", "load_position_mm": "mm",
                              "current_A": "A", "motor_position_mm": "mm"}
    assert SETPOINT_COLUMNS == ("setpoint_deg", "setpoint_mm")


def test_spaces_blank_lines_and_bom_are_tolerated(tmp_path):
    text = "\ufefftime_s, voltage_V, load_angle_deg\n0, 1, 2\n\n0.1, 1, 2\n0.2,1,3\n\n"
    m = read_measurement(write(tmp_path, text))
    np.testing.assert_array_equal(m.time_s, [0.0, 0.1, 0.2])


def test_blank_lines_do_not_shift_row_numbers(tmp_path):
    text = "time_s,voltage_V,load_angle_deg\n0,1,2\n\n0.1,1,x\n"
    assert "data row 3 (file line 4)" in rejected(tmp_path, text)


@pytest.mark.parametrize("text, expected", [
    ("time_s,voltage_V,load_angle_deg,foo\n0,1,2,3\n0.1,1,2,3\n", "unknown column 'foo'"),
    ("time_s,voltage_V,load_angle_rad\n0,1,2\n0.1,1,2\n", "unknown unit or column 'load_angle_rad'"),
    ("time_s,voltage_V,load_position_in\n0,1,2\n0.1,1,2\n", "unknown unit or column 'load_position_in'"),
    ("time_s,voltage_V,motor_angle_degs\n0,1,2\n0.1,1,2\n", "unknown unit or column 'motor_angle_degs'"),
    ("time_s,supply_V,load_angle_deg\n0,1,2\n0.1,1,2\n", "unknown unit or column 'supply_V'"),
    ("time_ms,voltage_V,load_angle_deg\n0,1,2\n1,1,2\n", "unknown unit or column 'time_ms'"),
    ("voltage_V,load_angle_deg\n1,2\n1,2\n", "missing column 'time_s'"),
    ("time_s,load_angle_deg\n0,2\n0.1,2\n", "no input column"),
    ("time_s,voltage_V,drive_torque_Nm,load_angle_deg\n0,1,1,2\n0.1,1,1,2\n",
     "more than one input column ('voltage_V', 'drive_torque_Nm')"),
    ("time_s,voltage_V\n0,1\n0.1,1\n", "no measured signal"),
    ("time_s,voltage_V,load_angle_deg,load_angle_deg\n0,1,2,2\n0.1,1,2,2\n",
     "column 'load_angle_deg' appears 2 times (columns 3, 4)"),
    ("time_s,voltage_V,load_angle_deg,setpoint_deg,setpoint_mm\n0,1,2,0,0\n0.1,1,2,0,0\n",
     "more than one set-point column"),
    ("time_s,voltage_V,load_angle_deg,\n0,1,2,\n0.1,1,2,\n", "column 4 has no name"),
])
def test_bad_columns_are_named(tmp_path, text, expected):
    message = rejected(tmp_path, text)
    assert expected in message
    if "unknown" in expected:
        assert "gearbench reads time_s (s), voltage_V (V)" in message


def test_unit_hint_names_our_column(tmp_path):
    message = rejected(tmp_path, "time_s,voltage_V,load_angle_rad\n0,1,2\n0.1,1,2\n")
    assert "did you mean 'load_angle_deg', in deg?" in message


@pytest.mark.parametrize("row3, column, what", [
    ("0.2,1,nan", "load_angle_deg", "missing or NaN value"),
    ("0.2,1,", "load_angle_deg", "missing or NaN value"),
    ("0.2,,3", "voltage_V", "missing or NaN value"),
    ("0.2,1,abc", "load_angle_deg", "non-numeric value 'abc'"),
    ("0.2,1,inf", "load_angle_deg", "infinite value"),
    (",1,3", "time_s", "missing or NaN value"),
])
def test_bad_values_name_column_and_row(tmp_path, row3, column, what):
    text = f"time_s,voltage_V,load_angle_deg\n0,1,2\n0.1,1,2\n{row3}\n0.3,1,2\n"
    message = rejected(tmp_path, text)
    assert f"column '{column}': {what}" in message
    assert "data row 3 (file line 4)" in message


def test_bad_value_count(tmp_path):
    text = "time_s,voltage_V,load_angle_deg\n0,1,x\n0.1,1,2\n0.2,1,y\n"
    message = rejected(tmp_path, text)
    assert "non-numeric value 'x' at data row 1 (file line 2) (2 bad rows in all)" in message


def test_repeated_time(tmp_path):
    message = rejected(tmp_path, "time_s,voltage_V,load_angle_deg\n0,1,2\n0.1,1,2\n0.1,1,2\n0.05,1,2\n")
    assert "repeated time: data row 3 (file line 4) has time_s = 0.1 s" in message


def test_decreasing_time(tmp_path):
    message = rejected(tmp_path, "time_s,voltage_V,load_angle_deg\n0,1,2\n0.2,1,2\n0.1,1,2\n")
    assert "decreasing time: data row 3 (file line 4) has time_s = 0.1 s after 0.2 s" in message


def test_ragged_row(tmp_path):
    message = rejected(tmp_path, "time_s,voltage_V,load_angle_deg\n0,1,2\n0.1,1,2,9\n")
    assert "data row 2 (file line 3) has 4 fields, the header names 3 columns" in message


def test_short_row(tmp_path):
    message = rejected(tmp_path, "time_s,voltage_V,load_angle_deg\n0,1,2\n0.1,1\n")
    assert "column 'load_angle_deg': missing or NaN value at data row 2 (file line 3)" in message


@pytest.mark.parametrize("text, expected", [
    ("", "is empty"),
    ("\n\n", "is empty"),
    ("\ntime_s,voltage_V,load_angle_deg\n0,1,2\n", "file line 1 is blank"),
    ("time_s,voltage_V,load_angle_deg\n", "no data rows"),
    ("time_s,voltage_V,load_angle_deg\n0,1,2\n", "1 sample(s): a measurement needs at least 2"),
])
def test_empty_files(tmp_path, text, expected):
    assert expected in rejected(tmp_path, text)


def test_missing_file(tmp_path):
    with pytest.raises(MeasurementError, match="does not exist"):
        read_measurement(tmp_path / "nope.csv")
    with pytest.raises(MeasurementError, match="is a directory"):
        read_measurement(tmp_path)


def test_every_problem_is_listed(tmp_path):
    text = "time_s,voltage_V,drive_force_N,load_angle_rad,current_A\n0,1,1,2,x\n0,1,1,2,3\n"
    with pytest.raises(MeasurementError) as info:
        read_measurement(write(tmp_path, text))
    problems = info.value.problems
    assert len(problems) == 4
    assert any("load_angle_rad" in p for p in problems)
    assert any("more than one input" in p for p in problems)
    assert any("'current_A': non-numeric value 'x'" in p for p in problems)
    assert any("repeated time: data row 2" in p for p in problems)
    assert isinstance(info.value, ValueError)


def _full_measurement(n=50):
    t = np.linspace(0.0, 0.49, n)
    return from_arrays(t, "drive_force_N", 3.0 * np.sin(t),
                       {"motor_position_mm": 1e-3 * np.arange(n), "current_A": np.cos(t)},
                       setpoint=0.5 * t, setpoint_name="setpoint_mm", disturbance_V=np.where(t > 0.2, 1.0, 0.0))


def test_round_trip_all_fields(tmp_path):
    m = _full_measurement()
    path = write_measurement(m, tmp_path / "sub" / "rt.csv")
    back = read_measurement(path)
    assert list(pd.read_csv(path).columns) == ["time_s", "drive_force_N", "motor_position_mm", "current_A",
                                               "setpoint_mm", "disturbance_V"]
    assert back.input_name == "drive_force_N" and back.setpoint_name == "setpoint_mm"
    pd.testing.assert_frame_equal(back.to_frame(), m.to_frame(), rtol=1e-9)
    assert [p.name for p in (tmp_path / "sub").iterdir()] == ["rt.csv"]    # no temporary left


def test_trace_frame_round_trips(tmp_path):
    t = np.arange(0.0, 1.0, 1e-3)
    frame = pd.DataFrame({"time_s": t, "voltage_V": np.sign(np.sin(9 * t)), "motor_angle_deg": 100 * t,
                          "load_angle_deg": 10 * t, "current_A": 0.1 * t, "setpoint_deg": 12 * t,
                          "load_position_mm": 0.03 * t})
    back = read_measurement(write_measurement(frame, tmp_path / "trace.csv"))
    pd.testing.assert_frame_equal(back.to_frame()[frame.columns], frame, rtol=1e-9)


def test_write_keeps_close_times_apart(tmp_path):
    t = 1000.0 + np.arange(5) * 1e-8        # equal in 10 significant digits
    m = from_arrays(t, "voltage_V", np.zeros(5), {"load_angle_deg": np.zeros(5)})
    back = read_measurement(write_measurement(m, tmp_path / "close.csv"))
    np.testing.assert_array_equal(back.time_s, t)


def test_write_rejects_a_bad_frame(tmp_path):
    frame = pd.DataFrame({"time_s": [0.0, 0.0], "voltage_V": [1.0, 1.0], "load_angle_rad": [0.0, 1.0]})
    with pytest.raises(MeasurementError, match="load_angle_rad"):
        write_measurement(frame, tmp_path / "bad.csv")
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("kwargs, expected", [
    (dict(signals={"load_angle_deg": np.zeros(3)}), "has 3 samples, time_s has 4"),
    (dict(signals={"load_angle_rad": np.zeros(4)}), "signal 'load_angle_rad' is not a measured signal"),
    (dict(input_name="voltage"), "input_name 'voltage' is not an input"),
    (dict(setpoint=np.zeros(4)), "a set point needs one of setpoint_deg, setpoint_mm"),
    (dict(signals={"load_angle_deg": [0.0, 1.0, np.nan, 2.0]}), "'load_angle_deg': missing or NaN value at sample 2"),
    (dict(time_s=[0.0, 0.1, 0.1, 0.2]), "repeated time: sample 2"),
    (dict(signals={"current_A": np.zeros((4, 2))}), "must be one-dimensional"),
    (dict(signals={"current_A": ["a", "b", "c", "d"]}), "not numbers"),
])
def test_from_arrays_checks(kwargs, expected):
    args = dict(time_s=[0.0, 0.1, 0.2, 0.3], input_name="voltage_V", input=np.ones(4),
                signals={"load_angle_deg": np.zeros(4)})
    args.update(kwargs)
    with pytest.raises(MeasurementError, match=None) as info:
        from_arrays(**args)
    assert expected in str(info.value)


def test_signal_unit_unknown():
    m = _full_measurement()
    with pytest.raises(KeyError, match="unknown column 'x_rad'"):
        m.signal_unit("x_rad")
    assert isinstance(m, Measurement)


@settings(max_examples=25, deadline=None)
@given(steps=st.lists(st.floats(1e-6, 1e3), min_size=1, max_size=30),
       values=st.lists(st.floats(-1e6, 1e6, allow_subnormal=False), min_size=31, max_size=31))
def test_round_trip_property(tmp_path_factory, steps, values):
    t = np.concatenate(([0.0], np.cumsum(steps)))
    y = np.asarray(values[: t.size])
    m = from_arrays(t, "drive_torque_Nm", y, {"load_angle_deg": -y})
    back = read_measurement(write_measurement(m, tmp_path_factory.mktemp("rt") / "p.csv"))
    np.testing.assert_allclose(back.time_s, t, rtol=1e-9)
    np.testing.assert_allclose(back.input, y, rtol=1e-9, atol=1e-300)
    assert np.all(np.diff(back.time_s) > 0)


def test_an_integer_beyond_the_float_range_is_named(tmp_path):
    """A 400-digit integer (the fuzz found it) is an infinite value named by column and row,
    not pandas' OverflowError."""
    path = tmp_path / "huge.csv"
    path.write_text("time_s,voltage_V,motor_angle_deg\n0.0,0.0," + "9" * 400 + "\n0.001,0.0,0.0\n")
    with pytest.raises(MeasurementError, match=r"column 'motor_angle_deg': infinite value inf at data row 1"):
        read_measurement(path)
