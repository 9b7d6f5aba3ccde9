"""Inverse-dynamics identification by least squares (IDIM-LS) on the EMPS benchmark.

Reference: A. Janot, M. Gautier, M. Brunot, "Data Set and Reference Models of EMPS", Workshop on
Nonlinear System Identification Benchmarks, Eindhoven, April 2019, HAL hal-02178709
(``gearbench.measure.emps.EMPS_CITATION``).  This is an independent re-implementation of the
authors' Script_IDIM_LS / Script_IDIM_LS_Asym_Fric procedure.

Inverse dynamic model (force on the load side, N; q in m):

    symmetric:   tau = M*qdd + Fv*qd + Fc*sign(qd) + offset
    asymmetric:  tau = M*qdd + Fv+*qd*[qd>0] + Fc+*[qd>0] + Fv-*qd*[qd<0] - Fc-*[qd<0]

(the asymmetric Coulomb pair absorbs the offset: both together are collinear).  Procedure:

1. q_f = filtfilt(butter(4, 100 Hz), qm)
2. qd = diffcent(q_f)/Ts, qdd = diffcent(qd)/Ts  with diffcent(y) = [y1-y0, (y[k+1]-y[k-1])/2,
   y[n-1]-y[n-2]] (so qdd is a central difference of the central difference)
3. drop the first 49 samples (MATLAB ``x(50:end)``)
4. decimate every regressor column and the force y = gtau*vir by 10 (Chebyshev-I, order 8,
   0.05 dB ripple, cut-off 0.8*fs/(2*10), zero phase), r = round(0.8*fnyq/40) = 10 at 1 kHz
5. ordinary least squares;  relative error = 100*||y - y_hat||/||y||  [%]

Step 4 must follow MATLAB's ``decimate`` and ``filtfilt`` exactly to reproduce the printed
digits: MATLAB pads 3*(order) = 24 samples (scipy's filtfilt default pads 27) and keeps the
samples x[nbeg-1::r] with nbeg = r - (r*ceil(N/r) - N), i.e. the phase that ends on the last
sample (scipy.signal.decimate keeps x[0::r]).  With scipy.signal.decimate(ftype='iir', n=8,
zero_phase=True) the train error is 4.124 % instead of the paper's 4.0834 %
(``emulate_matlab=False`` shows it).  With the MATLAB emulation this module gives
M = 95.1089 kg, Fv = 203.5034 N s/m, Fc = 20.3935 N, offset = -3.1648 N, 4.0834 % (train),
5.9824 % (cross-test on the pulses run) and 3.1117 % (asymmetric), as published.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import scipy.signal as ss

BUTTER_ORDER = 4
BUTTER_CUTOFF_HZ = 100.0          # 5 x the ~20 Hz position bandwidth
N_DROP = 49                       # the scripts keep x(50:end)
CHEBY_ORDER = 8
CHEBY_RIPPLE_DB = 0.05

SYMMETRIC = ("mass_kg", "viscous_Ns_per_m", "coulomb_N", "offset_N")
ASYMMETRIC = ("mass_kg", "viscous_pos_Ns_per_m", "coulomb_pos_N", "viscous_neg_Ns_per_m",
              "coulomb_neg_N")
MODELS = {"symmetric": SYMMETRIC, "asymmetric": ASYMMETRIC}

LADDER = (
    ("M only", "symmetric", ("mass_kg",)),
    ("+ viscous", "symmetric", ("mass_kg", "viscous_Ns_per_m")),
    ("+ Coulomb", "symmetric", ("mass_kg", "viscous_Ns_per_m", "coulomb_N")),
    ("+ offset (paper)", "symmetric", SYMMETRIC),
    ("asymmetric friction", "asymmetric", ASYMMETRIC),
)


def diffcent(y: np.ndarray, h: float) -> np.ndarray:
    """Central difference [unit/s]: one-sided at both ends, (y[k+1] - y[k-1])/(2h) inside."""
    y = np.asarray(y, dtype=float)
    return np.concatenate(([y[1] - y[0]], (y[2:] - y[:-2]) / 2.0, [y[-1] - y[-2]])) / h


def filtfilt_matlab(b: np.ndarray, a: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Zero-phase filtering as MATLAB ``filtfilt``: odd padding of 3*(max(len(a), len(b)) - 1)."""
    return ss.filtfilt(b, a, x, padtype="odd", padlen=3 * (max(len(a), len(b)) - 1))


def decimate_matlab(x: np.ndarray, r: int) -> np.ndarray:
    """MATLAB ``decimate(x, r)``: Chebyshev-I order 8, 0.05 dB, cut-off 0.8/r (of Nyquist),
    ``filtfilt``, then keep x[nbeg-1::r] with nbeg = r - (r*ceil(N/r) - N) (ends on the last
    sample).  Output length ceil(N/r)."""
    b, a = ss.cheby1(CHEBY_ORDER, CHEBY_RIPPLE_DB, 0.8 / r)
    y = filtfilt_matlab(b, a, np.asarray(x, dtype=float))
    nd = y.size
    nout = -(-nd // r)
    nbeg = r - (r * nout - nd)
    return y[nbeg - 1::r]


def kinematics(position_m, ts: float, *, emulate_matlab: bool = True
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Filtered position (m), velocity (m/s) and acceleration (m/s^2) by the paper's IDIM chain:
    a 4th-order Butterworth at 100 Hz applied forwards and backwards (MATLAB ``filtfilt``'s
    padding when ``emulate_matlab``), then :func:`diffcent` twice.  ``ts``: sample time, s."""
    b, a = ss.butter(BUTTER_ORDER, BUTTER_CUTOFF_HZ / (0.5 / ts))
    q = np.asarray(position_m, dtype=float)
    q_f = filtfilt_matlab(b, a, q) if emulate_matlab else ss.filtfilt(b, a, q)
    qd = diffcent(q_f, ts)
    return q_f, qd, diffcent(qd, ts)


def _decimate(x: np.ndarray, r: int, emulate_matlab: bool) -> np.ndarray:
    if emulate_matlab:
        return decimate_matlab(x, r)
    return ss.decimate(x, r, n=CHEBY_ORDER, ftype="iir", zero_phase=True)


def _signals(d: Any) -> tuple[np.ndarray, np.ndarray, float]:
    """(qm [m], force [N], Ts [s]) from a read_emps dict or a measurement frame."""
    try:
        import pandas as pd
        if isinstance(d, pd.DataFrame):
            for col in ("time_s", "motor_position_mm", "drive_force_N"):
                if col not in d.columns:
                    raise ValueError(f"measurement frame lacks column '{col}'")
            t = d["time_s"].to_numpy(dtype=float)
            ts = float(f"{(t[-1] - t[0]) / (t.size - 1):.9g}")
            return (d["motor_position_mm"].to_numpy(dtype=float) / 1000.0,
                    d["drive_force_N"].to_numpy(dtype=float), ts)
    except ImportError:  # pragma: no cover - pandas is a dependency
        pass
    if not isinstance(d, Mapping):
        raise TypeError("expected a read_emps dict or a measurement DataFrame")
    for key in ("qm", "Ts"):
        if key not in d:
            raise ValueError(f"EMPS record lacks '{key}'")
    if "force" in d:
        force = np.asarray(d["force"], dtype=float)
    elif "vir" in d and "gtau" in d:
        force = float(d["gtau"]) * np.asarray(d["vir"], dtype=float)
    else:
        raise ValueError("EMPS record lacks 'force' (or 'vir' and 'gtau')")
    return np.asarray(d["qm"], dtype=float), force, float(d["Ts"])


def observation(d: Any, *, emulate_matlab: bool = True) -> dict[str, Any]:
    """Filtered, differentiated, trimmed and decimated regressors of an EMPS record.

    Returns ``{"X": {name: column}, "y": force [N], "time_s": sample times of the rows [s],
    "r": decimation factor}`` with a column for every parameter of both models (units: qdd
    m/s^2 for mass_kg, qd m/s for viscous terms, dimensionless for Coulomb/offset).
    """
    qm, force, ts = _signals(d)
    if qm.size != force.size:
        raise ValueError(f"qm has {qm.size} samples, the force {force.size}")
    fnyq = 0.5 / ts
    r = int(round(0.8 * fnyq / (2 * 20.0)))
    if qm.size < N_DROP + 3 * (CHEBY_ORDER + 1) + r:
        raise ValueError(f"record too short for IDIM-LS ({qm.size} samples)")
    _, qd, qdd = kinematics(qm, ts, emulate_matlab=emulate_matlab)
    keep = slice(N_DROP, None)
    qd, qdd, y = qd[keep], qdd[keep], force[keep]
    sgn = np.sign(qd)
    pos = (1.0 + sgn) / 2.0
    neg = (1.0 - sgn) / 2.0
    raw = {
        "mass_kg": qdd,
        "viscous_Ns_per_m": qd,
        "coulomb_N": sgn,
        "offset_N": np.ones_like(qd),
        "viscous_pos_Ns_per_m": qd * pos,
        "coulomb_pos_N": sgn * pos,
        "viscous_neg_Ns_per_m": qd * neg,
        "coulomb_neg_N": sgn * neg,
    }
    X = {name: _decimate(col, r, emulate_matlab) for name, col in raw.items()}
    n = y.size
    if emulate_matlab:
        idx = N_DROP + (r - (r * (-(-n // r)) - n) - 1) + r * np.arange(-(-n // r))
    else:
        idx = N_DROP + r * np.arange(-(-n // r))
    return {"X": X, "y": _decimate(y, r, emulate_matlab), "time_s": idx * ts, "r": r}


def _columns(model: str, columns: Sequence[str] | None) -> tuple[str, ...]:
    if model not in MODELS:
        raise ValueError(f"model must be 'symmetric' or 'asymmetric', got {model!r}")
    allowed = MODELS[model]
    if columns is None:
        return allowed
    cols = tuple(columns)
    unknown = [c for c in cols if c not in allowed]
    if unknown:
        hint = (" (the asymmetric Coulomb pair absorbs the offset)"
                if model == "asymmetric" and "offset_N" in unknown else "")
        raise ValueError(f"unknown column(s) {unknown} for the {model} model; "
                         f"choose from {list(allowed)}{hint}")
    if not cols or len(set(cols)) != len(cols):
        raise ValueError(f"columns must be a non-empty list without repeats, got {cols}")
    return cols


def _errors(y: np.ndarray, y_hat: np.ndarray) -> dict[str, Any]:
    e = y - y_hat
    return {
        "rel_error_pct": 100.0 * float(np.linalg.norm(e) / np.linalg.norm(y)),
        "error_norm_N": float(np.linalg.norm(e)),
        "error_std_N": float(np.std(e, ddof=1)),
        "force_N": y,
        "force_fit_N": y_hat,
    }


def idim_ls(d: Any, model: str = "symmetric", columns: Sequence[str] | None = None, *,
            emulate_matlab: bool = True) -> dict[str, Any]:
    """IDIM-LS fit of the inverse dynamic model to one EMPS record.

    ``d``: a ``read_emps`` dict (or a measurement frame with time_s, motor_position_mm,
    drive_force_N).  ``model``: "symmetric" (mass_kg, viscous_Ns_per_m, coulomb_N, offset_N)
    or "asymmetric" (mass_kg, viscous_pos_Ns_per_m, coulomb_pos_N, viscous_neg_Ns_per_m,
    coulomb_neg_N); ``columns`` picks a subset of the model's parameters, in order.

    Returns ``params`` {name: value} (kg, N s/m, N), ``param_std`` {name: std} (the scripts'
    std(e)*sqrt(diag((X'X)^-1))), ``rel_error_pct`` = 100*||y - y_hat||/||y||, ``error_norm_N``,
    ``error_std_N`` (ddof 1, as MATLAB ``std``), ``cond`` (of the decimated observation matrix),
    ``n_rows``, ``model``, ``columns``, and the arrays ``time_s``, ``force_N``, ``force_fit_N``.
    """
    cols = _columns(model, columns)
    obs = observation(d, emulate_matlab=emulate_matlab)
    X = np.column_stack([obs["X"][c] for c in cols])
    y = obs["y"]
    beta, *_ = np.linalg.lstsq(X, y, rcond=None)
    out = _errors(y, X @ beta)
    std = out["error_std_N"] * np.sqrt(np.diag(np.linalg.inv(X.T @ X)))
    out.update(
        params={c: float(v) for c, v in zip(cols, beta)},
        param_std={c: float(v) for c, v in zip(cols, std)},
        cond=float(np.linalg.cond(X)),
        n_rows=int(y.size),
        model=model,
        columns=cols,
        time_s=obs["time_s"],
    )
    return out


def evaluate(d: Any, params: Mapping[str, float], *, emulate_matlab: bool = True) -> dict[str, Any]:
    """Relative inverse-dynamics error of given ``params`` on a record (e.g. a cross-test).

    The record goes through the same filter/difference/decimation as ``idim_ls``; the model is
    asymmetric when any *_pos_*/*_neg_* parameter is present.  Returns ``rel_error_pct``,
    ``error_norm_N``, ``error_std_N``, ``n_rows`` and the arrays ``time_s``, ``force_N``,
    ``force_fit_N``.
    """
    names = tuple(params)
    model = "asymmetric" if any("_pos_" in p or "_neg_" in p for p in names) else "symmetric"
    cols = _columns(model, names)
    obs = observation(d, emulate_matlab=emulate_matlab)
    y_hat = sum(float(params[c]) * obs["X"][c] for c in cols)
    out = _errors(obs["y"], np.asarray(y_hat, dtype=float))
    out.update(n_rows=int(obs["y"].size), model=model, time_s=obs["time_s"])
    return out


def idim_ladder(train: Any, test: Any | None = None, *,
                emulate_matlab: bool = True) -> list[dict[str, Any]]:
    """The ladder of docs/real-data.md: one physical effect per row, fitted on ``train``, scored on ``test``.

    Rows: "M only", "+ viscous", "+ Coulomb", "+ offset (paper)", "asymmetric friction".  Each
    row is ``{"model": label, "params": {...}, "train_rel_error_pct": %,
    "test_rel_error_pct": % or None}``.
    """
    rows = []
    for label, model, cols in LADDER:
        fit = idim_ls(train, model, cols, emulate_matlab=emulate_matlab)
        test_err = (evaluate(test, fit["params"], emulate_matlab=emulate_matlab)["rel_error_pct"]
                    if test is not None else None)
        rows.append({"model": label, "params": fit["params"],
                     "train_rel_error_pct": fit["rel_error_pct"], "test_rel_error_pct": test_err})
    return rows
