"""Missing samples (``measure.gaps``; ``--gaps`` / ``gaps=``): refused by default naming the option,
interpolated (runs of up to 5) or dropped (at the record's ends), and said how many and where.

The truth: a clean record of known values, from which cells and rows are taken out; what is filled
must be the line between the neighbours (signals) or the value before (the input), and the count the
number taken out."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

import gearbench as gb
from gearbench.cli import main
from gearbench.errors import ConfigError, MeasurementError
from gearbench.measure.data import from_frame, read_measurement
from gearbench.measure.gaps import MAX_RUN

ROOT = Path(__file__).resolve().parents[1]
RIG = ROOT / "experiments" / "plants" / "bench_rig.yaml"
HIDDEN = ROOT / "experiments" / "data" / "bench_rig_hidden.csv"


@pytest.fixture(scope="module")
def record():
    """A 2 s excerpt of the bench rig's record."""
    return pd.read_csv(HIDDEN).iloc[:2000].reset_index(drop=True)


def holed(record):
    """One missing load angle (sample 100), a run of 3 missing currents (500-502), and two rows gone
    (800, 801: a time step of 3 ms)."""
    d = record.copy()
    d.loc[100, "load_angle_deg"] = np.nan
    d.loc[500:502, "current_A"] = np.nan
    return d.drop(index=[800, 801])


def test_refused_by_default_naming_the_option(record):
    with pytest.raises(MeasurementError, match=r"load_angle_deg.*sample 100.*--gaps interpolate\|drop"):
        from_frame(holed(record))
    with pytest.raises(MeasurementError, match=r"missing after data row 800 .*0\.799 to 0\.802 s.*--gaps"):
        gb.compare(RIG, record.drop(index=[800, 801]))


def test_one_sample_a_run_of_three_and_missing_rows_are_filled(record):
    m = from_frame(holed(record), gaps="interpolate")
    g = m.gaps
    assert len(m.time_s) == len(record)
    np.testing.assert_allclose(m.time_s, record["time_s"], rtol=0, atol=1e-12)
    assert g.filled == 1 + 3 + 2
    assert g.at_s == pytest.approx([0.1, 0.5, 0.501, 0.502, 0.8, 0.801])
    assert g.columns == {"voltage_V": 2, "motor_angle_deg": 2, "load_angle_deg": 1 + 2, "current_A": 3 + 2}
    y = record["load_angle_deg"].to_numpy()
    assert m.signals["load_angle_deg"][100] == pytest.approx(0.5 * (y[99] + y[101]))
    c = record["current_A"].to_numpy()
    np.testing.assert_allclose(m.signals["current_A"][500:503], c[499] + (c[503] - c[499]) * np.arange(1, 4) / 4)
    u = record["voltage_V"].to_numpy()
    assert list(m.input[800:802]) == [u[799], u[799]]            # the input held, as the replay holds it
    others = np.ones(len(record), bool)
    others[[100, 500, 501, 502, 800, 801]] = False
    for name in ("motor_angle_deg", "load_angle_deg", "current_A"):
        np.testing.assert_array_equal(m.signals[name][others], record[name].to_numpy()[others])


def test_a_run_longer_than_the_maximum_is_refused_naming_row_time_and_option(record):
    d = record.copy()
    d.loc[1000:1000 + MAX_RUN, "motor_angle_deg"] = np.nan           # MAX_RUN + 1 in a row
    with pytest.raises(MeasurementError, match=rf"'motor_angle_deg': {MAX_RUN + 1} missing samples in a row from "
                                               r"data row 1001 \(t = 1 s\).*--gaps interpolate"):
        from_frame(d, gaps="interpolate")
    d.loc[1000 + MAX_RUN, "motor_angle_deg"] = record.loc[1000 + MAX_RUN, "motor_angle_deg"]
    assert from_frame(d, gaps="interpolate").gaps.filled == MAX_RUN


def test_drop_takes_the_ends_and_refuses_the_inside(record):
    d = record.copy()
    d.loc[0:1, "current_A"] = np.nan
    d.loc[len(d) - 1, "voltage_V"] = np.nan
    m = from_frame(d, gaps="drop")
    assert len(m.time_s) == len(record) - 3 and m.gaps.dropped == 3 and m.gaps.filled == 0
    assert m.gaps.dropped_at_s == pytest.approx([0.0, 0.001, (len(record) - 1) * 1e-3])
    with pytest.raises(MeasurementError, match=r"3 row\(s\) with a missing sample from data row 501 "
                                               r"\(t = 0\.5 s\).*--gaps interpolate"):
        from_frame(holed(record), gaps="drop")


def test_text_is_still_refused(record):
    d = record.astype(object)
    d.loc[10, "current_A"] = "n/a"
    with pytest.raises(MeasurementError, match="non-numeric value 'n/a'"):
        from_frame(d, gaps="interpolate")


def test_api_and_cli_say_how_many_and_where(record, tmp_path):
    c = gb.compare(RIG, holed(record), gaps="interpolate")
    assert c.to_dict()["gaps"]["filled"] == 6
    with pytest.raises(ConfigError, match="gaps must be None .* interpolate, drop, got the string 'fill'"):
        gb.compare(RIG, holed(record), gaps="fill")
    path = tmp_path / "holed.csv"
    holed(record).to_csv(path, index=False)
    assert read_measurement(path, gaps="interpolate").gaps.at_s[0] == pytest.approx(0.1)
    refused = CliRunner().invoke(main, ["compare", str(RIG), str(path), "--results", str(tmp_path)])
    assert refused.exit_code == 2 and "--gaps" in refused.output
    out = CliRunner().invoke(main, ["compare", str(RIG), str(path), "--gaps", "interpolate", "--json",
                                    "--results", str(tmp_path)])
    assert out.exit_code == 0, out.output
    assert "gaps (interpolate): filled 6 missing sample(s)" in out.stderr
    j = json.loads(out.stdout[out.stdout.index("{"):])
    assert j["gaps"]["filled"] == 6 and j["gaps"]["at_s"][:2] == pytest.approx([0.1, 0.5])
    f = gb.fit(RIG, holed(record), "sensor_offset", options={"signal": "current_A"}, gaps="interpolate")
    assert f.to_dict()["gaps"]["filled"] == 6
