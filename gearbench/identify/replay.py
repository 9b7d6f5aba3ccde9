"""Drive the model the way the measured record was driven.

Open loop: the measured input (voltage, drive torque or force), held from
sample to sample.  Closed loop (``controller`` given, e.g. EMPS's sampled
position-velocity cascade): the controller driven by the recorded set point
(and disturbance), its output compared with the measured input.

An open-loop record of a plant that integrates (speed -> angle) drifts: a
small speed error grows into a large angle error that says nothing about the
physics.  So open-loop replays are cut into windows (``window_s``); at each
window's start the angle states are moved by the model's drift, measured minus
simulated position over the previous window's last samples fitted by a straight
line (so the reset does not carry one sample's noise), when that drift is
significant against the noise, white or coloured, as the record's opening rest
shows it (:meth:`Replay._reset_angles`); the speeds, current and mesh state run on
from the previous window.
Opt-in, ``Replay(reset_speeds=True)`` also sets the speeds at every seam to the
measured ones (:func:`seam_speed`, a local polynomial fit of the measured angles
around the seam), and starts the model at the record's first sample as measured,
moving: its angles, a shaft's twist and its speeds.  For a record whose low
frequencies are not excited (a multisine on a current-driven machine,
``studies/twomass.py``) the speed error a window carries over from the last drifts
the angles far more than the dynamics in the window, and the windows then compare
the model on what the record excites.
A run returns where it moved them with its columns (:class:`ReplayRun`); the replay itself
is frozen, so one run's resets cannot be read as another's.

The noise of each compared column is read from the record (``measure.noise.noise_floor``,
from its third differences, which assumes the noise is white) unless it is stated
(``noise_std``): coloured noise (a filtered sensor, a drifting amplifier) shows in the
differences only in part (a quarter of it for an AR(1) process of lag-1 correlation 0.9),
and the level of its slow part cannot be read from a record of a moving machine.
"""
from __future__ import annotations

import copy
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field, replace

import math

import numpy as np

from .. import layout as L
from ..errors import ReplayError, ReplayRunError
from ..measure.data import Measurement
from ..measure.noise import line_end_noise, noise_estimate, rest_noise
from ..measure.phases import smoothed_speed
from ..plant.components import Plant
from ..plant.pack import pack_plant, rest_state, tolerance_scales
from ..simulate import Segments, SolverOptions, failure_message, simulate_packed
from ..measure import signals as S

DRIVES = {"voltage_V": "voltage", "drive_torque_Nm": "torque", "drive_force_N": "force"}
RESET_SAMPLES = 21
"""Samples at the end of a window over which the model's drift is measured."""
STEPS_PER_SAMPLE = 2000
"""Step budget of a replay window per sample of the record (2 million for a 1 s window at 1 kHz),
unless ``options.max_steps`` is smaller.  The most a replay that finished took, measured over every
first-rung candidate fit on three records (the tutorial's, the 16 s hidden-backlash and the 4 s two-effect
records of ``benchmarks/bench_ladder.py``), was 295,000 steps per simulated second (a stiff shaft
compliance); stick-slip friction on the rotor of the bench rig written without clearance chatters at 1.5
million, and with the solver's own budget (20 million steps a run) each such replay ran 50 s before
failing."""
MAX_STEP_S = 1e-3
"""A replay's largest solver step, s."""
RESET_SPEED_HALF = 5
"""``reset_speeds``: samples either side of a seam in the local polynomial fit of a measured angle
that gives its speed (:func:`seam_speed`; 11 samples: 4.4 ms at 2.5 kHz, a third of the period of
the two-mass bench's 77 Hz mode)."""
RESET_SPEED_DEGREE = 4
"""The degree of :func:`seam_speed`'s polynomial.  Its slope is a filter of the measured angle, and
it must pass the speeds of the band the record excites: over 11 samples at 2.5 kHz a quadratic's
slope gives 89 % of a 77 Hz motion's speed and 22 % at 250 Hz (the two-mass bench's mode and the
top of its multisine), a quartic's 99.8 % and 82 %.  The price is noise: a white noise ``sigma`` on
the angle gives the quartic's slope ``614 sigma`` per second (the quadratic's ``238 sigma``), with
the bench's 2^20-count encoders 0.006 deg over a 0.1 s window.  On the two-mass bench, started as
measured, the diagnosis with the quadratic's seams ended 0.870 deg from record A over its 19 periods
and 1.50 deg from record B; with the quartic's, 0.610 and 0.862 deg (``docs/twomass.md``)."""


@dataclass
class _Solved:
    """What :meth:`Replay.run`'s windows gave so far: their sampled outputs, held inputs, the seams
    that moved the angles, and the solver's accepted steps and events."""
    outs: list = field(default_factory=list)
    seg_u: list = field(default_factory=list)
    moved: list = field(default_factory=list)
    steps: int = 0
    events: int = 0


def solver_options(rtol: float = 1e-6) -> SolverOptions:
    """A replay's solver options: relative tolerance ``rtol``, steps of at most :data:`MAX_STEP_S`,
    ``rodas4-exp``: where the model is affine (a plant whose effects are all piecewise linear), an
    event-free step from one sample of the record to the next is taken exactly
    (``solver/exponential.py``; 2-3x faster replays of practice records p02-p04 at the same
    accuracy, ``docs/speed.md``)."""
    return SolverOptions(rtol=rtol, max_step_s=MAX_STEP_S, method="rodas4-exp")


def noise_at_rest(rest: Measurement, columns) -> dict[str, float]:
    """``noise_std`` from a record of the machine at rest: each of ``columns`` it has,
    :func:`gearbench.measure.noise.rest_noise` (its standard deviation there, in its unit).
    ``ReplayError`` when it has none of them or one does not vary."""
    names = [n for n in columns if n in rest.signals or n == rest.input_name]
    if not names:
        raise ReplayError(f"{rest.source or 'the record at rest'} has none of the compared columns "
                          f"({', '.join(columns)})")
    try:
        return {n: rest_noise(rest.signals[n] if n in rest.signals else rest.input, f"{n} of {rest.source}")
                for n in names}
    except ValueError as exc:
        raise ReplayError(str(exc)) from None


def stated_noise(data: Measurement, closed_loop: bool, stated=None, rest: Measurement | None = None) -> dict | None:
    """A replay's ``noise_std``: ``stated`` (``{column: standard deviation}`` in each column's unit;
    the key ``"all"`` or ``"*"`` sets every compared column, the ones named beside it win) over
    the noise read from ``rest``, a record of the machine at rest (:func:`noise_at_rest`); None
    when neither gives any."""
    every = list(data.signals) + ([data.input_name] if closed_loop else [])
    out = dict(stated or {})
    for key in ("*", "all"):
        if key in out:
            std = out.pop(key)
            out = {**{n: std for n in every}, **out}
    if rest is not None:
        out = {**noise_at_rest(rest, every), **out}
    return out or None


def local_fit(t: np.ndarray, y: np.ndarray, i: int, half: int = 10, degree: int = 2):
    """Polynomial fit of ``y`` over samples ``i - half .. i + half`` (a quadratic by
    default, so an accelerating stretch does not bias it): value and slope at
    ``t[i]``, each with its standard error."""
    a, b = max(0, i - half), min(len(t), i + half + 1)
    tt = t[a:b] - t[i]
    if b - a < degree + 3:
        return float(y[i]), 0.0, np.inf, np.inf
    coef, cov = np.polyfit(tt, y[a:b], degree, cov="unscaled")
    r = y[a:b] - np.polyval(coef, tt)
    s2 = float(r @ r) / (b - a - degree - 1)
    return (float(coef[-1]), float(coef[-2]), float(np.sqrt(cov[-1, -1] * s2)),
            float(np.sqrt(cov[-2, -2] * s2)))


def seam_speed(t: np.ndarray, y: np.ndarray, a: int, half: int = RESET_SPEED_HALF,
               degree: int = RESET_SPEED_DEGREE) -> float:
    """The slope of ``y`` at sample ``a`` (per unit of ``t``): the derivative at ``t[a]`` of the
    least-squares polynomial of ``degree`` through ``2 half + 1`` samples, centred on ``a`` where
    the record allows and else its first or last ``2 half + 1`` (a record's first sample: a
    one-sided fit); the degree falls to what fewer samples support (0 for under three)."""
    n, m = len(t), 2 * half + 1
    lo = min(max(0, a - half), max(0, n - m))
    hi = min(n, lo + m)
    degree = min(degree, hi - lo - 2)
    if degree < 1:
        return 0.0
    scale = float(np.max(np.abs(t[lo:hi] - t[a]))) or 1.0  # a well-conditioned Vandermonde
    coef = np.polyfit((t[lo:hi] - t[a]) / scale, y[lo:hi], degree)
    return float(coef[-2]) / scale


@dataclass(frozen=True, eq=False)
class ReplayRun(Mapping):
    """The simulated columns of one :meth:`Replay.run`, by name (``sim[name]``, ``sim.items()``),
    and where that run moved the model's angles to the record's: ``seams``, the window seams'
    first sample numbers, and ``reinitialised_s``, their times (s from the record's start);
    ``steps`` and ``events``: the solver's accepted steps and located events, summed over the
    windows (what the replay cost; ``timing``); ``stopped``: the run ended before the record's
    end (``Replay.run(stop=...)``), its columns those of the samples it solved."""
    columns: dict
    seams: tuple[int, ...] = ()
    reinitialised_s: tuple[float, ...] = ()
    steps: int = 0
    events: int = 0
    stopped: bool = False

    def __getitem__(self, name: str) -> np.ndarray:
        return self.columns[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self.columns)

    def __len__(self) -> int:
        return len(self.columns)


@dataclass(frozen=True, eq=False)
class Replay:
    """How to simulate ``data`` with a plant.

    controller: a closed-loop law (``control.sampled.SampledPV``) driven by the
    record's set point, or None for open loop; window_s: open-loop re-initialisation
    interval, s (None: one window); options: solver options (each window's step budget at most
    :data:`STEPS_PER_SAMPLE` per sample); start_moving: the
    record starts in motion (EMPS's do), so the model starts at the measured speed
    (None: in closed loop, whose records are cut from a running machine); noise_std: the
    measurement noise's standard deviation of some compared columns, each in its column's
    unit, where it is known (a record of the machine at rest, a sensor's datasheet): it is
    their noise floor (:meth:`noise_floor`) and the least drift a window's reset acts on;
    reset_speeds: at every window seam also set the model's speeds to the measured ones
    (:meth:`_reset_speeds`), and start it at the record's first sample as measured
    (:meth:`_start_as_measured`; open loop with more than one window only; off by default).

    Frozen: a run returns what it found (:class:`ReplayRun`) and sets nothing here.  Equal and
    hashed by identity (it holds the record's arrays).  ``meter``: what counts each run and fit
    (``timing``: a ``Cost`` or ``Timing``, :meth:`metered`), None by default; it stays in this
    process (a pickled replay leaves it behind).
    """
    data: Measurement
    controller: object | None = None
    window_s: float | None = 1.0
    options: SolverOptions = field(default_factory=solver_options)
    start_moving: bool | None = None
    noise_std: dict | None = None
    reset_speeds: bool = False
    t0: float = field(init=False, repr=False)
    t: np.ndarray = field(init=False, repr=False)
    # read off the record once: "found" (windows()), ("rest line", column, m) (_line_noise_at_rest)
    _read: dict = field(init=False, repr=False, default_factory=dict)
    meter: object | None = field(init=False, repr=False, default=None)

    def metered(self, meter) -> "Replay":
        """This replay, its runs and fits counted by ``meter`` (``timing.Cost`` or ``timing.Timing``:
        ``replayed(steps)`` per run, ``fitted()`` per fit).  A shallow copy: the record and the
        windows found are shared, so its runs are this replay's."""
        out = copy.copy(self)
        object.__setattr__(out, "meter", meter)
        return out

    def __getstate__(self) -> dict:
        return {**self.__dict__, "meter": None}  # a meter counts in its own process only

    def __post_init__(self):
        t = self.data.time_s
        object.__setattr__(self, "t0", float(t[0]))
        object.__setattr__(self, "t", t - self.t0)
        if self.start_moving is None:
            object.__setattr__(self, "start_moving", self.controller is not None)
        if self.controller is not None and self.data.setpoint is None:
            raise ReplayError(f"{self.data.source}: a closed-loop replay needs a set point column "
                              "(setpoint_deg or setpoint_mm)")
        object.__setattr__(self, "noise_std", self._checked_noise(self.noise_std))

    def _checked_noise(self, stated) -> dict[str, float]:
        if stated is None:
            return {}
        if not isinstance(stated, dict):
            raise ReplayError(f"noise_std must be a dict {{column: standard deviation}}, got {stated!r}")
        compared, problems = self.compared(), []
        for name, std in stated.items():
            if name not in compared:
                problems.append(f"noise_std (--noise): {name!r} is not a compared column of "
                                f"{self.data.source or 'the record'} (it has {', '.join(compared)})")
                continue
            ok = isinstance(std, (int, float)) and not isinstance(std, bool) and math.isfinite(std) and std > 0
            if not ok:
                problems.append(f"noise_std[{name!r}] (--noise) must be a standard deviation > 0 in {self.unit(name)}, got {std!r}")
        if problems:
            raise ReplayError("; ".join(problems))
        return {name: float(std) for name, std in stated.items()}

    @property
    def closed_loop(self) -> bool:
        return self.controller is not None

    def unit(self, name: str) -> str:
        """The unit of compared column ``name`` (a signal's, or the input's in closed loop)."""
        return self.data.signal_unit(name) if name in self.data.signals else self.data.input_unit

    def noise_reading(self, name: str) -> tuple[float, str]:
        """``(noise_floor(name), noise_rule(name))``, the record's column read once."""
        if name in self.noise_std:
            return self.noise_std[name], "stated"
        est = noise_estimate(self.measured(name))
        return est.floor, est.rule

    def noise_floor(self, name: str) -> float:
        """Standard deviation of the noise on compared column ``name``, in its unit: the stated one
        (``noise_std``), else :func:`gearbench.measure.noise.noise_floor` of the record's column."""
        return self.noise_reading(name)[0]

    def noise_rule(self, name: str) -> str:
        """How :meth:`noise_floor` read compared column ``name``'s floor: ``"stated"`` (``noise_std``:
        given, or from a record at rest), else the rule of
        :func:`gearbench.measure.noise.noise_estimate` (a key of ``measure.noise.RULES``:
        ``"differences"``, ``"quantum"``, ``"quantized differences"``)."""
        return self.noise_reading(name)[1]

    def compared(self) -> list[str]:
        """The columns a replay predicts: the measured signals, and the input in closed loop."""
        names = list(self.data.signals)
        if self.closed_loop:
            names.append(self.data.input_name)
        return names

    def check(self, plant: Plant) -> None:
        want = DRIVES[self.data.input_name]
        if plant.drive != want:
            raise ReplayError(f"the plant {plant.name!r} is driven by {plant.drive} but "
                              f"{self.data.source or 'the record'}'s input is {self.data.input_name}; "
                              f"set the plant's drive: {want}")
        for name in self.data.signals:
            if name.endswith("_mm") and plant.leadscrew is None:
                raise ReplayError(f"{self.data.source}: column {name} needs a plant with a leadscrew")

    # ---------------------------------------------------------------- state
    def motion(self, plant: Plant):
        """``(column, measured output angle in rad)`` from the best position signal (the motor's
        angle or position first), or ``(None, None)``."""
        for name in ("motor_angle_deg", "motor_position_mm", "load_angle_deg", "load_position_mm"):
            if name in self.data.signals:
                return name, S.to_output_rad(name, self.data.signals[name], plant)
        return None, None

    def scales(self, plant: Plant) -> np.ndarray:
        """Tolerance scales of the plant itself, not of this record: they also
        set friction's regularisation speed, which must not move with the data."""
        return tolerance_scales(plant)

    def initial_state(self, plant: Plant) -> np.ndarray:
        """At rest with the mesh centred (SPEC: a record starts at rest), unless
        ``start_moving``: then at the speed a local fit of the first samples gives.

        Which records start moving is known, not guessed: an estimate from the
        first samples cannot tell a moving start from a fast start out of rest.
        """
        x = rest_state(plant)
        _, th = self.motion(plant)
        if th is not None and self.start_moving:
            _, w, _, _ = local_fit(self.t, th, 0, 20, 1)
            n = plant.gear.ratio
            x[L.X_WL] = w
            x[L.X_WM] = x[L.X_WP] = w * n
            if plant.drive == "voltage":
                m = plant.motor
                x[L.X_I] = (float(self.data.input[0]) - m.back_emf_constant * w * n) / m.resistance
        return x

    def _reset_angles(self, x: np.ndarray, a: int, plant: Plant, out_prev: np.ndarray, motion,
                      seams: frozenset | None) -> bool:
        """Move the angle states by the model's drift at sample ``a``, when it is significant
        (``seams`` None), or when ``a`` is one of ``seams`` (see :meth:`run`).

        The drift is measured minus simulated position (output rad) over the last
        ``RESET_SAMPLES`` samples of the previous window (``out_prev``, its sampled outputs),
        fitted by a straight line in time and evaluated at sample ``a``, with that value's
        standard error (``motion``: :meth:`motion`'s); the states move only past 5 standard
        errors, so a right model is left alone.  Where the motion signal's noise is stated
        (``noise_std``), the standard error is at least that noise: its colour is not known, and
        coloured noise moves the last samples together, so their line's end is as far off as one
        sample (on the bench rig with AR(1) noise of lag-1 correlation 0.9, the straight line's own
        error moved a right model at 4-8 of 15 windows, and its motor angle's error rose from 1.0x
        to 1.3-1.7x the noise).  Whether stated or not, the standard error is also at least the
        error of such a line's end through the noise of the record's opening rest
        (:meth:`_line_noise_at_rest`): it is read where the machine is still, so it does not move
        with the model, and it knows the noise's colour (practice case p10, AR(1) angle noise of
        lag-1 correlation 0.9 and 0.04 deg: the line through 21 samples of white noise is 0.45 of
        a sample's error off, through these 1.09, and the true plant had a false reset at
        10.525 s that left its motor angle's error at 1.59x the noise; none, and 1.00x, with the
        opening rest's).  The difference of two trajectories is
        smooth where the model is right, whatever the motion: a polynomial fit of the
        measurement alone is biased where the motion is not polynomial (a motor crossing
        the clearance at 33 rad/s in practice case p03: it moved a right model 0.35 deg and
        its motor-angle error went from 0.98x to 38x the noise).  The model's signal carries its
        constant sensor effects (``Effect.shifts``: a ``sensor_offset`` on that angle), so a right
        offset is no drift.  True if it moved them."""
        name, th = motion
        m = min(RESET_SAMPLES, len(out_prev))
        if th is None or m < 3:
            return False
        y = S.from_outputs(name, out_prev[-m:], plant)
        for e in plant.effects:  # a sensor's constant (``Effect.shifts``) is no drift of the model
            if e.effect.shifts:
                y = e.effect.measure(e.values, name, y, self.t[a - m:a], plant)
        sim = S.to_output_rad(name, y, plant)
        d = th[a - m:a] - sim
        # the difference grows while the model drifts: its straight line, evaluated at sample a
        tt = self.t[a - m:a] - self.t[a]
        coef, cov = np.polyfit(tt, d, 1, cov="unscaled")
        r = d - np.polyval(coef, tt)
        drift = float(coef[-1])
        se = float(np.sqrt(cov[-1, -1] * (r @ r) / (m - 2)))
        floor = max(self._line_noise_at_rest(name, m), self.noise_std.get(name, 0.0))  # the column's unit
        se = max(se, float(abs(S.to_output_rad(name, floor, plant))))
        move = abs(drift) > 5.0 * se if seams is None else a in seams
        if move:
            x[L.X_THM] += plant.gear.ratio * drift
        return move

    def opening_rest(self) -> int:
        """The samples of an open-loop record before its input first leaves zero (0 where it starts
        elsewhere, and in closed loop).  The record starts at rest (SPEC) and nothing drives the
        machine there, so all a measured signal does in them is its noise, white or coloured,
        whatever the model."""
        u = self.measured(self.data.input_name)
        if self.closed_loop or u.size == 0 or u[0] != 0.0:
            return 0
        moved = np.flatnonzero(u != 0.0)
        return int(moved[0]) if moved.size else u.size

    def _line_noise_at_rest(self, name: str, m: int) -> float:
        """The standard deviation of a straight line's end through ``m`` samples of column
        ``name``'s noise as :meth:`opening_rest` shows it (``measure.noise.line_end_noise``; 0
        where that is shorter than ``5 m`` samples), in the column's unit, read once."""
        key = ("rest line", name, m)
        if key not in self._read:
            self._read[key] = line_end_noise(self.measured(name)[:self.opening_rest()], m)
        return self._read[key]

    def _start_as_measured(self, x: np.ndarray, plant: Plant) -> None:
        """Set the angle states to the record's first sample (``reset_speeds``, whose record may
        start moving and twisted: a cut of a longer record): the rotor's angle from the motion
        signal (:meth:`motion`) and, where both the motor's and the load's angle are measured, a
        shaft's twist ``phi = theta_m - N (theta_l + delta)`` (rad at the rotor; the mesh's
        ``delta`` as it is, held by its contact).  Why: from rest and untwisted, a slice of the
        two-mass bench started with its coupling's -0.87 deg twist (at 1 s into record A) missing,
        8.7 N m on a 575 N m/rad coupling, and a slice of record B moving: the study's final model
        was 6.6 deg off in the first 0.1 s of each period of record B and 0.4-0.9 deg in the others."""
        name, th = self.motion(plant)
        if th is None:
            return
        n, sig = plant.gear.ratio, self.data.signals
        x[L.X_THM] = n * th[0] if name.startswith("motor") else n * (th[0] + x[L.X_DELTA]) + x[L.X_PHI]
        if plant.resolved().shaft is not None and name == "motor_angle_deg" and "load_angle_deg" in sig:
            theta_l = S.to_output_rad("load_angle_deg", sig["load_angle_deg"][0], plant)
            x[L.X_PHI] = x[L.X_THM] - n * (theta_l + x[L.X_DELTA])

    def _reset_speeds(self, x: np.ndarray, a: int, plant: Plant) -> None:
        """Set the speed states at sample ``a`` to the measured ones (``reset_speeds``): each measured
        angle's slope at ``a`` (:func:`seam_speed`).  The rotor's speed from the motor's angle (else
        from the load's), the load's (and on a rigid gear the pinion's) from the load's angle (else
        from the motor's); a shaft's pinion speed on a compliant gear from the motor's.  The angles are moved as without it
        (:meth:`_reset_angles`)."""
        n = plant.gear.ratio
        rates = {}
        for name in ("motor_angle_deg", "motor_position_mm", "load_angle_deg", "load_position_mm"):
            if name in self.data.signals and name.split("_")[0] not in rates:
                th = S.to_output_rad(name, self.data.signals[name], plant)
                rates[name.split("_")[0]] = seam_speed(self.t, th, a)
        if not rates:
            return
        wl_motor = rates.get("motor", rates.get("load"))   # output rad/s
        wl_load = rates.get("load", rates.get("motor"))
        x[L.X_WM] = n * wl_motor
        x[L.X_WL] = wl_load
        shaft = plant.resolved().shaft is not None
        x[L.X_WP] = n * (wl_load if shaft and plant.gear.rigid else wl_motor)

    # ---------------------------------------------------------------- run
    def pack(self, plant: Plant) -> np.ndarray:
        p = pack_plant(plant)
        if self.closed_loop:
            self.controller.pack(plant, p)
        else:
            p[L.P_CTRL] = L.CTRL_OPEN
        return p

    def _segments(self, plant: Plant, a: int, b: int) -> Segments:
        t = self.t[a:b] - self.t[a]
        z = np.zeros(b - a)
        if self.closed_loop:
            r = S.to_output_rad(self.data.setpoint_name.replace("setpoint", "load_angle" if
                                self.data.setpoint_name.endswith("_deg") else "load_position"),
                                self.data.setpoint[a:b], plant)
            d = self.data.disturbance_V[a:b] if self.data.disturbance_V is not None else z
            return Segments(t, r, z, d)
        u = np.asarray(self.data.input[a:b], dtype=float)
        # a held input that does not change needs no restart of the integrator
        keep = np.r_[True, u[1:] != u[:-1]]
        return Segments(t[keep], u[keep], z[keep])

    def windows(self, plant: Plant) -> list[tuple[int, int]]:
        """Sample ranges [a, b) of the windows (b of one is a of the next).

        Each boundary is the slowest sample within a quarter window of its
        nominal time: at rest the reset's straight-line fit is exact.  The last
        window is at least half a window long (a 16.11 s record once ended in one of
        29 samples, too short for the residual tests' default lags).  They depend on
        the record alone (a plant scales the measured speed by a positive factor, which
        moves no minimum), so they are found once per replay, with the first plant given: smoothing
        the record's speed at every run took 11 % of a diagnosis.  Not when the replay is built,
        from the record's own units: the scale moves no minimum but does move the rounding, and
        an encoder-quantised record gives neighbouring samples the same smoothed speed, a tie
        the rounding breaks one way in rad and the other in degrees (a 6 s ``steps`` record of
        ``thesis_gear`` with 1024 counts per revolution, windows of 0.5 s: a seam at sample 2190
        in rad, 2191 in degrees).
        """
        found = self._read.get("found")
        if found is None:
            found = self._read.setdefault("found", self._find_windows(plant))
        return found

    def _find_windows(self, plant: Plant) -> list[tuple[int, int]]:
        n = len(self.t)
        if self.closed_loop or not self.window_s:
            return [(0, n)]
        _, th = self.motion(plant)
        speed = np.abs(smoothed_speed(self.t, th)[0]) if th is not None else np.zeros(n)
        edges = [0]
        while True:
            nominal = self.t[edges[-1]] + self.window_s
            lo = int(np.searchsorted(self.t, nominal - 0.25 * self.window_s))
            hi = int(np.searchsorted(self.t, nominal + 0.25 * self.window_s))
            if hi >= n - 2 or self.t[-1] - self.t[hi] < 0.5 * self.window_s:
                break  # the last window runs to the end: never a sliver of a few samples
            edges.append(lo + int(np.argmin(speed[lo:hi + 1])))
        edges.append(n)
        return list(zip(edges[:-1], edges[1:]))

    def run(self, plant: Plant, seams=None, label: str = "", stop=None) -> ReplayRun:
        """Simulated columns (``compared()``) at the record's samples, in its units, sensor
        effects applied, with the seams at which this run moved the model's angles to the
        record's (:class:`ReplayRun`).  Raises :class:`ReplayError` if the solver fails.

        ``seams`` None: a seam moves them when the model's drift there is significant
        (:meth:`_reset_angles`).  Given (window seams' first samples, e.g. an earlier run's
        ``seams``): they move at exactly those, each by its drift, whatever its significance.
        A fit does its least squares so: the test of significance switches a seam's reset on or
        off as the parameters move, and the residual jumps there (on the bench rig with p04's
        datasheet errors, the motor angle's error along the straight line from where the
        calibration stopped to the truth went 1.77, 1.95, ..., 1.47, 1.59, 1.18x the noise),
        which stalled the fit in false minima.

        ``stop``: called after each window but the last with the run so far (the columns of the
        samples solved), it ends the run there when it returns True; the result is then
        ``stopped``, shorter than the record.  Ignored where a sensor effect of ``plant`` does not
        measure causally (``Effect.measures_causally``): the first samples' columns would not be
        those of the whole run.  A scan stops a point that can no longer rank among its best
        (``search.scan``)."""
        self.check(plant)
        held = None if seams is None else frozenset(seams)
        if stop is not None and not all(e.effect.measures_causally() for e in plant.effects):
            stop = None
        solved = _Solved()
        try:
            self._solve(plant, held, label, solved, stop)
        finally:
            if self.meter is not None:
                self.meter.replayed(solved.steps)
        return self._columns(plant, solved)

    def _columns(self, plant: Plant, solved: "_Solved") -> ReplayRun:
        """The :class:`ReplayRun` of the windows ``solved`` so far."""
        out = np.vstack(solved.outs)
        t = self.t[:len(out)]
        sim = {}
        for name in self.data.signals:
            y = S.from_outputs(name, out, plant)
            for e in plant.effects:
                y = e.effect.measure(e.values, name, y, t, plant)
            sim[name] = y
        if self.closed_loop:
            sim[self.data.input_name] = np.concatenate(solved.seg_u)
        moved = solved.moved
        return ReplayRun(sim, tuple(moved), tuple(float(self.t[a]) for a in moved), solved.steps, solved.events,
                         len(out) < len(self.t))

    def _solve(self, plant: Plant, held: frozenset | None, label: str, solved: "_Solved", stop=None) -> None:
        """:meth:`run`'s windows, one after the other, into ``solved`` (it keeps the steps of a
        window that failed before :class:`ReplayRunError` is raised), until ``stop`` of the run so
        far is true."""
        p = self.pack(plant)
        sc = self.scales(plant)
        x = self.initial_state(plant)
        windows = self.windows(plant)
        motion = self.motion(plant) if len(windows) > 1 else None
        for a, b in windows:
            if a > 0 and self._reset_angles(x, a, plant, solved.outs[-1], motion, held):
                solved.moved.append(a)
            if self.reset_speeds:
                if a == 0:
                    self._start_as_measured(x, plant)
                self._reset_speeds(x, a, plant)
            segs = self._segments(plant, a, b)
            t_end = float(self.t[b - 1] - self.t[a]) if b == len(self.t) else float(self.t[b] - self.t[a])
            times = self.t[a:b] - self.t[a]
            options = replace(self.options, max_steps=min(self.options.max_steps, STEPS_PER_SAMPLE * (b - a)))
            run = simulate_packed(p, sc, segs, max(t_end, times[-1]), x, options,
                                  label, output_times=times)
            solved.steps += run.steps
            solved.events += int(run.stats[L.S_EVENTS])
            if not run.ok:
                msg = failure_message(run, plant.name, plant)
                raise ReplayRunError(msg.replace(f"t = {run.stats[L.S_T_FAIL]:.6g} s",
                                              f"t = {self.t[a] + run.stats[L.S_T_FAIL] + self.t0:.6g} s"))
            solved.outs.append(run.outputs)
            solved.seg_u.append(run.meta["segment_input"])
            x = run.meta["x_end"].copy()
            if stop is not None and b < len(self.t) and stop(self._columns(plant, solved)):
                return
            x[L.X_IAE] = x[L.X_ISE] = 0.0

    def residuals(self, sim: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        """Measured minus simulated, per compared column, over the samples the simulated column
        holds (all of them, or a stopped run's first ones: ``ReplayRun.stopped``)."""
        res = {}
        for name, y in sim.items():
            meas = self.data.input if name == self.data.input_name else self.data.signals[name]
            res[name] = np.asarray(meas, dtype=float)[:len(y)] - y
        return res

    def measured(self, name: str) -> np.ndarray:
        return np.asarray(self.data.input if name == self.data.input_name else self.data.signals[name],
                          dtype=float)
