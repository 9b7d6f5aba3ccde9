"""``sensor_offset``: a constant on a measured signal.

    y_measured = y + offset

A current sensor's amplifier (a shunt's op-amp, a Hall sensor's zero) or a
potentiometer's wiper has one; the dynamics are untouched.  ``signal`` is the
measurement column, ``offset`` is in that column's unit: A on ``current_A``, deg on
an angle (``*_deg``), mm on a position (``*_mm``).  One parameter serves the three
units (a :class:`~gearbench.plant.effects.base.Param` has one unit), so its unit reads
"the signal's unit" and the column's suffix says which.

An offset on the angle a replay re-initialises from (the motor's, or the output's when
it is the only one) is seen through by the window resets, which compare the record with
the model's signal with its offset (``shifts``); it then shows in the first window only,
and a record that starts at rest tells it apart from a start away from zero only there.
"""
from __future__ import annotations

from .base import Effect, Param, register

SIGNALS = ("current_A", "motor_angle_deg", "load_angle_deg", "load_position_mm", "motor_position_mm")
UNITS = {"_A": "A", "_deg": "deg", "_mm": "mm"}
"""The offset's unit by the column's suffix."""


def unit(signal: str) -> str:
    """The unit of an offset on column ``signal`` (A, deg or mm)."""
    return next(u for suffix, u in UNITS.items() if signal.endswith(suffix))


def _scale(plant, values):
    """A typical offset: 1 % of the stall current (A), a tenth of a degree, a hundredth of a mm."""
    u = unit(values["signal"])
    if u == "A":
        return 0.01 * plant.typical_torque / plant.motor.torque_constant
    return 0.1 if u == "deg" else 0.01


@register
class SensorOffset(Effect):
    """A constant added to a measured signal (a current sensor's or a potentiometer's zero)."""
    name = "sensor_offset"
    causal = True  # each sample from the signal up to its time
    signature = "a constant offset"
    # a current's constant is a steady torque to the model (a bias, or dry friction while the load
    # turns one way); an angle's constant is what a spring's rest angle moves
    confounders = ("bias_torque", "coulomb_friction", "load_spring")
    acts_on = "measured signal"
    shifts = True
    options = {"signal": SIGNALS}
    params = (Param("offset", "the signal's unit (A for current_A, deg for an angle, mm for a position)",
                    -1e6, 1e6, _scale, "constant added to the measured signal, signed", start=0.0),)

    def measure(self, values, name, y, time_s, plant):
        if name != values["signal"]:
            return y
        return y + float(values["offset"])
