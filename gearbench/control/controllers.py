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

COMPENSATORS = ("none", "thesis_shift", "setpoint_direction", "direction_feedforward")
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
  cannot remove.
"""

KINDS = {"open": L.CTRL_OPEN, "bang_bang": L.CTRL_BANGBANG, "p": L.CTRL_P,
         "pi": L.CTRL_PI, "pid": L.CTRL_PID}


@dataclass(frozen=True)
class Controller:
    """A feedback law on the motor-side angle, with the optional set-point shift.

    kind: ``bang_bang``, ``p``, ``pi``, ``pid`` (or ``open``: no feedback);
    kp (V/deg), ki (1/s), kd (s), derivative_filter_s (s), band_deg (deg);
    shift: apply thesis Equation 1; shift_deg: its size (deg), default half
    the clearance; compensator: ``none``, ``thesis_shift`` or
    ``setpoint_direction`` (see ``COMPENSATORS``); ``shift=True`` with
    ``compensator="none"`` is the thesis shift (the historical spelling).
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
        if self.compensator not in COMPENSATORS:
            raise ValueError(f"compensator must be one of {', '.join(COMPENSATORS)}, "
                             f"got {self.compensator!r}")

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


def pack_controller(ctrl: Controller, backlash_deg: float, p: np.ndarray) -> np.ndarray:
    """Fill the controller slots of ``p`` (SI: V/rad, 1/s, s, rad)."""
    per_rad = 180.0 / math.pi
    p[L.P_CTRL] = KINDS[ctrl.kind]
    p[L.P_KP] = ctrl.kp * per_rad
    p[L.P_KI] = ctrl.ki
    p[L.P_KD] = ctrl.kd
    p[L.P_TF] = ctrl.derivative_filter_s
    p[L.P_BAND] = math.radians(ctrl.band_deg) / 2.0
    comp = ctrl.effective_compensator
    if comp != "none":
        shift = ctrl.shift_deg if ctrl.shift_deg is not None else backlash_deg / 2.0
        p[L.P_SHIFT] = math.radians(shift)
    else:
        p[L.P_SHIFT] = 0.0
    p[L.P_COMP] = L.COMP_DIRECTION if comp in ("setpoint_direction", "direction_feedforward") else L.COMP_THESIS
    p[L.P_FF] = 0.0
    if comp == "direction_feedforward" and p[L.P_TORQUE_IN] == 0.0:
        n, b = p[L.P_N], p[L.P_BM] + p[L.P_BL] / p[L.P_N] ** 2
        p[L.P_FF] = n * (p[L.P_KE] + p[L.P_R] * b / p[L.P_KT])
    return p
