"""Measurements in any column names, units and CSV dialect (gearbench.measure.columns,
gearbench.measure.csvformat) and ``gearbench import csv``: a mapped file reads as the
canonical one, and every bad mapping is named with what is needed."""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner
from hypothesis import given, settings, strategies as st

from gearbench.cli import main
from gearbench.experiment.files import ConfigError
from gearbench.measure.columns import ColumnMap, load_column_map, unit_factor
from gearbench.measure.csvformat import sniff
from gearbench.measure.data import MeasurementError, read_mapped, read_measurement

ROOT = Path(__file__).resolve().parents[1]
HIDDEN = ROOT / "experiments" / "data" / "bench_rig_hidden.csv"
RIG = ROOT / "experiments" / "plants" / "bench_rig.yaml"
MAPPING = "time_s=t,voltage_V=u,motor_angle_deg=phi,load_angle_deg=theta_out,current_A=i"
UNITS = "time=ms,motor_angle=turn,load_angle=rad,current=mA"


@pytest.fixture(scope="module")
def canonical(tmp_path_factory) -> Path:
    """The first 1.5 s of the shipped bench-rig record, as gearbench writes it."""
    frame = pd.read_csv(HIDDEN).iloc[:1501]
    path = tmp_path_factory.mktemp("canon") / "rig.csv"
    frame.to_csv(path, index=False, float_format="%.10g")
    return path


@pytest.fixture(scope="module")
def raw(canonical, tmp_path_factory) -> Path:
    """The same record as a lab might log it: other names, ms, turns, rad, mA, semicolons,
    decimal commas, an extra column; the values rounded to 15 digits by the writer."""
    f = pd.read_csv(canonical)
    out = pd.DataFrame({
        "t": f.time_s * 1e3, "u": f.voltage_V, "phi": f.motor_angle_deg / 360.0,
        "theta_out": np.radians(f.load_angle_deg), "i": f.current_A * 1e3, "temp": 21.5})
    path = tmp_path_factory.mktemp("raw") / "lab.csv"
    out.to_csv(path, index=False, sep=";", decimal=",", float_format="%.15g")
    return path


def same_record(a, b, rtol=1e-12):
    assert a.input_name == b.input_name and list(a.signals) == list(b.signals)
    np.testing.assert_allclose(a.time_s, b.time_s, rtol=rtol, atol=1e-15)
    np.testing.assert_allclose(a.input, b.input, rtol=rtol, atol=1e-15)
    for k in a.signals:
        np.testing.assert_allclose(a.signals[k], b.signals[k], rtol=rtol, atol=1e-12, err_msg=k)


# ------------------------------------------------------------------ dialects

@pytest.mark.parametrize("sep, decimal", [(";", "."), ("\t", "."), (";", ","), ("\t", ",")])
def test_semicolon_and_tab_files_read_as_comma_ones(canonical, tmp_path, sep, decimal):
    path = tmp_path / "d.csv"
    pd.read_csv(canonical).to_csv(path, index=False, sep=sep, decimal=decimal, float_format="%.10g")
    assert sniff(path).delimiter == sep and sniff(path).decimal == decimal
    same_record(read_measurement(path), read_measurement(canonical), rtol=0)


def test_decimal_comma_is_not_guessed_against_points(tmp_path):
    path = tmp_path / "mixed.csv"
    path.write_text("time_s;voltage_V;load_angle_deg\n0;1.5;2\n0,1;1.5;2\n")
    with pytest.raises(MeasurementError, match=r"column 'time_s': non-numeric value '0,1' at data row 2"):
        read_measurement(path)


def test_windows_1252_file_reads_and_binary_file_is_named(tmp_path):
    path = tmp_path / "latin.csv"
    path.write_bytes("t;u;\u00b0out\n0;1,5;2\n0,1;1,5;2,5\n".encode("cp1252"))  # a spreadsheet's export
    m = read_measurement(path, "time_s=t,voltage_V=u,load_angle_deg=\u00b0out")
    np.testing.assert_array_equal(m.signals["load_angle_deg"], [2.0, 2.5])
    assert sniff(path).encoding == "cp1252"
    binary = tmp_path / "blob.csv"
    binary.write_bytes(b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR")
    with pytest.raises(MeasurementError, match=r"measurement file '.*blob.csv' is binary"):
        read_measurement(binary)


# ------------------------------------------------------------------ mapping and units

def test_mapping_with_units_gives_the_canonical_record(canonical, raw):
    m, used, ignored = read_mapped(raw, MAPPING, UNITS)
    same_record(m, read_measurement(canonical), rtol=1e-12)
    assert ignored == ["temp"]
    assert "load_angle_deg <- 'theta_out' in rad (x 57.2958)" in used


def test_quantity_keys_mapping_objects_and_python_mappings_agree(canonical, raw):
    by_text = read_measurement(raw, MAPPING, UNITS)
    by_dict = read_measurement(raw, {"time": "t", "voltage": "u", "motor_angle": "phi", "load_angle": "theta_out",
                                     "current": "i"}, {"time_s": "ms", "motor_angle_deg": "turn",
                                                       "load_angle_deg": "rad", "current_A": "mA"})
    by_map = read_measurement(raw, ColumnMap.build(MAPPING, UNITS))
    same_record(by_text, by_dict, rtol=0)
    same_record(by_text, by_map, rtol=0)


@pytest.mark.parametrize("unit, column, factor", [
    ("rad", "load_angle_deg", 180 / math.pi), ("ms", "time_s", 1e-3), ("mA", "current_A", 1e-3),
    ("turn/4096", "motor_angle_deg", 360 / 4096), ("rev", "motor_angle_deg", 360.0), ("inch", "load_position_mm", 25.4),
    ("mN*m", "drive_torque_Nm", 1e-3), ("kN", "drive_force_N", 1e3), ("mV", "voltage_V", 1e-3), ("mm", "setpoint_mm", 1.0),
])
def test_unit_factors(unit, column, factor):
    assert unit_factor(unit, column) == pytest.approx(factor, rel=1e-12)


def test_setpoint_quantity_is_resolved_by_its_unit():
    assert ColumnMap.build("setpoint=sp", "setpoint=mm").columns == {"setpoint_mm": "sp"}
    assert ColumnMap.build("setpoint=sp", "setpoint=rad").columns == {"setpoint_deg": "sp"}
    with pytest.raises(MeasurementError, match="'setpoint' is setpoint_deg or setpoint_mm"):
        ColumnMap.build("setpoint=sp")


def test_unmapped_gearbench_columns_are_read_as_they_are(tmp_path):
    path = tmp_path / "part.csv"
    path.write_text("zeit,voltage_V,load_angle_deg\n0,1,2\n1,1,3\n")
    m = read_measurement(path, "time_s=zeit", "time=ms")
    np.testing.assert_array_equal(m.time_s, [0.0, 0.001])
    np.testing.assert_array_equal(m.signals["load_angle_deg"], [2.0, 3.0])


def test_swapped_columns_can_be_mapped(tmp_path):
    path = tmp_path / "swap.csv"
    path.write_text("time_s,voltage_V,motor_angle_deg,load_angle_deg\n0,1,2,3\n1,1,4,5\n")
    m = read_measurement(path, "motor_angle_deg=load_angle_deg,load_angle_deg=motor_angle_deg")
    np.testing.assert_array_equal(m.signals["motor_angle_deg"], [3.0, 5.0])


@pytest.mark.parametrize("columns, units, expected", [
    (MAPPING, "load_angle=V", ["units load_angle=V", "'V' is a voltage, not an angle",
                               "load_angle_deg needs an angle unit such as deg, rad"]),
    (MAPPING, "load_angle=percent", ["'percent' is dimensionless, not an angle"]),
    (MAPPING, "time=rad", ["'rad' is an angle, not a time", "time_s needs a time unit such as s, ms"]),
    (MAPPING, "load_angle=radd", ["unknown unit 'radd'", "load_angle_deg needs an angle unit"]),
    (MAPPING, "current=", ["--units: 'current=' is not KEY=VALUE"]),
    ("time_s=t,voltage_V=u,drive_torque_Nm=x", "drive_torque=Nm", ["write N*m"]),
    (MAPPING, "setpoint=mm", ["units setpoint=mm: no file column is mapped to setpoint_mm"]),
    ("t=time_s," + MAPPING, None, ["'t' is not a gearbench column",
                                   "the form is GEARBENCH_COLUMN=FILE_COLUMN: time_s=t?"]),
    ("lode_angle=theta_out", None, ["'lode_angle' is not a gearbench column (did you mean 'load_angle'?)",
                                    "keys are gearbench's columns time_s"]),
    ("time_s=t,time=u", None, ["time_s is mapped twice"]),
    ("time_s=t,voltage_V=t", None, ["file column 't' is mapped to time_s and voltage_V"]),
    ("time_s", None, ["--columns: 'time_s' is not KEY=VALUE"]),
])
def test_bad_mappings_are_named(raw, columns, units, expected):
    with pytest.raises(MeasurementError) as info:
        read_measurement(raw, columns, units)
    for text in expected:
        assert text in str(info.value)


@pytest.mark.parametrize("columns, units, expected", [
    (MAPPING.replace("theta_out", "theta"), UNITS,
     ["columns load_angle_deg=theta: the file has no column 'theta' (did you mean 'theta_out'?)",
      "the file's columns are 't', 'u', 'phi', 'theta_out', 'i', 'temp'"]),
    ("time_s=t,load_angle_deg=theta_out", "time=ms,load_angle=rad",
     ["no input column", "the file's columns are 't', 'u'", "mapped: time_s <- 't' in ms",
      "a measurement needs time_s (s); one input of voltage_V (V)"]),
    ("voltage_V=u,load_angle_deg=theta_out", None, ["missing column 'time_s' (sample time, s)",
                                                    "the file's columns are"]),
])
def test_mapping_that_does_not_fit_the_file_lists_what_it_has(raw, columns, units, expected):
    with pytest.raises(MeasurementError) as info:
        read_measurement(raw, columns, units)
    for text in expected:
        assert text in str(info.value)


def test_mapped_bad_value_names_both_columns_and_the_row(tmp_path):
    path = tmp_path / "bad.csv"
    path.write_text("t,u,theta\n0,1,0\n1,1,oops\n")
    with pytest.raises(MeasurementError, match=r"column 'load_angle_deg' \(file column 'theta'\): "
                                               r"non-numeric value 'oops' at data row 2 \(file line 3\)"):
        read_measurement(path, "time_s=t,voltage_V=u,load_angle_deg=theta", "time=ms")


def test_mapped_column_that_also_exists_under_its_own_name(tmp_path):
    path = tmp_path / "both.csv"
    path.write_text("time_s,t2,voltage_V,load_angle_deg\n0,0,1,0\n1,1,1,0\n")
    with pytest.raises(MeasurementError, match="the file has a column named time_s too"):
        read_measurement(path, "time_s=t2")


def test_unmapped_file_with_foreign_names_points_to_the_mapping(tmp_path):
    path = tmp_path / "lab.csv"
    path.write_text("t,u,theta\n0,1,0\n1,1,0\n")
    with pytest.raises(MeasurementError, match=r"map them: --columns"):
        read_measurement(path)


# ------------------------------------------------------------------ mapping files

def test_mapping_file_and_options_override(raw, canonical, tmp_path):
    path = tmp_path / "map.yaml"
    path.write_text("columns:\n  time_s: t\n  voltage_V: u\n  motor_angle: phi\n  load_angle_deg: theta_out\n"
                    "  current_A: i\nunits:\n  time: s\n  motor_angle: turn\n  load_angle: rad\n"
                    "  current: mA\ndelimiter: semicolon\ndecimal: ','\n")
    cmap = load_column_map(path)
    assert cmap.delimiter == ";" and cmap.decimal == ","
    fixed = cmap.merged(ColumnMap.build(units="time=ms", partial=True))
    same_record(read_measurement(raw, fixed), read_measurement(canonical), rtol=1e-12)


@pytest.mark.parametrize("text, expected", [
    ("colums:\n  time_s: t\n", ["colums is not a column mapping key (did you mean 'columns'?)"]),
    ("- time_s\n", ["a column mapping file must be a mapping"]),
    ("columns: [time_s, t]\n", ["columns must be a mapping"]),
    ("columns:\n  time_s: t\nunits:\n  time: parsec\n", ["units time=parsec", "not a time"]),
    ("columns:\n  time_s: t\ndelimiter: '|'\n", ["delimiter '|' is not one of comma"]),
    ("columns: {time_s: t\n", ["YAML syntax error"]),
])
def test_bad_mapping_files_are_named(tmp_path, text, expected):
    path = tmp_path / "map.yaml"
    path.write_text(text)
    with pytest.raises(ConfigError) as info:
        load_column_map(path)
    assert str(info.value).startswith("map.yaml: ")
    for t in expected:
        assert t in str(info.value)


# ------------------------------------------------------------------ command line

def invoke(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


def test_import_csv_writes_the_canonical_file(raw, canonical, tmp_path):
    out = tmp_path / "imported.csv"
    r = invoke("import", "csv", raw, "-o", out, "--columns", MAPPING, "--units", UNITS)
    assert r.exit_code == 0, r.output
    assert "1501 rows" in r.output and "left out (not mapped): temp" in r.output
    assert "current_A <- 'i' in mA (x 0.001)" in r.output
    assert pd.read_csv(out).columns.tolist() == pd.read_csv(canonical).columns.tolist()
    same_record(read_measurement(out), read_measurement(canonical), rtol=1e-11)


def test_import_csv_json(raw, tmp_path):
    out = tmp_path / "imported.csv"
    r = CliRunner().invoke(main, ["import", "csv", str(raw), "-o", str(out), "--columns", MAPPING, "--units",
                                  UNITS, "--json"])
    assert r.exit_code == 0, r.output
    j = json.loads(r.stdout)
    assert j["output"] == str(out) and j["rows"] == 1501 and j["left_out"] == ["temp"]
    assert j["columns"] == pd.read_csv(out).columns.tolist()
    assert any("current_A <- 'i' in mA" in line for line in j["mapped"])


def test_import_csv_with_a_mapping_file(raw, canonical, tmp_path):
    cmap = tmp_path / "map.yaml"
    cmap.write_text("columns: {time: t, voltage: u, motor_angle: phi, load_angle: theta_out, current: i}\n"
                    "units: {time: ms, motor_angle: turn, load_angle: rad, current: A}\n")
    out = tmp_path / "imported.csv"
    r = invoke("import", "csv", raw, "-o", out, "--columns-file", cmap, "--units", "current=mA")
    assert r.exit_code == 0, r.output
    same_record(read_measurement(out), read_measurement(canonical), rtol=1e-11)


@pytest.mark.parametrize("args, expected", [
    (["--columns", MAPPING, "--units", "load_angle=V"], "'V' is a voltage, not an angle"),
    (["--columns", MAPPING.replace("=i", "=amps")], "the file has no column 'amps'"),
    (["--columns", "time_s=t"], "no input column"),
])
def test_import_csv_errors_exit_2_and_write_nothing(raw, tmp_path, args, expected):
    out = tmp_path / "never.csv"
    r = invoke("import", "csv", raw, "-o", out, *args)
    assert r.exit_code == 2, r.output
    assert r.output.startswith("error: ") and expected in " ".join(r.output.split())
    assert "Traceback" not in r.output and not out.exists()


def test_import_csv_refuses_to_overwrite_its_input(raw):
    before = raw.read_bytes()
    r = invoke("import", "csv", raw, "-o", raw, "--columns", MAPPING, "--units", UNITS)
    assert r.exit_code == 2 and "would overwrite the input" in " ".join(r.output.split())
    assert raw.read_bytes() == before


def test_compare_on_a_mapped_file_equals_compare_on_the_canonical_one(raw, canonical, tmp_path):
    a = invoke("compare", RIG, canonical, "--results", tmp_path / "a", "--json")
    b = invoke("compare", RIG, raw, "--columns", MAPPING, "--units", UNITS, "--results", tmp_path / "b", "--json")
    assert a.exit_code == 0 and b.exit_code == 0, a.output + b.output
    sa, sb = json.loads(a.stdout)["signals"], json.loads(b.stdout)["signals"]
    assert [s["signal"] for s in sa] == [s["signal"] for s in sb] == ["motor_angle_deg", "load_angle_deg", "current_A"]
    for x, y in zip(sa, sb):
        for key in ("rms_error", "max_error", "noise_floor"):
            assert y[key] == pytest.approx(x[key], rel=1e-6), (x["signal"], key)
    bad = invoke("compare", RIG, raw, "--columns", MAPPING, "--units", "time=V", "--results", tmp_path / "c")
    assert bad.exit_code == 2 and "time_s needs a time unit" in " ".join(bad.output.split())


# ------------------------------------------------------------------ fuzz: named error or a record

KEYS = ["time_s", "time", "voltage_V", "voltage", "load_angle", "motor_angle_deg", "current", "setpoint",
        "setpoint_mm", "drive_torque", "t", "lode", ""]
FILE_COLS = ["t", "u", "phi", "theta_out", "i", "temp", "nope", ""]
UNIT_TEXT = ["ms", "s", "rad", "deg", "turn/4096", "mA", "V", "N*m", "Nm", "percent", "1/0", "((", "m/s", "kg",
             "degC", "1e999 rad", "0 rad", "__x__", ""]
_piece = st.one_of(st.sampled_from(KEYS), st.text(max_size=8))
_pair = st.tuples(_piece, st.one_of(st.sampled_from(FILE_COLS + UNIT_TEXT), st.text(max_size=8)))
_pairs_text = st.lists(_pair, max_size=6).map(lambda ps: ",".join(f"{k}={v}" for k, v in ps))


@settings(max_examples=150, deadline=None)
@given(columns=st.one_of(st.none(), _pairs_text, st.text(max_size=30)),
       units=st.one_of(st.none(), _pairs_text, st.text(max_size=30)))
def test_any_mapping_gives_a_record_or_a_named_error(raw, columns, units):
    try:
        m = read_measurement(raw, columns, units)
    except MeasurementError as exc:
        assert str(exc) and exc.problems
    else:
        assert np.all(np.diff(m.time_s) > 0) and m.signals


_cell = st.one_of(st.floats(allow_nan=True, allow_infinity=True).map(repr), st.integers(-5, 5).map(str),
                  st.sampled_from(["", "1,5", "x", '"', "0.1", " 2 ", "1e-3"]), st.text(max_size=4))


@settings(max_examples=150, deadline=None)
@given(header=st.lists(st.sampled_from(["time_s", "voltage_V", "load_angle_deg", "t", "u", "current_A", ""]),
                       min_size=1, max_size=5),
       rows=st.lists(st.lists(_cell, min_size=1, max_size=6), max_size=6),
       sep=st.sampled_from([",", ";", "\t"]), blob=st.binary(max_size=12))
def test_any_csv_text_gives_a_record_or_a_named_error(tmp_path_factory, header, rows, sep, blob):
    path = tmp_path_factory.mktemp("fuzz") / "f.csv"
    text = "\n".join(sep.join(r) for r in [header] + rows) + "\n"
    path.write_bytes(text.encode("utf-8", "surrogatepass") + blob)
    for columns in (None, "time_s=t,voltage_V=u"):
        try:
            read_measurement(path, columns)
        except MeasurementError as exc:
            assert str(path) in str(exc), str(exc)  # every file error names the file
