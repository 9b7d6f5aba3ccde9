"""The two-mass study (studies/twomass.py) on the real FdiTools bench records (data/twomass/, in the repository).

Data: T. Beauduin and W. Ohnishi, FdiTools (HoriFujimotoLab/FdiTools, MIT); see data/twomass/README.md.
The source's anti-resonance and resonance (52.4 and 76.6 Hz) are read off its FRF figure, to about
+-1 Hz (``SOURCE_READING_HZ``); a record's own estimate sits on its grid of excited lines (1 Hz for
record A, 4 Hz for record B), so each comparison allows the grid's spacing plus that reading.
"""
import json
import math
from dataclasses import replace

import numpy as np
import pytest
from click.testing import CliRunner

from gearbench import layout as L
from gearbench.identify.fit import Free, _Trials
from gearbench.identify.replay import Replay, seam_speed
from gearbench.identify.scoring import Scorer
from gearbench.measure.data import from_arrays
from gearbench.plant.effects import AddedEffect
from gearbench.simulate import mesh_figures
from studies import twomass as T


@pytest.fixture(scope="module")
def records():
    return T.load_records()


@pytest.fixture(scope="module")
def frf_a(records):
    return T.record_frf(records["A"])


def test_records_load_and_validate(records):
    for tag in ("A", "B"):
        m = records[tag]
        assert m.input_name == "drive_torque_Nm"
        assert set(m.signals) == {"motor_angle_deg", "load_angle_deg"}
        assert len(m.time_s) == 50000
        assert m.sample_time_s == pytest.approx(1 / 2500, rel=1e-9)
        assert m.signals["motor_angle_deg"][0] == 0.0 and m.signals["load_angle_deg"][0] == 0.0
        # continuous angles (SPEC: not wrapped): no sample-to-sample jump near a turn
        for col in ("motor_angle_deg", "load_angle_deg"):
            assert np.max(np.abs(np.diff(m.signals[col]))) < 1.0
    bare = T.bare_plant()
    assert bare.drive == "torque" and bare.gear.rigid
    Replay(records["A"]).check(bare)   # the plant's drive matches the record's input


def test_a_slice_keeps_the_couplings_twist(records):
    """Both angles of a slice are measured from one zero, so the twist (motor minus load angle) is the
    record's: at 1 s into record A the coupling is twisted, and zeroing each angle on its own would
    put that twist on the load angle as a constant."""
    m = records["A"]
    a = int(round(T.FIT_SLICE_S[0] / m.sample_time_s))
    twist = np.asarray(m.signals["motor_angle_deg"]) - np.asarray(m.signals["load_angle_deg"])
    assert abs(twist[a]) > 0.5    # the case the slice must keep: twisted at the slice's start (deg)
    s = T.cut(m, T.FIT_SLICE_S, "A slice")
    np.testing.assert_allclose(s.signals["motor_angle_deg"] - s.signals["load_angle_deg"], twist[a:a + len(s.time_s)],
                               rtol=0, atol=1e-9)
    assert s.signals["motor_angle_deg"][0] == 0.0


def _periodic_record(periods=6, drift=False, sigma=0.0, seed=0):
    """A bench that repeats a 1 s motion exactly (2.5 kHz), each window of each period started at its
    own angle and speed when ``drift`` (a steady acceleration over the record, the same inside every
    window), with independent noise ``sigma`` (deg) on every sample."""
    ts, n = 1 / 2500, 2500
    t = np.arange(periods * n) * ts
    tau = t % 1.0
    shape = 3.0 * np.sin(2 * np.pi * 13 * tau) + 0.7 * np.sin(2 * np.pi * 77 * tau + 1.0)
    rng = np.random.default_rng(seed)
    angles = {}
    for name in ("motor_angle_deg", "load_angle_deg"):
        y = shape.copy()
        if drift:  # what the restart takes out: another angle and speed at every seam of every period
            y += rng.uniform(1.0, 3.0) * t ** 2
        angles[name] = y + sigma * rng.standard_normal(t.size)
    return from_arrays(t, "drive_torque_Nm", np.sin(2 * np.pi * 13 * tau), angles, source="periodic")


def test_a_bench_that_repeats_up_to_its_seams_angles_and_speeds_has_no_repeatability_floor():
    exact = T.repeatability(_periodic_record())
    drifting = T.repeatability(_periodic_record(drift=True))
    for name in ("motor_angle_deg", "load_angle_deg"):
        assert exact[name] < 1e-9 and drifting[name] < 1e-9, (exact, drifting)


def _slope_weights(offsets, ts, degree):
    """The weights ``c_k`` that the least-squares polynomial of ``degree`` through samples at ``offsets``
    (from the seam) gives its slope at the seam: ``s = sum_k c_k y(seam + k)``."""
    k = np.asarray(offsets, dtype=float)  # in samples: a Vandermonde in seconds is too ill-conditioned
    return np.linalg.pinv(np.vander(k, degree + 1))[-2] / ts


def test_independent_noise_gives_the_repeatability_its_restart_predicts():
    """rel(t) = e(t) - e(a) - s t with s = sum_k c_k e(a + k) the seam's slope (centred 11 samples, the
    period's first 11 at its first seam): the variance at each sample from the restart's coefficients."""
    sigma, ts, w, n, half, degree = 0.01, 1 / 2500, 250, 2500, 5, 4
    var = []
    for a in range(0, n, w):
        offsets = np.arange(0, 2 * half + 1) if a == 0 else np.arange(-half, half + 1)
        c = _slope_weights(offsets, ts, degree)
        for j in range(w):
            coef = np.zeros(n + half + 1)
            coef[a + j] += 1.0
            coef[a] -= 1.0
            coef[a + offsets] -= c * j * ts
            var.append(np.sum(coef ** 2))
    predicted = sigma * math.sqrt(np.mean(var))
    # 200 periods: the estimate's own spread is 3.4 % (over 6 seeds; 8 % with 40 periods), its first window,
    # whose one-sided slope takes in six times the noise of a centred one, weighing most
    got = T.repeatability(_periodic_record(periods=201, sigma=sigma, seed=4))
    for name in got:
        assert got[name] == pytest.approx(predicted, rel=0.12), (got, predicted)


def test_the_period_spread_is_nothing_for_identical_periods_and_what_independent_noise_predicts():
    """Identical periods spread by 0, free-running and in windows; independent noise ``sigma`` by
    ``sigma sqrt(2 (w - 1) / w)`` (each sample less its window's first, which is itself exact), over
    200 periods within 3 standard errors: the window's first sample, half the variance and common to the
    window, is estimated from 199 degrees of freedom per window, so the spread's relative standard error
    is about ``0.25 sqrt(2 / 199) / sqrt(windows)``."""
    for window_s, w in ((T.PERIOD_S, 2500), (T.WINDOW_S, 250)):
        exact = T.period_spread(_periodic_record(), window_s)
        noisy = T.period_spread(_periodic_record(periods=201, sigma=0.01, seed=3), window_s)
        rel = 3 * 0.25 * math.sqrt(2 / 199) / math.sqrt(2500 / w)
        for name in exact:
            assert exact[name] < 1e-12, exact
            assert noisy[name] == pytest.approx(0.01 * math.sqrt(2 * (w - 1) / w), rel=rel), (window_s, noisy)


def test_the_replay_costs_an_exact_model_nothing_without_noise_and_in_proportion_to_it():
    """A free mass (the bare plant) replayed on its own run: with no noise, on its 13 Hz motion of 0.86 deg
    amplitude, within 1e-3 deg (3.4e-4 measured: the seams' slopes of a quartic and the solver's
    tolerance); with noise, in proportion to it (the seams' speeds are linear in the samples, and the
    reset test's threshold scales with the noise it reads), and far above the noise itself (the
    speeds read over 11 samples carried over 0.1 s windows)."""
    m = _periodic_record(periods=31)
    cost = {s: T.replay_cost(T.bare_plant(), m, {"motor_angle_deg": s, "load_angle_deg": s}, seed=5)
            for s in (0.0, 0.005, 0.01)}
    for name in cost[0.0]:
        assert cost[0.0][name] < 1e-3, cost
        assert cost[0.01][name] == pytest.approx(2 * cost[0.005][name], rel=0.05), cost
        assert cost[0.01][name] > 10 * 0.01, cost


def test_the_seam_speed_is_exact_on_a_quartic_and_passes_the_excited_band():
    """``seam_speed``: the slope of a quartic exactly, centred and at a record's first and last sample
    (one-sided); on a sine at 2.5 kHz, at least 99.5 % of the speed at the two-mass bench's 77 Hz mode
    and 80 % at the multisine's top line, 250 Hz, where a quadratic through the same 11 samples gives
    89 % and 22 % (the analytic gains of the two filters, ``_slope_weights``)."""
    ts = 1 / 2500
    t = np.arange(400) * ts
    y = 3.0 - 2.0 * t + 40.0 * t ** 2 - 900.0 * t ** 3 + 5000.0 * t ** 4
    dy = -2.0 + 80.0 * t - 2700.0 * t ** 2 + 20000.0 * t ** 3
    for a in (0, 3, 200, 399):
        assert seam_speed(t, y, a) == pytest.approx(dy[a], rel=1e-7, abs=1e-9)
    for f, least, quadratic in ((77.0, 0.995, 0.893), (250.0, 0.80, 0.223)):
        w = 2 * np.pi * f
        got = seam_speed(t, np.sin(w * t), 200) / (w * math.cos(w * t[200]))
        k = np.arange(-5, 6)
        gain2 = float(_slope_weights(k, ts, 2) @ np.sin(w * k * ts)) / w
        assert least <= got <= 1.0 + 1e-9 and gain2 == pytest.approx(quadratic, abs=1e-3), (f, got, gain2)


def test_a_cut_of_a_moving_twisted_record_replays_from_its_measured_state():
    """A two-mass plant's own record (gearbench's simulator, 2 s of a multisine of 11-95 Hz at 2.5 kHz,
    no noise) cut at 1 s, where it moves at 6.2 rad/s with its coupling twisted by 1.7 deg: the plant
    replays the cut within 2 % of its motion's RMS, its first window too (measured 0.65 %; the seams'
    speeds are within 0.6 % up to 100 Hz).  Started from rest and untwisted, with a quadratic's seam
    speeds, it was 0.46 deg off (22 %), 1.23 deg in its first window."""
    ts = 1 / 2500
    t = np.arange(5000) * ts
    rng = np.random.default_rng(1)
    u = sum(2.0 * np.sin(2 * np.pi * f * t + rng.uniform(0, 2 * np.pi)) for f in range(11, 101, 6))
    bare = T.bare_plant()
    plant = replace(bare, motor=replace(bare.motor, inertia=0.01)).with_effects(
        AddedEffect("shaft_compliance", {"stiffness": 575.0, "damping": 0.01, "pinion_inertia": 0.005}),
        AddedEffect("viscous_friction", {"location": "motor", "coefficient": 0.1}))
    still = {"motor_angle_deg": np.zeros_like(t), "load_angle_deg": np.zeros_like(t)}
    sim = Replay(from_arrays(t, "drive_torque_Nm", u, still, source="drive"), window_s=None).run(plant)
    part = T.cut(from_arrays(t, "drive_torque_Nm", u, {k: np.asarray(sim[k]) for k in still}, source="own"),
                 (1.0, 2.0), "cut at 1 s")
    assert abs(part.signals["load_angle_deg"][0]) > 1.0  # twisted: the load angle is measured from the motor's
    out = Replay(part, window_s=0.1, reset_speeds=True).run(plant)
    for name in still:
        y = np.asarray(part.signals[name])
        e = y - out[name]
        rms, first = float(np.sqrt(np.mean(e ** 2))), float(np.sqrt(np.mean(e[:250] ** 2)))
        assert rms < 0.02 * y.std() and first < 0.02 * y.std(), (name, rms, first, y.std())


def test_the_real_bench_repeats_itself_closer_than_a_straight_line_restart_says(records):
    """Both real records: the periods spread, free-running and in the replay's windows, by over ten times the
    encoders' noise, so no model of the input reaches that noise; and started at each window's angle they
    spread by less than a third of the straight-line repeatability (0.08 against 0.49 deg on record A's
    motor angle, 2026-12-07), which carries a seam's speed forward where the bench's coupling turns it back:
    that repeatability is no floor."""
    for tag in ("A", "B"):
        slice_ = T.replay_of(T.cut(records[tag], T.FIT_SLICE_S, tag))
        spread_free, spread = T.period_spread(records[tag]), T.period_spread(records[tag], T.WINDOW_S)
        rep = T.repeatability(records[tag])
        for name in rep:
            noise = slice_.noise_floor(name)
            assert min(spread_free[name], spread[name]) > 10 * noise, (tag, name, spread_free, spread, noise)
            assert spread[name] < rep[name] / 3, (tag, name, spread, rep)


def test_missing_data_is_a_clear_error(tmp_path):
    with pytest.raises(FileNotFoundError, match="--data-dir"):
        T.data_files(tmp_path / "nowhere")
    with pytest.raises(FileNotFoundError, match="twomass_A.csv"):
        T.data_files(tmp_path)
    res = CliRunner().invoke(T.main, ["--results", str(tmp_path / "r"), "--data-dir", str(tmp_path / "nowhere")])
    assert res.exit_code == 2 and "--data-dir" in res.output
    assert not (tmp_path / "r").exists()


@pytest.mark.parametrize("tag, df", [("A", 1.0), ("B", 4.0)])
def test_the_records_frf_has_the_sources_antiresonance_and_resonance(records, tag, df):
    frf = T.record_frf(records[tag])
    assert frf["df_hz"] == pytest.approx(df)
    assert len(frf["f_hz"]) == {"A": 240, "B": 60}[tag]
    feat = T.frf_features(frf["f_hz"], frf["motor"], frf["load"])
    tol = frf["df_hz"] + T.SOURCE_READING_HZ
    assert abs(feat["antiresonance_hz"] - T.SOURCE["antiresonance_hz"]) <= tol, feat
    assert abs(feat["resonance_hz"] - T.SOURCE["resonance_hz"]) <= tol, feat
    assert abs(feat["load_resonance_hz"] - T.SOURCE["resonance_hz"]) <= tol, feat
    # measured, not noise: the FRF is far above its standard error over the periods
    assert np.median(np.abs(frf["motor"]) / np.abs(frf["motor_stderr"])) > 30


def test_the_coupling_start_is_a_two_mass_plant_with_the_records_frequencies(frf_a):
    st = T.coupling_start(frf_a)
    feat = T.frf_features(frf_a["f_hz"], frf_a["motor"])
    bare = T.bare_plant()
    p = replace(bare, motor=replace(bare.motor, inertia=st["rotor_inertia"] + st["load_inertia"]))
    p = p.with_effects(AddedEffect("shaft_compliance", {"stiffness": st["stiffness"], "damping": 1e-3,
                                                        "pinion_inertia": st["load_inertia"]}))
    two = T.two_mass(p)
    assert two["rotor_inertia"] == pytest.approx(st["rotor_inertia"], rel=1e-3)   # + the token load
    assert two["antiresonance_hz"] == pytest.approx(feat["antiresonance_hz"], rel=2e-4)
    assert two["resonance_hz"] == pytest.approx(feat["resonance_hz"], rel=2e-4)
    # and its linear FRF has its dip and peak there (lightly damped: on the 0.05 Hz grid)
    mf = T.model_features(p)
    assert mf["antiresonance_hz"] == pytest.approx(feat["antiresonance_hz"], abs=0.1)
    assert mf["resonance_hz"] == pytest.approx(feat["resonance_hz"], abs=0.1)
    assert mf["load_resonance_hz"] == pytest.approx(feat["resonance_hz"], abs=0.1)
    # a rigid plant has no dip and no peak in the band
    rigid = T.model_features(bare)
    assert rigid["antiresonance_hz"] is None and rigid["resonance_hz"] is None and rigid["undamped"] is None


@pytest.fixture(scope="module")
def stated(records, frf_a):
    """The coupling stated from the FRF, with a constant torque and Coulomb friction on the load from
    neutral starts, fitted on the study's slice of record A."""
    bare = T.bare_plant()
    model = bare.with_effects(AddedEffect("bias_torque", {"location": "load", "torque": 0.0}),
                              AddedEffect("coulomb_friction", {"location": "load", "torque": 0.1}))
    fit_data = T.cut(records["A"], T.FIT_SLICE_S, "A slice")
    return T.stated_coupling(model, fit_data, frf_a), fit_data


def test_the_stated_coupling_lowers_the_error_and_resonates_at_the_sources_frequency(stated, frf_a):
    s, fit_data = stated
    assert s["converged"], s["message"]
    rigid = T.score(replace(s["plant"], effects=tuple(e for e in s["plant"].effects if e.name != "shaft_compliance"),
                            motor=replace(s["plant"].motor, inertia=s["plant"].motor_inertia_total)), fit_data)
    assert s["error_deg"] < 0.8 * rigid["error_deg"], (s["error_deg"], rigid["error_deg"])
    two = T.two_mass(s["plant"])
    tol = frf_a["df_hz"] + T.SOURCE_READING_HZ
    assert abs(two["resonance_hz"] - T.SOURCE["resonance_hz"]) <= tol, two


@pytest.mark.xfail(strict=True, reason="the time-domain fit puts the rotor's inertia ~35 % above the FRF's "
                   "high-frequency asymptote (0.0058 for 0.0043), so the fitted anti-resonance sits near 57 Hz, "
                   "not 52.4 Hz")
def test_the_stated_coupling_has_the_sources_antiresonance(stated, frf_a):
    two = T.two_mass(stated[0]["plant"])
    assert abs(two["antiresonance_hz"] - T.SOURCE["antiresonance_hz"]) <= frf_a["df_hz"] + T.SOURCE_READING_HZ, two


@pytest.fixture(scope="module")
def diagnosed(records):
    return T.diagnosis(T.cut(records["A"], T.FIT_SLICE_S, "A slice"))


@pytest.mark.slow
def test_the_diagnosis_finds_the_coupling(diagnosed, frf_a):
    """diagnose from the bare plant ends with a shaft compliance whose undamped resonance is the source's,
    within the FRF grid's step and the figure's reading (until 2026-12-02 a strict xfail: the shaft it
    kept was a soft, heavily damped one, modes near 5-8 Hz, that played friction; a fit now ends no
    worse than its start, ``fit._rounds``)."""
    two = T.two_mass(diagnosed["plant"])
    assert two is not None, diagnosed["plant"]
    assert abs(two["resonance_hz"] - T.SOURCE["resonance_hz"]) <= frf_a["df_hz"] + T.SOURCE_READING_HZ, two


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason="the final model is 3.3x and 3.4x the floor under the replay on its "
                   "slice (motor, load angle: 0.448 and 0.468 deg against 0.136; 2026-12-07), and 23x "
                   "it run free over a period (8.8 deg against 0.38; docs/twomass.md)")
def test_the_diagnosis_reaches_the_benchs_floor_on_its_slice(records, diagnosed):
    """On the slice it was fitted to, diagnose's final model within 1.2x (the practice cases' criterion)
    of what no model of the input gets under in the study's replay (``bench_floor``), on both angles.
    (It was within 1.2x of the straight-line repeatability, which is no floor.)"""
    sl = T.cut(records["A"], T.FIT_SLICE_S, "A slice")
    got = T.score(diagnosed["plant"], sl)
    floor = T.bench_floor(records["A"], diagnosed["plant"], got["noise_floor_deg"])
    for name, f in floor.items():
        assert got["rms_deg"][name] <= 1.2 * f["replay"], (name, got["rms_deg"][name], f)


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason="since slices start as measured and seams take a quartic's speeds "
                   "(2026-12-07) the final model's anti-resonance is 55.3 Hz, 0.55 Hz standard error, where "
                   "the record's FRF has 53 Hz and the source 52.4 Hz (docs/twomass.md)")
def test_the_diagnosis_finds_the_sources_antiresonance(diagnosed, frf_a):
    two = T.two_mass(diagnosed["plant"])
    assert abs(two["antiresonance_hz"] - T.SOURCE["antiresonance_hz"]) <= frf_a["df_hz"] + T.SOURCE_READING_HZ, two


# ----------------------------------------------------------------------------- what the study needed
def _parabola(acc=3.0, n=2500, ts=4e-4):
    t = np.arange(n) * ts
    th = 0.5 * acc * t ** 2
    return t, from_arrays(t, "drive_torque_Nm", np.zeros(n), {"motor_angle_deg": np.degrees(th),
                                                                "load_angle_deg": np.degrees(th)}, source="parabola")


def test_reset_speeds_sets_the_measured_speeds():
    t, m = _parabola()
    plant = T.bare_plant()
    r = Replay(m, window_s=0.1, reset_speeds=True)
    x = np.zeros(L.N_STATE)
    r._reset_speeds(x, 1000, plant)
    assert x[L.X_WM] == pytest.approx(3.0 * t[1000], rel=1e-9)
    assert x[L.X_WL] == pytest.approx(3.0 * t[1000], rel=1e-9)
    # with a shaft on the rigid gear the pinion (carrying the load) takes the load's measured speed
    shafted = replace(plant, motor=replace(plant.motor, inertia=0.01)).with_effects(
        AddedEffect("shaft_compliance", {"stiffness": 500.0, "damping": 0.01, "pinion_inertia": 0.005}))
    x = np.zeros(L.N_STATE)
    r._reset_speeds(x, 1000, shafted)
    assert x[L.X_WP] == pytest.approx(3.0 * t[1000], rel=1e-9)


def test_reset_speeds_is_what_keeps_a_window_from_carrying_a_speed_error():
    """A plant whose constant drive torque is missing: without the speed resets each window starts at
    the last one's wrong speed and the error grows window by window; with them it stays each window's."""
    t, m = _parabola(acc=3.0)
    plant = replace(T.bare_plant(), motor=replace(T.bare_plant().motor, inertia=1.0))   # no torque: no motion
    off = Replay(m, window_s=0.1)
    on = Replay(m, window_s=0.1, reset_speeds=True)
    assert not off.reset_speeds
    e_off, e_on = Scorer(off).error(off.run(plant)), Scorer(on).error(on.run(plant))
    # within a 0.1 s window the missing 3 rad/s^2 moves the angle 0.5*3*0.1^2 rad = 0.86 deg at most
    assert e_on < 1.0 < e_off


def test_reset_speeds_from_the_api_and_the_command_line(tmp_path):
    """``reset_speeds`` (``--reset-speeds``) reaches the replay from ``gb.compare`` and ``gearbench
    compare``: the same record and plant as above, the error within the 0.86 deg a window allows with
    it and above it without; a value that is not a bool, or a replay without windows, is refused by name."""
    import gearbench as gb
    from gearbench.cli import main
    from gearbench.errors import ConfigError
    import yaml
    from gearbench.experiment.writer import plant_to_dict
    from gearbench.measure.data import write_measurement
    t, m = _parabola(acc=3.0)
    plant = replace(T.bare_plant(), motor=replace(T.bare_plant().motor, inertia=1.0))
    e = {flag: gb.compare(plant, m, window_s=0.1, reset_speeds=flag).to_pandas().loc["motor_angle_deg", "rms_error"]
         for flag in (False, True)}
    assert e[True] < 1.0 < e[False]
    with pytest.raises(ConfigError, match="reset_speeds must be True or False"):
        gb.compare(plant, m, window_s=0.1, reset_speeds="yes")
    with pytest.raises(ConfigError, match="window_s > 0"):
        gb.compare(plant, m, window_s=0.0, reset_speeds=True)
    plant_file, data_file = tmp_path / "plant.yaml", tmp_path / "data.csv"
    plant_file.write_text(yaml.safe_dump(plant_to_dict(plant)))
    write_measurement(m, data_file)
    cli = {}
    for flag in ([], ["--reset-speeds"]):
        res = CliRunner().invoke(main, ["compare", str(plant_file), str(data_file), "--window", "0.1", "--json",
                                        "--results", str(tmp_path / "r")] + flag)
        assert res.exit_code == 0, res.output
        cli[bool(flag)] = json.loads(res.output)["signals"][0]["rms_error"]
    assert cli == pytest.approx(e, rel=1e-6)   # the CSV holds 10 significant digits


def test_a_fit_trial_at_values_that_make_no_plant_is_a_bad_point_not_a_crash():
    """A shaft's pinion_inertia is taken out of the motor's inertia: with both free, a trial step can put
    the pinion above the rotor's whole inertia (it ended the stated fit of this bench with 'the fit could
    not run').  Such a point is as bad as a failed solve."""
    t, m = _parabola()
    plant = replace(T.bare_plant(), motor=replace(T.bare_plant().motor, inertia=0.01)).with_effects(
        AddedEffect("shaft_compliance", {"stiffness": 500.0, "damping": 0.01, "pinion_inertia": 0.005}))
    frees = [Free.plant(plant, "motor.inertia")] + Free.effect(plant, 0)
    r = Replay(m, window_s=0.1)
    trials = _Trials(r, Scorer(r), plant, frees, np.ones(len(frees)))
    good = trials.residual(np.array([0.01, 500.0, 0.01, 0.005]), seams=())
    assert np.all(np.isfinite(good)) and good.size > 1
    bad = trials.residual(np.array([0.004, 500.0, 0.01, 0.005]), seams=())
    assert bad.size == good.size and np.all(bad == 1e6)
    assert "pinion_inertia" in trials.failures[-1]
    assert trials.settle(np.array([0.004, 500.0, 0.01, 0.005])) == ((), math.inf)


def test_the_mesh_figures_of_a_torque_driven_plant():
    """A failed run's message asks for the mesh's frequency; for a torque-driven plant that raised
    TypeError (its electrics are None) and took the diagnosis down with it."""
    bare = T.bare_plant()
    p = replace(bare, gear=replace(bare.gear, rigid=False, mesh_stiffness=1.0e4, mesh_damping=0.1),
                load=replace(bare.load, inertia=1e-3))
    k, f = mesh_figures(p)
    assert k == 1.0e4
    expected = math.sqrt(1.0e4 * (1 / 1e-3 + 1 / 1e-2)) / (2 * math.pi)
    assert f == pytest.approx(expected, rel=1e-3)
