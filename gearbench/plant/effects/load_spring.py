"""``load_spring``: a spring on the load, such as a valve's return spring.

    T = -k (theta_l - theta_0)

``stiffness`` k in N m/rad at the output shaft, ``rest_angle_deg`` theta_0
in degrees of the output (0 = where the record starts).
"""
import math

import numba as nb

from .base import Effect, Param, register


@nb.njit(cache=True, inline="always", _nrt=False)
def torque(p, o, theta, w, eps):
    """Spring torque on the load at output angle ``theta`` (rad), N m; stiffness
    ``p[o]`` (N m/rad), rest angle ``p[o + 1]`` (rad)."""
    return -p[o] * (theta - p[o + 1])


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
    term = torque
    places = ("load",)
    slots = ("stiffness, N m/rad", "rest angle, rad")

    def compiled(self, values, plant):
        return "load", (float(values["stiffness"]), math.radians(float(values["rest_angle_deg"])))

    def piecewise_linear(self, values):
        return True

    def linear(self, values, plant):
        return "load", float(values["stiffness"]), 0.0
