"""``sensor_delay``: a measured signal lags the truth.

    y_measured(t) = y(t - tau)        (y(t) = y(0) before the record starts)

``signal`` is a measurement column name, ``delay`` tau in s.  Acts on the
measured signal only (linear interpolation of the simulated trace).
"""
import numpy as np

from .base import Effect, Param, register

SIGNALS = ("motor_angle_deg", "load_angle_deg", "load_position_mm", "current_A", "motor_position_mm")


@register
class SensorDelay(Effect):
    """A measured signal that lags the truth by a constant time."""
    name = "sensor_delay"
    causal = True  # each sample from the signal up to its time
    signature = "a lag"
    acts_on = "measured signal"
    options = {"signal": SIGNALS}
    params = (Param("delay", "s", 0.0, 10.0, 0.005, "lag of the measured signal"),)

    def measure(self, values, name, y, time_s, plant):
        if name != values["signal"]:
            return y
        return np.interp(time_s - float(values["delay"]), time_s, y)
