"""``stribeck_friction``: breakaway friction that falls to the Coulomb level.

    T_f = -(T_c + (T_s - T_c) exp(-|w| / w_s)) sign(w)

``static_torque`` T_s (N m) >= ``coulomb_torque`` T_c (N m; a T_s below T_c
acts as T_c), ``stribeck_speed``
w_s (rad/s); at the carriage: ``static_force``, ``coulomb_force`` (N) and
``stribeck_speed_m_s`` (m/s).  At rest it holds any torque up to T_s.  By
default (``model: stick_slip``) stick and slip are modes with located events
(``plant/friction.py``); ``model: regularized`` smooths the sign as
``tanh(w / eps)``, as ``coulomb_friction`` does.
"""
import math

import numba as nb

from .base import Effect, Param, register
from .location import LOCATIONS, at_shaft, key, speed_scale, stick_slip_floor, torque_scale


@nb.njit(cache=True, inline="always", _nrt=False)
def torque(p, o, theta, w, eps):
    """Friction torque on the body turning at ``w`` (rad/s), N m; ``p[o]`` the
    breakaway level, ``p[o + 1]`` the Coulomb level (N m), ``p[o + 2]`` the
    Stribeck speed (rad/s)."""
    t_s, t_c, w_s = p[o], p[o + 1], p[o + 2]
    if w_s <= 0.0:
        return 0.0
    # a breakaway below the sliding level is not Stribeck's curve: it adds nothing
    return -(t_c + max(t_s - t_c, 0.0) * math.exp(-abs(w) / w_s)) * math.tanh(w / eps)


@nb.njit(cache=True, inline="always", _nrt=False)
def stick_slip(p, o, s, w):
    """Stick-slip law, either direction: ``T_c + (T_s - T_c) exp(-|w|/w_s)``
    while slipping, breakaway ``max(T_s, T_c)`` at rest, N m."""
    t_s, t_c, w_s = p[o], p[o + 1], p[o + 2]
    if w_s <= 0.0:
        return 0.0, 0.0
    return t_c + max(t_s - t_c, 0.0) * math.exp(-abs(w) / w_s), max(t_s, t_c)


def _breakaway_scale(plant, values):
    return 1.5 * torque_scale(plant, values)


def _stribeck_speed(plant, values):
    return 0.05 * speed_scale(plant, values)


@register
class StribeckFriction(Effect):
    """Stribeck friction: breakaway above the Coulomb level, decaying with speed."""
    name = "stribeck_friction"
    signature = "stick and breakaway"
    acts_on = "motor or load torque"
    options = {"location": LOCATIONS}
    settings = {"model": ("stick_slip", "regularized")}
    params = (
        Param("static_torque", "N m (N at the carriage: static_force)", 0.0, 1e6, _breakaway_scale,
              "breakaway level T_s", carriage="static_force"),
        Param("coulomb_torque", "N m (N at the carriage: coulomb_force)", 0.0, 1e6, torque_scale,
              "sliding level T_c", carriage="coulomb_force", fit_low=stick_slip_floor),
        Param("stribeck_speed", "rad/s (m/s at the carriage: stribeck_speed_m_s)", 1e-9, 1e6,
              _stribeck_speed, "speed w_s over which T_s decays to T_c", carriage="stribeck_speed_m_s"),
    )
    term = torque
    friction = stick_slip
    places = ("motor", "load")
    slots = ("static torque, N m", "Coulomb torque, N m", "Stribeck speed, rad/s")

    def simpler(self, values):
        """Coulomb friction at the sliding level (T_s = T_c)."""
        out = {"location": values.get("location", "load")}
        out[key(values, "torque")] = values[key(values, "coulomb_torque")]
        if "model" in values:
            out["model"] = values["model"]
        return "coulomb_friction", out

    def compiled(self, values, plant):
        loc, ts = at_shaft(values, plant, "static_torque", 1)
        tc = at_shaft(values, plant, "coulomb_torque", 1)[1]
        ws = at_shaft(values, plant, "stribeck_speed", -1)[1]
        return loc, (ts, tc, ws)

    def piecewise_linear(self, values):
        """Only without friction (levels 0)."""
        return all(float(values[key(values, k)]) == 0.0 for k in ("static_torque", "coulomb_torque"))

    def steady_drag(self, values, plant):
        """The sliding level: at speed the breakaway excess has decayed (exact for |w| >> w_s)."""
        loc, tc = at_shaft(values, plant, "coulomb_torque", 1)
        return loc, 0.0, tc
