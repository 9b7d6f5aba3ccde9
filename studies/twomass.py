"""The two-mass study: a real motor bench with a flexible coupling, from the bare plant, against the bench's floor.

Data: the FdiTools two-mass bench (HoriFujimotoLab/FdiTools, MIT; T. Beauduin and W. Ohnishi),
two multisine records at 2.5 kHz in ``data/twomass/`` (provenance, licence and citation in its
README; ``TWOMASS_CITATION``).  Run from the repository's root (``make run`` does)::

    python -m studies.twomass --results results [--data-dir PATH]

It writes ``results/twomass.md``, ``results/twomass.json`` and PNG figures under
``results/twomass/`` (atomically).  What it does, in the order of the report:

1. **The record's own FRF** (``record_frf``): the multisine is periodic (1 s), so the spectra of
   the input (the measured current, ``drive_torque_Nm`` with a lumped 1 N m/A) and of each angle
   are averaged over the periods after the first (the source's transient), and their ratio at
   the excited lines is the FRF, with its standard error from the spread over the periods.  The
   motor side's anti-resonance and resonance are the dip and the peak of ``|H| w^2`` (the FRF to
   the motor's acceleration) on record A's 1 Hz grid (``frf_features``); they are set beside
   the source's, read off its figure (``SOURCE``).
2. **Diagnosis** (``diagnosis``): from the bare plant (``experiments/plants/twomass_bare.yaml``:
   one rigid inertia, torque-driven), ``diagnose`` climbs its ladder on one period of record A
   (``FIT_SLICE_S``), the rotor's inertia refitted with every candidate, among the effects this
   bench can have (``CANDIDATES``: no gear, so no backlash; no voltage, so no dead zone).  The
   replay cuts the record into windows of ``WINDOW_S`` and, at each seam, sets the model's angles
   and speeds to the measured ones (``Replay(reset_speeds=True)``): the multisine excites nothing
   below 11 Hz, where the machine wanders on its friction, and a window's speed error would
   otherwise drift its angles by far more than the coupling moves them.
3. **The coupling stated** (``stated_coupling``): diagnose's final model with a
   ``shaft_compliance`` whose start comes from the record's FRF (for two masses
   ``w_ar = sqrt(k/J_L)``, ``w_r = sqrt(k (J_M + J_L)/(J_M J_L))``, ``J_M`` from the FRF above
   the resonance), everything refitted (``fit``).
4. **The bench's own floor** (``bench_floor``, ``period_errors``): what no model driven by the
   record's input gets under, from above, from how closely the periods come to each other
   (``period_spread``: free-running, and started at each window's angle) and what the replay costs
   a model that is exactly right (``replay_cost``: the encoders' noise, the speeds its restarts read);
   and diagnose's final model's error on every period of record A under the study's replay, split
   into the part that repeats each period and the part that does not, and run free from each
   period's start on both records.
5. For each model: its error on the fit slice and on one period of record B (validation), its
   linear FRF (coupling, inertias and viscous terms; Coulomb friction and constant torques left
   out) and that FRF's anti-resonance and resonance beside the record's and the source's.

Nothing here is tuned to an outcome: whatever the ladder takes, and whatever resonance each
model has, is what the report says.
"""
from __future__ import annotations

import json
import math
import time
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path

import click
import numpy as np

from gearbench.experiment.files import load_plant
from gearbench.identify.diagnose import diagnose
from gearbench.identify.fit import Free, fit
from gearbench.identify.replay import Replay, seam_speed
from gearbench.identify.scoring import Scorer
from gearbench.measure.data import Measurement, from_arrays, read_measurement
from gearbench.plant.components import Plant
from gearbench.plant.effects import AddedEffect
from gearbench.report.io import save_figure_atomic, write_text_atomic
from studies.emps import plant_from_model

REPO = Path(__file__).resolve().parents[1]
DEFAULT_DATA_DIR = REPO / "data" / "twomass"
RECORD_FILES = {"A": "twomass_A.csv", "B": "twomass_B.csv"}
BARE_PLANT = REPO / "experiments" / "plants" / "twomass_bare.yaml"
COMMAND = "python -m studies.twomass --results results"
TWOMASS_CITATION = ("T. Beauduin (KU Leuven, 2014) and W. Ohnishi (The University of Tokyo, 2019), FdiTools: "
                    "Frequency Domain System Identification MATLAB Toolbox, HoriFujimotoLab/FdiTools (MIT), "
                    "commit 5925fae; R. Pintelon and J. Schoukens, System Identification: A Frequency Domain "
                    "Approach, 2nd ed., Wiley-IEEE Press, 2012")

PERIOD_S = 1.0
"""The multisines' period, s (2500 samples at 2.5 kHz)."""
BAND_HZ = (11.0, 250.0)
"""The excited band of both records (record B excites every 4th line of it)."""
SOURCE = {"antiresonance_hz": 52.4, "resonance_hz": 76.6}
"""The source's motor-side anti-resonance and resonance, read off its FRF figure
(``data/twomass/source_frf.png``, to about +-1 Hz; data/twomass/README.md)."""
SOURCE_READING_HZ = 1.0
FIT_SLICE_S = (1.0, 2.0)
"""The stretch of record A that diagnose and the fits see: its second period (the first is the
source's transient), every excited line once.  A longer stretch costs proportionally more: two
periods took the whole-library ladder 614 s."""
VALIDATION_SLICE_S = (1.0, 2.0)
"""The stretch of record B the models are scored on."""
WINDOW_S = 0.1
"""Replay windows, s: the angles and speeds are set to the record's at every seam."""
CANDIDATES = ("viscous_friction", "coulomb_friction", "bias_torque", "load_spring", "shaft_compliance")
"""What this bench can have among gearbench's effects: no gear (backlash), no voltage input
(amplifier_deadzone), encoders of 2^20 counts (their quantisation is far below the errors)."""
MAX_STEPS = 4
"""The ladder's longest: what bounds the study's time.  No time limit: a limit of 150 s, where the
ladder took 141 s, stopped it at 199 s, three rungs short, on a machine running 1.5-2x slower
(2026-11-30, beside the test suite): the study's answer depended on the machine."""
FREE_PLANT = ("motor.inertia",)


# ----------------------------------------------------------------------------- data
def data_files(data_dir: str | Path | None = None) -> dict[str, Path]:
    """Records A and B in ``data_dir`` (default ``data/twomass``); FileNotFoundError saying where it
    looked and how to point elsewhere."""
    d = Path(data_dir) if data_dir is not None else DEFAULT_DATA_DIR
    if not d.is_dir():
        raise FileNotFoundError(f"two-mass data directory {d} not found: convert the FdiTools records with "
                                f"data/twomass/convert.py and pass --data-dir PATH")
    out = {}
    for tag, name in RECORD_FILES.items():
        if not (d / name).is_file():
            raise FileNotFoundError(f"two-mass record {name} not found in {d} (data/twomass/convert.py writes it)")
        out[tag] = d / name
    return out


def load_records(data_dir: str | Path | None = None) -> dict[str, Measurement]:
    """Both records, read and validated by gearbench's measurement reader."""
    return {tag: read_measurement(path) for tag, path in data_files(data_dir).items()}


def cut(m: Measurement, span_s: tuple[float, float], label: str) -> Measurement:
    """``m`` from ``span_s[0]`` to ``span_s[1]`` s, both angles measured from the motor angle at the
    slice's start.  One offset for both keeps the coupling's twist (motor minus load angle) the
    encoders show: the records start at rest with both angles 0, and at 1 s into record A the
    coupling is twisted by -0.87 deg, which zeroing each angle on its own would have put on the load
    angle as a constant no model of the bench has."""
    ts = m.sample_time_s
    a, b = int(round(span_s[0] / ts)), int(round(span_s[1] / ts))
    zero = float(m.signals["motor_angle_deg"][a])
    sig = {k: np.asarray(v[a:b], dtype=float) - zero for k, v in m.signals.items()}
    return from_arrays(m.time_s[a:b], m.input_name, m.input[a:b], sig, source=label)


def bare_plant() -> Plant:
    return load_plant(BARE_PLANT)


def replay_of(m: Measurement) -> Replay:
    return Replay(m, window_s=WINDOW_S, reset_speeds=True)


# ----------------------------------------------------------------------------- frequency domain
def record_frf(m: Measurement, drop_periods: int = 1) -> dict:
    """The FRF of a periodic record at its excited lines: period-averaged spectra of the input and of
    each angle (rad), their ratio, and its standard error from the spread over the periods.

    Returns ``f_hz``, ``df_hz``, ``periods``, and per side (``motor``, ``load``) the complex FRF
    (rad per N m of the lumped input) and its standard error."""
    ts = m.sample_time_s
    n = int(round(PERIOD_S / ts))
    u = np.asarray(m.input, dtype=float)
    periods = len(u) // n - drop_periods
    if periods < 2:
        raise ValueError(f"{m.source}: needs at least {drop_periods + 2} periods of {PERIOD_S} s")
    sl = slice(drop_periods * n, (drop_periods + periods) * n)
    U = np.fft.rfft(u[sl].reshape(periods, n), axis=1)
    f = np.fft.rfftfreq(n, ts)
    Um = U.mean(axis=0)
    band = (f >= BAND_HZ[0] - 1e-9) & (f <= BAND_HZ[1] + 1e-9)
    # the multisines have flat amplitudes: an excited line is above a tenth of the largest (record B's
    # unexcited lines carry the current loop's own ~3 % of it)
    excited = band & (np.abs(Um) > 0.1 * np.abs(Um[band]).max())
    out = {"f_hz": f[excited], "df_hz": float(np.diff(f[excited]).min()), "periods": periods}
    for side, col in (("motor", "motor_angle_deg"), ("load", "load_angle_deg")):
        y = np.radians(np.asarray(m.signals[col], dtype=float))[sl].reshape(periods, n)
        Y = np.fft.rfft(y, axis=1)
        h_each = Y[:, excited] / U[:, excited]
        out[side] = Y[:, excited].mean(axis=0) / Um[excited]
        out[side + "_stderr"] = h_each.std(axis=0, ddof=1) / math.sqrt(periods)
    return out


def frf_features(f_hz: np.ndarray, h_motor: np.ndarray, h_load: np.ndarray | None = None) -> dict:
    """The motor side's anti-resonance (dip) and resonance (peak) of ``|H| w^2``, Hz, and the load
    side's resonance (peak of ``|H| w^2``) when given; None where the extremum is at the band's edge
    (no dip or peak inside it)."""
    w2 = (2 * math.pi * np.asarray(f_hz)) ** 2
    g = np.abs(h_motor) * w2

    def inner(i):
        return float(f_hz[i]) if 0 < i < len(f_hz) - 1 else None

    peak = int(np.argmax(g))
    # the dip below the resonance: the anti-resonance comes first on the motor side
    dip = int(np.argmin(g[:peak])) if peak > 1 else 0
    out = {"antiresonance_hz": inner(dip), "resonance_hz": inner(peak)}
    if h_load is not None:
        out["load_resonance_hz"] = inner(int(np.argmax(np.abs(h_load) * w2)))
    return out


def high_frequency_inertia(frf: dict, above_hz: float = 150.0) -> float:
    """The rotor's own inertia (per N m/A): above the resonance the motor side is ``1/(J_M s^2)``."""
    sel = frf["f_hz"] >= above_hz
    return float(1.0 / np.median(np.abs(frf["motor"][sel]) * (2 * math.pi * frf["f_hz"][sel]) ** 2))


def coupling_start(frf: dict) -> dict:
    """Two-mass parameters from the record's FRF: ``J_M`` (high-frequency asymptote), and from the
    anti-resonance and resonance ``J_L = J_M ((w_r/w_ar)^2 - 1)``, ``k = J_L w_ar^2``."""
    feat = frf_features(frf["f_hz"], frf["motor"])
    jm = high_frequency_inertia(frf)
    w_ar, w_r = 2 * math.pi * feat["antiresonance_hz"], 2 * math.pi * feat["resonance_hz"]
    jl = jm * ((w_r / w_ar) ** 2 - 1.0)
    return {"rotor_inertia": jm, "load_inertia": jl, "stiffness": jl * w_ar ** 2}


def two_mass(plant: Plant) -> dict | None:
    """``J_M``, ``J_L``, ``k``, ``d`` of a plant with a shaft on a rigid 1:1 gear (rotor | pinion +
    load), with its undamped anti-resonance and resonance (Hz); None without a shaft."""
    r = plant.resolved()
    if r.shaft is None:
        return None
    jm, jl = r.motor.inertia, r.shaft.pinion_inertia + r.output_inertia / r.gear.ratio ** 2
    k = r.shaft.stiffness
    return {"rotor_inertia": jm, "load_inertia": jl, "stiffness": k, "damping": r.shaft.damping,
            "antiresonance_hz": math.sqrt(k / jl) / (2 * math.pi),
            "resonance_hz": math.sqrt(k * (jm + jl) / (jm * jl)) / (2 * math.pi)}


def _viscous(plant: Plant) -> tuple[float, float]:
    bm, bl = plant.motor.damping, plant.output_damping
    for e in plant.effects:
        if e.name == "viscous_friction":
            if e.values.get("location", "motor") == "motor":
                bm += float(e.values["coefficient"])
            else:
                bl += float(e.values["coefficient"])
    return bm, bl


def model_frf(plant: Plant, f_hz: np.ndarray) -> dict:
    """The plant's linear FRF from the drive torque to the motor and load angles (rad per N m): its
    inertias, shaft and viscous terms, and a load spring's stiffness; Coulomb friction and constant
    torques have no linear part and are left out."""
    r = plant.resolved()
    s = 2j * math.pi * np.asarray(f_hz, dtype=float)
    bm, bl = _viscous(plant)
    kl = sum(float(e.values["stiffness"]) for e in plant.effects if e.name == "load_spring")
    if r.shaft is None:
        j = r.driven_inertia
        h = 1.0 / (j * s ** 2 + (bm + bl) * s + kl)
        return {"motor": h, "load": h}
    t = two_mass(plant)
    c = t["damping"] * s + t["stiffness"]
    k11 = t["rotor_inertia"] * s ** 2 + bm * s + c
    k22 = t["load_inertia"] * s ** 2 + bl * s + kl + c
    det = k11 * k22 - c * c
    return {"motor": k22 / det, "load": c / det}


def model_features(plant: Plant) -> dict:
    """:func:`frf_features` of the model's FRF on a 0.05 Hz grid over the band, and its undamped
    two-mass frequencies (None without a shaft)."""
    f = np.arange(BAND_HZ[0], BAND_HZ[1] + 1e-9, 0.05)
    h = model_frf(plant, f)
    out = frf_features(f, h["motor"], h["load"])
    t = two_mass(plant)
    out["undamped"] = None if t is None else {k: t[k] for k in ("antiresonance_hz", "resonance_hz")}
    return out


# ----------------------------------------------------------------------------- time domain
def score(plant: Plant, m: Measurement) -> dict:
    """Per-signal RMS error (deg) of ``plant`` replayed on ``m``, and diagnose's error (the scorer's)."""
    rp = replay_of(m)
    sim = rp.run(plant)
    per = {k: float(np.sqrt(np.mean((np.asarray(m.signals[k]) - sim[k]) ** 2))) for k in m.signals}
    return {"error_deg": float(Scorer(rp).error(sim)), "rms_deg": per,
            "noise_floor_deg": {k: float(rp.noise_floor(k)) for k in m.signals}}


# ----------------------------------------------------------------------------- the bench's own floor
def _period_count(m: Measurement, drop_periods: int) -> tuple[int, int]:
    """The samples in a period and the whole periods of ``m`` after its first ``drop_periods``
    (at least two: a spread over the periods needs them)."""
    n = int(round(PERIOD_S / m.sample_time_s))
    periods = len(m.time_s) // n - drop_periods
    if periods < 2:
        raise ValueError(f"{m.source}: needs at least {drop_periods + 2} periods of {PERIOD_S} s")
    return n, periods


def _cut_periods(m: Measurement, drop_periods: int) -> Iterator[Measurement]:
    """Each period of ``m`` after its first ``drop_periods``, cut as the fit slice is (:func:`cut`)."""
    _, periods = _period_count(m, drop_periods)
    for p in range(drop_periods, drop_periods + periods):
        yield cut(m, (p * PERIOD_S, (p + 1) * PERIOD_S), f"{m.source}, period {p + 1}")


def repeatability(m: Measurement, window_s: float = WINDOW_S, drop_periods: int = 1) -> dict[str, float]:
    """How closely the bench's periods come to each other when each window carries its first
    sample's angle and speed forward in a straight line, per angle (deg).  Not a floor (below).

    Each period after the first ``drop_periods`` is cut as
    :func:`period_errors` cuts it and into the replay's windows, and each window restarted as
    ``Replay(reset_speeds=True)`` restarts the model (which moves the angles only where the model's
    drift is significant, the speeds at every seam): its angle less the angle at the window's
    first sample ``a`` and the speed there (``seam_speed`` of the period's samples: one-sided at its
    first) times the time since ``a``.  The measure is the RMS over a period's samples of their
    standard deviation over the periods (ddof 1).  Periods that differ only in their angle and
    speed at each seam give 0; independent noise ``sigma`` on the samples gives at each sample the
    variance ``sigma^2`` times the sum of the squares of its coefficients on the samples (+1 on
    itself, -1 on the seam's, ``-t c_k`` on each sample the slope reads with weight ``c_k``, ``t``
    the time since the seam; added where two fall on one sample): the restart's angle and speed take
    the noise in as they take it into the model.

    A model goes under it: the periods' speeds differ at a seam, and this carries the difference
    forward in a straight line over the window, where the bench's own coupling and friction turn it
    back.  On record A it is 0.49 deg, where the same periods started at each window's angle alone
    spread by 0.08 deg (:func:`period_spread`)."""
    n, periods = _period_count(m, drop_periods)
    w = int(round(window_s / m.sample_time_s))
    t = np.asarray(m.time_s, dtype=float)[:n] - float(m.time_s[0])
    out = {}
    for name in ("motor_angle_deg", "load_angle_deg"):
        rel = np.empty((periods, n))
        for p in range(periods):
            first = (drop_periods + p) * n
            y = np.asarray(m.signals[name][first:first + n], dtype=float)
            for a in range(0, n, w):
                seg = slice(a, min(a + w, n))
                rel[p, seg] = y[seg] - y[a] - seam_speed(t, y, a) * (t[seg] - t[a])
        out[name] = float(np.sqrt(np.mean(rel.var(axis=0, ddof=1))))
    return out


def period_spread(m: Measurement, window_s: float = PERIOD_S, drop_periods: int = 1) -> dict[str, float]:
    """How closely the bench's periods come to each other, each window of ``window_s`` started at its
    own first sample's angle, per angle (deg): each period after the first ``drop_periods`` cut into
    windows, each sample less the angle at its window's first sample, and the RMS over a period's
    samples of their standard deviation over the periods (ddof 1).  ``window_s`` of a whole period
    (the default) is the bench free-running from where each period starts.

    It bounds the floor from above.  A period is the bench's response to its input and to where it
    starts, which a model driven by the measured current and started as measured explains, plus what
    no model of the input explains (disturbances, the encoders' noise).  Where the two are independent their
    variances add, so the spread is at least the second's.  Identical periods give 0, independent
    noise ``sigma`` on every sample ``sigma sqrt(2 (w - 1) / w)`` for windows of ``w`` samples."""
    n, periods = _period_count(m, drop_periods)
    w = int(round(window_s / m.sample_time_s))
    out = {}
    for name in ("motor_angle_deg", "load_angle_deg"):
        y = np.asarray(m.signals[name], dtype=float)[drop_periods * n:(drop_periods + periods) * n]
        rel = y.reshape(periods, n).copy()
        for a in range(0, n, w):
            rel[:, a:a + w] -= rel[:, a:a + 1]
        out[name] = float(np.sqrt(np.mean(rel.var(axis=0, ddof=1))))
    return out


def replay_cost(plant: Plant, m: Measurement, noise_deg: dict[str, float], window_s: float = WINDOW_S,
                drop_periods: int = 1, seed: int = 0) -> dict[str, float]:
    """What the study's replay costs a model that is exactly right, per angle (deg).

    On each period of ``m`` after the first ``drop_periods`` (cut as :func:`period_errors` cuts it),
    ``plant`` run free from the period's first sample as measured makes a record of its own, moving as
    the bench moves; independent noise ``noise_deg`` (per angle, deg) goes on its angles, and ``plant``
    replays it in windows of ``window_s`` as the study replays the bench.  The cost is the RMS over the
    periods of that replay's error against the noise-free run: each window starts at a speed read off
    noisy samples by a polynomial (``seam_speed``; one-sided at a period's first sample), and the model's
    own dynamics carry what it read."""
    rng = np.random.default_rng(seed)
    sq = {k: 0.0 for k in noise_deg}
    count = 0
    for part in _cut_periods(m, drop_periods):
        clean = Replay(part, window_s=None, reset_speeds=True).run(plant)
        noisy = {k: np.asarray(clean[k]) + s * rng.standard_normal(len(part.time_s)) for k, s in noise_deg.items()}
        own = from_arrays(part.time_s, part.input_name, part.input, noisy, source=f"{plant.name}'s own run")
        out = Replay(own, window_s=window_s, reset_speeds=True).run(plant)
        for k in sq:
            sq[k] += float(np.sum((np.asarray(out[k]) - np.asarray(clean[k])) ** 2))
        count += len(part.time_s)
    return {k: math.sqrt(v / count) for k, v in sq.items()}


def bench_floor(m: Measurement, plant: Plant, noise_deg: dict[str, float]) -> dict[str, dict[str, float]]:
    """Per angle (deg), what no model of ``m``'s input gets under, from above, for a model run free
    over a period from its first sample (``free``) and under the study's replay (``replay``): the
    periods' spread (:func:`period_spread`: free-running, ``spread_free``, and each window started at
    its angle, ``spread_windows``) with what the replay costs ``plant`` were it exactly right
    (:func:`replay_cost`, ``cost_free`` and ``cost_windows``: the encoders' noise ``noise_deg`` and the
    speeds the restarts read), added as independent: ``free = hypot(spread_free, cost_free)``,
    ``replay = hypot(spread_windows, cost_windows)``.  A window started at the measured speed explains
    the speed's differences from period to period, so the spread started at the angle alone is at
    least what a window's own disturbances do."""
    spread_free, spread_windows = period_spread(m), period_spread(m, WINDOW_S)
    cost_free, cost_windows = replay_cost(plant, m, noise_deg, PERIOD_S), replay_cost(plant, m, noise_deg)
    return {k: {"encoders": noise_deg[k], "spread_free": spread_free[k], "spread_windows": spread_windows[k],
                "cost_free": cost_free[k], "cost_windows": cost_windows[k],
                "free": math.hypot(spread_free[k], cost_free[k]),
                "replay": math.hypot(spread_windows[k], cost_windows[k])} for k in noise_deg}


def period_errors(plant: Plant, m: Measurement, drop_periods: int = 1,
                  window_s: float = WINDOW_S) -> dict[str, dict]:
    """``plant`` replayed on each period of ``m`` after the first ``drop_periods`` (each cut as the
    fit slice is, :func:`cut`; windows of ``window_s``, ``PERIOD_S`` to run it free from the period's
    first sample), and per angle (deg) its error's RMS over them all, the part that
    repeats every period (the RMS of the error's mean over the periods, its own share of the
    non-repeating part taken out: what a better model could still explain) and the part that does
    not (the RMS of its standard deviation over the periods, ddof 1)."""
    errors = {}
    for part in _cut_periods(m, drop_periods):
        sim = Replay(part, window_s=window_s, reset_speeds=True).run(plant)
        for name in ("motor_angle_deg", "load_angle_deg"):
            errors.setdefault(name, []).append(np.asarray(part.signals[name]) - sim[name])
    out = {}
    for name, e in errors.items():
        e = np.array(e)
        var = float(np.mean(e.var(axis=0, ddof=1)))
        out[name] = {"rms_deg": float(np.sqrt(np.mean(e ** 2))),
                     "repeating_deg": float(np.sqrt(max(0.0, np.mean(e.mean(axis=0) ** 2) - var / len(e)))),
                     "non_repeating_deg": math.sqrt(var), "periods": len(e)}
    return out


def diagnosis(fit_data: Measurement, workers: int | None = 1) -> dict:
    """diagnose's ladder from the bare plant on ``fit_data`` (see the module docstring)."""
    bare = bare_plant()
    t0 = time.perf_counter()
    d = diagnose(bare, replay_of(fit_data), free_plant=FREE_PLANT, workers=workers, max_steps=MAX_STEPS,
                 only=CANDIDATES)
    wall = time.perf_counter() - t0
    rungs = [{"effect": "bare (inertia fitted)", "action": "", "error_deg": float(d.baseline_error),
              "params": {k: float(v) for k, v in d.baseline.values.items()}, "plant": d.baseline.plant}]
    for st in d.ladder:
        rungs.append({"effect": st.effect, "action": st.action, "error_deg": float(st.error),
                      "params": {k: float(v) for k, v in st.params.items() if not isinstance(v, str)},
                      "plant": plant_from_model(st.model, st.plant_params, bare)})
    return {"verdict": d.verdict, "stopped": d.stopped, "reason": d.reason, "noise_floor_deg": float(d.noise_floor),
            "baseline_error_deg": float(d.baseline_error), "rungs": rungs, "plant": d.plant, "wall_s": wall,
            "final_over_noise": float(rungs[-1]["error_deg"] / d.noise_floor)}


def stated_coupling(model: Plant, fit_data: Measurement, frf: dict) -> dict:
    """``model`` with a ``shaft_compliance`` started from the record's FRF (:func:`coupling_start`;
    replacing any shaft it has), the rotor's total inertia ``J_M + J_L``, damping ratio ~2 %, and
    every parameter refitted."""
    st = coupling_start(frf)
    effects = [e for e in model.effects if e.name != "shaft_compliance"]
    jt = st["rotor_inertia"] + st["load_inertia"]
    mu = st["rotor_inertia"] * st["load_inertia"] / jt
    d0 = 2 * 0.02 * math.sqrt(st["stiffness"] * mu)
    p = replace(model, motor=replace(model.motor, inertia=jt), effects=tuple(effects))
    p = p.with_effects(AddedEffect("shaft_compliance", {"stiffness": st["stiffness"], "damping": d0,
                                                        "pinion_inertia": st["load_inertia"]}))
    frees = [Free.plant(p, "motor.inertia")]
    for i in range(len(p.effects)):
        frees += Free.effect(p, i, fit_data.sample_time_s)
    rp = replay_of(fit_data)
    t0 = time.perf_counter()
    res = fit(rp, p, frees)
    return {"start": {**st, "damping": d0}, "start_plant": p, "plant": res.plant, "converged": bool(res.converged),
            "message": res.message, "error_deg": float(res.error), "wall_s": time.perf_counter() - t0,
            "params": {k: float(v) for k, v in res.values.items()}}


# ----------------------------------------------------------------------------- figures, report
def frf_figure(frf: dict, models: dict, path: Path) -> None:
    from matplotlib.figure import Figure

    fig = Figure(figsize=(10, 6.5))
    axes = fig.subplots(2, 1, sharex=True)
    f = frf["f_hz"]
    fine = np.arange(BAND_HZ[0], BAND_HZ[1] + 1e-9, 0.1)
    for ax, side in zip(axes, ("motor", "load")):
        ax.loglog(f, np.abs(frf[side]), ".", ms=3, color="k", label="record A (period-averaged)")
        ax.loglog(f, np.abs(frf[side + "_stderr"]), "-", lw=0.8, color="r", label="its standard error")
        for (label, plant), style in zip(models.items(), ("--", "-", ":")):
            ax.loglog(fine, np.abs(model_frf(plant, fine)[side]), style, lw=1.3, label=label)
        for key, c in (("antiresonance_hz", "tab:purple"), ("resonance_hz", "tab:green")):
            ax.axvline(SOURCE[key], color=c, lw=0.8, alpha=0.7,
                       label=f"source's {key.split('_')[0]} {SOURCE[key]} Hz")
        ax.set_ylabel(f"|{side} angle / torque| (rad/N m)")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].legend(fontsize=7, loc="lower left")
    axes[1].set_xlabel("frequency (Hz)")
    axes[0].set_title("Two-mass bench: FRF of the record, of the models, and the source's resonance")
    save_figure_atomic(fig, path)


def ladder_figure(diag: dict, stated: dict, path: Path) -> None:
    from matplotlib.figure import Figure

    fig = Figure(figsize=(9, 4.5))
    ax = fig.subplots()
    labels = [r["effect"] if not r["action"] or r["action"] == "add" else f"- {r['effect']}" for r in diag["rungs"]]
    errs = [r["error_deg"] for r in diag["rungs"]]
    labels.append("coupling stated from the FRF")
    errs.append(stated["error_deg"])
    ax.bar(range(len(errs)), errs, color=["tab:blue"] * (len(errs) - 1) + ["tab:orange"])
    ax.axhline(diag["noise_floor_deg"], color="r", lw=1, label=f"noise floor {diag['noise_floor_deg']:.2g} deg")
    ax.set_yscale("log")
    ax.set_xticks(range(len(errs)), labels, fontsize=7, rotation=15)
    ax.set_ylabel("error (deg, diagnose's metric)")
    ax.set_title("Two-mass bench: the diagnosis' error per rung (record A, one period)")
    ax.legend(fontsize=8)
    fig.subplots_adjust(bottom=0.18)
    save_figure_atomic(fig, path)


def _fmt(v, spec=".4g"):
    return "–" if v is None else format(v, spec)


def markdown(r: dict) -> str:
    src, rec = r["source"], r["record_features"]
    md = ["# Two-mass bench (FdiTools): from the bare plant, against the bench's floor", "",
          f"Regenerate: `{COMMAND}` (wall time {r['wall_s']:.0f} s). Data: `data/twomass/` "
          f"(MIT; {TWOMASS_CITATION}).", "",
          "## The record's FRF against the source's", "",
          f"Record A, {r['frf_periods']} periods averaged (the first dropped), {r['frf_lines']} excited lines, "
          f"{r['frf_df_hz']:g} Hz apart. Motor side = current to motor angle; the dip and peak of |H| w^2.", "",
          "| | anti-resonance (Hz) | resonance (Hz) | load-side resonance (Hz) |", "|---|---|---|---|",
          f"| source (read off its figure, +-{SOURCE_READING_HZ:g} Hz) | {src['antiresonance_hz']} | "
          f"{src['resonance_hz']} | {src['resonance_hz']} |",
          f"| record A | {_fmt(rec['antiresonance_hz'])} | {_fmt(rec['resonance_hz'])} | "
          f"{_fmt(rec['load_resonance_hz'])} |",
          f"| record B ({r['record_features_B']['df_hz']:g} Hz grid) | {_fmt(r['record_features_B']['antiresonance_hz'])} | "
          f"{_fmt(r['record_features_B']['resonance_hz'])} | {_fmt(r['record_features_B']['load_resonance_hz'])} |"]
    for name, feat in r["model_features"].items():
        und = feat["undamped"]
        extra = "" if und is None else (f" (undamped {und['antiresonance_hz']:.4g} / {und['resonance_hz']:.4g})")
        md.append(f"| {name} | {_fmt(feat['antiresonance_hz'])} | {_fmt(feat['resonance_hz'])}{extra} | "
                  f"{_fmt(feat['load_resonance_hz'])} |")
    md += ["", "A model's dip and peak are those of its linear FRF (inertias, coupling, viscous terms, "
           "a load spring) on a 0.05 Hz grid; '–': none inside the band.", "",
           "![FRF](twomass/frf.png)", "",
           "## Diagnosis from the bare plant", "",
           f"Record A from {FIT_SLICE_S[0]:g} to {FIT_SLICE_S[1]:g} s, windows of {WINDOW_S:g} s with angles "
           f"and speeds set to the record's at each seam, candidates {', '.join(CANDIDATES)}, "
           f"`motor.inertia` refitted with each. Wall time {r['diagnosis']['wall_s']:.0f} s.", "",
           f"- verdict: **{r['diagnosis']['verdict']}**; the ladder stopped: {r['diagnosis']['stopped']}",
           f"- noise floor {r['diagnosis']['noise_floor_deg']:.3g} deg; the final model's error is "
           f"**{r['diagnosis']['final_over_noise']:.0f}x** it",
           f"- in diagnose's words: {r['diagnosis']['reason']}", "",
           "| rung | error (deg) | validation, record B (deg) | parameters |", "|---|---|---|---|"]
    for row in r["diagnosis"]["rungs"]:
        name = row["effect"] if row["action"] in ("", "add") else f"remove {row['effect']}"
        params = ", ".join(f"{k} {v:.4g}" for k, v in row["params"].items())
        md.append(f"| {name} | {row['error_deg']:.4g} | {row['validation_error_deg']:.4g} | {params} |")
    final = r["diagnosis"]["plant"]
    md += ["", f"Each rung's parameters are as it added them; the final model, refitted jointly: motor.inertia "
           f"{final.motor.inertia:.4g}, " + "; ".join(
               e.name + " " + ", ".join(f"{k} {v:.4g}" if not isinstance(v, str) else f"{k} {v}" for k, v in e.values.items())
               for e in final.effects) + "."]
    s = r["stated"]
    md += ["", "![ladder](twomass/ladder.png)", "",
           "## The bench's own floor", "",
           f"The multisine is the same every period. Each period after the first ({r['period_errors']['motor_angle_deg']['periods']} "
           f"on record A), started at its own measured angle: how far the periods spread free-running over the whole "
           f"period, and in the replay's {WINDOW_S:g} s windows each started at its first sample's angle "
           f"(`period_spread`). A period is the bench's response to its input and its start, which a model explains, "
           f"plus what none does; where the two are independent the spread is at least the second. Beside it, what "
           f"the replay costs diagnose's final model were it exactly right (`replay_cost`: its own run from each "
           f"period's first sample, the encoders' noise added, replayed as the study replays the bench; each window "
           f"starts at a speed read off noisy samples). The floor, from above (`bench_floor`), adds the two: for a "
           f"model run free over a period, and under the study's replay. The last column (`repeatability`, the floor "
           f"this study used until it was found to be none) carries each seam's speed forward in a straight line, "
           f"where the bench's coupling and friction turn it back.", "",
           "| angle | record | encoders' noise | spread, free-running | spread, windows | replay's cost, free-running "
           "| replay's cost, windows | floor, free-running | floor under the replay | straight-line repeatability (not a floor) |",
           "|---|---|---|---|---|---|---|---|---|---|"]
    for name in r["period_errors"]:
        for tag, rep in (("A", r["repeatability_deg"]), ("B", r["repeatability_B_deg"])):
            f = r["bench_floor"][tag][name]
            md.append(f"| {name} | {tag} | {f['encoders']:.2g} | {f['spread_free']:.3g} | {f['spread_windows']:.3g} | "
                      f"{f['cost_free']:.3g} | {f['cost_windows']:.3g} | **{f['free']:.3g}** | **{f['replay']:.3g}** | "
                      f"{rep[name]:.3g} |")
    md += ["", "Diagnose's final model (deg): under the study's replay on its fit slice, on every period of record A "
           "(`period_errors`: RMS / the part that repeats every period, what a better model could still explain / "
           "the part that does not) and on record B's validation slice; and run free from each period's first "
           "sample, as measured (`period_errors(..., window_s=1)`), over every period of each record.", "",
           "| angle | fit slice | every period of A: RMS / repeating / not | record B's slice "
           "| free-running, every period of A | of B |", "|---|---|---|---|---|---|"]
    for name, row in r["period_errors"].items():
        fa, fb = r["free_running"]["A"][name], r["free_running"]["B"][name]
        md.append(f"| {name} | {r['fit_slice_rms_deg'][name]:.4g} | {row['rms_deg']:.3g} / {row['repeating_deg']:.3g} / "
                  f"{row['non_repeating_deg']:.3g} | {r['validation_rms_deg'][name]:.4g} | {fa['rms_deg']:.3g} | "
                  f"{fb['rms_deg']:.3g} |")
    md += ["", "## The coupling stated, started from the FRF", "",
           f"Start: rotor {s['start']['rotor_inertia']:.4g}, load {s['start']['load_inertia']:.4g} kg m^2 "
           f"(per N m/A), stiffness {s['start']['stiffness']:.4g} N m/rad; fitted with the final "
           f"model's other effects ({'converged' if s['converged'] else 'did not converge'}; {s['wall_s']:.0f} s).", "",
           f"- error {s['error_deg']:.4g} deg on the fit slice ({s['error_deg'] / r['diagnosis']['noise_floor_deg']:.0f}x the "
           f"noise floor), {s['validation_error_deg']:.4g} deg on record B; diagnose's final model: "
           f"{r['diagnosis']['rungs'][-1]['error_deg']:.4g} / {r['diagnosis']['rungs'][-1]['validation_error_deg']:.4g} deg",
           "- parameters: " + ", ".join(f"{k} {v:.4g}" for k, v in s["params"].items()), "",
           "## What it says", ""] + [f"- {line}" for line in r["findings"]]
    return "\n".join(md) + "\n"


def findings(r: dict) -> list[str]:
    """The outcome in words, from the numbers (nothing here is decided in advance)."""
    out = []
    src, rec, df = r["source"], r["record_features"], r["frf_df_hz"]
    tol = df + SOURCE_READING_HZ
    for key in ("antiresonance_hz", "resonance_hz"):
        ok = rec[key] is not None and abs(rec[key] - src[key]) <= tol
        out.append(f"The record's {key.split('_')[0]} {_fmt(rec[key])} Hz {'agrees' if ok else 'disagrees'} with the "
                   f"source's {src[key]} Hz (tolerance {tol:g} Hz: the grid's {df:g} Hz plus the figure's reading).")
    hits = {}
    for name, feat in r["model_features"].items():
        und = feat["undamped"]
        if und is None:
            out.append(f"{name}: no coupling, so no resonance.")
            continue
        hit = hits[name] = abs(und["resonance_hz"] - src["resonance_hz"]) <= max(tol, 0.05 * src["resonance_hz"])
        off = None if rec["antiresonance_hz"] is None else und["antiresonance_hz"] - rec["antiresonance_hz"]
        out.append(f"{name}: its coupling resonates at {und['resonance_hz']:.4g} Hz (anti-resonance "
                   f"{und['antiresonance_hz']:.4g} Hz), {'within 5 % of' if hit else 'not'} the source's "
                   f"{src['resonance_hz']} Hz{'' if hit else ': it is not the bench coupling'}; its anti-resonance "
                   + ("cannot be set beside the record's, which has none." if off is None else
                      f"{'agrees with' if abs(off) <= tol else 'is off'} the record's {_fmt(rec['antiresonance_hz'])} Hz "
                      f"({off:+.2g} Hz; tolerance {tol:g} Hz)."))
    d = r["diagnosis"]
    out.append(f"The diagnosis ended {d['final_over_noise']:.0f}x above the noise floor "
               f"({d['rungs'][-1]['error_deg']:.3g} deg against {d['noise_floor_deg']:.2g} deg, the 2^20-count "
               f"encoders' noise); the coupling stated from the FRF ends {r['stated']['error_deg'] / d['noise_floor_deg']:.0f}x "
               f"above it. Neither reaches the encoders' noise, which no model of this record's input can (next): "
               f"the part of the rest that repeats every period is not explained by any effect tried here "
               f"(candidates not tested: a torque or friction that depends on position or on the speed's "
               f"history, the current loop between the measured current and the torque).")
    fa, fb, per, free = r["bench_floor"]["A"], r["bench_floor"]["B"], r["period_errors"], r["free_running"]
    worst = max(fa, key=lambda k: r["fit_slice_rms_deg"][k] / fa[k]["replay"])
    out.append(f"Under the study's replay no model of the record's input gets under about {fa['motor_angle_deg']['replay']:.2g} "
               f"deg on the motor angle and {fa['load_angle_deg']['replay']:.2g} deg on the load angle of record A "
               f"(from above: the periods started at each window's angle spread by {fa[worst]['spread_windows']:.2g} deg, "
               f"and the replay costs the final model, were it exactly right, {fa[worst]['cost_windows']:.2g} deg; "
               f"{worst}). Diagnose's final model is at {r['fit_slice_rms_deg'][worst] / fa[worst]['replay']:.1f}x that "
               f"on its fit slice, {per[worst]['rms_deg'] / fa[worst]['replay']:.1f}x over all {per[worst]['periods']} "
               f"periods of record A ({per[worst]['repeating_deg']:.2g} deg of its error repeats every period: what a "
               f"better model could still explain) and {r['validation_rms_deg'][worst] / fb[worst]['replay']:.1f}x "
               f"record B's on its validation slice: it is not at the bench's floor.")
    out.append(f"Run free from where each period starts, the final model is off by {free['A'][worst]['rms_deg']:.2g} deg "
               f"on record A ({free['A'][worst]['rms_deg'] / fa[worst]['free']:.1f}x the floor for such a run, "
               f"{fa[worst]['free']:.2g} deg) and {free['B'][worst]['rms_deg']:.2g} deg on record B "
               f"({free['B'][worst]['rms_deg'] / fb[worst]['free']:.1f}x {fb[worst]['free']:.2g} deg); the bench's own "
               f"periods spread by {fa[worst]['spread_free']:.2g} and {fb[worst]['spread_free']:.2g} deg, the rest of "
               f"those floors being the start's speed, read off a period's first samples. The straight-line "
               f"repeatability ({r['repeatability_deg'][worst]:.2g} deg) is {r['repeatability_deg'][worst] / fa[worst]['replay']:.1f}x "
               f"the floor under the replay, so being within it said little.")
    better = r["stated"]["error_deg"] < d["rungs"][-1]["error_deg"]
    out.append(f"The coupling stated from the FRF {'beats' if better else 'does not beat'} diagnose's final model "
               f"on the fit slice ({r['stated']['error_deg']:.3g} against {d['rungs'][-1]['error_deg']:.3g} deg) and "
               f"{'beats' if r['stated']['validation_error_deg'] < d['rungs'][-1]['validation_error_deg'] else 'does not beat'} "
               f"it on record B ({r['stated']['validation_error_deg']:.3g} against "
               f"{d['rungs'][-1]['validation_error_deg']:.3g} deg)"
               + ("." if not better else
                  ": diagnose's final model resonates at the source's resonance too; they differ in the other values."
                  if hits.get("diagnose's final model") else
                  ": diagnose's search of a shaft's parameters did not reach the coupling's basin."))
    return out


def run_study(data_dir=None, workers: int | None = 1) -> dict:
    t0 = time.perf_counter()
    recs = load_records(data_dir)
    frf = record_frf(recs["A"])
    rec_feat = frf_features(frf["f_hz"], frf["motor"], frf["load"])
    frf_b = record_frf(recs["B"])
    rec_feat_b = {**frf_features(frf_b["f_hz"], frf_b["motor"], frf_b["load"]), "df_hz": frf_b["df_hz"]}
    fit_data = cut(recs["A"], FIT_SLICE_S, f"record A, {FIT_SLICE_S[0]:g}-{FIT_SLICE_S[1]:g} s")
    val_data = cut(recs["B"], VALIDATION_SLICE_S, f"record B, {VALIDATION_SLICE_S[0]:g}-{VALIDATION_SLICE_S[1]:g} s")
    diag = diagnosis(fit_data, workers)
    for row in diag["rungs"]:
        row["validation_error_deg"] = score(row["plant"], val_data)["error_deg"]
    floor, floor_b = repeatability(recs["A"]), repeatability(recs["B"])
    errors = period_errors(diag["plant"], recs["A"])
    on_slice, on_b = score(diag["plant"], fit_data), score(diag["plant"], val_data)
    floors = {tag: bench_floor(recs[tag], diag["plant"], sc["noise_floor_deg"]) for tag, sc in (("A", on_slice), ("B", on_b))}
    free = {tag: period_errors(diag["plant"], recs[tag], window_s=PERIOD_S) for tag in ("A", "B")}
    stated = stated_coupling(diag["plant"], fit_data, frf)
    stated["validation_error_deg"] = score(stated["plant"], val_data)["error_deg"]
    models = {"diagnose's final model": diag["plant"], "coupling stated (from the FRF, refitted)": stated["plant"]}
    r = {"source": dict(SOURCE), "record_features": rec_feat, "record_features_B": rec_feat_b, "frf_df_hz": frf["df_hz"],
         "frf_periods": frf["periods"], "frf_lines": int(len(frf["f_hz"])),
         "diagnosis": diag, "stated": stated, "repeatability_deg": floor, "repeatability_B_deg": floor_b,
         "period_errors": errors, "bench_floor": floors, "free_running": free,
         "noise_floors_deg": on_slice["noise_floor_deg"], "fit_slice_rms_deg": on_slice["rms_deg"],
         "validation_rms_deg": on_b["rms_deg"], "model_features": {k: model_features(p) for k, p in models.items()}}
    r["findings"] = findings(r)
    r["wall_s"] = time.perf_counter() - t0
    r["_frf"], r["_models"] = frf, models
    return r


def to_json(r: dict) -> dict:
    """The report's numbers (plants as their effects and inertias; no arrays)."""
    def plant_summary(p: Plant) -> dict:
        return {"motor_inertia": p.motor.inertia, "load_inertia": p.load.inertia,
                "effects": [{"type": e.name, **e.values} for e in p.effects], "two_mass": two_mass(p)}

    d = dict(r["diagnosis"])
    d["rungs"] = [{k: v for k, v in row.items() if k != "plant"} | {"model": plant_summary(row["plant"])}
                  for row in d["rungs"]]
    d["plant"] = plant_summary(d["plant"])
    s = {k: v for k, v in r["stated"].items() if k not in ("plant", "start_plant")}
    s["model"] = plant_summary(r["stated"]["plant"])
    return {"command": COMMAND, "citation": TWOMASS_CITATION, "source": r["source"],
            "record_features": r["record_features"], "record_features_B": r["record_features_B"], "frf_df_hz": r["frf_df_hz"], "frf_periods": r["frf_periods"],
            "frf_lines": r["frf_lines"], "fit_slice_s": FIT_SLICE_S, "validation_slice_s": VALIDATION_SLICE_S,
            "window_s": WINDOW_S, "candidates": CANDIDATES, "diagnosis": d, "stated": s,
            "repeatability_deg": r["repeatability_deg"], "repeatability_B_deg": r["repeatability_B_deg"],
            "period_errors": r["period_errors"], "bench_floor": r["bench_floor"], "free_running": r["free_running"],
            "noise_floors_deg": r["noise_floors_deg"], "fit_slice_rms_deg": r["fit_slice_rms_deg"],
            "validation_rms_deg": r["validation_rms_deg"],
            "model_features": r["model_features"], "findings": r["findings"], "wall_s": r["wall_s"]}


@click.command()
@click.option("--results", "results_dir", type=click.Path(file_okay=False, path_type=Path),
              default=Path("results"), show_default=True, help="Output folder.")
@click.option("--data-dir", type=click.Path(path_type=Path), default=None,
              help="Folder with twomass_A.csv and twomass_B.csv (default: data/twomass).")
@click.option("--workers", type=int, default=1, show_default=True, help="Local processes for diagnose.")
def main(results_dir: Path, data_dir: Path | None, workers: int) -> None:
    """The two-mass bench study: FRF, diagnosis, the coupling stated; results/twomass.md and .json."""
    try:
        data_files(data_dir)
    except FileNotFoundError as exc:
        raise click.UsageError(str(exc)) from None
    r = run_study(data_dir, workers)
    fig_dir = results_dir / "twomass"
    fig_dir.mkdir(parents=True, exist_ok=True)
    frf_figure(r["_frf"], r["_models"], fig_dir / "frf.png")
    ladder_figure(r["diagnosis"], r["stated"], fig_dir / "ladder.png")
    write_text_atomic(results_dir / "twomass.md", markdown(r))
    write_text_atomic(results_dir / "twomass.json",
                      json.dumps(to_json(r), indent=1, default=lambda o: o.tolist() if hasattr(o, "tolist") else str(o)) + "\n")
    print((results_dir / "twomass.md").read_text(encoding="utf-8"))


if __name__ == "__main__":
    main()
