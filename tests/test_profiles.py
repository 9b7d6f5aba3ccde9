"""The three thesis profiles have the structure the thesis describes (section Simulations)."""
import numpy as np
import pytest

from gearbench.experiment.files import load_plant
from gearbench.plant.linear import plant_info
from pathlib import Path

from gearbench.profiles import Profile, ProfileError, load_profile

REPO = Path(__file__).resolve().parents[1]
PLANT = REPO / "experiments" / "plants" / "thesis_gear.yaml"


def sloped_sections(prof: Profile) -> list[float]:
    """Slopes of the maximal sections of constant non-zero slope (a step ends a section)."""
    steps = {t for t, _ in prof.steps()}
    out = []
    for k, s in enumerate(prof.slope_deg_per_s):
        joins_previous = (k > 0 and prof.start_s[k] not in steps
                          and prof.slope_deg_per_s[k - 1] == s)
        if s != 0.0 and not joins_previous:
            out.append(s)
    return out


def dwells(prof: Profile) -> list[tuple[float, float]]:
    ends = list(prof.start_s[1:]) + [prof.duration_s]
    return [(a, b) for a, b, s in zip(prof.start_s, ends, prof.slope_deg_per_s) if s == 0.0]


def max_deviation(prof: Profile) -> float:
    t = np.linspace(0.0, prof.duration_s, 20001)
    return float(np.max(np.abs(prof(t))))


@pytest.fixture(scope="module")
def profiles():
    return [load_profile(f"profile{i}") for i in (1, 2, 3)]


def test_each_profile_lasts_ten_seconds(profiles):
    assert [p.duration_s for p in profiles] == [10.0, 10.0, 10.0]


def test_profile1_initial_dwell_two_steps_two_slopes(profiles):
    p1 = profiles[0]
    assert p1.slope_deg_per_s[0] == 0.0 and p1.value_deg[0] == 0.0 and p1.start_s[1] > 0.0
    assert len(p1.steps()) == 2
    assert len(sloped_sections(p1)) == 2
    assert dwells(p1) == [(0.0, p1.start_s[1])]


def test_profile2_two_steps_three_slopes(profiles):
    p2 = profiles[1]
    assert len(p2.steps()) == 2
    assert len(sloped_sections(p2)) == 3
    assert dwells(p2) == []


def test_profile3_is_the_sum_with_middle_dwell_slope_change_and_four_steps(profiles):
    p1, p2, p3 = profiles
    t = np.linspace(0.0, 10.0, 4001)
    assert np.allclose(p3(t), p1(t) + p2(t))
    assert len(p3.steps()) == 4
    middle = [(a, b) for a, b in dwells(p3) if a > 0.0 and b < p3.duration_s]
    assert middle, "profile 3 must dwell in the middle"
    # a section where the slope changes: two adjacent sloped segments, different slopes
    s = p3.slope_deg_per_s
    assert any(a != 0.0 and b != 0.0 and a != b for a, b in zip(s, s[1:]))


def test_each_profile_deviates_more_than_the_one_before(profiles):
    devs = [max_deviation(p) for p in profiles]
    assert devs[0] < devs[1] < devs[2], devs


def test_only_profile3_outruns_the_motor(profiles):
    """Profile 3 asks for more speed than the thesis plant's top output speed for
    part of the run; profiles 1 and 2 never do."""
    top = plant_info(load_plant(PLANT))["output_top_speed_deg_s"]
    fastest = [max(abs(s) for s in p.slope_deg_per_s) for p in profiles]
    assert fastest[0] < top and fastest[1] < top
    assert fastest[2] > top


def test_csv_profile_round_trip(tmp_path):
    f = tmp_path / "ramp.csv"
    f.write_text("time_s,setpoint_deg\n0,0\n1,10\n3,10\n")
    prof = load_profile(f)
    assert np.allclose(prof([0.0, 0.5, 2.0]), [0.0, 5.0, 10.0])


@pytest.mark.parametrize("text, needle", [
    ("time_s,setpoint_deg\n0,0\n1,nan\n", "row 3"),
    ("time_s,setpoint_deg\n0,0\n0,1\n", "increase strictly"),
    ("time,setpoint_deg\n0,0\n1,1\n", "time_s"),
])
def test_bad_csv_profile_names_row_or_column(tmp_path, text, needle):
    f = tmp_path / "bad.csv"
    f.write_text(text)
    with pytest.raises(ProfileError, match=needle):
        load_profile(f)


def test_bad_yaml_profile_names_key(tmp_path):
    f = tmp_path / "bad.yaml"
    f.write_text("segments:\n  - {start_s: 0, value_deg: 0, slope: 1}\n")
    with pytest.raises(ProfileError, match=r"segments\[0\]"):
        load_profile(f)
