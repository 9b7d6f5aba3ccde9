"""The EMPS benchmark: real measurements of a DC-motor ball-screw axis under a known controller.

Data and reference models: A. Janot, M. Gautier, M. Brunot, "Data Set and Reference Models of
EMPS", Workshop on Nonlinear System Identification Benchmarks, Eindhoven, April 2019, HAL
hal-02178709 (``EMPS_CITATION``; cite it wherever the data or numbers derived from them appear).
The data carry no explicit licence; use them for research/benchmarking with that citation and do
not ship them inside the package.

The axis is a Maxon DC motor with a 50000 counts/rev encoder driving a ball-screw prismatic
joint.  It always runs in closed loop (the plant holds a pure integrator) under a dSPACE
controller at 1 kHz.  A record holds

=========  ======  ==========================================================================
variable   unit    meaning
=========  ======  ==========================================================================
``t``      s       time stamps (1 kHz nominal; they jitter by a few 1e-8 s)
``qm``     m       motor-encoder position expressed on the load side (train: 5e-8 m steps)
``qg``     m       reference position (the same array in both runs)
``vir``    V       controller output.  The authors' PDF calls it a force; it is **volts**.
``gtau``   N/V     drive gain, force = gtau * vir (35.15065188 N/V)
``kp``     1/s     position gain (160.18 1/s)
``kv``     V/(m/s) velocity gain (243.45 V/(m/s))
pulses_N   V       validation run only: 0/5 V square wave (1 s period, 50 % duty).  Despite
                   its name it is a voltage, added to ``vir`` after the saturation and before
                   ``gtau``; the recorded ``vir`` already contains it (~5 V x 35.15 N/V
                   ~ 176 N per pulse).
=========  ======  ==========================================================================

``read_emps`` reads the original ``.mat`` files or their CSV copies (columns ``t_s, qm_m, qg_m,
vir_V, force_N[, pulse_V]``); ``to_measurement_frame`` turns a record into gearbench's
measurement format (docs/measurements.md) with the drive force as the input.
"""
from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import EMPSFormatError

EMPS_CITATION = ('A. Janot, M. Gautier, M. Brunot, "Data Set and Reference Models of EMPS", '
                 'Workshop on Nonlinear System Identification Benchmarks, Eindhoven, April 2019, '
                 'HAL hal-02178709')

# The controller that produced the records (EMPS_Description.pdf and the authors' Simulink model):
#
#   qf(k)     = 0.5*q(k) + 0.5*q(k-1)                  FIR-filtered motor position [m]
#   qd_est(k) = (qf(k) - qf(k-1)) / Ts                 velocity estimate [m/s]
#   vir(k)    = kv * (kp * (qg(k) - q(k)) - qd_est(k))  command [V]
#   the Simulink model then applies a one-sample unit delay and saturates at +-10 V;
#   force     = gtau * (vir_sat + pulse)               drive force on the load side [N]
#
# In the recorded data ``vir`` is aligned WITHOUT the one-sample delay: vir(k) matches the law
# evaluated at sample k plus pulse(k) (residual 3.7 mV rms on the train run, 50 mV rms on the
# pulses run, whose qm is not on the 5e-8 m encoder grid).
# The recorded |vir| stays below 9.1 V, so the saturation is never active.
EMPS_CONTROLLER: dict[str, Any] = {
    "gtau_N_per_V": 35.15065188248547,
    "kp_per_s": 160.18,
    "kv_V_per_m_per_s": 243.45,
    "Ts_s": 1e-3,
    "vir_limit_V": 10.0,
    "pulse_amplitude_V": 5.0,
    "fir_position_weights": (0.5, 0.5),
    "delay_samples": 1,
    "law": ("vir = kv*(kp*(qg - q) - qd_est); qf(k) = 0.5*q(k) + 0.5*q(k-1); "
            "qd_est(k) = (qf(k) - qf(k-1))/Ts; one-sample delay; saturation +-10 V; "
            "force = gtau*(vir_sat + pulse)"),
}

MAT_SIGNALS = ("t", "qm", "qg", "vir")
MAT_CONSTANTS = ("gtau", "kp", "kv")
CSV_COLUMNS = ("t_s", "qm_m", "qg_m", "vir_V", "force_N")

# The stored time stamps may jitter; anything beyond this fraction of Ts means lost or
# duplicated samples, and then "sample index x Ts" would be wrong.
MAX_JITTER_FRACTION = 0.01


def _vector(name: str, value: Any, where: str) -> np.ndarray:
    arr = np.asarray(value)
    if arr.ndim == 2 and 1 in arr.shape:
        arr = arr.reshape(-1)
    if arr.ndim != 1:
        raise EMPSFormatError(f"{where}: variable '{name}' must be a vector (N x 1), "
                              f"got shape {np.shape(value)}")
    try:
        arr = arr.astype(float)
    except (TypeError, ValueError) as exc:
        raise EMPSFormatError(f"{where}: variable '{name}' is not numeric ({exc})") from None
    bad = np.flatnonzero(~np.isfinite(arr))
    if bad.size:
        raise EMPSFormatError(f"{where}: variable '{name}' has a non-finite value at sample "
                              f"{bad[0]} (0-based)")
    return arr


def _scalar(name: str, value: Any, where: str) -> float:
    arr = np.asarray(value)
    if arr.size != 1:
        raise EMPSFormatError(f"{where}: variable '{name}' must be a scalar, got shape {arr.shape}")
    out = float(arr.reshape(-1)[0])
    if not np.isfinite(out) or out <= 0:
        raise EMPSFormatError(f"{where}: variable '{name}' must be a positive number, got {out}")
    return out


def _read_mat(path: Path) -> tuple[dict[str, np.ndarray], dict[str, float], np.ndarray | None]:
    import scipy.io

    where = str(path)
    try:
        raw = scipy.io.loadmat(path)
    except Exception as exc:  # scipy raises several types for a broken file
        raise EMPSFormatError(f"{where}: not a readable MATLAB file ({exc})") from None
    for name in MAT_SIGNALS + MAT_CONSTANTS:
        if name not in raw:
            raise EMPSFormatError(f"{where}: variable '{name}' missing (an EMPS .mat holds "
                                  f"{', '.join(MAT_SIGNALS + MAT_CONSTANTS)}[, pulses_N])")
    sig = {name: _vector(name, raw[name], where) for name in MAT_SIGNALS}
    const = {name: _scalar(name, raw[name], where) for name in MAT_CONSTANTS}
    pulse = _vector("pulses_N", raw["pulses_N"], where) if "pulses_N" in raw else None
    return sig, const, pulse


def _csv_constants(path: Path) -> tuple[dict[str, float], str, float | None]:
    """gtau, kp, kv (and Ts) for a CSV copy: from ``constants.json`` beside it, else published."""
    published = {"gtau": EMPS_CONTROLLER["gtau_N_per_V"], "kp": EMPS_CONTROLLER["kp_per_s"],
                 "kv": EMPS_CONTROLLER["kv_V_per_m_per_s"]}
    cfile = path.with_name("constants.json")
    if not cfile.is_file():
        return published, "published EMPS constants (no constants.json beside the CSV)", None
    try:
        table = json.loads(cfile.read_text())
    except (OSError, ValueError) as exc:
        raise EMPSFormatError(f"{cfile}: unreadable ({exc})") from None
    # The CSV copies are named <prefix>_<mat stem>.csv; take the longest matching stem, so
    # DATA_EMPS_PULSES wins over DATA_EMPS.
    matches = [k for k in table if isinstance(table[k], dict) and Path(k).stem in path.stem]
    if not matches:
        return published, f"published EMPS constants ({cfile.name} has no entry for {path.name})", None
    key = max(matches, key=lambda k: len(Path(k).stem))
    entry = table[key]
    names = {"gtau": "gtau_N_per_V", "kp": "kp_per_s", "kv": "kv_V_per_m_per_s"}
    const = {}
    for short, long in names.items():
        if long not in entry:
            raise EMPSFormatError(f"{cfile}: entry '{key}' lacks '{long}'")
        const[short] = _scalar(long, entry[long], str(cfile))
    ts = _scalar("Ts_s", entry["Ts_s"], str(cfile)) if "Ts_s" in entry else None
    return const, f"{cfile.name} entry '{key}'", ts


def _read_csv(path: Path):
    import pandas as pd

    where = str(path)
    try:
        frame = pd.read_csv(path)
    except Exception as exc:
        raise EMPSFormatError(f"{where}: not a readable CSV file ({exc})") from None
    for col in CSV_COLUMNS:
        if col not in frame.columns:
            raise EMPSFormatError(f"{where}: column '{col}' missing (an EMPS CSV has "
                                  f"{', '.join(CSV_COLUMNS)}[, pulse_V])")
    names = dict(zip(("t_s", "qm_m", "qg_m", "vir_V"), MAT_SIGNALS))
    sig = {names[c]: _vector(c, frame[c].to_numpy(), where) for c in names}
    force = _vector("force_N", frame["force_N"].to_numpy(), where)
    pulse = _vector("pulse_V", frame["pulse_V"].to_numpy(), where) if "pulse_V" in frame else None
    const, source, ts = _csv_constants(path)
    # The CSV stores force_N = gtau*vir_V, both to 10 significant digits: a gtau that does not
    # reproduce it means the constants belong to another record.
    scale = max(float(np.max(np.abs(force))), 1e-12)
    gap = float(np.max(np.abs(force - const["gtau"] * sig["vir"])))
    if gap > 1e-6 * scale:
        raise EMPSFormatError(f"{where}: column 'force_N' is not gtau*vir_V with gtau = "
                              f"{const['gtau']} N/V from {source} (largest gap {gap:.3g} N)")
    return sig, const, pulse, force, source, ts


def read_emps(path: str | Path) -> dict[str, Any]:
    """Read an EMPS record (the original ``.mat`` or its CSV copy) into SI numpy arrays.

    ``.mat``: variables ``t, qm, qg, vir`` (N x 1), ``gtau, kp, kv`` (scalars) and, in the
    validation run, ``pulses_N`` (N x 1 uint8).  ``.csv``: columns ``t_s, qm_m, qg_m, vir_V,
    force_N`` and optionally ``pulse_V``; the CSV holds no constants, so gtau, kp, kv (and Ts)
    come from ``constants.json`` beside it when present, else from ``EMPS_CONTROLLER``, and
    ``force_N`` is checked against gtau*vir_V.  The CSV copies keep 10 significant digits, so
    their signals agree with the .mat to ~5e-10 relative.

    Returns a dict: ``t`` [s], ``qm`` [m], ``qg`` [m], ``vir`` [V], ``force`` = gtau*vir [N],
    ``pulse`` [V] or None, ``gtau`` [N/V], ``kp`` [1/s], ``kv`` [V/(m/s)], ``Ts`` [s], ``n``,
    ``t_jitter_max`` = max |t(k) - t(0) - k*Ts| [s], ``path`` and ``constants_source``.  Ts is
    the mean step rounded to 9 significant digits (0.001 s for EMPS) unless constants.json
    gives it.  Raises ``EMPSFormatError`` (a ValueError) naming the missing or malformed
    variable or column; FileNotFoundError for a missing file.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such file")
    suffix = path.suffix.lower()
    force_file = None
    if suffix == ".mat":
        sig, const, pulse = _read_mat(path)
        source, ts = "the .mat file", None
    elif suffix == ".csv":
        sig, const, pulse, force_file, source, ts = _read_csv(path)
    else:
        raise EMPSFormatError(f"{path}: unknown file type '{path.suffix}' (expected .mat or .csv)")

    n = sig["t"].size
    for name, arr in sig.items():
        if arr.size != n:
            raise EMPSFormatError(f"{path}: variable '{name}' has {arr.size} samples, 't' has {n}")
    if pulse is not None and pulse.size != n:
        raise EMPSFormatError(f"{path}: variable 'pulses_N' has {pulse.size} samples, 't' has {n}")
    if n < 2:
        raise EMPSFormatError(f"{path}: variable 't' has {n} sample(s); need at least 2")
    t = sig["t"]
    steps = np.diff(t)
    if np.any(steps <= 0):
        k = int(np.flatnonzero(steps <= 0)[0])
        raise EMPSFormatError(f"{path}: variable 't' is not strictly increasing at sample {k + 1} "
                              f"(0-based): {t[k]!r} then {t[k + 1]!r}")
    if ts is None:
        ts = float(f"{(t[-1] - t[0]) / (n - 1):.9g}")
    jitter = float(np.max(np.abs(t - t[0] - np.arange(n) * ts)))
    if jitter > MAX_JITTER_FRACTION * ts:
        raise EMPSFormatError(f"{path}: variable 't' departs from a uniform {ts} s grid by "
                              f"{jitter:.3g} s (lost or repeated samples?)")
    out = dict(sig)
    out.update(const)
    out.update(
        force=const["gtau"] * sig["vir"],
        pulse=pulse,
        Ts=ts,
        n=n,
        t_jitter_max=jitter,
        path=str(path),
        constants_source=source,
    )
    if force_file is not None:
        out["force_file"] = force_file
    return out


def to_measurement_frame(d: dict[str, Any]):
    """An EMPS record (from ``read_emps``) as a gearbench measurement frame (docs/measurements.md).

    Columns:

    - ``time_s`` [s] = k * Ts, k = 0..N-1.  The stored stamps jitter by up to ~3e-8 s around
      the 1 kHz grid (step 0.99997-1.00002 ms); the sample index times Ts from t[0] = 0 gives
      exact, strictly increasing times.  (Both EMPS records have t[0] = 0 exactly.)
    - ``drive_force_N`` [N] = gtau * vir, the input: the force the drive applies to the load.
      ``vir`` is volts and already contains the pulses, so this is the total force.
    - ``motor_position_mm`` [mm] = 1000 * (qm - qm[0]): motor encoder expressed on the load side.
    - ``setpoint_mm`` [mm] = 1000 * (qg - qm[0]): the reference position.
    - ``disturbance_V`` [V], only when the record has pulses: the 0/5 V pulse voltage the
      authors add to vir after the +-10 V saturation.  It is already inside drive_force_N
      (informational; do not add it again).

    Zero is where the record starts: the records do not start at qm = 0 (qm[0] = 7.45e-6 m
    train, 7.67e-6 m pulses; qg[0] = 1.078e-4 m), so qm[0] is subtracted from qm AND qg, which
    keeps the tracking error qg - qm unchanged.  Note that EMPS records do not start at rest
    (the axis already moves at ~7 mm/s and the drive pushes ~89 N at t = 0).
    ``frame.attrs`` carries the offset, the constants, the citation and the source path.
    """
    import pandas as pd

    n = int(d["n"]) if "n" in d else np.asarray(d["t"]).size
    ts = float(d["Ts"])
    qm = np.asarray(d["qm"], dtype=float)
    qg = np.asarray(d["qg"], dtype=float)
    q0 = float(qm[0])
    cols = {
        "time_s": np.arange(n) * ts,
        "drive_force_N": float(d["gtau"]) * np.asarray(d["vir"], dtype=float),
        "motor_position_mm": (qm - q0) * 1000.0,
        "setpoint_mm": (qg - q0) * 1000.0,
    }
    if d.get("pulse") is not None:
        cols["disturbance_V"] = np.asarray(d["pulse"], dtype=float)
    frame = pd.DataFrame(cols)
    frame.attrs.update(
        source=d.get("path"),
        citation=EMPS_CITATION,
        position_offset_m=q0,
        t0_s=float(np.asarray(d["t"])[0]),
        Ts_s=ts,
        gtau_N_per_V=float(d["gtau"]),
        kp_per_s=float(d["kp"]),
        kv_V_per_m_per_s=float(d["kv"]),
    )
    return frame
