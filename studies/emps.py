"""The EMPS study: gearbench's closed-loop identification on real data, beside the published numbers.

Data and reference models: A. Janot, M. Gautier, M. Brunot, "Data Set and Reference Models of
EMPS", Workshop on Nonlinear System Identification Benchmarks, Eindhoven, April 2019, HAL
hal-02178709 (``EMPS_CITATION``).  The two records are in the repository, ``data/emps/``
(provenance and terms in its README); ``--data-dir`` points elsewhere.

Run from the repository's root (``make run`` does)::

    python -m studies.emps --results results [--data-dir PATH]

It writes ``results/emps.md``, ``results/emps.json`` and PNG figures under ``results/emps/``
(atomically).  What it does, in the order of the report:

1. **Ladder** (``paper_ladder``): from the bare plant (``experiments/plants/emps_bare.yaml``, a
   force-driven rigid carriage with its mass only) on the training run, ``diagnose`` adds one
   effect per step, restricted to the paper's structure (viscous + Coulomb friction + a
   constant force), refitting the mass and every earlier effect with each candidate.  The
   error is the closed-loop force error ``100 ||F - F_sim|| / ||F||`` of a replay driven by
   the recorded set point (and pulses) through the EMPS controller.  The same ladder over the
   whole effect library (``only=()``) shows what gearbench picks unaided.
2. **Validation**: the fitted paper-structure model on the pulses run (``score``).
3. **Asymmetric friction** (``fit_asymmetric``): Fv+/Fv-, Fc+/Fc-, no offset (collinear with
   the Coulomb pair), fitted on train; the inverse-dynamics (IDIM-LS) errors of
   ``measure/idim.py`` beside the paper's.
4. **Closed-loop errors per signal** (``closed_loop_errors``): position, velocity,
   acceleration and force; velocity and acceleration come from the measured and the simulated
   motor position by the same chain, the paper's IDIM one: 4th-order Butterworth 100 Hz,
   ``filtfilt`` (MATLAB padding), then central differences twice; over the whole record and
   from sample 49 on (the IDIM scripts' cut, which leaves out the replay's start transient).
5. **Where the validation run fails** (``where_it_fails``): errors by motion phase and in the
   windows after the pulse edges; then a compliance between motor and carriage
   (``compliance_test``): the rotor carries part of the moving mass, a spring-damper
   (``shaft_compliance``) joins it to the carriage side, total mass fixed; fitted on the
   validation run (where the pulses excite it) and on train, scored on both.
6. Everything that depends on the controller's delay is done for ``delay_samples`` 0 (what
   the data show: the recorded vir is the control law at the same sample; the default) and 1
   (the authors' Simulink model).
"""
from __future__ import annotations

import json
import math
import time
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

import numpy as np
import click

from gearbench.control.sampled import SampledPV
from gearbench.experiment.controller_file import load_controller
from gearbench.experiment.files import load_plant
from gearbench.identify.diagnose import diagnose
from gearbench.identify import uncertainty
from gearbench.identify.fit import Free, fit, get_value, set_values
from gearbench.identify.scoring import Scorer
from gearbench.identify.uncertainty import central_jacobian
from gearbench.identify.replay import Replay, ReplayError
from gearbench.measure import idim
from gearbench.measure.data import Measurement, from_frame
from gearbench.measure.emps import EMPS_CITATION, read_emps, to_measurement_frame
from gearbench.measure import phases
from gearbench.measure.phases import PHASES, classify_phases, error_shares
from gearbench.plant.components import Plant
from gearbench.plant.effects import AddedEffect
from gearbench.report.compare import comparison_figure, ladder_figure
from gearbench.report.io import save_figure_atomic, write_text_atomic

REPO = Path(__file__).resolve().parents[1]
DEFAULT_DATA_DIR = REPO / "data" / "emps"
RUN_FILES = {"train": ("DATA_EMPS.mat", "emps_train_DATA_EMPS.csv"),
             "validation": ("DATA_EMPS_PULSES.mat", "emps_test_DATA_EMPS_PULSES.csv")}
BARE_PLANT = REPO / "experiments" / "plants" / "emps_bare.yaml"
CONTROLLER_FILE = REPO / "experiments" / "controllers" / "emps.yaml"
COMMAND = "python -m studies.emps --results results"

PAPER_STRUCTURE = ("viscous_friction", "coulomb_friction", "bias_torque")
FREE_PLANT = ("leadscrew.mass",)
# Janot, Gautier, Brunot 2019 (IDIM-LS, symmetric and asymmetric friction)
PAPER_PARAMS = {"mass_kg": 95.1089, "viscous_Ns_per_m": 203.5034, "coulomb_N": 20.3935,
                "offset_N": -3.1648}
PAPER_ASYMMETRIC = {"mass_kg": 95.1540, "viscous_pos_Ns_per_m": 166.7061,
                    "viscous_neg_Ns_per_m": 240.4236, "coulomb_pos_N": 20.1440,
                    "coulomb_neg_N": 20.6277}
PAPER_IDIM = {"symmetric_train_pct": 4.0834, "symmetric_cross_test_pct": 5.9824,
              "asymmetric_train_pct": 3.1117}
PAPER_CLOSED_LOOP = {  # authors' Simulink (one-sample delay), symmetric model, relative errors %
    "train": {"position": 0.0138, "velocity": 0.229, "acceleration": 8.60, "force": 5.85},
    "validation": {"position": 0.0080, "velocity": 0.479, "acceleration": 19.8, "force": 8.94},
}
PARAM_TOLERANCE_PCT = 5.0
SIGNALS = ("position", "velocity", "acceleration", "force")
EDGE_WINDOW_S = 0.05          # "after a pulse edge": the 50 ms following each edge
ZOOM_S = (4.0, 7.0)           # a stretch of the validation run with pulse edges in motion
ZOOM_EDGE_S = (5.32, 5.46)    # one pulse edge (5.344 s) close up


# ----------------------------------------------------------------------------- data, plants
@dataclass
class Runs:
    """The two EMPS records, as gearbench measurements and as ``read_emps`` dicts."""
    train: Measurement
    validation: Measurement
    raw_train: dict
    raw_validation: dict
    data_dir: Path
    files: dict

    def __getitem__(self, run: str) -> Measurement:
        return {"train": self.train, "validation": self.validation}[run]

    def raw(self, run: str) -> dict:
        return {"train": self.raw_train, "validation": self.raw_validation}[run]


def data_files(data_dir: str | Path | None = None) -> dict[str, Path]:
    """The train and validation files in ``data_dir`` (the .mat, else the CSV copy).

    Raises FileNotFoundError, saying where it looked and how to point elsewhere."""
    d = Path(data_dir) if data_dir is not None else DEFAULT_DATA_DIR
    if not d.is_dir():
        raise FileNotFoundError(f"EMPS data directory {d} not found: get the benchmark's "
                                f"DATA_EMPS.mat and DATA_EMPS_PULSES.mat (nonlinearbenchmark.org, "
                                f"EMPS) and pass --data-dir PATH")
    out = {}
    for run, names in RUN_FILES.items():
        hits = [d / n for n in names if (d / n).is_file()]
        if not hits:
            raise FileNotFoundError(f"EMPS {run} record not found in {d}: expected "
                                    f"{' or '.join(names)}")
        out[run] = hits[0]
    return out


def load_runs(data_dir: str | Path | None = None) -> Runs:
    """Read both EMPS records (see :func:`data_files`)."""
    files = data_files(data_dir)
    raw = {run: read_emps(path) for run, path in files.items()}
    meas = {run: from_frame(to_measurement_frame(raw[run]), source=f"EMPS {run} ({files[run].name})")
            for run in files}
    return Runs(meas["train"], meas["validation"], raw["train"], raw["validation"],
                Path(data_dir) if data_dir is not None else DEFAULT_DATA_DIR, files)


def bare_plant() -> Plant:
    """The force-driven rigid carriage with its mass only (``emps_bare.yaml``)."""
    return load_plant(BARE_PLANT)


def controller(delay_samples: int = 0) -> SampledPV:
    """The EMPS controller (``experiments/controllers/emps.yaml``) with the given delay."""
    return replace(load_controller(CONTROLLER_FILE), delay_samples=int(delay_samples))


def _radius(plant: Plant) -> float:
    return plant.leadscrew.radius / plant.gear.ratio   # m of carriage per rad of rotor


def moving_mass(plant: Plant) -> float:
    """Everything that moves, as a mass at the carriage (kg): carriage + (rotor, pinion, screw)
    inertia / r^2.  The bare plant's 1e-9 kg m^2 rotor adds 1 g."""
    r = plant.leadscrew.radius
    return (plant.leadscrew.mass + plant.load.inertia / r ** 2
            + plant.motor_inertia_total / _radius(plant) ** 2)


def rigid_plant(params: Mapping[str, float], bare: Plant | None = None) -> Plant:
    """The bare plant with the paper's model: ``mass_kg`` (the whole moving mass, so the
    carriage gets it less the bare rotor's 1 g), ``viscous_Ns_per_m``, ``coulomb_N``,
    ``offset_N`` (= minus the carriage force), or the asymmetric ``viscous_pos/neg_Ns_per_m``,
    ``coulomb_pos/neg_N``.  Absent keys: no effect."""
    p = bare if bare is not None else bare_plant()
    p = replace(p, effects=())
    others = moving_mass(p) - p.leadscrew.mass
    p = replace(p, leadscrew=replace(p.leadscrew, mass=float(params["mass_kg"]) - others))
    effects = []
    if "viscous_pos_Ns_per_m" in params:
        effects.append(AddedEffect("viscous_friction", {
            "location": "carriage", "coefficient": float(params["viscous_pos_Ns_per_m"]),
            "coefficient_negative": float(params["viscous_neg_Ns_per_m"])}))
    elif "viscous_Ns_per_m" in params:
        effects.append(AddedEffect("viscous_friction", {"location": "carriage",
                                                        "coefficient": float(params["viscous_Ns_per_m"])}))
    if "coulomb_pos_N" in params:
        effects.append(AddedEffect("coulomb_friction", {
            "location": "carriage", "force": float(params["coulomb_pos_N"]),
            "force_negative": float(params["coulomb_neg_N"])}))
    elif "coulomb_N" in params:
        effects.append(AddedEffect("coulomb_friction", {"location": "carriage",
                                                        "force": float(params["coulomb_N"])}))
    if "offset_N" in params:
        effects.append(AddedEffect("bias_torque", {"location": "carriage",
                                                   "force": -float(params["offset_N"])}))
    return p.with_effects(*effects)


_PAPER_NAMES = {  # (effect, file key) -> (paper name, sign)
    ("viscous_friction", "coefficient"): ("viscous_Ns_per_m", 1.0),
    ("viscous_friction", "coefficient_negative"): ("viscous_neg_Ns_per_m", 1.0),
    ("coulomb_friction", "force"): ("coulomb_N", 1.0),
    ("coulomb_friction", "force_negative"): ("coulomb_neg_N", 1.0),
    ("bias_torque", "force"): ("offset_N", -1.0),
}


def _paper_name(effect: str, key: str, values: Mapping) -> tuple[str, float]:
    """The paper's name of an effect parameter at the carriage, and the sign that maps it."""
    if (effect, key) in _PAPER_NAMES:
        name, sign = _PAPER_NAMES[(effect, key)]
        asym = ("coefficient_negative" in values) if effect == "viscous_friction" else (
            "force_negative" in values)
        if asym and name in ("viscous_Ns_per_m", "coulomb_N"):
            name = name.replace("_Ns", "_pos_Ns") if "viscous" in name else "coulomb_pos_N"
        return name, sign
    return f"{effect}.{key}", 1.0


def paper_params(plant: Plant) -> dict[str, float]:
    """A plant's model in the paper's names and signs (mass = :func:`moving_mass`)."""
    out = {"mass_kg": moving_mass(plant)}
    for e in plant.effects:
        for k, v in e.values.items():
            if isinstance(v, str):
                continue
            name, sign = _paper_name(e.name, k, e.values)
            out[name] = sign * float(v)
    return out


def plant_from_model(model: Sequence[Mapping], plant_params: Mapping[str, float],
                     bare: Plant | None = None) -> Plant:
    """A plant from a diagnose step's ``model`` (effects as in a file) and ``plant_params``."""
    p = bare if bare is not None else bare_plant()
    for path, v in plant_params.items():
        section, key = path.split(".")
        p = replace(p, **{section: replace(getattr(p, section), **{key: float(v)})})
    effects = tuple(AddedEffect(m["type"], {k: v for k, v in m.items() if k != "type"}) for m in model)
    return replace(p, effects=effects)


# ----------------------------------------------------------------------------- scoring
def rel_pct(y, y_hat) -> float:
    """``100 ||y - y_hat|| / ||y||`` (%)."""
    y = np.asarray(y, dtype=float)
    return float(100.0 * np.linalg.norm(y - np.asarray(y_hat, dtype=float)) / np.linalg.norm(y))


def simulate(plant: Plant, data: Measurement, ctrl: SampledPV) -> dict[str, np.ndarray]:
    """Closed-loop replay of ``data``: simulated ``motor_position_mm`` and ``drive_force_N``."""
    return Replay(data, ctrl).run(plant)


def score(plant: Plant, data: Measurement, ctrl: SampledPV) -> float:
    """Closed-loop force error of ``plant`` on ``data``, % (the paper's measure)."""
    return rel_pct(data.input, simulate(plant, data, ctrl)["drive_force_N"])


def signal_pairs(data: Measurement, sim: Mapping[str, np.ndarray]) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """(measured, simulated) of position (m), velocity (m/s), acceleration (m/s^2) and
    force (N), every sample; velocity and acceleration by :func:`gearbench.measure.idim.kinematics` on both."""
    ts = data.sample_time_s
    q_m = np.asarray(data.signals["motor_position_mm"], dtype=float) / 1000.0
    q_s = np.asarray(sim["motor_position_mm"], dtype=float) / 1000.0
    _, v_m, a_m = idim.kinematics(q_m, ts)
    _, v_s, a_s = idim.kinematics(q_s, ts)
    return {"position": (q_m, q_s), "velocity": (v_m, v_s), "acceleration": (a_m, a_s),
            "force": (np.asarray(data.input, dtype=float), np.asarray(sim["drive_force_N"], dtype=float))}


def closed_loop_errors(data: Measurement, sim: Mapping[str, np.ndarray],
                       drop: int = 0) -> dict[str, float]:
    """Relative errors (%) of position, velocity, acceleration and force, the first ``drop``
    samples left out (0: the whole record, as the ladder's force error; the IDIM scripts
    drop 49).  Position is the motor encoder from the record's
    start (qm - qm[0]; qm[0] = 7.5 um, negligible beside the 0.246 m travel)."""
    return {k: rel_pct(m[drop:], s[drop:]) for k, (m, s) in signal_pairs(data, sim).items()}


# ----------------------------------------------------------------------------- fitting helpers
def frees_of(plant: Plant, mass: bool = True) -> list[Free]:
    """Every numeric parameter of the plant's effects (and the carriage mass) as a ``Free``,
    scaled by its current value.

    ``Free.effect`` leaves out a carriage ``coulomb_friction``'s ``force_negative`` (see the
    note in the study's report: ``Effect.fit_params`` looks for ``torque_negative``), so it is
    added here."""
    out = [Free.plant(plant, "leadscrew.mass")] if mass else []
    for i, e in enumerate(plant.effects):
        fr = Free.effect(plant, i)
        keys = {f.key for f in fr}
        if e.name == "coulomb_friction" and "force_negative" in e.values and "force_negative" not in keys:
            fr.append(Free("force_negative", i, 0.0, 1e6, 1.0, "N"))
        out += fr
    return [replace(f, scale=abs(get_value(plant, f)) or f.scale) for f in out]


def carriage_force_negative_left_out() -> bool:
    """Whether ``Free.effect`` leaves out a carriage Coulomb friction's ``force_negative``."""
    p = bare_plant().with_effects(AddedEffect("coulomb_friction", {"location": "carriage", "force": 1.0,
                                                                   "force_negative": 1.0}))
    return "force_negative" not in {f.key for f in Free.effect(p, 0)}


def _free_paper_name(plant: Plant, f: Free) -> str:
    if f.index is None:
        return "mass_kg" if f.key == "leadscrew.mass" else f.key
    e = plant.effects[f.index]
    return _paper_name(e.name, f.key, e.values)[0]


def standard_errors(replay: Replay, plant: Plant, frees: Sequence[Free],
                    rel_step: float = 1e-4) -> dict[str, float]:
    """Standard errors of ``frees`` at ``plant`` (paper names and units): the sandwich covariance
    of :func:`gearbench.identify.uncertainty.covariance` (valid for the closed-loop force
    residual's strong correlation in time) with a central-difference Jacobian."""
    scorer = Scorer(replay)
    x0 = np.array([get_value(plant, f) for f in frees])
    r0 = scorer.weighted(replay.run(plant))
    jac = central_jacobian(lambda x: scorer.weighted(replay.run(set_values(plant, list(frees), x))), x0,
                           [rel_step * max(abs(x), f.scale) for x, f in zip(x0, frees)])
    se = uncertainty.standard_errors(uncertainty.covariance(jac, r0, 1))
    return {_free_paper_name(plant, f): float(e) for f, e in zip(frees, se)}


def compare_to_paper(params: Mapping[str, float], paper: Mapping[str, float] = PAPER_PARAMS,
                     stderr: Mapping[str, float] | None = None) -> list[dict]:
    """Rows ``{name, fitted, paper, rel_diff_pct, stderr, within_tolerance}``."""
    rows = []
    for k, ref in paper.items():
        v = params.get(k)
        diff = None if v is None else 100.0 * (v - ref) / abs(ref)
        rows.append({"name": k, "fitted": v, "paper": ref, "rel_diff_pct": diff,
                     "stderr": (stderr or {}).get(k),
                     "within_tolerance": diff is not None and abs(diff) <= PARAM_TOLERANCE_PCT})
    return rows


# ----------------------------------------------------------------------------- 1. ladders
def run_ladder(runs: Runs, ctrl: SampledPV, only: tuple[str, ...] = PAPER_STRUCTURE,
               workers: int | None = None, max_steps: int = 4, progress: Callable | None = None) -> dict:
    """``diagnose`` from the bare plant on the training run (mass refitted with every step).

    Returns ``rows`` (first the bare model as effect "bare"; each
    ``{effect, options, train_force_error_pct, rms_force_error_N, params (paper names, whole
    model), step_params, step_stderr, bic, model}``), ``plant`` (the last rung), ``params``,
    ``candidates`` (the first step's, best first, with their force errors), ``verdict``,
    ``reason``, ``seconds`` and the ``diagnosis`` itself."""
    bare = bare_plant()
    replay = Replay(runs.train, ctrl)
    t0 = time.perf_counter()
    # the paper's procedure: its own free values (FREE_PLANT), no datasheet calibration beside them
    d = diagnose(bare, replay, free_plant=FREE_PLANT, only=only, workers=workers, calibrate=False,
                 max_steps=max_steps, progress=progress)
    seconds = time.perf_counter() - t0
    y = np.asarray(runs.train.input, dtype=float)
    to_rel = 100.0 * math.sqrt(y.size) / float(np.linalg.norm(y))   # RMS (N) -> relative %
    rows = [{"effect": "bare", "options": {}, "train_force_error_pct": d.baseline_relative_pct,
             "rms_force_error_N": d.baseline.error, "params": paper_params(d.baseline_plant),
             "step_params": {}, "step_stderr": {}, "bic": d.baseline.bic, "model": []}]
    for s in d.ladder:
        p = plant_from_model(s.model, s.plant_params, bare)
        rows.append({"effect": s.effect, "action": s.action, "options": s.options,
                     "train_force_error_pct": s.relative_error_pct, "rms_force_error_N": s.error,
                     "params": paper_params(p), "step_params": s.params, "step_stderr": s.stderr,
                     "bic": s.bic, "model": s.model})
    cands = [{"effect": t.candidate.label(), "params": t.params,
              "train_force_error_pct": t.result.error * to_rel if t.ok else None,
              "bic": t.result.bic if t.ok else None, "note": t.note} for t in d.tried]
    return {"rows": rows, "plant": d.plant, "params": paper_params(d.plant), "candidates": cands,
            "verdict": d.verdict, "reason": d.reason, "seconds": seconds, "diagnosis": d,
            "only": list(only), "not_tried": d.not_tried}


def paper_ladder(runs: Runs, ctrl: SampledPV, workers: int | None = None,
                 progress: Callable | None = None, with_stderr: bool = True) -> dict:
    """:func:`run_ladder` with the paper's structure, plus the standard errors of the final
    model's four parameters and their comparison with the paper's values (``comparison``)."""
    out = run_ladder(runs, ctrl, PAPER_STRUCTURE, workers=workers, progress=progress)
    stderr = None
    if with_stderr:
        t0 = time.perf_counter()
        stderr = standard_errors(Replay(runs.train, ctrl), out["plant"], frees_of(out["plant"]))
        out["stderr_seconds"] = time.perf_counter() - t0
    out["stderr"] = stderr
    out["comparison"] = compare_to_paper(out["params"], PAPER_PARAMS, stderr)
    out["effects_in_order"] = [r["effect"] for r in out["rows"][1:]]
    return out


# ----------------------------------------------------------------------------- 3. asymmetric
def fit_asymmetric(runs: Runs, ctrl: SampledPV, start: Mapping[str, float]) -> dict:
    """Asymmetric viscous and Coulomb friction (no offset: collinear with the Coulomb pair),
    with the mass, fitted on the training run from the symmetric ``start`` (paper names).

    Returns ``params`` (paper names), ``stderr`` (fit's, paper names), ``train_force_error_pct``,
    ``validation_force_error_pct``, ``plant``, ``converged``, ``message``, ``seconds``."""
    p0 = rigid_plant({"mass_kg": start["mass_kg"],
                      "viscous_pos_Ns_per_m": start["viscous_Ns_per_m"],
                      "viscous_neg_Ns_per_m": start["viscous_Ns_per_m"],
                      "coulomb_pos_N": start["coulomb_N"], "coulomb_neg_N": start["coulomb_N"]})
    replay = Replay(runs.train, ctrl)
    frees = frees_of(p0)
    t0 = time.perf_counter()
    res = fit(replay, p0, frees)
    seconds = time.perf_counter() - t0
    sim_train = res.sim if res.sim is not None else replay.run(res.plant)
    return {"params": paper_params(res.plant),
            "stderr": {_free_paper_name(res.plant, f): res.stderr.get(f.name) for f in frees},
            "train_force_error_pct": rel_pct(runs.train.input, sim_train["drive_force_N"]),
            "validation_force_error_pct": score(res.plant, runs.validation, ctrl),
            "plant": res.plant, "converged": res.converged, "message": res.message,
            "nfev": res.nfev, "seconds": seconds}


def idim_results(runs: Runs) -> dict:
    """IDIM-LS (``measure/idim.py``): the ladder, the symmetric and asymmetric fits, and the
    cross-test on the pulses run, beside the paper's figures."""
    t0 = time.perf_counter()
    sym = idim.idim_ls(runs.raw_train, "symmetric")
    asym = idim.idim_ls(runs.raw_train, "asymmetric")
    cross = idim.evaluate(runs.raw_validation, sym["params"])
    cross_asym = idim.evaluate(runs.raw_validation, asym["params"])
    ladder = idim.idim_ladder(runs.raw_train, runs.raw_validation)
    return {
        "symmetric": {"params": sym["params"], "param_std": sym["param_std"],
                      "train_pct": sym["rel_error_pct"], "cross_test_pct": cross["rel_error_pct"],
                      "error_norm_N": sym["error_norm_N"], "error_std_N": sym["error_std_N"],
                      "cond": sym["cond"]},
        "asymmetric": {"params": asym["params"], "param_std": asym["param_std"],
                       "train_pct": asym["rel_error_pct"], "cross_test_pct": cross_asym["rel_error_pct"]},
        "ladder": ladder,
        "paper": PAPER_IDIM,
        "seconds": time.perf_counter() - t0,
    }


# ----------------------------------------------------------------------------- 5. where it fails
def pulse_edges(data: Measurement) -> np.ndarray:
    """Sample indices where the record's pulse (disturbance) voltage changes."""
    return phases.pulse_edges(data.disturbance_V)


def edge_mask(data: Measurement, window_s: float = EDGE_WINDOW_S) -> np.ndarray:
    """True in the ``window_s`` after each pulse edge."""
    return phases.edge_mask(data.time_s, data.disturbance_V, window_s)


def where_it_fails(data: Measurement, sim: Mapping[str, np.ndarray],
                   drop: int = idim.N_DROP) -> dict:
    """Where the residuals of acceleration and force sit: shares of time and of squared error
    by motion phase (``classify_phases`` of the measured position) and in the
    ``EDGE_WINDOW_S`` after each pulse edge, and the error with those windows left out."""
    pairs = signal_pairs(data, sim)
    labels = classify_phases(data.time_s, data.signals["motor_position_mm"])
    edges = edge_mask(data)
    keep = np.zeros(data.time_s.size, dtype=bool)
    keep[drop:] = True
    out = {"phases": {}, "pulse_edges": {}, "n_pulse_edges": int(pulse_edges(data).size),
           "edge_window_s": EDGE_WINDOW_S}
    for sig in ("acceleration", "force"):
        m, s = pairs[sig]
        r = (m - s)[keep]
        out["phases"][sig] = error_shares(labels[keep], r)
        if edges.any():
            e = edges[keep]
            out["pulse_edges"][sig] = {
                "time_share": float(e.mean()),
                "error_share": float(np.sum(r[e] ** 2) / np.sum(r ** 2)),
                "error_without_edge_windows_pct": rel_pct(m[keep][~e], s[keep][~e]),
                "rms_in_windows": float(np.sqrt(np.mean(r[e] ** 2))),
                "rms_elsewhere": float(np.sqrt(np.mean(r[~e] ** 2))),
            }
    m, s_ = pairs["force"]
    r = m - s_
    out["start_transient"] = {"samples": drop, "force_error_share": float(np.sum(r[:drop] ** 2) / np.sum(r ** 2)),
                              "force_error_from_sample_pct": rel_pct(m[drop:], s_[drop:])}
    if edges.any():
        out["edge_lag"] = edge_lag(data, sim)
    out["labels"] = labels
    return out


def edge_lag(data: Measurement, sim: Mapping[str, np.ndarray], max_ms: float = 2.0,
             step_ms: float = 0.05) -> dict:
    """How far the measured acceleration lags the simulated one after the pulse edges: the
    shift ``tau`` of the simulated acceleration (``a_sim(t - tau)``, linear interpolation) that
    minimises its error in the ``EDGE_WINDOW_S`` windows, searched over +-``max_ms``.
    Positive: the machine responds later than the model."""
    a_m, a_s = signal_pairs(data, sim)["acceleration"]
    mask = edge_mask(data)
    t = data.time_s
    taus = np.arange(-max_ms, max_ms + 1e-9, step_ms) * 1e-3
    errs = np.array([rel_pct(a_m[mask], np.interp(t - tau, t, a_s)[mask]) for tau in taus])
    k = int(np.argmin(errs))
    i0 = int(np.argmin(np.abs(taus)))
    shifted = np.interp(t - taus[k], t, a_s)
    return {"lag_ms": float(taus[k] * 1e3), "edge_acceleration_error_pct": float(errs[i0]),
            "edge_acceleration_error_at_lag_pct": float(errs[k]),
            "acceleration_error_at_lag_pct": rel_pct(a_m, shifted),
            "acceleration_error_pct": rel_pct(a_m, a_s),
            "peak_ratio": float(np.max(np.abs(a_m[mask])) / np.max(np.abs(a_s[mask])))}


def start_speed(data: Measurement, plant: Plant, ctrl: SampledPV, half: int = 20) -> dict:
    """The carriage speed the replay starts from (m/s) beside estimates from the first
    ``half + 1`` samples of the measured position: a straight line (the speed about
    ``half/2`` samples in, biased by the acceleration) and a quadratic (the speed at t = 0),
    and the measured acceleration there (m/s^2)."""
    from gearbench import layout as L
    t = data.time_s[:half + 1] - data.time_s[0]
    q = np.asarray(data.signals["motor_position_mm"][:half + 1], dtype=float) / 1000.0
    lin = np.polyfit(t, q, 1)
    quad = np.polyfit(t, q, 2)
    x = Replay(data, ctrl).initial_state(plant)
    return {"replay_m_per_s": float(x[L.X_WL] * plant.leadscrew.radius), "linear_fit_m_per_s": float(lin[0]),
            "quadratic_fit_m_per_s": float(quad[1]), "acceleration_m_per_s2": float(2 * quad[0]),
            "samples": half + 1}


def spring_as_force(plant: Plant, travel_m: Sequence[float]) -> dict | None:
    """A ``load_spring`` of ``plant`` as the force it puts on the carriage (N, positive
    forward) at the given travel positions (m from the record's start), or None."""
    e = next((e for e in plant.effects if e.name == "load_spring"), None)
    if e is None:
        return None
    r = plant.leadscrew.radius
    th0 = math.radians(float(e.values["rest_angle_deg"]))
    k = float(e.values["stiffness"])
    return {f"{x:g}": -k * (x / r - th0) / r for x in travel_m}


def compliance_plant(rigid: Plant, carriage_fraction: float, stiffness_N_per_m: float,
                     damping_Ns_per_m: float) -> Plant:
    """``rigid`` with its moving mass split by a spring-damper between motor and carriage.

    The rotor (what the encoder reads and the drive pushes) keeps ``1 - carriage_fraction``
    of the moving mass M, the carriage side (``shaft_compliance``'s pinion, on which the
    friction and offset act) the rest; M stays as it was.  Carriage units are turned into the
    plant's rotational ones with r = lead/2 pi (1 mm/rad: J = m 1e-6 kg m^2,
    k_rot = k r^2, d_rot = d r^2)."""
    r = _radius(rigid)
    m_total = moving_mass(rigid)
    j_total = m_total * r ** 2
    p = replace(rigid, motor=replace(rigid.motor, inertia=j_total),
                leadscrew=replace(rigid.leadscrew, mass=0.0), load=replace(rigid.load, inertia=0.0))
    return p.with_effects(AddedEffect("shaft_compliance", {
        "stiffness": float(stiffness_N_per_m) * r ** 2, "damping": float(damping_Ns_per_m) * r ** 2,
        "pinion_inertia": float(carriage_fraction) * j_total}))


def compliance_params(plant: Plant) -> dict:
    """The compliance of a :func:`compliance_plant` in carriage units, with its mode."""
    r = _radius(plant)
    e = next(e for e in plant.effects if e.name == "shaft_compliance")
    j_total = plant.motor_inertia_total
    m_c = e.values["pinion_inertia"] / r ** 2
    m_r = j_total / r ** 2 - m_c
    k = e.values["stiffness"] / r ** 2
    d = e.values["damping"] / r ** 2
    mu = m_r * m_c / (m_r + m_c)
    return {"stiffness_N_per_m": k, "damping_Ns_per_m": d, "rotor_mass_kg": m_r, "carriage_mass_kg": m_c,
            "total_mass_kg": m_r + m_c, "carriage_fraction": m_c / (m_r + m_c),
            "mode_hz": math.sqrt(k / mu) / (2 * math.pi), "damping_ratio": d / (2 * math.sqrt(k * mu))}


def _compliance_frees(plant: Plant) -> list[Free]:
    i = next(i for i, e in enumerate(plant.effects) if e.name == "shaft_compliance")
    total = plant.motor_inertia_total
    out = []
    for f in Free.effect(plant, i):
        v = get_value(plant, f)
        f = replace(f, scale=abs(v) or f.scale)
        if f.key == "pinion_inertia":
            f = replace(f, low=0.02 * total, high=0.98 * total)
        if f.key == "stiffness":
            f = replace(f, low=max(f.low, 1e-3 * v))
        out.append(f)
    return out


def fit_compliance(data: Measurement, rigid: Plant, ctrl: SampledPV,
                   grid_hz: Sequence[float] = (40.0, 80.0, 160.0, 320.0),
                   grid_fraction: Sequence[float] = (0.1, 0.3, 0.6), zeta: float = 0.1,
                   max_nfev: int = 60) -> dict:
    """Fit the compliance (stiffness, damping, mass split; M total and the friction fixed at
    ``rigid``'s) to ``data``'s force by bounded least squares, started from the best of a grid
    of modes (Hz) and carriage fractions at damping ratio ``zeta``.  Returns ``plant``,
    ``params`` (:func:`compliance_params`), ``grid`` (each start's force error), ``converged``,
    ``message``, ``nfev`` and ``seconds``."""
    t0 = time.perf_counter()
    m_total = moving_mass(rigid)
    grid = []
    best = None
    for fc in grid_fraction:
        mu = m_total * fc * (1 - fc)
        for hz in grid_hz:
            k = mu * (2 * math.pi * hz) ** 2
            p = compliance_plant(rigid, fc, k, 2 * zeta * math.sqrt(k * mu))
            try:
                err = score(p, data, ctrl)
            except (ReplayError, ValueError) as exc:
                grid.append({"mode_hz": hz, "carriage_fraction": fc, "force_error_pct": None,
                             "note": str(exc)[:200]})
                continue
            grid.append({"mode_hz": hz, "carriage_fraction": fc, "force_error_pct": err})
            if best is None or err < best[0]:
                best = (err, p)
    if best is None:
        raise ReplayError("no compliance start could be simulated")
    start = best[1]
    res = fit(Replay(data, ctrl), start, _compliance_frees(start), max_nfev=max_nfev)
    return {"plant": res.plant, "params": compliance_params(res.plant), "grid": grid,
            "grid_hz": list(grid_hz), "grid_fraction": list(grid_fraction), "grid_zeta": zeta,
            "start": compliance_params(start), "start_force_error_pct": best[0],
            "converged": res.converged, "message": res.message, "nfev": res.nfev,
            "seconds": time.perf_counter() - t0}


def compliance_test(runs: Runs, rigid: Plant, ctrl: SampledPV, fit_on: Sequence[str] = ("validation", "train"),
                    progress: Callable[[str], None] | None = None) -> dict:
    """Does a motor-carriage compliance lower the validation run's errors?

    The rigid model's errors on both runs, then for each run in ``fit_on`` the compliance
    fitted there (:func:`fit_compliance`) and its closed-loop errors (all four signals) and
    error shares after the pulse edges on both runs."""
    out = {"rigid": {}, "fits": {}}
    sims = {}
    for run in ("train", "validation"):
        sim = simulate(rigid, runs[run], ctrl)
        out["rigid"][run] = closed_loop_errors(runs[run], sim)
    for where in fit_on:
        if progress:
            progress(f"compliance fitted on {where}")
        f = fit_compliance(runs[where], rigid, ctrl)
        errs, edges = {}, {}
        for run in ("train", "validation"):
            sim = simulate(f["plant"], runs[run], ctrl)
            sims[(where, run)] = sim
            errs[run] = closed_loop_errors(runs[run], sim)
            if run == "validation":
                edges = where_it_fails(runs[run], sim)["pulse_edges"]
        out["grid"] = {"mode_hz": f["grid_hz"], "carriage_fraction": f["grid_fraction"], "zeta": f["grid_zeta"]}
        out["fits"][where] = {"params": f["params"], "start": f["start"],
                              "start_force_error_pct": f["start_force_error_pct"], "grid": f["grid"],
                              "converged": f["converged"], "message": f["message"], "nfev": f["nfev"],
                              "seconds": f["seconds"], "errors": errs, "validation_pulse_edges": edges,
                              "plant": f["plant"]}
    out["sims"] = sims
    return out


# ----------------------------------------------------------------------------- figures
def _zoom_figure(data: Measurement, series: Mapping[str, np.ndarray], measured: np.ndarray, name: str,
                 unit: str, window: tuple[float, float], title: str):
    """Measured and several simulated traces over ``window`` (s), pulse edges marked."""
    from matplotlib.figure import Figure
    t = data.time_s
    sel = (t >= window[0]) & (t <= window[1])
    fig = Figure(figsize=(10, 6), layout="constrained")
    top, bottom = fig.subplots(2, 1, sharex=True, gridspec_kw={"height_ratios": [2, 1]})
    top.plot(t[sel], measured[sel], color="k", lw=1.0, label="measured")
    for i, (label, y) in enumerate(series.items()):
        lw = 2.0 if i == 0 else 1.0        # the first (the rigid model) stays visible under the others
        top.plot(t[sel], y[sel], lw=lw, ls="--" if i == 0 else "-", color=f"C{i}", label=label)
        bottom.plot(t[sel], (measured - y)[sel], lw=lw * 0.8, ls="--" if i == 0 else "-", color=f"C{i}",
                    label=label)
    for i in pulse_edges(data):
        if window[0] <= t[i] <= window[1]:
            for ax in (top, bottom):
                ax.axvline(t[i], color="C3", lw=0.6, alpha=0.5)
    top.set_ylabel(f"{name} ({unit})")
    bottom.set_ylabel(f"residual ({unit})")
    bottom.set_xlabel("time (s); red lines: pulse edges")
    bottom.axhline(0.0, color="k", lw=0.5)
    top.legend(fontsize=8, loc="upper left")
    top.set_title(title)
    for ax in (top, bottom):
        ax.grid(alpha=0.3)
    return fig


def write_figures(out_dir: Path, runs: Runs, sims: Mapping[str, Mapping], labels: Mapping[str, np.ndarray],
                  ladders: Mapping[str, dict], compliance: dict | None) -> list[str]:
    """PNG figures of the study under ``out_dir``; returns their names."""
    names = []

    def save(fig, name):
        save_figure_atomic(fig, out_dir / name)
        names.append(name)

    for key, lad in ladders.items():
        steps = [{"effect": r["effect"], "error": r["train_force_error_pct"], "action": r.get("action", "add")}
                 for r in lad["rows"]]
        save(ladder_figure(steps, unit="% closed-loop force error, train",
                           title=f"EMPS ladder ({key})"), f"ladder_{key}.png")
    for run in ("train", "validation"):
        pairs = signal_pairs(runs[run], sims[run])
        for sig, unit in (("force", "N"), ("acceleration", "m/s^2")):
            m, s = pairs[sig]
            save(comparison_figure(runs[run].time_s, m, s, labels[run], sig, unit,
                                   f"EMPS {run}: {sig}, fitted rigid model (delay 0)"),
                 f"{run}_{sig}.png")
    val = runs.validation
    pairs = signal_pairs(val, sims["validation"])
    series_a = {"rigid": pairs["acceleration"][1]}
    series_f = {"rigid": pairs["force"][1]}
    if compliance is not None:
        for where, key in (("validation", "compliant (fit on validation)"),
                           ("train", "compliant (fit on train)")):
            if (where, "validation") in compliance["sims"]:
                cp = signal_pairs(val, compliance["sims"][(where, "validation")])
                series_a[key] = cp["acceleration"][1]
                series_f[key] = cp["force"][1]
    save(_zoom_figure(val, series_a, pairs["acceleration"][0], "acceleration", "m/s^2", ZOOM_S,
                      "EMPS validation: acceleration around pulse edges"), "validation_acceleration_zoom.png")
    save(_zoom_figure(val, series_a, pairs["acceleration"][0], "acceleration", "m/s^2", ZOOM_EDGE_S,
                      "EMPS validation: acceleration at one pulse edge"), "validation_acceleration_edge.png")
    save(_zoom_figure(val, series_f, pairs["force"][0], "force", "N", ZOOM_S,
                      "EMPS validation: force around pulse edges"), "validation_force_zoom.png")
    return names


# ----------------------------------------------------------------------------- the study
def _plain(x):
    """JSON-able copy: numpy to Python, plants and arrays dropped."""
    if isinstance(x, Mapping):
        return {str(k): _plain(v) for k, v in x.items()
                if not isinstance(v, (Plant, np.ndarray)) and k not in ("diagnosis", "sims", "labels", "plant")}
    if isinstance(x, (list, tuple)):
        return [_plain(v) for v in x]
    if isinstance(x, np.generic):
        return x.item()
    if isinstance(x, float) and not math.isfinite(x):
        return None
    return x


def study_delay(runs: Runs, delay: int, workers: int | None, log: Callable[[str], None]) -> dict:
    """Everything that depends on the controller's delay: the paper-structure ladder, the
    validation score, the paper's own parameters, the closed-loop errors per signal and the
    asymmetric fit."""
    ctrl = controller(delay)
    out: dict[str, Any] = {"delay_samples": delay}
    log(f"[delay {delay}] ladder with the paper's structure on train")
    lad = paper_ladder(runs, ctrl, workers=workers)
    out["ladder"] = lad
    fitted = lad["plant"]
    out["params"] = {k: lad["params"][k] for k in PAPER_PARAMS}
    t0 = time.perf_counter()
    sims = {run: simulate(fitted, runs[run], ctrl) for run in ("train", "validation")}
    out["simulation_seconds"] = {"both runs": time.perf_counter() - t0}
    out["sims"] = sims
    out["closed_loop"] = {run: closed_loop_errors(runs[run], sims[run]) for run in sims}
    out["closed_loop_from_49"] = {run: closed_loop_errors(runs[run], sims[run], drop=idim.N_DROP)
                                  for run in sims}
    out["train_force_error_pct"] = out["closed_loop"]["train"]["force"]
    out["validation_force_error_pct"] = out["closed_loop"]["validation"]["force"]
    paper = rigid_plant(PAPER_PARAMS)
    psims = {run: simulate(paper, runs[run], ctrl) for run in ("train", "validation")}
    out["paper_params_closed_loop"] = {run: closed_loop_errors(runs[run], psims[run]) for run in psims}
    out["paper_params_closed_loop_from_49"] = {run: closed_loop_errors(runs[run], psims[run], drop=idim.N_DROP)
                                               for run in psims}
    log(f"[delay {delay}] asymmetric friction on train")
    out["asymmetric"] = fit_asymmetric(runs, ctrl, out["params"])
    out["asymmetric"]["closed_loop"] = {
        run: closed_loop_errors(runs[run], simulate(out["asymmetric"]["plant"], runs[run], ctrl))
        for run in ("train", "validation")}
    return out


def run_study(results: str | Path, data_dir: str | Path | None = None, workers: int | None = None,
              library: bool = True, compliance: bool = True, delays: Sequence[int] = (0, 1),
              log: Callable[[str], None] | None = None) -> dict:
    """Run the whole study and write ``results/emps.md``, ``results/emps.json`` and
    ``results/emps/*.png``.  Returns the JSON object."""
    log = log or (lambda s: click.echo(s, err=True))
    t_start = time.perf_counter()
    results = Path(results)
    runs = load_runs(data_dir)
    timings = {}
    by_delay = {}
    for d in delays:
        t0 = time.perf_counter()
        by_delay[d] = study_delay(runs, d, workers, log)
        timings[f"delay_{d}_s"] = time.perf_counter() - t0
    main_d = by_delay[delays[0]]
    ctrl = controller(delays[0])

    lib = None
    if library:
        log("ladder over the whole effect library on train (slow)")
        t0 = time.perf_counter()
        lib = run_ladder(runs, ctrl, only=(), workers=workers,
                         progress=lambda e: e.done and log(f"  step {e.step}, {e.stage} {e.done}/{e.total}: "
                                                           f"{e.label} (best so far: {e.best or 'none'})"))
        lib["validation_force_error_pct"] = score(lib["plant"], runs.validation, ctrl)
        timings["library_ladder_s"] = time.perf_counter() - t0

    log("IDIM-LS")
    idm = idim_results(runs)

    log("where the validation run fails")
    labels = {}
    fails = {}
    for run in ("train", "validation"):
        w = where_it_fails(runs[run], main_d["sims"][run])
        labels[run] = w.pop("labels")
        fails[run] = w

    starts = {run: start_speed(runs[run], main_d["ladder"]["plant"], ctrl) for run in ("train", "validation")}
    if lib is not None:
        q = np.asarray(runs.train.signals["motor_position_mm"], dtype=float) / 1000.0
        lib["spring_force_N"] = spring_as_force(lib["plant"], (float(q.min()), float(q.max())))

    comp = None
    if compliance:
        t0 = time.perf_counter()
        comp = compliance_test(runs, main_d["ladder"]["plant"], ctrl, progress=log)
        comp["verdict"] = compliance_verdict(comp, comp["rigid"]["validation"])
        timings["compliance_s"] = time.perf_counter() - t0
        for d in delays[1:]:
            c1 = controller(d)
            comp[f"delay_{d}"] = {where: {run: closed_loop_errors(runs[run], simulate(f["plant"], runs[run], c1))
                                          for run in ("train", "validation")}
                                  for where, f in comp["fits"].items()}
            comp[f"delay_{d}"]["rigid"] = {run: by_delay[d]["closed_loop"][run] for run in ("train", "validation")}

    log("figures")
    fig_dir = results / "emps"
    ladders = {"paper_structure": main_d["ladder"]}
    if lib is not None:
        ladders["whole_library"] = lib
    figures = write_figures(fig_dir, runs, main_d["sims"], labels, ladders, comp)
    timings["total_s"] = time.perf_counter() - t_start

    summary = build_summary(runs, by_delay, delays, lib, idm, fails, comp, figures, timings)
    summary["start_speed"] = _plain(starts)
    summary["carriage_force_negative_left_out"] = carriage_force_negative_left_out()
    old = results / "emps.json"
    if lib is None and old.is_file():
        # a run without the whole-library ladder (--no-library) keeps the last one's
        earlier = json.loads(old.read_text()).get("library_ladder")
        if earlier is not None:
            summary["library_ladder"] = dict(earlier, from_earlier_run=True)
    results.mkdir(parents=True, exist_ok=True)
    write_text_atomic(results / "emps.json", json.dumps(summary, indent=2) + "\n")
    write_text_atomic(results / "emps.md", markdown(summary))
    return summary


def _delay_json(d: dict) -> dict:
    lad = d["ladder"]
    return {
        "delay_samples": d["delay_samples"],
        "ladder": [{"effect": r["effect"], "action": r.get("action", "add"), "train_force_error_pct": r["train_force_error_pct"],
                    "rms_force_error_N": r["rms_force_error_N"], "params": r["params"],
                    "step_stderr": r["step_stderr"], "bic": r["bic"]} for r in lad["rows"]],
        "ladder_candidates_first_step": lad["candidates"],
        "ladder_reason": lad["reason"],
        "ladder_seconds": lad["seconds"],
        "train_force_error_pct": d["train_force_error_pct"],
        "validation_force_error_pct": d["validation_force_error_pct"],
        "params": d["params"],
        "stderr": lad["stderr"],
        "params_vs_paper": lad["comparison"],
        "params_within_5pct": all(r["within_tolerance"] for r in lad["comparison"]),
        "closed_loop_errors_pct": d["closed_loop"],
        "closed_loop_errors_from_sample_49_pct": d["closed_loop_from_49"],
        "paper_params_closed_loop_errors_pct": d["paper_params_closed_loop"],
        "paper_params_closed_loop_errors_from_sample_49_pct": d["paper_params_closed_loop_from_49"],
        "asymmetric": {k: v for k, v in d["asymmetric"].items() if k != "plant"},
    }


def build_summary(runs: Runs, by_delay: dict, delays: Sequence[int], lib: dict | None, idm: dict,
                  fails: dict, comp: dict | None, figures: list[str], timings: dict) -> dict:
    main_d = _delay_json(by_delay[delays[0]])
    out = {
        "benchmark": "EMPS",
        "citation": EMPS_CITATION,
        "command": COMMAND,
        "data_files": {k: _repo_relative(v) for k, v in runs.files.items()},
        "delay_samples": delays[0],
        "error_measure": "100 ||y - y_sim|| / ||y|| over the whole record (closed-loop replay driven by "
                         "the recorded set point and pulses), unless a table says from sample 49",
        "derivatives": "velocity and acceleration of measured and simulated motor position alike: "
                       "4th-order Butterworth 100 Hz, MATLAB-style filtfilt, central differences twice",
        **main_d,
        "paper": {"params": PAPER_PARAMS, "asymmetric": PAPER_ASYMMETRIC, "idim": PAPER_IDIM,
                  "closed_loop_errors_pct": PAPER_CLOSED_LOOP},
        "by_delay": {str(d): _delay_json(by_delay[d]) for d in delays},
        "idim": _plain(idm),
        "where_it_fails": _plain(fails),
        "figures": [f"emps/{f}" for f in figures],
        "timings_s": timings,
    }
    if lib is not None:
        out["library_ladder"] = {
            "ladder": [{"effect": r["effect"], "action": r.get("action", "add"), "options": r["options"],
                        "train_force_error_pct": r["train_force_error_pct"], "params": r["params"],
                        "step_params": r["step_params"], "bic": r["bic"]} for r in lib["rows"]],
            "candidates_first_step": lib["candidates"], "verdict": lib["verdict"],
            "reason": lib["reason"], "seconds": lib["seconds"],
            "validation_force_error_pct": lib["validation_force_error_pct"],
            "spring_force_N": lib.get("spring_force_N"), "not_tried": lib["not_tried"],
        }
    if comp is not None:
        out["compliance"] = _plain({k: v for k, v in comp.items() if k != "sims"})
    return _plain(out)


# ----------------------------------------------------------------------------- Markdown
def _f(v, nd=3):
    if v is None:
        return "–"
    if isinstance(v, bool):
        return "yes" if v else "no"
    return f"{v:.{nd}g}" if abs(v) < 1e-2 or abs(v) >= 1e4 else f"{v:.{nd}f}"


def _pct(v, nd=2):
    return "–" if v is None else f"{v:.{nd}f} %"


def markdown(s: dict) -> str:
    """The report, from :func:`build_summary`'s object."""
    L = []
    d0 = s["by_delay"][str(s["delay_samples"])]
    other = [k for k in s["by_delay"] if k != str(s["delay_samples"])]
    L += ["# EMPS: closed-loop identification of a real ball-screw axis", "",
          f"Data and reference models: {s['citation']}.  The data are the benchmark's own measurements "
          "(not shipped with gearbench).", "",
          f"Made by `{s['command']}` (data: {', '.join(Path(v).name for v in s['data_files'].values())}); "
          f"total time {s['timings_s']['total_s']:.0f} s on this machine.", "",
          "Error measure: " + s["error_measure"] + ".  " +
          f"Controller delay: `delay_samples: {s['delay_samples']}` unless a table says otherwise "
          "(0 = what the data show, the recorded vir is the control law at the same sample; "
          "1 = the authors' Simulink model).", ""]

    # 1. ladder
    L += ["## 1. Ladder from the bare plant (training run, paper structure)", "",
          "`diagnose(bare, Replay(train, controller), free_plant=('leadscrew.mass',), "
          "only=('viscous_friction', 'coulomb_friction', 'bias_torque'))`: each step adds the best "
          "effect and refits it with the mass and every earlier effect.", ""]
    hdr = "| step | " + " | ".join(f"force error, delay {k}" for k in s["by_delay"]) + f" | M (kg, delay {s['delay_samples']}) | Fv (N s/m) | Fc (N) | offset (N) |"
    L += [hdr, "|" + "---|" * (5 + len(s["by_delay"]))]
    for i, r in enumerate(d0["ladder"]):
        errs = " | ".join(_pct(s["by_delay"][k]["ladder"][i]["train_force_error_pct"])
                          if i < len(s["by_delay"][k]["ladder"]) else "–" for k in s["by_delay"])
        p = r["params"]
        L.append(f"| {'bare (mass)' if i == 0 else '+ ' + r['effect']} | {errs} | {_f(p.get('mass_kg'), 5)} | "
                 f"{_f(p.get('viscous_Ns_per_m'), 5)} | {_f(p.get('coulomb_N'), 4)} | {_f(p.get('offset_N'), 3)} |")
    L += ["", f"Order chosen: {' → '.join(r['effect'] for r in d0['ladder'][1:])}.  The ladder stops: {d0['ladder_reason']}.  "
          f"It took {d0['ladder_seconds']:.0f} s.", ""]
    L += ["Fitted parameters (last rung, delay "
          f"{s['delay_samples']}) beside the paper's IDIM-LS values.  Standard errors: "
          "the sandwich `H⁻¹ΩH⁻¹` of the noise-weighted force residual (prewhitened Newey-West Ω, "
          "gearbench.identify.uncertainty), valid for the closed-loop residual's correlation in time.", "",
          "| parameter | fitted | ± std. error | paper | difference | within 5 % |", "|---|---|---|---|---|---|"]
    for r in d0["params_vs_paper"]:
        L.append(f"| {r['name']} | {_f(r['fitted'], 5)} | {_f(r['stderr'], 2)} | {r['paper']} | "
                 f"{r['rel_diff_pct']:+.2f} % | {_f(r['within_tolerance'])} |")
    for k in other:
        dk = s["by_delay"][k]
        L += ["", f"With `delay_samples: {k}`: " + ", ".join(
            f"{r['name']} {_f(r['fitted'], 5)} ({r['rel_diff_pct']:+.2f} %)" for r in dk["params_vs_paper"]) +
            f"; all within 5 %: {_f(dk['params_within_5pct'])}."]
    ok = d0["params_within_5pct"]
    L += ["", ("All four parameters are within 5 % of the paper's." if ok else
               "**Not all parameters are within 5 % of the paper's** (see the table).") +
          " The paper's values come from inverse dynamics (IDIM-LS, filtered and decimated "
          "derivatives); these come from the closed-loop force error of a simulation, a different "
          "estimator (output error on the controller's output), so small differences are expected.", ""]
    L.append("First-step candidates (paper structure): " + "; ".join(
        f"{c['effect']} {_pct(c['train_force_error_pct'])}" for c in d0["ladder_candidates_first_step"]) + ".")
    L.append("")
    if "library_ladder" in s:
        lib = s["library_ladder"]
        L += ["### The same ladder over the whole effect library", "",
              "`diagnose(...)` with no `only`: every effect that can act on this plant and record."
              + (" Kept from an earlier run with the whole library (this run skipped it; "
                 f"`{COMMAND}` recomputes it)." if lib.get("from_earlier_run") else ""), "",
              "| step | train force error | parameters of the step |", "|---|---|---|"]
        for i, r in enumerate(lib["ladder"]):
            sp = ", ".join(f"{k} {_f(v, 4)}" for k, v in r["step_params"].items())
            L.append(f"| {'bare (mass)' if i == 0 else '+ ' + r['effect']} | {_pct(r['train_force_error_pct'])} | "
                     f"{sp if i else 'M ' + _f(r['params']['mass_kg'], 5)} |")
        last = lib["ladder"][-1]
        L += ["", "Final model: " + ", ".join(f"{k} {_f(v, 5)}" for k, v in last["params"].items()) +
              f"; validation force error {_pct(lib['validation_force_error_pct'])}.  Stops: {lib['reason']}.  "
              f"Took {lib['seconds']:.0f} s.", "",
              "First-step candidates: " + "; ".join(
                  f"{c['effect']} {_pct(c['train_force_error_pct'])}" for c in lib["candidates_first_step"]) + ".", ""]
        if lib.get("not_tried"):
            L += ["Not tried (they cannot act on this plant and record):", ""]
            L += [f"- `{name}`: {why}." for name, why in lib["not_tried"].items()] + [""]
        first = lib["ladder"][1]["effect"] if len(lib["ladder"]) > 1 else None
        if first and first != d0["ladder"][1]["effect"]:
            L += [f"**Finding:** unaided, the ladder starts with `{first}` rather than "
                  f"`{d0['ladder'][1]['effect']}`; see the numbers above.", ""]
        stri = next((c for c in lib["candidates_first_step"] if c["effect"].startswith("stribeck")), None)
        coul = next((c for c in lib["candidates_first_step"] if c["effect"].startswith("coulomb")), None)
        if stri and coul and stri["train_force_error_pct"] is not None:
            sp = stri["params"]
            L += [f"**Finding (Stribeck):** on the first step Stribeck friction fits to "
                  f"{_pct(stri['train_force_error_pct'], 3)} against Coulomb's {_pct(coul['train_force_error_pct'], 3)}, "
                  f"with static force {_f(sp.get('static_force'), 3)} N, Coulomb force {_f(sp.get('coulomb_force'), 4)} N, "
                  f"Stribeck speed {_f(sp.get('stribeck_speed_m_s'), 3)} m/s: "
                  + ("its breakaway is not above the sliding level by 1 % of it, i.e. it reduces to Coulomb "
                     "friction, and the BIC charges its two extra parameters, so Coulomb wins: the data show no "
                     "breakaway peak."
                     if (sp.get('static_force') or 0) <= 1.01 * (sp.get('coulomb_force') or 0) else
                     "a breakaway above the sliding level; the BIC decides between them.")
                  + f" (BIC {stri['bic']:.1f} vs {coul['bic']:.1f}.)", ""]
        sf = lib.get("spring_force_N")
        if sf:
            (x0, f0), (x1, f1) = list(sf.items())[0], list(sf.items())[-1]
            L += [f"**Finding (load spring):** the library's last rung is a `load_spring` relaxed far outside the "
                  f"travel; on the carriage it is a forward force of {f0:.2f} N at {float(x0) * 1000:.0f} mm and "
                  f"{f1:.2f} N at {float(x1) * 1000:.0f} mm: it plays the paper's offset ({PAPER_PARAMS['offset_N']} N, "
                  "a forward push of 3.16 N) with a slight dependence on position, which buys a hair more than a "
                  "constant force; the constant force is then collinear with it and is rejected.", ""]

    # 2. validation
    L += ["## 2. Validation (pulses run)", "",
          "| model | delay | train force error | validation force error | paper (validation) |",
          "|---|---|---|---|---|"]
    for k, dk in s["by_delay"].items():
        L.append(f"| fitted on train (paper structure) | {k} | {_pct(dk['train_force_error_pct'])} | "
                 f"{_pct(dk['validation_force_error_pct'])} | 8.94 % |")
        pp = dk["paper_params_closed_loop_errors_pct"]
        L.append(f"| paper's parameters | {k} | {_pct(pp['train']['force'])} | {_pct(pp['validation']['force'])} | 8.94 % |")
    v = d0["validation_force_error_pct"]
    L += ["", f"With the default delay the fitted model's validation force error is {_pct(v)}: "
          f"{'at or below' if v <= 8.94 else 'above'} the paper's 8.94 %.", ""]

    # 3. asymmetric + IDIM
    L += ["## 3. Asymmetric friction; inverse dynamics", "",
          "Fv+/Fv−, Fc+/Fc− and the mass fitted on train by closed-loop force error (no offset: an "
          "offset is collinear with the asymmetric Coulomb pair).", "",
          "| model | delay | train force error | validation force error | M | Fv+ | Fv− | Fc+ | Fc− |",
          "|---|---|---|---|---|---|---|---|---|"]
    for k, dk in s["by_delay"].items():
        a = dk["asymmetric"]
        p = a["params"]
        L.append(f"| symmetric (+offset) | {k} | {_pct(dk['train_force_error_pct'])} | "
                 f"{_pct(dk['validation_force_error_pct'])} | {_f(dk['params']['mass_kg'], 5)} | "
                 f"{_f(dk['params']['viscous_Ns_per_m'], 5)} | = | {_f(dk['params']['coulomb_N'], 4)} | = |")
        L.append(f"| asymmetric | {k} | {_pct(a['train_force_error_pct'])} | {_pct(a['validation_force_error_pct'])} | "
                 f"{_f(p['mass_kg'], 5)} | {_f(p.get('viscous_pos_Ns_per_m'), 5)} | {_f(p.get('viscous_neg_Ns_per_m'), 5)} | "
                 f"{_f(p.get('coulomb_pos_N'), 4)} | {_f(p.get('coulomb_neg_N'), 4)} |")
    pa = s["paper"]["asymmetric"]
    L.append(f"| paper, asymmetric (IDIM-LS) | – | – | – | {pa['mass_kg']} | {pa['viscous_pos_Ns_per_m']} | "
             f"{pa['viscous_neg_Ns_per_m']} | {pa['coulomb_pos_N']} | {pa['coulomb_neg_N']} |")
    idm = s["idim"]
    L += ["", "Inverse dynamics (IDIM-LS, `gearbench/measure/idim.py`) on the same records:", "",
          "| IDIM-LS | train | cross-test (pulses) | paper train | paper cross-test |", "|---|---|---|---|---|",
          f"| symmetric | {_pct(idm['symmetric']['train_pct'], 4)} | {_pct(idm['symmetric']['cross_test_pct'], 4)} | 4.0834 % | 5.9824 % |",
          f"| asymmetric | {_pct(idm['asymmetric']['train_pct'], 4)} | {_pct(idm['asymmetric']['cross_test_pct'], 4)} | 3.1117 % | – |",
          "", "IDIM-LS ladder (one effect per row): " + "; ".join(
              f"{r['model']} {_pct(r['train_rel_error_pct'])} / {_pct(r['test_rel_error_pct'])}" for r in idm["ladder"]) +
          " (train / cross-test).", ""]

    # 4. closed-loop per signal
    L += ["## 4. Closed-loop simulation errors per signal", "",
          s["derivatives"] + ".  Position is the motor encoder from the record's start.  Whole record:", "",
          "| run | model | delay | position | velocity | acceleration | force |", "|---|---|---|---|---|---|---|"]

    def rows(key_fitted, key_paper, with_asym):
        out = []
        for run in ("train", "validation"):
            for k, dk in s["by_delay"].items():
                models = [("fitted (paper structure)", dk[key_fitted][run]),
                          ("paper's parameters", dk[key_paper][run])]
                if with_asym:
                    models.append(("asymmetric", dk["asymmetric"]["closed_loop"][run]))
                for label, errs in models:
                    out.append(f"| {run} | {label} | {k} | " + " | ".join(
                        _pct(errs[x], 4 if x == "position" else 3) for x in SIGNALS) + " |")
            pc = s["paper"]["closed_loop_errors_pct"][run]
            out.append(f"| {run} | **paper (Simulink)** | 1 | " + " | ".join(f"{pc[x]} %" for x in SIGNALS) + " |")
        return out

    L += rows("closed_loop_errors_pct", "paper_params_closed_loop_errors_pct", True)
    L += ["", "The same from sample 49 on (the IDIM scripts' cut; the replay's start transient left out):", "",
          "| run | model | delay | position | velocity | acceleration | force |", "|---|---|---|---|---|---|---|"]
    L += rows("closed_loop_errors_from_sample_49_pct", "paper_params_closed_loop_errors_from_sample_49_pct", False)
    st = s["where_it_fails"]["train"]["start_transient"]
    L += ["", f"The first {st['samples']} samples (49 ms) hold {100 * st['force_error_share']:.0f} % of the training "
          "run's squared force residual (fitted model, delay "
          f"{s['delay_samples']}): the records start in motion and accelerating, and the replay's initial state "
          "comes from the first samples (see the note at the end).", ""]

    # 5. where it fails
    wf = s["where_it_fails"]
    L += ["## 5. Where the validation run fails", "",
          "Residual shares by motion phase (fitted model, default delay; phases from the measured "
          "position by `classify_phases`):", "",
          "| run | signal | " + " | ".join(PHASES) + " |", "|---|---|" + "---|" * len(PHASES)]
    for run in ("train", "validation"):
        for sig in ("acceleration", "force"):
            sh = wf[run]["phases"][sig]
            L.append(f"| {run} | {sig} | " + " | ".join(
                f"{100 * sh[p]['error_share']:.0f} % of error / {100 * sh[p]['time_share']:.0f} % of time"
                for p in PHASES) + " |")
    pe = wf["validation"]["pulse_edges"]
    L += ["", f"The validation run has {wf['validation']['n_pulse_edges']} pulse edges.  In the "
          f"{1000 * wf['validation']['edge_window_s']:.0f} ms after them:", "",
          "| signal | time share | share of squared error | RMS in windows | RMS elsewhere | error without the windows |",
          "|---|---|---|---|---|---|"]
    for sig, unit in (("acceleration", "m/s²"), ("force", "N")):
        e = pe[sig]
        L.append(f"| {sig} | {100 * e['time_share']:.1f} % | {100 * e['error_share']:.1f} % | "
                 f"{_f(e['rms_in_windows'])} {unit} | {_f(e['rms_elsewhere'])} {unit} | "
                 f"{_pct(e['error_without_edge_windows_pct'])} |")
    lag = wf["validation"].get("edge_lag")
    if lag:
        L += ["", f"Shape of the failure: shifting the simulated acceleration by {lag['lag_ms']:+.2f} ms (positive: the "
              f"machine responds later than the model) takes its error in the edge windows from "
              f"{_pct(lag['edge_acceleration_error_pct'])} to {_pct(lag['edge_acceleration_error_at_lag_pct'])} "
              f"(whole record {_pct(lag['acceleration_error_pct'])} → {_pct(lag['acceleration_error_at_lag_pct'])}); "
              f"the measured peak acceleration in those windows is {lag['peak_ratio']:.3f}× the simulated one."]
    L += ["", "Figures: " + ", ".join(f"`{f}`" for f in s["figures"]) + ".", ""]
    if "compliance" in s:
        c = s["compliance"]
        L += ["### Does a motor–carriage compliance explain it?", "",
              "The rigid model's moving mass M is split: the rotor keeps part of it (motor.inertia, "
              "J = m·1e-6 kg m² with lead 2π mm), `shaft_compliance` joins it to the carriage side "
              "(pinion_inertia = the carriage part, where the friction and offset act); M total and the "
              "friction are those fitted on train; stiffness, damping and split are fitted (bounded "
              "least squares on the closed-loop force, from the best of a grid of modes "
              f"{'/'.join(f'{h:g}' for h in c['grid']['mode_hz'])} Hz × carriage fractions "
              f"{'/'.join(f'{x:g}' for x in c['grid']['carriage_fraction'])} at ζ = {c['grid']['zeta']:g}).", "",
              "| model | fitted on | mode | ζ | carriage part | train force | train acc. | validation force | validation acc. | validation acc. share after edges |",
              "|---|---|---|---|---|---|---|---|---|---|"]
        r = c["rigid"]
        L.append(f"| rigid | train | – | – | – | {_pct(r['train']['force'])} | {_pct(r['train']['acceleration'])} | "
                 f"{_pct(r['validation']['force'])} | {_pct(r['validation']['acceleration'])} | "
                 f"{100 * pe['acceleration']['error_share']:.1f} % |")
        for where, f in c["fits"].items():
            p, e = f["params"], f["errors"]
            L.append(f"| compliant | {where} | {p['mode_hz']:.1f} Hz | {p['damping_ratio']:.3f} | "
                     f"{p['carriage_mass_kg']:.1f} kg | {_pct(e['train']['force'])} | {_pct(e['train']['acceleration'])} | "
                     f"{_pct(e['validation']['force'])} | {_pct(e['validation']['acceleration'])} | "
                     f"{100 * f['validation_pulse_edges']['acceleration']['error_share']:.1f} % |")
        for k in [k for k in c if k.startswith("delay_")]:
            ck = c[k]
            L.append("")
            L.append(f"With `{k.replace('_', ': ')}` (same fitted parameters): rigid validation force / acc. "
                     f"{_pct(ck['rigid']['validation']['force'])} / {_pct(ck['rigid']['validation']['acceleration'])}; " +
                     "; ".join(f"compliant (fit on {w}) {_pct(ck[w]['validation']['force'])} / "
                               f"{_pct(ck[w]['validation']['acceleration'])}" for w in c["fits"]) + ".")
        L += ["", "Fitted compliances (carriage units): " + "; ".join(
            f"on {w}: k = {_f(f['params']['stiffness_N_per_m'], 4)} N/m, d = {_f(f['params']['damping_Ns_per_m'], 4)} N s/m, "
            f"rotor {f['params']['rotor_mass_kg']:.1f} kg + carriage {f['params']['carriage_mass_kg']:.1f} kg "
            f"({f['nfev']} evaluations, {f['seconds']:.0f} s, {f['message']})" for w, f in c["fits"].items()) + ".", ""]
        if c.get("verdict"):
            L += [c["verdict"], ""]

    # 6. delays, timings
    L += ["## 6. Controller delay", "",
          "Both settings are in the tables above (`delay` column).  " +
          "; ".join(f"delay {k}: train {_pct(dk['train_force_error_pct'])}, validation "
                    f"{_pct(dk['validation_force_error_pct'])}" for k, dk in s["by_delay"].items()) + ".", "",
          "## Timings", "", ", ".join(f"{k} {v:.1f} s" for k, v in s["timings_s"].items()) + ".", ""]
    # notes
    notes = ["## Notes on the code used", ""]
    st = s.get("start_speed", {}).get("train")
    if st:
        notes += [f"- **Replay start state** (`gearbench/identify/replay.py`, `Replay.initial_state`): the records start "
                  f"in motion and accelerating ({st['acceleration_m_per_s2']:.2f} m/s² on train).  The replay starts the "
                  f"model at {1000 * st['replay_m_per_s']:.2f} mm/s; a straight line through the first {st['samples']} "
                  f"samples gives {1000 * st['linear_fit_m_per_s']:.2f} mm/s (the speed ~10 ms in), a quadratic "
                  f"{1000 * st['quadratic_fit_m_per_s']:.2f} mm/s (the speed at t = 0).  " +
                  ("The replay's start is too fast: the controller brakes for the first tens of ms, which is the "
                   "large early residual (section 4); a quadratic fit there (`local_fit(..., degree=2)`) removes it."
                   if abs(st["replay_m_per_s"] - st["quadratic_fit_m_per_s"]) > 0.2 * abs(st["quadratic_fit_m_per_s"])
                   else "The replay's start speed agrees with the quadratic estimate.")]
    if s.get("carriage_force_negative_left_out"):
        notes += ["- **Asymmetric Coulomb friction at the carriage** (`gearbench/plant/effects/base.py`, "
                  "`Effect.fit_params`): an optional parameter counts as given only under its rotational name "
                  "(`torque_negative`), so `Free.effect` leaves a carriage `force_negative` out of a fit.  This "
                  "study adds it itself (`frees_of`)."]
    notes.append("")
    L += notes

    return "\n".join(L)


def compliance_verdict(comp: dict, rigid_val: Mapping[str, float]) -> str:
    """One sentence: did the compliance lower the validation errors, with numbers."""
    parts = []
    for where, f in comp["fits"].items():
        e = f["errors"]["validation"]
        da = e["acceleration"] - rigid_val["acceleration"]
        dfo = e["force"] - rigid_val["force"]
        parts.append(f"fitted on {where}: validation acceleration {rigid_val['acceleration']:.2f} → "
                     f"{e['acceleration']:.2f} % ({da:+.2f} pt), force {rigid_val['force']:.2f} → "
                     f"{e['force']:.2f} % ({dfo:+.2f} pt)")
    return "**Compliance test:** " + "; ".join(parts) + "."


def _repo_relative(path: Path) -> str:
    """``path`` relative to the repository when it is inside it (results name no machine's folders)."""
    try:
        return str(Path(path).resolve().relative_to(REPO))
    except ValueError:
        return str(path)


@click.command(context_settings={"help_option_names": ["-h", "--help"]})
@click.option("--results", "results_dir", type=click.Path(file_okay=False, path_type=Path),
              default=Path("results"), show_default=True, help="Output folder.")
@click.option("--data-dir", type=click.Path(file_okay=False, path_type=Path), default=DEFAULT_DATA_DIR,
              show_default=True, help="Folder holding DATA_EMPS.mat and DATA_EMPS_PULSES.mat.")
@click.option("--workers", type=click.IntRange(min=1), default=None,
              help="Processes for diagnose (default: all cores).")
@click.option("--no-library", is_flag=True, help="Skip the (slow) whole-library ladder.")
@click.option("--no-compliance", is_flag=True, help="Skip the compliance test.")
def main(results_dir: Path, data_dir: Path, workers: int | None, no_library: bool, no_compliance: bool) -> None:
    """The EMPS study: gearbench's closed-loop identification on real data, beside the published numbers.

    Writes RESULTS/emps.md, RESULTS/emps.json and the figures under RESULTS/emps/.
    """
    try:
        data_files(data_dir)
    except FileNotFoundError as exc:
        raise click.UsageError(str(exc)) from None
    s = run_study(results_dir, data_dir, workers=workers, library=not no_library,
                  compliance=not no_compliance)
    click.echo(f"wrote {results_dir / 'emps.md'}, {results_dir / 'emps.json'} and "
               f"{len(s['figures'])} figures: train {s['train_force_error_pct']:.2f} %, validation "
               f"{s['validation_force_error_pct']:.2f} %")


if __name__ == "__main__":
    main()
