"""The EMPS study (studies/emps.py) on the real benchmark data (data/emps/, in the repository).

Data: A. Janot, M. Gautier, M. Brunot, "Data Set and Reference Models of EMPS", Workshop on
Nonlinear System Identification Benchmarks, Eindhoven, April 2019, HAL hal-02178709.
The ladder is the slow part (~35 s); it runs once per module and the tests share it.
"""
import math

import numpy as np
import pytest

from click.testing import CliRunner

from gearbench.measure.idim import kinematics
from studies import emps as E


@pytest.fixture(scope="module")
def runs():
    return E.load_runs()


@pytest.fixture(scope="module")
def ctrl():
    return E.controller(0)


@pytest.fixture(scope="module")
def ladder(runs, ctrl):
    return E.paper_ladder(runs, ctrl, with_stderr=False)


@pytest.fixture(scope="module")
def asym(runs, ctrl, ladder):
    return E.fit_asymmetric(runs, ctrl, ladder["params"])


def test_paper_ladder_falls_to_the_papers_error_and_parameters(ladder):
    rows = ladder["rows"]
    assert rows[0]["effect"] == "bare"
    errs = [r["train_force_error_pct"] for r in rows]
    assert all(b < a for a, b in zip(errs, errs[1:])), errs
    assert sorted(r["effect"] for r in rows[1:]) == sorted(E.PAPER_STRUCTURE)
    assert errs[0] > 50.0                      # mass alone: ~70 %
    assert errs[-1] <= E.PAPER_CLOSED_LOOP["train"]["force"]          # 5.85 %
    for row in ladder["comparison"]:
        assert abs(row["rel_diff_pct"]) <= E.PARAM_TOLERANCE_PCT, row


def test_fitted_model_validates_within_the_papers_error(runs, ctrl, ladder):
    err = E.score(ladder["plant"], runs.validation, ctrl)
    assert err <= E.PAPER_CLOSED_LOOP["validation"]["force"]         # 8.94 %


def test_asymmetric_friction_lowers_the_training_error(ladder, asym):
    assert asym["converged"]
    assert asym["train_force_error_pct"] < ladder["rows"][-1]["train_force_error_pct"]
    p = asym["params"]
    # the paper's asymmetry: more viscous friction moving backward
    assert p["viscous_neg_Ns_per_m"] > p["viscous_pos_Ns_per_m"]
    assert "offset_N" not in p


def test_plant_round_trip_in_the_papers_names():
    for params in (E.PAPER_PARAMS, E.PAPER_ASYMMETRIC):
        back = E.paper_params(E.rigid_plant(params))
        assert set(back) == set(params)
        for k, v in params.items():
            assert back[k] == pytest.approx(v, rel=1e-12)
    # offset is minus the carriage force
    p = E.rigid_plant(E.PAPER_PARAMS)
    bias = next(e for e in p.effects if e.name == "bias_torque")
    assert bias.values["force"] == pytest.approx(3.1648)


def test_compliance_plant_keeps_the_moving_mass():
    rigid = E.rigid_plant(E.PAPER_PARAMS)
    m = E.moving_mass(rigid)
    c = E.compliance_plant(rigid, 0.25, 4.0e6, 500.0)
    par = E.compliance_params(c)
    assert par["total_mass_kg"] == pytest.approx(m, rel=1e-12)
    assert par["carriage_mass_kg"] == pytest.approx(0.25 * m)
    assert par["stiffness_N_per_m"] == pytest.approx(4.0e6)
    mu = 0.25 * 0.75 * m
    assert par["mode_hz"] == pytest.approx(math.sqrt(4.0e6 / mu) / (2 * math.pi))
    resolved = c.resolved()
    assert resolved.shaft is not None and resolved.motor_inertia_total == pytest.approx(m * 1e-6)


def test_kinematics_of_a_parabola():
    ts = 1e-3
    t = np.arange(2000) * ts
    q, v, a = kinematics(0.5 * 2.0 * t ** 2 + 0.1 * t, ts)
    inner = slice(100, -100)
    np.testing.assert_allclose(v[inner], 2.0 * t[inner] + 0.1, rtol=1e-6)
    np.testing.assert_allclose(a[inner], 2.0, rtol=1e-6)


def test_missing_data_is_a_clear_error(tmp_path):
    with pytest.raises(FileNotFoundError, match="--data-dir"):
        E.data_files(tmp_path / "nowhere")
    with pytest.raises(FileNotFoundError, match="DATA_EMPS.mat"):
        E.data_files(tmp_path)
    res = CliRunner().invoke(E.main, ["--results", str(tmp_path / "r"), "--data-dir", str(tmp_path / "nowhere")])
    assert res.exit_code == 2 and "--data-dir" in res.output
    assert not (tmp_path / "r").exists()
