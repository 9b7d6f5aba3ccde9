"""EMPS benchmark (Janot, Gautier, Brunot 2019, HAL hal-02178709): importer, IDIM-LS, CLI.

The published IDIM-LS figures are reproduced to every printed digit.
"""
import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import scipy.io
from click.testing import CliRunner

from conftest import DATA
from gearbench.cli import main
from gearbench.measure.emps import (EMPS_CITATION, EMPS_CONTROLLER, EMPSFormatError, read_emps,
                                    to_measurement_frame)
from gearbench.measure.idim import evaluate, idim_ladder, idim_ls

MATS = DATA / "emps"
FILES = {
    "train_mat": "DATA_EMPS.mat",
    "test_mat": "DATA_EMPS_PULSES.mat",
    "train_csv": "emps_train_DATA_EMPS.csv",
    "test_csv": "emps_test_DATA_EMPS_PULSES.csv",
}


def write_csv_copy(mat: Path, out_dir: Path, prefix: str) -> Path:
    """The CSV copy of an EMPS ``.mat`` (``t_s, qm_m, qg_m, vir_V, force_N[, pulse_V]``, 10
    significant digits, ``force_N = gtau vir_V``) that ``read_emps`` also reads.  Written the way
    the copies beside the benchmark's files were made: for both records it reproduces them byte
    for byte (checked when the data were moved into the repository)."""
    m = scipy.io.loadmat(mat)
    cols = {"t_s": m["t"].ravel(), "qm_m": m["qm"].ravel(), "qg_m": m["qg"].ravel(),
            "vir_V": m["vir"].ravel()}
    cols["force_N"] = float(np.squeeze(m["gtau"])) * cols["vir_V"]
    if "pulses_N" in m:
        cols["pulse_V"] = m["pulses_N"].ravel().astype(float)
    out = out_dir / f"{prefix}_{mat.stem}.csv"
    pd.DataFrame(cols).to_csv(out, index=False, float_format="%.10g")
    return out


@pytest.fixture(scope="module")
def paths(tmp_path_factory) -> dict:
    """The two ``.mat`` files from the repository and their CSV copies (with ``constants.json``)
    written to a temporary folder."""
    out = tmp_path_factory.mktemp("emps_csv")
    constants = {}
    for run, prefix in (("train", "emps_train"), ("test", "emps_test")):
        mat = MATS / FILES[f"{run}_mat"]
        write_csv_copy(mat, out, prefix)
        m = scipy.io.loadmat(mat)
        constants[mat.name] = {"gtau_N_per_V": float(np.squeeze(m["gtau"])),
                               "kp_per_s": float(np.squeeze(m["kp"])),
                               "kv_V_per_m_per_s": float(np.squeeze(m["kv"])),
                               "n_samples": int(m["t"].size), "Ts_s": 0.001}
    (out / "constants.json").write_text(json.dumps(constants, indent=1))
    return {key: (MATS if key.endswith("_mat") else out) / name for key, name in FILES.items()}


@pytest.fixture(scope="module")
def rec(paths):
    return {key: read_emps(path) for key, path in paths.items()}


@pytest.fixture(scope="module")
def sym(rec):
    return idim_ls(rec["train_mat"])


def test_citation_and_controller():
    assert EMPS_CITATION == ('A. Janot, M. Gautier, M. Brunot, "Data Set and Reference Models of '
                             'EMPS", Workshop on Nonlinear System Identification Benchmarks, '
                             'Eindhoven, April 2019, HAL hal-02178709')
    assert EMPS_CONTROLLER["kp_per_s"] == 160.18 and EMPS_CONTROLLER["kv_V_per_m_per_s"] == 243.45
    assert EMPS_CONTROLLER["vir_limit_V"] == 10.0


@pytest.mark.parametrize("run", ["train", "test"])
def test_mat_and_csv_give_the_same_record(rec, run):
    mat, csv = rec[f"{run}_mat"], rec[f"{run}_csv"]
    assert mat["n"] == csv["n"] == 24841
    assert mat["Ts"] == csv["Ts"] == 1e-3
    for key in ("gtau", "kp", "kv"):
        assert mat[key] == pytest.approx(csv[key], rel=1e-12)
    for key in ("t", "qm", "qg", "vir", "force"):  # the CSV copies keep 10 significant digits
        np.testing.assert_allclose(csv[key], mat[key], rtol=1e-9, atol=1e-12 * np.abs(mat[key]).max())
    assert (mat["pulse"] is None) == (csv["pulse"] is None) == (run == "train")
    if run == "test":
        np.testing.assert_array_equal(mat["pulse"], csv["pulse"])
        assert set(np.unique(mat["pulse"])) == {0.0, 5.0}
    assert mat["t_jitter_max"] < 5e-8  # the stamps jitter by a few 1e-8 s around k*Ts


@pytest.mark.parametrize("run", ["train", "test"])
def test_measurement_frame(rec, run):
    d = rec[f"{run}_csv"]
    frame = to_measurement_frame(d)
    cols = ["time_s", "drive_force_N", "motor_position_mm", "setpoint_mm"]
    assert list(frame.columns) == cols + (["disturbance_V"] if run == "test" else [])
    t = frame["time_s"].to_numpy()
    assert t[0] == 0 and np.all(np.diff(t) > 0)
    np.testing.assert_allclose(t, np.arange(d["n"]) * 1e-3, rtol=0, atol=1e-12)
    # the input is the drive force gtau*vir: the CSV's own force_N column
    np.testing.assert_allclose(frame["drive_force_N"], d["force_file"], rtol=1e-8, atol=1e-7)
    # positions in mm, zero at the first motor sample; qg shifted by the same qm[0]
    assert frame["motor_position_mm"].iloc[0] == 0
    q0 = frame.attrs["position_offset_m"]
    assert q0 == d["qm"][0] and 7e-6 < q0 < 8e-6
    np.testing.assert_allclose(frame["motor_position_mm"], (d["qm"] - q0) * 1e3, atol=1e-12)
    np.testing.assert_allclose(frame["setpoint_mm"], (d["qg"] - q0) * 1e3, atol=1e-12)
    assert 245 < frame["motor_position_mm"].max() < 247  # travel 0 to 0.246 m
    if run == "test":
        np.testing.assert_array_equal(frame["disturbance_V"], d["pulse"])


def test_bad_files_name_the_variable(tmp_path):
    good = scipy.io.loadmat(MATS / FILES["train_mat"])
    partial = {k: v for k, v in good.items() if not k.startswith("__") and k != "qg"}
    scipy.io.savemat(tmp_path / "noqg.mat", partial)
    with pytest.raises(EMPSFormatError, match="'qg' missing"):
        read_emps(tmp_path / "noqg.mat")
    partial["qg"] = good["qg"][:-5]
    scipy.io.savemat(tmp_path / "short.mat", partial)
    with pytest.raises(EMPSFormatError, match="'qg' has 24836 samples"):
        read_emps(tmp_path / "short.mat")
    pd.DataFrame({"t_s": [0.0, 0.001], "qm_m": [0.0, 0.0], "vir_V": [0.0, 0.0],
                  "force_N": [0.0, 0.0]}).to_csv(tmp_path / "x.csv", index=False)
    with pytest.raises(EMPSFormatError, match="'qg_m' missing"):
        read_emps(tmp_path / "x.csv")


def test_idim_ls_reproduces_the_paper(rec, sym):
    p = sym["params"]
    assert round(p["mass_kg"], 4) == 95.1089
    assert round(p["viscous_Ns_per_m"], 4) == 203.5034
    assert round(p["coulomb_N"], 4) == 20.3935
    assert round(p["offset_N"], 4) == -3.1648
    assert round(sym["rel_error_pct"], 4) == 4.0834
    assert round(sym["error_norm_N"], 2) == 108.76 and round(sym["error_std_N"], 2) == 2.18
    assert round(sym["cond"]) == 26
    cross = evaluate(rec["test_mat"], p)
    assert round(cross["rel_error_pct"], 4) == 5.9824
    assert round(cross["error_norm_N"], 2) == 169.49 and round(cross["error_std_N"], 2) == 3.40
    # the CSV copies give the same printed digits
    csv = idim_ls(rec["train_csv"])
    assert round(csv["rel_error_pct"], 4) == 4.0834
    assert round(evaluate(rec["test_csv"], csv["params"])["rel_error_pct"], 4) == 5.9824


def test_idim_ls_asymmetric(rec):
    fit = idim_ls(rec["train_mat"], model="asymmetric")
    p = fit["params"]
    assert round(p["mass_kg"], 4) == 95.1540
    assert round(p["viscous_pos_Ns_per_m"], 4) == 166.7061
    assert round(p["viscous_neg_Ns_per_m"], 4) == 240.4236
    assert round(p["coulomb_pos_N"], 4) == 20.1440
    assert round(p["coulomb_neg_N"], 4) == 20.6277
    assert round(fit["rel_error_pct"], 4) == 3.1117
    with pytest.raises(ValueError, match="absorbs the offset"):
        idim_ls(rec["train_mat"], model="asymmetric", columns=["mass_kg", "offset_N"])


def test_plain_scipy_decimate_misses_the_printed_digits(rec):
    """scipy.signal.decimate pads and phases differently from MATLAB's decimate."""
    assert round(idim_ls(rec["train_mat"], emulate_matlab=False)["rel_error_pct"], 3) == 4.124


def test_ladder(rec):
    rows = idim_ladder(rec["train_mat"], rec["test_mat"])
    got = [(r["model"], round(r["train_rel_error_pct"], 2), round(r["test_rel_error_pct"], 2))
           for r in rows]
    assert got == [("M only", 69.43, 67.21), ("+ viscous", 17.98, 17.82), ("+ Coulomb", 7.13, 8.18),
                   ("+ offset (paper)", 4.08, 5.98), ("asymmetric friction", 3.11, 5.36)]
    assert round(rows[1]["params"]["viscous_Ns_per_m"], 1) == 411.0


@pytest.mark.parametrize("name", ["test_mat", "test_csv"])
def test_cli_import_emps(tmp_path, paths, rec, name):
    out = tmp_path / "emps.csv"
    res = CliRunner().invoke(main, ["import", "emps", str(paths[name]), "-o", str(out)])
    assert res.exit_code == 0, res.output
    assert "24841 rows" in res.output and "hal-02178709" in res.output
    back = pd.read_csv(out)
    frame = to_measurement_frame(rec[name])
    assert list(back.columns) == list(frame.columns)
    for col in frame.columns:
        np.testing.assert_allclose(back[col], frame[col], rtol=1e-11, atol=1e-12)
    assert np.all(np.diff(back["time_s"]) > 0)


def test_cli_keeps_the_encoder_grid(tmp_path, rec):
    out = tmp_path / "train.csv"
    res = CliRunner().invoke(main, ["import", "emps", str(MATS / FILES["train_mat"]), "-o", str(out)])
    assert res.exit_code == 0, res.output
    steps = pd.read_csv(out)["motor_position_mm"].to_numpy() / 5e-5  # 5e-8 m counts
    assert np.abs(steps - np.round(steps)).max() < 1e-6


def test_cli_errors(tmp_path):
    res = CliRunner().invoke(main, ["import", "emps", str(tmp_path / "none.mat"), "-o",
                                    str(tmp_path / "o.csv")])
    assert res.exit_code == 2
    assert "error:" in res.output and "none.mat" in res.output
    assert not (tmp_path / "o.csv").exists()


def _law(d: dict) -> np.ndarray:
    """The EMPS controller's law evaluated on the recorded samples, V (measure/emps.py):
    qf(k) = (q(k) + q(k-1))/2, qd(k) = (qf(k) - qf(k-1))/Ts, vir(k) = kv (kp (qg(k) - q(k)) - qd(k))
    plus the pulse, if any."""
    q, qg = d["qm"], d["qg"]
    qf = 0.5 * (q[1:] + q[:-1])
    qd = np.diff(qf) / d["Ts"]
    law = d["kv"] * (d["kp"] * (qg[2:] - q[2:]) - qd)
    return law + (d["pulse"][2:] if d["pulse"] is not None else 0.0)


@pytest.mark.parametrize("run", ["train_mat", "test_mat"])
def test_recorded_command_is_the_law_at_the_same_sample(rec, run):
    """Why the replays default to ``delay_samples: 0``: the recorded vir(k) is the law at
    sample k (3.7 mV rms on train, 50 mV on the pulses run, whose qm is off the encoder
    grid), while the law one sample earlier, the authors' Simulink delay, misses it by
    54 mV and 250 mV (15x and 5x as far).  The shipped controller file and the EMPS
    study use delay 0."""
    from gearbench.experiment.controller_file import load_controller
    from studies.emps import CONTROLLER_FILE, controller
    d = rec[run]
    law, vir = _law(d), d["vir"][2:]
    same = np.sqrt(np.mean((vir - law) ** 2))
    delayed = np.sqrt(np.mean((vir[1:] - law[:-1]) ** 2))
    assert same < (0.005 if run == "train_mat" else 0.06)
    assert delayed > 4 * same
    assert load_controller(CONTROLLER_FILE).delay_samples == controller().delay_samples == 0
