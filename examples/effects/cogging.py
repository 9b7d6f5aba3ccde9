"""``cogging``: a torque that repeats with a shaft's angle -- the detent torque
of a permanent-magnet motor, or a load with a lumpy cam or a pump's pistons.

    T = a sin(n theta + phi)          (N m, on the shaft named by ``location``)

* ``theta`` (rad): the angle of that shaft -- the rotor's for ``location: motor``,
  the output shaft's for ``location: load`` -- counted from where the record
  starts (0 there);
* ``amplitude`` a (N m, >= 0): the peak torque;
* ``periods_per_rev`` n (an integer): periods per revolution of that shaft (a
  motor with 12 slots and 8 poles cogs lcm(12, 8) = 24 times per turn);
* ``phase_deg`` phi (deg): where in its period the record starts.

It averages to zero over a revolution, so it has no steady drag.  ``n`` is a
count a least-squares fit cannot move: ``estimate`` reads it (and a starting
phase) off the record, as the order of the strongest ripple in the shaft's
acceleration against its angle (``gearbench.plant.effects.periodic``).

In a plant file (next to ``effect_modules: [path/to/cogging.py]``)::

    effects:
      - {type: cogging, location: motor, amplitude: 0.01, periods_per_rev: 24, phase_deg: 0}
"""
import math

import numba as nb
import numpy as np
from scipy.signal import savgol_filter

from gearbench.plant.effects import Effect, Param, register
from gearbench.plant.effects import periodic
from gearbench.plant.effects.location import torque_scale


@nb.njit(cache=True, inline="always", _nrt=False)
def torque(p, o, theta, w, eps):
    """Cogging torque at shaft angle ``theta`` (rad), N m: ``p[o] sin(p[o + 1] theta + p[o + 2])``,
    amplitude ``p[o]`` (N m), ``p[o + 1]`` periods per revolution, phase ``p[o + 2]`` (rad)."""
    return p[o] * math.sin(p[o + 1] * theta + p[o + 2])


def _angle_rad(measured, values, plant):
    """The measured angle of the shaft the cogging acts on, rad (None when not measured)."""
    n = plant.gear.ratio
    if values.get("location", "load") == "motor":
        if "motor_angle_deg" in measured:
            return np.radians(np.asarray(measured["motor_angle_deg"], dtype=float))
        if "load_angle_deg" in measured:
            return np.radians(np.asarray(measured["load_angle_deg"], dtype=float)) * n
    elif "load_angle_deg" in measured:
        return np.radians(np.asarray(measured["load_angle_deg"], dtype=float))
    return None


@register
class Cogging(Effect):
    """A torque periodic in a shaft's angle, a sin(n theta + phi) (cogging, detent torque)."""
    name = "cogging"
    signature = "position"
    acts_on = "motor or load torque"
    options = {"location": ("motor", "load")}
    params = (
        Param("amplitude", "N m", 0.0, 1e6, torque_scale, "peak cogging torque on the shaft"),
        Param("periods_per_rev", "1/rev", 1.0, 1e4, 6.0,
              "periods per revolution of that shaft (a whole number)", integer=True),
        Param("phase_deg", "deg", -720.0, 720.0, 90.0, "phase where the record starts (theta = 0)", start=0.0),
    )
    term = torque
    places = ("motor", "load")
    slots = ("amplitude, N m", "periods per revolution (per rad of the shaft)", "phase, rad")

    def compiled(self, values, plant):
        return values.get("location", "load"), (float(values["amplitude"]), float(values["periods_per_rev"]),
                                                math.radians(float(values["phase_deg"])))

    def piecewise_linear(self, values):
        """A sine of the angle is not affine in the state: the solver re-evaluates its Jacobian."""
        return False

    def steady_drag(self, values, plant):
        """None: over a revolution it averages to zero."""
        return None

    def estimate(self, values, measured, plant):
        """``periods_per_rev`` and a starting ``phase_deg``, read off the record: the shaft's
        acceleration (per sample, from its measured angle) less what the drive explains (a
        least-squares blend of the current, the speed and a constant), projected on each order
        of the angle; the strongest ripple is the cogging (acceleration = T / J)."""
        theta = _angle_rad(measured, values, plant)
        if theta is None or theta.size < 101:
            return None
        speed, mask = periodic.moving(theta)
        accel = savgol_filter(theta, 21, 3, deriv=2)
        drive = [np.ones(theta.size), speed]
        if "current_A" in measured:
            drive.append(savgol_filter(np.asarray(measured["current_A"], dtype=float), 21, 3))
        a = np.column_stack(drive)[mask]
        coef, *_ = np.linalg.lstsq(a, accel[mask], rcond=None)
        rest = np.zeros_like(accel)
        rest[mask] = accel[mask] - a @ coef
        found = periodic.dominant(theta, rest, speed, mask)
        if found is None:
            return None
        n, _, phase = found
        return {"periods_per_rev": n, "phase_deg": phase}
