"""``lugre_friction``: dynamic friction with presliding (the LuGre model).

The contact is a brush of elastic bristles whose mean deflection ``z`` (rad of
the shaft it acts on) is the effect's own state (Canudas de Wit, Olsson, Astrom
and Lischinsky, IEEE TAC 40(3), 1995)::

    dz/dt = w - sigma0 |w| z / g(w)
    g(w)  = T_c + (T_s - T_c) exp(-|w| / w_s)
    T_f   = -(sigma0 z + sigma1 dz/dt + sigma2 w)

``coulomb_torque`` T_c and ``static_torque`` T_s (N m), ``stribeck_speed``
w_s (rad/s; the exponent 1, as ``stribeck_friction``), ``bristle_stiffness``
sigma0 (N m/rad), ``bristle_damping`` sigma1 (N m s/rad), optional
``viscous_coefficient`` sigma2 (N m s/rad), on the rotor (``location: motor``)
or the output shaft (``load``).

What it adds to ``stribeck_friction``: below breakaway a shaft is not stuck but
held by the bristles' spring, so a torque ``T < T_s`` turns it by about
``T / sigma0`` and it springs back (presliding); breakaway is a smooth
transition with the bristles' lag, with no events.  In steady sliding
``z = g(w) sign(w) / sigma0`` and the torque is Stribeck's curve plus
``sigma2 w``.  Starting from ``z = 0`` the deflection stays within
``T_s / sigma0``.  As sigma0 grows it tends to ``stribeck_friction``'s
stick-slip law, which ``simpler`` offers.  ``diagnose`` tries it only when asked
for (``--also lugre_friction``, ``on_request``): it refines what Stribeck friction
explains, and its bristles' parameters are costly to fit.
"""
import math

import numba as nb

from .base import Effect, Param, register
from .location import coefficient_scale, speed_scale, torque_scale


@nb.njit(cache=True, inline="always", _nrt=False)
def bristle_rate(p, o, theta, w, z):
    """``dz/dt`` (rad/s) at speed ``w`` (rad/s) and deflection ``z`` (rad); ``p[o:o + 6]`` =
    T_c, T_s (N m), w_s (rad/s), sigma0 (N m/rad), sigma1, sigma2 (N m s/rad)."""
    t_c, t_s, w_s, s0 = p[o], p[o + 1], p[o + 2], p[o + 3]
    g = t_c + max(t_s - t_c, 0.0) * math.exp(-abs(w) / w_s)
    if g <= 0.0:
        return 0.0  # no dry friction: the bristles stay unloaded
    return w - s0 * abs(w) * z / g


@nb.njit(cache=True, inline="always", _nrt=False)
def torque(p, o, theta, w, eps, z):
    """Friction torque on the body turning at ``w`` (rad/s) with the bristles deflected by
    ``z`` (rad), N m."""
    return -(p[o + 3] * z + p[o + 4] * bristle_rate(p, o, theta, w, z) + p[o + 5] * w)


def _inertia(plant, values):
    return plant.motor_inertia_total if values.get("location", "load") == "motor" else plant.output_inertia


PRESLIDING_RAD = 1e-3
"""A typical presliding turn at breakaway, rad of the output (N times that at the rotor), as the
typical torques and speeds are scaled from the output (``location.torque_scale``, ``speed_scale``)."""


def _stiffness(plant, values):
    """Breakaway after a presliding turn of PRESLIDING_RAD of the output."""
    turn = PRESLIDING_RAD * (plant.gear.ratio if values.get("location", "load") == "motor" else 1.0)
    return 1.5 * torque_scale(plant, values) / turn


def _damping(plant, values):
    """The bristles' spring on the shaft's inertia, damped at half critical."""
    return math.sqrt(_stiffness(plant, values) * _inertia(plant, values))


@register
class LuGreFriction(Effect):
    """LuGre friction: bristles that hold the shaft elastically below breakaway (presliding)."""
    name = "lugre_friction"
    signature = "stick and breakaway"
    acts_on = "motor or load torque"
    options = {"location": ("motor", "load")}
    params = (
        Param("coulomb_torque", "N m", 0.0, 1e6, torque_scale, "sliding level T_c"),
        Param("static_torque", "N m", 0.0, 1e6, lambda plant, values: 1.5 * torque_scale(plant, values),
              "breakaway level T_s"),
        Param("stribeck_speed", "rad/s", 1e-9, 1e6, lambda plant, values: 0.05 * speed_scale(plant, values),
              "speed w_s over which T_s decays to T_c"),
        Param("bristle_stiffness", "N m/rad", 1e-9, 1e12, _stiffness, "sigma0: presliding stiffness"),
        Param("bristle_damping", "N m s/rad", 0.0, 1e9, _damping, "sigma1: damping of the bristles' motion"),
        Param("viscous_coefficient", "N m s/rad", 0.0, 1e6, coefficient_scale, "sigma2: viscous friction",
              optional=True),
    )
    term = torque
    rate = bristle_rate
    state = "bristle deflection, rad"
    places = ("motor", "load")
    slots = ("Coulomb torque, N m", "static torque, N m", "Stribeck speed, rad/s",
             "bristle stiffness, N m/rad", "bristle damping, N m s/rad", "viscous coefficient, N m s/rad")
    on_request = True

    def compiled(self, values, plant):
        return values.get("location", "load"), tuple(float(values.get(q.name, 0.0)) for q in self.params)

    def state_scale(self, values, plant):
        """The deflection at breakaway, T_s / sigma0 (rad)."""
        ts = max(float(values["static_torque"]), float(values["coulomb_torque"]))
        return ts / float(values["bristle_stiffness"]) if ts > 0.0 else 1.0

    def simpler(self, values):
        """Stribeck friction's stick-slip law (infinitely stiff bristles), when there is no viscous part."""
        if float(values.get("viscous_coefficient", 0.0)) != 0.0:
            return None
        return "stribeck_friction", {"location": values.get("location", "load"),
                                     **{k: values[k] for k in ("static_torque", "coulomb_torque", "stribeck_speed")}}

    def steady_drag(self, values, plant):
        return values.get("location", "load"), float(values.get("viscous_coefficient", 0.0)), float(
            values["coulomb_torque"])
