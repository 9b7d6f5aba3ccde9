"""``viscous_friction``: friction proportional to speed.

    T_f = -c w                   (c- instead of c when w < 0, if given)

``coefficient`` c in N m s/rad at the motor or load shaft, N s/m at the
carriage; ``coefficient_negative`` makes it asymmetric (EMPS's Fv+ / Fv-).
"""
import numba as nb

from ... import layout as L
from .base import Effect, Param, register
from .location import LOCATIONS, add, at_shaft, key, coefficient_scale, slot


@nb.njit(cache=True, inline="always", _nrt=False)
def torque(w, c_pos, c_neg):
    """Viscous friction torque on the body turning at ``w`` (rad/s), N m."""
    return -(c_pos if w >= 0.0 else c_neg) * w


@register
class ViscousFriction(Effect):
    """Viscous friction, proportional to speed."""
    name = "viscous_friction"
    signature = "speed"
    acts_on = "motor or load torque"
    options = {"location": LOCATIONS}
    params = (
        Param("coefficient", "N m s/rad (N s/m at the carriage)", 0.0, 1e9, coefficient_scale,
              "friction per unit speed (forward, or both ways)"),
        Param("coefficient_negative", "N m s/rad (N s/m at the carriage)", 0.0, 1e9, coefficient_scale,
              "coefficient moving backward when asymmetric", optional=True),
    )

    def simpler(self, values):
        """The symmetric form, when asymmetric."""
        neg = key(values, "coefficient_negative")
        if neg not in values:
            return None
        return self.name, {k: v for k, v in values.items() if k != neg}

    def pack(self, values, p, plant):
        loc, c = at_shaft(values, plant, "coefficient", 2)
        cn = at_shaft(values, plant, "coefficient_negative", 2)[1] if (
            "coefficient_negative" in values) else c
        add(p, slot(loc, L.P_VISC_M, L.P_VISC_L), c)
        add(p, slot(loc, L.P_VISC_M_NEG, L.P_VISC_L_NEG), cn)
