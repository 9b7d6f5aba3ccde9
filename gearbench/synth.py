"""Synthetic measurements: a known plant with hidden effects, driven open loop.

To practise the measure -> diagnose loop (and to test it) one needs records
whose truth is known.  :func:`synthesize` plays the part of the real rig: it
simulates a plant with extra *hidden* effects (friction, a spring, a sensor
delay, ...) under a recorded open-loop input and returns the record an
engineer would have measured, in the SPEC's measurement format (section 3):

* the input column is the commanded input (V, N m or N), held from sample to
  sample (zero-order hold), exactly as ``Replay`` drives a model with it;
* the signals are the simulated ones (``signals.from_outputs``), then the
  plant's sensor effects (``Effect.measure``: delay, quantisation), then
  gaussian noise of a given standard deviation, white or AR(1)-coloured
  (:func:`ar1`) -- except on a signal
  an encoder quantises: an encoder counts the true angle and has no analog
  noise, so that signal gets none;
* the record starts at rest with the mesh centred in its clearance.

:func:`excitation` makes the inputs (``steps``, ``mixed``, ``prbs``, ``chirp``, ``multisine``,
``profile:N`` or a CSV file)
and :func:`truth_dict` the record of what was hidden, saved beside the data.
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np
import pandas as pd
from scipy.signal import lfilter

from . import layout as L
from .control.controllers import Controller
from .errors import SynthError, SynthRunError
from .measure.data import INPUT_COLUMNS, SIGNAL_COLUMNS, Measurement, from_arrays
from .plant.components import Plant
from .plant.effects.base import AddedEffect
from .plant.pack import pack_plant, rest_state, tolerance_scales
from .simulate import Segments, SolverOptions, failure_message, simulate, simulate_packed
from .measure import signals as S

INPUT_COLUMN = {"voltage": "voltage_V", "torque": "drive_torque_Nm", "force": "drive_force_N"}
"""The measurement column of each drive's input."""

DEFAULT_NOISE = {"_deg": 0.01, "_A": 0.005, "_mm": 0.001}
"""Default noise standard deviation by column unit: 0.01 deg on angles (a
good incremental encoder after interpolation), 0.005 A on current (a shunt
amplifier), 0.001 mm on positions (1 um)."""

STEP_LEVELS = (0.12, 0.2, 0.35, 0.6, 1.0)
"""Magnitudes of the ``steps`` excitation, fractions of the input's limit:
two small (12 %, 20 %: below or near the break-away of typical friction or an
amplifier dead zone, so these show), a middle one and two large."""

HOLD_S = (0.3, 0.6)     # a step is held this long (s): reaches steady speed (~5 tau_m)
REST_S = (0.3, 0.5)     # then the input rests at 0 this long (s): the train stops
FIRST_REST_S = 0.2      # the record opens with a rest: a standstill to see the noise on

SOLVER = SolverOptions(rtol=1e-6, max_step_s=1e-3)
"""Synthesis is the 'truth': tighter than a replay's rtol 1e-5."""


# ------------------------------------------------------------------ inputs

def input_column(plant: Plant) -> str:
    """The measurement column of ``plant``'s input: ``voltage_V``, ``drive_torque_Nm`` or ``drive_force_N``."""
    return INPUT_COLUMN[plant.drive]


def input_scale(plant: Plant, hold_s: float = 0.5) -> float:
    """The input that a ``steps`` level of 1.0 means, in the input's unit.

    The input's limit (``motor.max_voltage``, V, or ``max_drive``, N m or N)
    when it is finite.  A torque/force drive without a limit gets a typical
    drive instead: the input that, acting on the whole train (pure inertia
    ``J = Jm + Jl/N^2`` plus its viscous damping ``b``), moves the output
    half a turn (``theta = pi``; 20 mm of carriage travel with a leadscrew)
    in ``hold_s``: rotor torque ``T = J 2 theta N / t^2 + b theta N / t``,
    divided by the drive gain (``Plant.drive_gain``).
    """
    vmax = plant.motor.max_voltage
    if math.isfinite(vmax):
        return float(vmax)
    p = plant.resolved()
    n = p.gear.ratio
    theta = math.pi if p.leadscrew is None else 20e-3 / p.leadscrew.radius  # output rad
    j = p.driven_inertia
    b = p.driven_damping
    torque = j * 2.0 * theta * n / hold_s ** 2 + b * theta * n / hold_s
    return torque / p.drive_gain


def _grid(duration_s: float, sample_time_s: float) -> np.ndarray:
    """Sample times 0, Ts, ..., duration (s)."""
    if not (duration_s > 0 and math.isfinite(duration_s)):
        raise ValueError(f"duration must be a positive number of seconds, got {duration_s!r}")
    if not (sample_time_s > 0 and sample_time_s < duration_s):
        raise ValueError(f"sample time must be positive and shorter than the duration "
                         f"({duration_s:g} s), got {sample_time_s!r}")
    n = int(round(duration_s / sample_time_s)) + 1
    return np.arange(n) * sample_time_s


def steps(plant: Plant, duration_s: float = 10.0, sample_time_s: float = 1e-3,
          seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Open-loop input steps of several levels in both directions, each followed by a rest.

    The record opens with a rest of ``FIRST_REST_S``; then each step is held
    ``U(HOLD_S)`` s and followed by a rest at 0 for ``U(REST_S)`` s (durations
    drawn from ``seed``, on the sample grid).  The levels are
    ``+-STEP_LEVELS`` times :func:`input_scale`, signs alternating; the five
    magnitudes come in a seed-shuffled order, once with each sign in every
    ten steps, with one small and one large magnitude among the first two so
    that even a short record holds both.  So the record has standstills,
    break-away (or not) under small inputs, acceleration to steady speed,
    coasting to rest and reversals of direction (the gear crossing its
    clearance).  Returns ``(time_s, input)``, input in the plant's input unit.
    """
    t = _grid(duration_s, sample_time_s)
    rng = np.random.default_rng(seed)
    mags = list(rng.permutation(STEP_LEVELS))
    small = [m for m in mags if m <= 0.2]
    large = [m for m in mags if m >= 0.6]
    first, second = small[int(rng.integers(len(small)))], large[int(rng.integers(len(large)))]
    if rng.random() < 0.5:
        first, second = second, first
    mags = [first, second] + [m for m in mags if m not in (first, second)]
    scale = input_scale(plant)
    u = np.zeros_like(t)
    now, k = FIRST_REST_S, 0
    while now < t[-1]:
        hold = rng.uniform(*HOLD_S)
        rest = rng.uniform(*REST_S)
        # 2 passes of the odd-length magnitude list: each magnitude once with each sign
        level = (1.0 if k % 2 == 0 else -1.0) * mags[k % len(mags)] * scale
        on = (t >= now - 1e-12) & (t < now + hold - 1e-12)
        u[on] = level
        now += hold + rest
        k += 1
    return t, u


MIXED = (  # (shape, level, duration s): the practice cases' excitation (data/cases/README.md)
    ("hold", 0.0, 0.55),                                                   # opening rest
    ("hold", 0.27, 0.9), ("hold", 0.0, 0.55),                              # a step, a pause
    ("hold", -0.24, 0.9), ("hold", 0.48, 0.64), ("hold", -0.57, 0.57),     # the other way, direct reversals
    ("hold", 0.0, 0.55),
    ("hold", 0.11, 0.72), ("hold", 0.0, 0.35), ("hold", -0.11, 0.72),      # low-level steps
    ("hold", 0.0, 0.55),
    ("hold", 0.7, 0.3), ("hold", -0.7, 0.3), ("hold", 0.7, 0.3),          # fast reversals
    ("hold", 0.0, 0.5),
    ("sine", 0.3, 4.7), ("hold", 0.0, 0.5),                                # one slow sine period
    ("triangle", 0.27, 2.0), ("hold", 0.0, 0.5),                           # a triangle ramp
)
"""The ``mixed`` excitation, segment by segment: ``hold`` keeps ``level`` (a
fraction of :func:`input_scale`) for the duration; ``sine`` is one period
``level sin(2 pi t / duration)``; ``triangle`` rises linearly from 0 to
``level`` over half the duration and back.  Its nominal length is 16.1 s."""

MIXED_JITTER = 0.15
"""Every level and duration of :data:`MIXED` is multiplied by ``U(1 -+ MIXED_JITTER)``."""


def mixed(plant: Plant, duration_s: float = 16.0, sample_time_s: float = 1e-3,
          seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """The open-loop input of the practice cases (data/cases): :data:`MIXED`, jittered.

    Steps both ways with pauses and direct reversals, low-level steps (11 %
    of the limit: below the break-away of typical friction, so stick shows),
    three fast steps reversing (0.3 s each), one slow sine period (4.7 s)
    and a triangle ramp (2 s), each followed by a rest.  Each level
    (fraction of :func:`input_scale`) and each duration is jittered by
    ``+-MIXED_JITTER`` (uniform, from ``seed``); the durations are then
    scaled together so that the schedule fills ``duration_s`` (16.1 s
    nominally: a 15 s record runs it 7 % faster).  Returns ``(time_s,
    input)``, input in the plant's input unit, 0 at ``t = 0``.
    """
    t = _grid(duration_s, sample_time_s)
    rng = np.random.default_rng(seed)
    jitter = rng.uniform(1.0 - MIXED_JITTER, 1.0 + MIXED_JITTER, size=(len(MIXED), 2))
    levels = np.array([lvl for _, lvl, _ in MIXED]) * jitter[:, 0] * input_scale(plant)
    spans = np.array([d for _, _, d in MIXED]) * jitter[:, 1]
    ends = np.cumsum(spans) * (t[-1] + sample_time_s) / spans.sum()  # the last rest reaches the end
    starts = np.concatenate([[0.0], ends[:-1]])
    u = np.zeros_like(t)
    for (shape, _, _), level, a, b in zip(MIXED, levels, starts, ends):
        on = (t >= a - 1e-12) & (t < b - 1e-12)
        x = (t[on] - a) / (b - a)                # 0 -> 1 through the segment
        if shape == "hold":
            u[on] = level
        elif shape == "sine":
            u[on] = level * np.sin(2.0 * np.pi * x)
        else:
            u[on] = level * (1.0 - np.abs(2.0 * x - 1.0))
    return t, u


PRBS_LEVEL = 0.3        # +- this fraction of input_scale
PRBS_CLOCK_S = 0.04     # the sign may flip every clock tick, with probability 1/2
SWEEP_LEVEL = 0.35      # peak of chirp and multisine, a fraction of input_scale
SWEEP_HZ = (0.2, 10.0)  # their band, Hz (the top at most a tenth of the sample rate)
MULTISINE_LINES = 8     # multisine: this many log-spaced frequencies over SWEEP_HZ
FADE_S = 0.5            # chirp and multisine fade in and out over this long (cosine ramp)


def _opening(t: np.ndarray) -> np.ndarray:
    """True after the :data:`FIRST_REST_S` opening rest."""
    return t >= FIRST_REST_S - 1e-12


def _faded(t: np.ndarray, u: np.ndarray) -> np.ndarray:
    """``u`` (0 in the opening rest) raised from and lowered to 0 over :data:`FADE_S` by a half
    cosine: an abrupt start of a sweep would be a step."""
    a, b = FIRST_REST_S, float(t[-1])
    span = min(FADE_S, 0.25 * (b - a))
    x = np.clip(np.minimum(t - a, b - t) / span, 0.0, 1.0)
    return u * 0.5 * (1.0 - np.cos(np.pi * x))


def sweep_band(sample_time_s: float) -> tuple[float, float]:
    """The band of ``chirp`` and ``multisine``, Hz: :data:`SWEEP_HZ`, its top at most a tenth of
    the sample rate."""
    return SWEEP_HZ[0], min(SWEEP_HZ[1], 0.1 / sample_time_s)


def prbs(plant: Plant, duration_s: float = 10.0, sample_time_s: float = 1e-3,
         seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """A binary pseudo-random input: ``+-PRBS_LEVEL`` times :func:`input_scale`, its sign
    drawn anew (flipping with probability 1/2) every :data:`PRBS_CLOCK_S`, after the
    :data:`FIRST_REST_S` opening rest; no rests after it, so the train reverses through its
    clearance at random and never stands still long.  Returns ``(time_s, input)``."""
    t = _grid(duration_s, sample_time_s)
    rng = np.random.default_rng(seed)
    ticks = np.floor((t - FIRST_REST_S) / PRBS_CLOCK_S + 1e-9).astype(int)
    signs = np.where(rng.random(max(int(ticks.max()) + 1, 1)) < 0.5, -1.0, 1.0)
    u = PRBS_LEVEL * input_scale(plant) * signs[np.maximum(ticks, 0)]
    return t, np.where(_opening(t), u, 0.0)


def chirp(plant: Plant, duration_s: float = 10.0, sample_time_s: float = 1e-3,
          seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """A logarithmic sine sweep ``SWEEP_LEVEL input_scale sin(phi(t))`` from ``SWEEP_HZ[0]`` to
    ``SWEEP_HZ[1]`` (at most a tenth of the sample rate) over the record after its opening rest,
    faded in and out (:data:`FADE_S`); ``seed`` sets its starting phase.  Returns
    ``(time_s, input)``."""
    t = _grid(duration_s, sample_time_s)
    f0, f1 = sweep_band(sample_time_s)
    span = max(float(t[-1]) - FIRST_REST_S, sample_time_s)
    k = math.log(f1 / f0) / span
    x = np.maximum(t - FIRST_REST_S, 0.0)
    phase = 2.0 * np.pi * np.random.default_rng(seed).random()
    u = SWEEP_LEVEL * input_scale(plant) * np.sin(phase + 2.0 * np.pi * f0 * np.expm1(k * x) / k)
    return t, np.where(_opening(t), _faded(t, u), 0.0)


def multisine(plant: Plant, duration_s: float = 10.0, sample_time_s: float = 1e-3,
              seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """A sum of :data:`MULTISINE_LINES` sines at log-spaced frequencies over ``SWEEP_HZ`` (the
    top at most a tenth of the sample rate), equal amplitudes, random phases from ``seed``,
    scaled to a peak of ``SWEEP_LEVEL input_scale`` and faded in and out (:data:`FADE_S`) after
    the opening rest.  Returns ``(time_s, input)``."""
    t = _grid(duration_s, sample_time_s)
    f0, f1 = sweep_band(sample_time_s)
    freqs = np.geomspace(f0, f1, MULTISINE_LINES)
    phases = 2.0 * np.pi * np.random.default_rng(seed).random(MULTISINE_LINES)
    x = np.maximum(t - FIRST_REST_S, 0.0)
    u = np.sin(2.0 * np.pi * np.outer(x, freqs) + phases).sum(axis=1)
    u = np.where(_opening(t), _faded(t, u), 0.0)
    peak = float(np.max(np.abs(u)))
    return t, (SWEEP_LEVEL * input_scale(plant) / peak) * u if peak > 0 else u


def profile_controller(plant: Plant) -> Controller:
    """A well-behaved feedback law on the motor-side angle for ``profile:N``.

    Voltage drive: P control, ``Kp`` from the linear, engaged, no-inductance
    model ``theta_out/u = kt / (N (kt ke + R b)) / (s (tau s + 1))`` with
    ``tau = R J / (kt ke + R b)``, ``J = Jm + Jl/N^2``, ``b = bm + bl/N^2``:
    the loop ``tau s^2 + s + K = 0`` gets damping ratio 0.7 for
    ``K = 1 / (4 0.7^2 tau)``, ``Kp = K N (kt ke + R b) / kt`` (V/rad, given
    to the controller in V/deg).  Torque/force drive: a pure inertia under P
    control does not damp, so PD (``pid`` with ``ki = 0``): natural frequency
    ``w = 10 rad/s`` and damping ratio 0.7 on ``J s^2 + b s + (g/N) Kp (1 + Kd s)``.
    """
    p = plant.resolved()
    n = p.gear.ratio
    j = p.driven_inertia
    b = p.driven_damping
    zeta = 0.7
    if p.drive == "voltage":
        m = p.motor
        c = m.torque_constant * m.back_emf_constant + m.resistance * b
        tau = m.resistance * j / c
        k = 1.0 / (4.0 * zeta ** 2 * tau)
        kp = k * n * c / m.torque_constant
        return Controller("p", kp=math.radians(kp))
    g = p.drive_gain
    w = 10.0
    kp = j * w ** 2 * n / g                          # drive units per output rad
    kd = max((2.0 * zeta * w * j - b) * n / (g * kp), 0.0)
    return Controller("pid", kp=math.radians(kp), ki=0.0, kd=kd)


def profile_input(plant: Plant, number: int, duration_s: float = 10.0,
                  sample_time_s: float = 1e-3) -> tuple[np.ndarray, np.ndarray]:
    """The input a feedback law applied while following thesis profile ``number``.

    A set-point profile is not an input; so ``plant`` is simulated closed
    loop under :func:`profile_controller` following the profile (its last
    value held after its end), and the commanded input it applied is
    returned, sampled every ``sample_time_s``: for P control
    ``u = sat(Kp (r - theta_m/N))`` (before any amplifier dead zone, which is
    what a record's input column holds), else the applied drive.  Replayed
    open loop, it is a realistic closed-loop-looking excitation.
    """
    from .profiles import load_profile

    if number not in (1, 2, 3):
        raise ValueError(f"profile:N takes N = 1, 2 or 3 (the thesis profiles), got {number}")
    t = _grid(duration_s, sample_time_s)
    prof = load_profile(f"profile{number}")
    segs = prof.segments()
    if duration_s > prof.duration_s:  # hold the end value rather than extend the last ramp
        end = math.radians(float(prof.end_values()[-1]))
        segs = Segments(np.append(segs.t, prof.duration_s), np.append(segs.v, end), np.append(segs.s, 0.0))
    ctrl = profile_controller(plant)
    run = simulate(plant, ctrl, segs, float(t[-1]),
                   SolverOptions(rtol=SOLVER.rtol, max_step_s=SOLVER.max_step_s, output_dt_s=sample_time_s),
                   label=f"profile:{number} under {ctrl.kind} control")
    if not run.ok:
        raise SynthRunError(failure_message(run, plant.name, plant))
    out = run.outputs
    if len(out) != len(t):
        raise SynthError(f"profile:{number}: got {len(out)} samples, expected {len(t)}")
    if ctrl.kind == "p" and plant.drive == "voltage":
        kp = math.degrees(ctrl.kp)  # V/rad
        e = out[:, L.O_SETPOINT] - out[:, L.O_MOTOR] / plant.gear.ratio
        u = np.clip(kp * e, -plant.motor.max_voltage, plant.motor.max_voltage)
    else:
        u = out[:, L.O_VOLTAGE].copy()
    return t, u


def read_input_file(path: str | Path, plant: Plant | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``time_s`` and the one input column of a CSV (other columns are ignored,
    so a measurement file's input can be reused).  Raises ``ValueError`` naming
    the file, the column and the first bad row (data row 1 is file line 2)."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"excitation file '{path}' does not exist (give steps, mixed, prbs, chirp, multisine, profile:N or a CSV "
                         "with time_s and one input column)")
    try:
        df = pd.read_csv(path, skipinitialspace=True)
    except Exception as exc:  # pandas raises several types for a malformed CSV
        raise ValueError(f"excitation file '{path}' is not a readable CSV table: {exc}") from None
    df.columns = [str(c).strip() for c in df.columns]
    if "time_s" not in df.columns:
        raise ValueError(f"excitation file '{path}': missing column 'time_s' (sample time, s); "
                         f"found {', '.join(df.columns)}")
    inputs = [c for c in INPUT_COLUMNS if c in df.columns]
    if len(inputs) != 1:
        what = "no input column" if not inputs else f"{len(inputs)} input columns ({', '.join(inputs)})"
        raise ValueError(f"excitation file '{path}': {what}; it needs exactly one of "
                         f"{', '.join(INPUT_COLUMNS)}")
    name = inputs[0]
    if plant is not None and name != input_column(plant):
        raise ValueError(f"excitation file '{path}': column {name!r} does not drive the plant "
                         f"{plant.name!r}, whose input is {input_column(plant)} ({plant.drive} drive)")
    cols = {}
    for c in ("time_s", name):
        v = pd.to_numeric(df[c], errors="coerce").to_numpy(dtype=float)
        bad = np.flatnonzero(~np.isfinite(v))
        if bad.size:
            raise ValueError(f"excitation file '{path}': column {c!r}: missing, non-numeric or "
                             f"non-finite value {df[c].iloc[bad[0]]!r} at data row {bad[0] + 1} "
                             f"(file line {bad[0] + 2})" + (f"; {bad.size} bad rows in all" if bad.size > 1 else ""))
        cols[c] = v
    t = cols["time_s"]
    if len(t) < 2:
        raise ValueError(f"excitation file '{path}': {len(t)} row(s); it needs at least 2")
    back = np.flatnonzero(np.diff(t) <= 0)
    if back.size:
        i = int(back[0]) + 1
        raise ValueError(f"excitation file '{path}': column 'time_s' is not strictly increasing at "
                         f"data row {i + 1} (file line {i + 2}): {t[i]:.10g} s after {t[i - 1]:.10g} s")
    return t, cols[name]


NO_RESTS = {"prbs": prbs, "chirp": chirp, "multisine": multisine}
"""The excitations without rests after the opening one, by name."""


def excitation(kind: str, plant: Plant, duration_s: float | None = None, sample_time_s: float = 1e-3,
               seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """An open-loop input record ``(time_s, input)`` for ``plant``, input in its unit.

    kind:

    * ``steps``: :func:`steps`, levels in both directions with rests;
    * ``mixed``: :func:`mixed`, the practice cases' excitation (steps, direct
      and fast reversals, low levels, a slow sine and a triangle ramp);
    * ``prbs``, ``chirp``, ``multisine``: :func:`prbs`, :func:`chirp`,
      :func:`multisine`, inputs without steps and rests (a random binary
      sequence, a logarithmic sweep, a sum of sines);
    * ``profile:N`` (N = 1, 2, 3): :func:`profile_input`, the input a feedback
      law applied following thesis profile N;
    * anything else: a CSV file with ``time_s`` and one input column
      (:func:`read_input_file`), its own sample times.

    duration_s: record length, s (default 10 s, 16 s for ``mixed``; for a file
    its own length, or the first ``duration_s`` of it when given);
    sample_time_s: sample interval, s (not used for a file); seed: the random
    draws of ``steps``, ``mixed``, ``prbs`` and the phases of ``chirp`` and ``multisine``.
    """
    if kind == "steps":
        return steps(plant, 10.0 if duration_s is None else duration_s, sample_time_s, seed)
    if kind == "mixed":
        return mixed(plant, 16.0 if duration_s is None else duration_s, sample_time_s, seed)
    if kind in NO_RESTS:
        return NO_RESTS[kind](plant, 10.0 if duration_s is None else duration_s, sample_time_s, seed)
    if kind.startswith("profile:"):
        num = kind.split(":", 1)[1].strip()
        if num not in ("1", "2", "3"):
            raise ValueError(f"excitation {kind!r}: profile:N takes N = 1, 2 or 3 (the thesis profiles)")
        return profile_input(plant, int(num), 10.0 if duration_s is None else duration_s, sample_time_s)
    t, u = read_input_file(kind, plant)
    if duration_s is not None:
        if duration_s > t[-1] - t[0] + 1e-12:
            raise ValueError(f"excitation file '{kind}' lasts {t[-1] - t[0]:g} s, less than the "
                             f"{duration_s:g} s asked for")
        keep = t - t[0] <= duration_s + 1e-12
        t, u = t[keep], u[keep]
    return t, u


# ------------------------------------------------------------- synthesis

def default_signals(plant: Plant) -> tuple[str, ...]:
    """``motor_angle_deg``, the output (``load_angle_deg``, or
    ``load_position_mm`` with a leadscrew) and ``current_A`` (voltage drive only)."""
    out = ("motor_angle_deg", "load_angle_deg" if plant.leadscrew is None else "load_position_mm")
    return out + (("current_A",) if plant.drive == "voltage" else ())


def quantized_signals(plant: Plant) -> set[str]:
    """Signals a sensor effect of ``plant`` rounds to a grid (``Effect.rounds``:
    ``encoder_quantization``'s counts)."""
    return {e.values["signal"] for e in plant.effects if e.effect.rounds}


def resolved_noise(plant: Plant, signals: Sequence[str],
                   noise: Mapping[str, float] | None = None) -> dict[str, float]:
    """Noise standard deviation of each signal, in its unit.

    :data:`DEFAULT_NOISE` by unit, overridden by ``noise`` (keys: recorded
    signals); 0 on a signal an encoder quantises (an encoder has no analog
    noise).  Raises ``ValueError`` for a key that is not recorded or a
    negative or non-finite value.
    """
    noise = dict(noise or {})
    for name, std in noise.items():
        if name not in signals:
            raise ValueError(f"noise: {name!r} is not a recorded signal (recorded: {', '.join(signals)})")
        if not (isinstance(std, (int, float)) and math.isfinite(std) and std >= 0):
            raise ValueError(f"noise: {name} must be a standard deviation >= 0 in "
                             f"{SIGNAL_COLUMNS[name]}, got {std!r}")
    quantized = quantized_signals(plant)
    out = {}
    for name in signals:
        unit = next(u for u in DEFAULT_NOISE if name.endswith(u))
        out[name] = 0.0 if name in quantized else float(noise.get(name, DEFAULT_NOISE[unit]))
    return out


def _check_signals(plant: Plant, signals: Sequence[str]) -> None:
    problems = []
    for name in signals:
        if name not in SIGNAL_COLUMNS:
            problems.append(f"{name!r} is not a measured signal (use {', '.join(SIGNAL_COLUMNS)})")
        elif name == "current_A" and plant.drive != "voltage":
            problems.append(f"current_A: the plant {plant.name!r} is {plant.drive}-driven and has no electrics")
        elif name.endswith("_mm") and plant.leadscrew is None:
            problems.append(f"{name}: a position in mm needs a plant with a leadscrew")
    if len(set(signals)) != len(signals):
        problems.append(f"a signal is listed twice: {', '.join(signals)}")
    if not signals:
        problems.append("no signals to record")
    for e in plant.effects:
        if e.effect.acts_on == "measured signal" and e.values.get("signal") not in signals:
            problems.append(f"{e.name} acts on {e.values.get('signal')}, which is not recorded "
                            f"(recorded: {', '.join(signals)})")
    if problems:
        raise SynthError("cannot synthesize: " + "; ".join(problems))


def ar1(white: np.ndarray, rho: float) -> np.ndarray:
    """Stationary AR(1) noise of unit marginal variance from unit white noise ``e``:
    ``w_0 = e_0``, ``w_t = rho w_{t-1} + sqrt(1 - rho^2) e_t`` (lag-k correlation ``rho^k``);
    ``rho = 0`` returns ``e`` itself.  ``|rho| < 1``."""
    if not -1.0 < rho < 1.0:
        raise ValueError(f"the AR(1) noise coefficient must lie in (-1, 1), got {rho!r}")
    if rho == 0.0:
        return white
    b = math.sqrt(1.0 - rho ** 2)
    # the filter's state set so that w_0 = b e_0 + (1 - b) e_0 = e_0
    return lfilter([b], [1.0, -rho], white, zi=[(1.0 - b) * white[0]])[0]


def synthesize(plant: Plant, hidden: Sequence[AddedEffect], time_s, input,
               signals: Sequence[str] | None = None, noise: Mapping[str, float] | None = None,
               seed: int = 0, label: str = "", noise_ar1: float = 0.0,
               options: SolverOptions | None = None) -> Measurement:
    """The record ``plant`` with ``hidden`` effects gives for an open-loop ``input``.

    Parameters
    ----------
    plant : Plant
        The known model; the truth is ``plant.with_effects(*hidden)``.
    hidden : list of AddedEffect
        Effects the model does not know about (``{type, params}`` of SPEC section 5).
    time_s, input : array
        Sample times (s, increasing) and the commanded input in the plant's unit
        (V, N m or N), held from each sample to the next (zero-order hold).
    signals : list of str, optional
        Measured columns; default :func:`default_signals` (motor angle, output
        angle or carriage position, current for a voltage drive).
    noise : dict, optional
        Standard deviation per signal in its unit, over :data:`DEFAULT_NOISE`
        (0.01 deg, 0.005 A, 0.001 mm); see :func:`resolved_noise`.  White,
        gaussian, drawn from ``seed``.  ``{name: 0.0, ...}`` for a clean record.
    seed : int
        Seed of the noise.
    label : str
        Name of the run in error messages.
    noise_ar1 : float
        Lag-1 correlation ``rho`` of the noise (:func:`ar1`: each signal's noise an AR(1)
        process with the same marginal standard deviation); 0 (default): white.
    options : SolverOptions, optional
        The solver; default ``SOLVER``.

    Returns
    -------
    Measurement
        Checked like a file (``from_arrays``): ``time_s``, the input column,
        the signals ``y = noise + measure(from_outputs(sim))``.  The
        simulation: open loop, at rest with the mesh centred at ``t = 0``
        (``time_s[0]``), ``options`` (default ``SOLVER``: rtol 1e-6, steps <= 1 ms),
        sampled exactly at ``time_s``.

    Raises
    ------
    SynthError
        A signal the plant cannot give, or a failed simulation (which run, at
        which time of the record, the likely cause).
    """
    truth = plant.with_effects(*hidden)
    t = np.asarray(time_s, dtype=float)
    u = np.asarray(input, dtype=float)
    if t.ndim != 1 or u.shape != t.shape or len(t) < 2:
        raise SynthError(f"time_s and input must be 1-D arrays of one length >= 2, got shapes "
                         f"{t.shape} and {u.shape}")
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(u)) and np.all(np.diff(t) > 0)):
        raise SynthError("time_s must be finite and strictly increasing and input finite")
    signals = tuple(default_signals(plant) if signals is None else signals)
    _check_signals(truth, signals)
    try:
        sigma = resolved_noise(truth, signals, noise)
        p = pack_plant(truth)
        scales = tolerance_scales(truth)
    except ValueError as exc:
        raise SynthError(f"cannot synthesize with plant {truth.name!r}: {exc}") from None
    p[L.P_CTRL] = L.CTRL_OPEN
    t0 = float(t[0])
    tr = t - t0
    name = label or f"synth {truth.name}"
    run = simulate_packed(p, scales, Segments(tr, u, np.zeros_like(u)), float(tr[-1]),
                          rest_state(truth), options or SOLVER, name, output_times=tr)
    if not run.ok:
        when = run.stats[L.S_T_FAIL]
        msg = failure_message(run, truth.name, truth).replace(f"t = {when:.6g} s", f"t = {when + t0:.6g} s")
        raise SynthRunError(msg + f" (hidden effects: {', '.join(e.name for e in hidden) or 'none'})")
    rng = np.random.default_rng(seed)
    cols = {}
    for sig in signals:
        y = S.from_outputs(sig, run.outputs, truth)
        for e in truth.effects:
            y = e.effect.measure(e.values, sig, y, t, truth)
        # drawn for every signal, so one signal's noise does not depend on another's level
        w = ar1(rng.standard_normal(len(t)), noise_ar1)
        cols[sig] = y + sigma[sig] * w if sigma[sig] > 0 else y
    return from_arrays(t, input_column(truth), u, cols, source=name)


def truth_dict(plant_name: str, hidden: Sequence[AddedEffect], noise: Mapping[str, float] | None,
               seed: int, excitation: str | Mapping, **extra) -> dict:
    """What a synthetic record hides, as plain data for ``DATA.truth.yaml``.

    ``plant``: the plant (file) the record was made from; ``hidden_effects``:
    each as ``{type: NAME, <parameters>}``, the plant-file form (SPEC
    section 5); ``noise_std``: per signal, in its unit (0: none, e.g. on an
    encoder-quantised signal); ``seed``; ``excitation``: its kind and
    settings; ``extra``: more keys (signals, duration, notes).
    """
    def plain(v):
        if isinstance(v, (np.floating, np.integer)):
            return v.item()
        if isinstance(v, Mapping):
            return {str(k): plain(x) for k, x in v.items()}
        if isinstance(v, (list, tuple)):
            return [plain(x) for x in v]
        if isinstance(v, Path):
            return str(v)
        return v

    out = {
        "plant": str(plant_name),
        "hidden_effects": [plain(e.to_dict()) for e in hidden],
        "noise_std": plain(dict(noise or {})),
        "seed": int(seed),
        "excitation": plain(excitation if isinstance(excitation, Mapping) else {"kind": str(excitation)}),
    }
    out.update({k: plain(v) for k, v in extra.items()})
    return out


__all__ = ["excitation", "steps", "profile_input", "profile_controller", "read_input_file",
           "input_scale", "input_column", "synthesize", "ar1", "truth_dict", "resolved_noise",
           "default_signals", "quantized_signals", "SynthError", "DEFAULT_NOISE", "STEP_LEVELS"]
