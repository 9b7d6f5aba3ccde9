"""``encoder_quantization``: a measured angle is rounded to encoder counts.

    y_measured = q round(y / q),    q = 360 / counts_per_rev   (deg of its shaft)

``signal`` is the angle's column; ``counts_per_rev`` counts per revolution of
that signal's own shaft (the motor's for ``motor_angle_deg``, the output's for
``load_angle_deg``, the screw's for ``load_position_mm``: q = lead/counts mm).
"""
import numpy as np

from .base import Effect, Param, register

SIGNALS = ("motor_angle_deg", "load_angle_deg", "load_position_mm", "motor_position_mm")


def quantum(values, plant) -> float:
    """One count in the signal's unit (deg or mm)."""
    counts = float(values["counts_per_rev"])
    name = values["signal"]
    if name.endswith("_mm"):
        if plant.leadscrew is None:
            raise ValueError(f"{name} needs a plant with a leadscrew")
        lead = plant.leadscrew.lead_mm
        return lead / counts / (plant.gear.ratio if name == "motor_position_mm" else 1.0)
    return 360.0 / counts


@register
class EncoderQuantization(Effect):
    """A measured angle rounded to whole encoder counts."""
    name = "encoder_quantization"
    causal = True  # each sample from the signal up to its time
    signature = "steps of one count"
    acts_on = "measured signal"
    rounds = True
    options = {"signal": SIGNALS}
    params = (Param("counts_per_rev", "counts/rev", 1.0, 1e9, 1000.0,
                    "counts per revolution of the signal's shaft", integer=True),)

    def estimate(self, values, measured, plant):
        """Counts per revolution from the grid the measured values sit on."""
        from ...measure.noise import detect_quantum
        q = detect_quantum(measured[values["signal"]])
        if not q:
            return None
        counts = quantum(dict(values, counts_per_rev=1.0), plant) / q
        return {"counts_per_rev": int(round(counts))}

    def measure(self, values, name, y, time_s, plant):
        if name != values["signal"]:
            return y
        q = quantum(values, plant)
        return q * np.round(y / q)
