"""The effects' share of the right-hand side, compiled: one call per place.

Each function sums the effects acting at one place; an absent effect has
zero parameters and adds nothing (the friction regularisation speeds are
always positive, so no branch is needed to skip them).
"""
import numba as nb

from ... import layout as L
from . import (amplifier_deadzone, coulomb_friction, load_spring,
               stribeck_friction, viscous_friction)


@nb.njit(cache=True, inline="always", _nrt=False)
def motor_torque(p, w):
    """Torque of the effects on the rotor turning at ``w`` (rad/s), N m."""
    eps = p[L.P_FRIC_EPS_M]
    return (coulomb_friction.torque(w, eps, p[L.P_COUL_M], p[L.P_COUL_M_NEG])
            + stribeck_friction.torque(w, eps, p[L.P_STR_TS_M], p[L.P_STR_TC_M], p[L.P_STR_WS_M])
            + viscous_friction.torque(w, p[L.P_VISC_M], p[L.P_VISC_M_NEG]))


@nb.njit(cache=True, inline="always", _nrt=False)
def load_torque(p, theta, w):
    """Torque of the effects on the output shaft at angle ``theta`` (rad) and speed ``w`` (rad/s), N m."""
    eps = p[L.P_FRIC_EPS_L]
    return (coulomb_friction.torque(w, eps, p[L.P_COUL_L], p[L.P_COUL_L_NEG])
            + stribeck_friction.torque(w, eps, p[L.P_STR_TS_L], p[L.P_STR_TC_L], p[L.P_STR_WS_L])
            + viscous_friction.torque(w, p[L.P_VISC_L], p[L.P_VISC_L_NEG])
            + load_spring.torque(theta, p[L.P_SPRING_K], p[L.P_SPRING_TH0])
            + p[L.P_BIAS])


@nb.njit(cache=True, inline="always", _nrt=False)
def input_voltage(p, u):
    """The voltage the motor sees for command ``u`` (V), before saturation."""
    return amplifier_deadzone.voltage(u, p[L.P_DEADZONE])
