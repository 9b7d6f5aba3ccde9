"""``load_spring``: a spring on the load, such as a valve's return spring.

    T = -k (theta_l - theta_0)

``stiffness`` k in N m/rad at the output shaft, ``rest_angle_deg`` theta_0
in degrees of the output (0 = where the record starts).
"""
import math

import numba as nb

from ... import layout as L
from .base import Effect, Param, register


@nb.njit(cache=True, inline="always", _nrt=False)
def torque(theta_l, k, theta_0):
    """Spring torque on the load at output angle ``theta_l`` (rad), N m."""
    return -k * (theta_l - theta_0)


def _stiffness_scale(plant, values):
    # a spring that takes a tenth of the output torque over a radian
    return 0.1 * plant.typical_torque * plant.gear.ratio


@register
class LoadSpring(Effect):
    """A linear spring pulling the load back to a rest angle."""
    name = "load_spring"
    signature = "position"
    acts_on = "load torque"
    params = (
        Param("stiffness", "N m/rad", 0.0, 1e12, _stiffness_scale, "spring rate at the output shaft"),
        Param("rest_angle_deg", "deg", -1e6, 1e6, 10.0, "output angle where the spring is relaxed",
              start=0.0),
    )

    def pack(self, values, p, plant):
        p[L.P_SPRING_K] += float(values["stiffness"])
        p[L.P_SPRING_TH0] = math.radians(float(values["rest_angle_deg"]))
