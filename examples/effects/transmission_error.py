"""``transmission_error``: a gear's once-per-tooth transmission error.

Real teeth are not perfect involutes: profile errors, tooth spacing and
deflection make the output lag or lead the ideal ``theta_m / N`` by a small
angle that repeats with every tooth.  Here the mesh's relative angle as the
contact sees it is offset by

    e(theta_l) = a sin(z theta_l + phi)        (rad at the output; a given in deg)

so the contact law acts on ``delta + e(theta_l)`` (``delta = theta_m / N - theta_l``,
the wind-up of the mesh, rad at the output; ``gearbench.plant.rhs.mesh_seen``):

* ``theta_l`` (rad): the output angle, counted from where the record starts;
* ``amplitude_deg`` a (deg of output angle, >= 0): the peak error;
* ``teeth`` z (an integer): teeth of the output gear, one period per tooth;
* ``phase_deg`` phi (deg): where in a tooth period the record starts.

A **positive** e means the teeth touch early: the contact sees more wind-up
than the angles give, so on either flank the output angle sits e *higher*
(more positive) than the clearance alone would put it -- ahead of the motor
when turning forward, behind it when turning backward -- and the measured gap
``theta_m / N - theta_l`` is e smaller.  It needs a mesh (a plant with
mesh stiffness, not ``rigid: true``); it has no steady drag and is not
piecewise-linear.  ``z`` is a count a fit cannot move: ``estimate`` reads it
(and a starting phase) from the ripple of the measured gap against the output
angle (both angles must be measured).

In a plant file (next to ``effect_modules: [path/to/transmission_error.py]``)::

    effects:
      - {type: transmission_error, amplitude_deg: 0.05, teeth: 40, phase_deg: 0}
"""
import math

import numba as nb
import numpy as np

from gearbench.plant.effects import Effect, Param, register
from gearbench.plant.effects import periodic


@nb.njit(cache=True, inline="always", _nrt=False)
def offset(p, o, theta):
    """``(e, de/dtheta)`` at output angle ``theta`` (rad): ``e = p[o] sin(p[o + 1] theta + p[o + 2])``
    (rad), amplitude ``p[o]`` (rad), ``p[o + 1]`` teeth, phase ``p[o + 2]`` (rad)."""
    arg = p[o + 1] * theta + p[o + 2]
    return p[o] * math.sin(arg), p[o] * p[o + 1] * math.cos(arg)


@register
class TransmissionError(Effect):
    """A once-per-tooth offset a sin(z theta_l + phi) of the mesh's relative angle (transmission error)."""
    name = "transmission_error"
    signature = "lost motion"
    acts_on = "mesh angle"
    params = (
        Param("amplitude_deg", "deg", 0.0, 10.0, 0.01, "peak error, deg of output angle"),
        Param("teeth", "teeth", 1.0, 1e4, 40.0, "teeth on the output gear: periods per output turn",
              integer=True),
        Param("phase_deg", "deg", -720.0, 720.0, 90.0, "phase where the record starts (theta_l = 0)",
              start=0.0),
    )
    term = offset
    places = ("mesh",)
    slots = ("amplitude, rad", "teeth (periods per output revolution)", "phase, rad")

    def compiled(self, values, plant):
        return "mesh", (math.radians(float(values["amplitude_deg"])), float(values["teeth"]),
                        math.radians(float(values["phase_deg"])))

    def piecewise_linear(self, values):
        """A sine of the output angle is not affine in the state."""
        return False

    def steady_drag(self, values, plant):
        """None: the offset moves the contact, it takes no torque on average."""
        return None

    def applicable(self, plant, signals):
        """Only with a mesh: a rigid gear has no contact to offset."""
        return not plant.gear.rigid

    def estimate(self, values, measured, plant):
        """``teeth`` and a starting ``phase_deg``: the strongest ripple of the measured gap
        ``theta_m / N - theta_l`` (which is e smaller on either flank) against the output
        angle, over the moving samples, each flank's level taken out first (the flank: the
        gap's sign) and the samples crossing the clearance left out."""
        if "motor_angle_deg" not in measured or "load_angle_deg" not in measured:
            return None
        theta = np.radians(np.asarray(measured["load_angle_deg"], dtype=float))
        if theta.size < 101:
            return None
        gap = np.radians(np.asarray(measured["motor_angle_deg"], dtype=float)) / plant.gear.ratio - theta
        speed, mask = periodic.moving(theta)
        for flank in (gap > 0.0, gap <= 0.0):
            sel = mask & flank
            if sel.any():
                gap[sel] -= np.median(gap[sel])
        clearance = math.radians(plant.gear.backlash_deg)
        if clearance > 0.0:
            mask &= np.abs(gap) < 0.25 * clearance
        found = periodic.dominant(theta, -gap, speed, mask)  # -gap follows e
        if found is None:
            return None
        z, _, phase = found
        return {"teeth": z, "phase_deg": phase}
