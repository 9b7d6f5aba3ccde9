"""``viscous_friction``: friction proportional to speed.

    T_f = -c w                   (c- instead of c when w < 0, if given)

``coefficient`` c in N m s/rad at the motor or load shaft, N s/m at the
carriage; ``coefficient_negative`` makes it asymmetric (EMPS's Fv+ / Fv-).
"""
import numba as nb

from .base import Effect, Param, register
from .location import LOCATIONS, at_shaft, key, coefficient_scale


@nb.njit(cache=True, inline="always", _nrt=False)
def torque(p, o, theta, w, eps):
    """Viscous friction torque on the body turning at ``w`` (rad/s), N m;
    coefficients ``p[o]`` forward, ``p[o + 1]`` backward (N m s/rad)."""
    return -(p[o] if w >= 0.0 else p[o + 1]) * w


@register
class ViscousFriction(Effect):
    """Viscous friction, proportional to speed."""
    name = "viscous_friction"
    signature = "speed"
    acts_on = "motor or load torque"
    options = {"location": LOCATIONS}
    params = (
        Param("coefficient", "N m s/rad (N s/m at the carriage)", 0.0, 1e9, coefficient_scale,
              "friction per unit speed (forward, or both ways)", carriage="coefficient"),
        Param("coefficient_negative", "N m s/rad (N s/m at the carriage)", 0.0, 1e9, coefficient_scale,
              "coefficient moving backward when asymmetric", optional=True,
              carriage="coefficient_negative"),
    )
    term = torque
    places = ("motor", "load")
    slots = ("coefficient forward, N m s/rad", "coefficient backward, N m s/rad")

    def simpler(self, values):
        """The symmetric form, when asymmetric."""
        neg = key(values, "coefficient_negative")
        if neg not in values:
            return None
        return self.name, {k: v for k, v in values.items() if k != neg}

    def compiled(self, values, plant):
        loc, c = at_shaft(values, plant, "coefficient", 2)
        cn = at_shaft(values, plant, "coefficient_negative", 2)[1] if (
            "coefficient_negative" in values) else c
        return loc, (c, cn)

    def piecewise_linear(self, values):
        """Linear when symmetric."""
        neg = key(values, "coefficient_negative")
        return neg not in values or float(values[neg]) == float(values[key(values, "coefficient")])

    def linear(self, values, plant):
        """Linear when symmetric."""
        if not self.piecewise_linear(values):
            return None
        loc, c = at_shaft(values, plant, "coefficient", 2)
        return loc, 0.0, c

    def steady_drag(self, values, plant):
        loc, c = at_shaft(values, plant, "coefficient", 2)
        return loc, c, 0.0
