"""``coulomb_friction``: constant-magnitude friction opposing motion.

    T_f = -T_c sign(w)            (T_c- instead of T_c when w < 0, if given)

acting on the rotor (``location: motor``) or the output shaft (``load``), or
at the carriage as a force (``location: carriage``, ``force`` in N).  It sticks
below ``T_c``: at standstill it holds any torque up to ``T_c`` (``T_c-``
backward).  By default (``model: stick_slip``) stick and slip are modes with
located events (``plant/friction.py``): a stuck body does not move at all.
``model: regularized`` smooths the sign as ``tanh(w / eps)`` instead; ``eps``
is the solver's friction speed (``SolverOptions.friction_speed_rel`` times
the location's typical speed), and a stuck body creeps.
"""
import math

import numba as nb

from .base import Effect, Param, register
from .location import LOCATIONS, at_shaft, key, stick_slip_floor, torque_scale


@nb.njit(cache=True, inline="always", _nrt=False)
def torque(p, o, theta, w, eps):
    """Friction torque on the body turning at ``w`` (rad/s), N m; levels
    ``p[o]`` forward, ``p[o + 1]`` backward (N m)."""
    level = p[o] if w >= 0.0 else p[o + 1]
    if level == 0.0:
        return 0.0
    return -level * math.tanh(w / eps)


@nb.njit(cache=True, inline="always", _nrt=False)
def stick_slip(p, o, s, w):
    """Stick-slip law: ``(T_c, T_c)`` forward (``s`` = +1), ``(T_c-, T_c-)``
    backward, N m: the level while slipping, and the breakaway at rest."""
    level = p[o] if s > 0 else p[o + 1]
    return level, level


@register
class CoulombFriction(Effect):
    """Constant-magnitude (Coulomb) friction opposing motion, sticking below it."""
    name = "coulomb_friction"
    signature = "sign of the speed"
    acts_on = "motor or load torque"
    options = {"location": LOCATIONS}
    settings = {"model": ("stick_slip", "regularized")}
    params = (
        Param("torque", "N m (N at the carriage: force)", 0.0, 1e6, torque_scale,
              "friction level (moving forward, or both ways)", carriage="force", fit_low=stick_slip_floor),
        Param("torque_negative", "N m (N at the carriage: force_negative)", 0.0, 1e6, torque_scale,
              "level moving backward when friction is asymmetric", optional=True,
              carriage="force_negative", fit_low=stick_slip_floor),
    )
    term = torque
    friction = stick_slip
    places = ("motor", "load")
    slots = ("torque forward, N m", "torque backward, N m")

    def simpler(self, values):
        """The symmetric form, when asymmetric."""
        neg = key(values, "torque_negative")
        if neg not in values:
            return None
        return self.name, {k: v for k, v in values.items() if k != neg}

    def compiled(self, values, plant):
        loc, tc = at_shaft(values, plant, "torque", 1)
        tn = at_shaft(values, plant, "torque_negative", 1)[1] if (
            "torque_negative" in values or "force_negative" in values) else tc
        return loc, (tc, tn)

    def piecewise_linear(self, values):
        """Stick-slip: constant in each mode; regularized only without friction (levels 0)."""
        return values.get("model", "stick_slip") == "stick_slip" or all(float(values.get(key(values, k), 0.0)) == 0.0 for k in ("torque", "torque_negative"))

    def steady_drag(self, values, plant):
        loc, tc = at_shaft(values, plant, "torque", 1)
        return loc, 0.0, tc
