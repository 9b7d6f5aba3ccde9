"""``bias_torque``: a constant torque on the load.

    T = T_b           (positive drives the output forward)

Gravity on an incline, a drive offset (EMPS's ``offset``, which resists:
``T_b = -offset``).  ``torque`` in N m at the output shaft, or ``force`` in N
with ``location: carriage`` on a leadscrew plant.
"""
import numba as nb

from .base import Effect, Param, register
from .location import at_shaft, torque_scale


@nb.njit(cache=True, inline="always", _nrt=False)
def torque(p, o, theta, w, eps):
    """The constant torque ``p[o]`` on the output shaft, N m."""
    return p[o]


def _scale(plant, values):
    return torque_scale(plant, values)


@register
class BiasTorque(Effect):
    """A constant torque (or carriage force) on the load."""
    name = "bias_torque"
    signature = "a constant"
    # while the load turns one way, dry friction is a constant too; a spring's rest angle is one
    confounders = ("coulomb_friction", "stribeck_friction", "load_spring")
    acts_on = "load torque"
    options = {"location": ("load", "carriage")}
    params = (Param("torque", "N m (N at the carriage: force)", -1e6, 1e6, _scale,
                    "constant torque, positive forward", carriage="force"),)
    term = torque
    places = ("load",)
    slots = ("torque, N m",)

    def compiled(self, values, plant):
        return "load", (at_shaft(values, plant, "torque", 1)[1],)

    def piecewise_linear(self, values):
        return True

    def steady_drag(self, values, plant):
        """It helps forward motion when positive."""
        return "load", 0.0, -at_shaft(values, plant, "torque", 1)[1]
