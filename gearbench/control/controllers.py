"""Controllers as typed objects; ``laws.py`` holds their compiled equations.

Gains carry the thesis's units at the edge: the error is in output degrees,
so ``kp`` is in V/deg (Kp = 50 gives 50 V per degree of motor-side error),
``ki`` in 1/s (PI as the thesis writes it: ``Kp (e + Ki int e)``), ``kd`` in s,
``band_deg`` the bang-bang dead band (no output while ``|e| <= band/2``).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import layout as L
from ..errors import ConfigError
from ..schema import Choice, Number, is_number, show

COMPENSATORS = ("none", "thesis_shift", "setpoint_direction", "direction_feedforward", "damped_feedforward")
"""Backlash compensators (each adds the set-point shift, thesis Equation 1, of
``shift_deg``; they differ in what decides its sign):

* ``none``: no shift;
* ``thesis_shift``: the sign of the motor speed (the thesis's; every overshoot
  reverses the speed, flips the shift by twice its size and drives chatter);
* ``setpoint_direction``: the direction the set point last moved (the sign of
  the ramp's slope, or of the step that opens a dwell), held through dwells.
  The profile is known ahead, so the sign changes only at the profile's
  corners, never on an overshoot: the shift becomes a pure feedforward of the
  clearance, like a backlash inverse (Tao & Kokotovic) keyed to the commanded
  direction instead of the measured one;
* ``direction_feedforward``: ``setpoint_direction`` plus a velocity
  feedforward ``Kff dr/dt``, ``Kff = N (ke + R b / kt)`` V per rad/s of the
  set point's speed at the output, ``b = bm + bl/N^2`` (the voltage that holds
  the ramp's speed against back-emf and viscous load, engaged, in steady
  state; model-based, from the plant).  On the thesis's heavily damped valve
  the error left after the shift is mostly lag on the ramps, which a shift
  cannot remove;
* ``damped_feedforward``: ``direction_feedforward`` plus rate damping
  ``Kr (dr/dt - w_m/N)`` (V; ``w_m`` the rate of the measured motor angle,
  rad/s, as a tachometer gives it), with ``Kr = R bl / (kt N)`` V per rad/s at
  the output (``bl/(g N)`` N m per rad/s with a torque drive of gain ``g``).
  It puts back, electrically, the load's damping that the motor loses when
  the teeth part.  See below.

Why ``damped_feedforward`` (voltage drive; SI units, motor side).  With the
teeth in contact the load's damping reflects to the rotor as ``bl/N^2``
(thesis plant: 15/100^2 = 1.5e-3 N m s/rad, 9.3 times the motor's own
electrical damping ``kt ke / R`` = 1.6e-4 N m s/rad).  When the teeth part it is
gone, and the motor alone under ``u = K (r - theta_m/N)`` (``K`` in V/rad at
the output) has the characteristic polynomial

    L Jm s^3 + (R Jm + L bm) s^2 + (R bm + kt ke) s + kt K/N,

which Routh-Hurwitz makes stable only for
``K/N < (R Jm + L bm)(R bm + kt ke) / (L Jm kt)``: Kp < 87.8 V/deg on the
thesis plant, against 1448 V/deg engaged (``gearbench stability``).  At
Kp = 200 V/deg the motor is an oscillator inside the clearance, and the
+-Vmax saturation bounds it: its describing function
``n(A) = (2/pi) [asin(a/A) + (a/A) sqrt(1 - (a/A)^2)]``, ``a = Vmax/K``,
predicts a limit cycle where ``Kp n(A)`` equals the 87.8 V/deg limit, at the
phase-crossover frequency ``sqrt((R bm + kt ke)/(L Jm))`` = 634 rad/s
(101 Hz): ``a`` = 0.060 deg, ``A`` = 0.17 deg (simulated: 0.18 deg, 98 Hz;
tests/test_compensators.py).  That is the hunt of profile 3's dwell (the
load, pushed 0.18 deg past the set point by the step, leaves the motor's
target inside the clearance; ~370 voltage sign changes in 2 s).

The rate term adds ``kt Kr/N`` to the ``s`` coefficient (below ``R/L`` the
winding turns ``-Kr w_m/N`` volts into ``-(kt/R)(Kr/N) w_m`` of torque), and
``Kr = R bl/(kt N)`` makes that exactly ``R bl/N^2``: the coefficient becomes
the engaged one, ``R (bm + bl/N^2) + kt ke``, and the teeth-apart limit rises
to 906 V/deg (thesis plant; the engaged one to 2755 V/deg), damping ratio
~0.5 at Kp = 200.  Since ``n(A) <= 1``, ``Kp n(A)`` stays below the limit for
every amplitude: the describing function predicts no limit cycle at any gain
below 906 V/deg, and the free motor settles on its target.  ``Kr`` comes from
the plant alone (no tuning, the same for every gain, profile and P/PI).  It
acts on the error rate, ``dr/dt`` the segment's slope: zero on a tracked
ramp (the feedforward keeps carrying it), and a set-point step is not
differentiated (no derivative kick).  The rhs stays continuous (a linear term
in the state): no new event.  A differentiated encoder would need a filter
whose lag is small at ~1000 rad/s; this models the ideal rate.
"""

KINDS = {"open": L.CTRL_OPEN, "bang_bang": L.CTRL_BANGBANG, "p": L.CTRL_P,
         "pi": L.CTRL_PI, "pid": L.CTRL_PID}


KIND_NAMES = {"open": "open", "bang_bang": "bang-bang", "p": "P", "pi": "PI", "pid": "PID"}
"""How tables, reports and figures name each kind (the one place they are written)."""


def kind_name(kind: str, kp: float | None = None) -> str:
    """``KIND_NAMES[kind]`` (an unknown kind as it is), then ``, Kp=50`` when ``kp``
    is a number (not None or NaN): ``kind_name("p", 50.0)`` is ``"P, Kp=50"``."""
    name = KIND_NAMES.get(kind, kind)
    if kp is not None and not (isinstance(kp, float) and math.isnan(kp)):
        name += f", Kp={kp:g}"
    return name


SETTINGS = {"open": (), "bang_bang": ("band_deg",), "p": ("kp",), "pi": ("kp", "ki"),
            "pid": ("kp", "ki", "kd", "derivative_filter_s")}
"""The settings each kind reads (the others must stay at their defaults)."""

SETTING_UNITS = {"kp": ("V/deg", True), "ki": ("1/s", False), "kd": ("s", False),
          "derivative_filter_s": ("s", True), "band_deg": ("deg", True)}
"""Each setting's unit and whether it must be > 0 (else >= 0), as in an experiment file."""


@dataclass(frozen=True)
class Controller:
    """A feedback law on the motor-side angle, with the optional set-point shift.

    The error is the set point minus the motor angle referred to the output,
    ``e = r - theta_m/N`` in output degrees, so the gains are in the units of
    an experiment file's ``controllers`` entries: ``u = Kp e`` (P),
    ``Kp (e + Ki int e)`` (PI), ``Kp (e + Ki int e + Kd de_f/dt)`` (PID, the
    derivative filtered with time constant ``Tf``), ``Vmax sign(e)`` outside
    the dead band (bang-bang); every output saturates at the motor's
    ``max_voltage``.  Every setting is checked when the controller is made.

    Parameters
    ----------
    kind : str
        ``bang_bang``, ``p``, ``pi``, ``pid``, or ``open`` (no feedback: the
        input segments are the motor voltage, V).
    kp : float
        Proportional gain, V/deg (> 0; ``p``, ``pi``, ``pid``).
    ki : float
        Integral gain of ``Kp (e + Ki int e)``, 1/s (>= 0; ``pi``, ``pid``).
    kd : float
        Derivative gain of ``Kp (... + Kd de_f/dt)``, s (>= 0; ``pid``).
    derivative_filter_s : float
        Time constant ``Tf`` of the derivative filter, s (> 0; ``pid``).
    band_deg : float
        Bang-bang dead band, deg: no output while ``|e| <= band_deg/2`` (> 0).
    shift : bool
        Apply the set-point shift of thesis Equation 1 (``shift=True`` with
        ``compensator="none"`` is ``compensator="thesis_shift"``).
    shift_deg : float or None
        Size of the shift, deg (>= 0, at most the clearance); None: half the
        clearance ``gear.backlash_deg / 2``.
    compensator : str
        Backlash compensator, one of ``COMPENSATORS`` (see there).

    Raises
    ------
    ConfigError
        Naming every bad setting and its unit; a setting the kind does not
        read (``ki`` of a P controller) must stay at its default.

    Examples
    --------
    >>> from gearbench import Controller
    >>> Controller("pi", kp=50, ki=0.005).kind
    'pi'
    >>> Controller("p", kp=-5)
    Traceback (most recent call last):
    ...
    gearbench.errors.ConfigError: Controller: kp must be a positive number in V/deg, got -5
    """
    kind: str
    kp: float = 0.0
    ki: float = 0.0
    kd: float = 0.0
    derivative_filter_s: float = 1e-3
    band_deg: float = 0.25
    shift: bool = False
    shift_deg: float | None = None
    compensator: str = "none"

    def __post_init__(self):
        problems = self.problems()
        if problems:
            raise ConfigError("Controller", problems)

    def problems(self) -> list[str]:
        """Every bad setting, one text each naming it and its unit (empty when valid)."""
        problems: list[str] = []
        if Choice(tuple(KINDS)).check(self.kind, "kind", problems) is None:
            return problems
        reads = SETTINGS[self.kind]
        defaults = {f: Controller.__dataclass_fields__[f].default for f in SETTING_UNITS}
        for name, (unit, positive) in SETTING_UNITS.items():
            value = getattr(self, name)
            if name in reads:
                Number(unit, low=0.0, low_strict=positive).check(value, name, problems)
            elif not (is_number(value) and value == defaults[name]):
                problems.append(f"{name} does not apply to a {self.kind} controller (it reads "
                                f"{', '.join(reads) or 'no setting'}); leave it at its default "
                                f"{defaults[name]!r}, got {show(value)}")
        if not isinstance(self.shift, (bool, np.bool_)):
            problems.append(f"shift must be a boolean, got {show(self.shift)}")
        if self.shift_deg is not None:
            Number("deg", low=0.0, low_strict=False).check(self.shift_deg, "shift_deg", problems)
        Choice(COMPENSATORS).check(self.compensator, "compensator", problems)
        if self.kind == "open" and (self.shift is True or self.compensator != "none"):
            problems.append("shift and compensator do not apply to an open controller (no feedback)")
        return problems

    @property
    def effective_compensator(self) -> str:
        """``compensator``, or ``thesis_shift`` when only ``shift`` is set."""
        if self.compensator == "none" and self.shift:
            return "thesis_shift"
        return self.compensator

    @property
    def label(self) -> str:
        """Short name for tables: ``bang_bang``, ``p``, ``pi``, ``pid``."""
        return self.kind


def pack_controller(ctrl: Controller, plant, p: np.ndarray) -> np.ndarray:
    """Fill the controller slots of ``p`` (SI: V/rad, 1/s, s, rad) for the
    resolved ``plant`` (``Plant.resolved()``: its clearance may come from the
    ``backlash`` effect).  The default shift is half the clearance; the
    feedforward compensators' gains come from the plant's motor and drag."""
    per_rad = 180.0 / math.pi
    p[L.P_CTRL] = KINDS[ctrl.kind]
    p[L.P_KP] = ctrl.kp * per_rad
    p[L.P_KI] = ctrl.ki
    p[L.P_KD] = ctrl.kd
    p[L.P_TF] = ctrl.derivative_filter_s
    p[L.P_BAND] = math.radians(ctrl.band_deg) / 2.0
    comp = ctrl.effective_compensator
    if comp != "none":
        shift = ctrl.shift_deg if ctrl.shift_deg is not None else plant.gear.backlash_deg / 2.0
        p[L.P_SHIFT] = math.radians(shift)
    else:
        p[L.P_SHIFT] = 0.0
    keyed = ("setpoint_direction", "direction_feedforward", "damped_feedforward")
    p[L.P_COMP] = L.COMP_DIRECTION if comp in keyed else L.COMP_THESIS
    p[L.P_FF] = 0.0
    m, n, bl = plant.motor, plant.gear.ratio, plant.output_damping
    voltage = plant.drive == "voltage"
    if comp in ("direction_feedforward", "damped_feedforward") and voltage:
        b = m.damping + bl / n ** 2
        p[L.P_FF] = n * (m.back_emf_constant + m.resistance * b / m.torque_constant)
    p[L.P_KRATE] = 0.0
    if comp == "damped_feedforward":
        # the rotor torque that stands in for the load's damping bl/N^2 when the teeth part
        per_volt = m.torque_constant / m.resistance if voltage else plant.drive_gain
        p[L.P_KRATE] = bl / (per_volt * n)
    return p
