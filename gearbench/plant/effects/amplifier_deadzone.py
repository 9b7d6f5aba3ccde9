"""``amplifier_deadzone``: the motor sees nothing from small commands.

    u_m = 0                      for |u| < v0
    u_m = u - v0 sign(u)         otherwise

``threshold`` v0 in V.  Acts on the voltage, before the amplifier saturates.
"""
import numba as nb

from .base import Effect, Param, register


@nb.njit(cache=True, inline="always", _nrt=False)
def voltage(p, o, u):
    """Voltage (V) the motor sees for command ``u`` (V); threshold ``p[o]`` (V)."""
    v0 = p[o]
    if u > v0:
        return u - v0
    if u < -v0:
        return u + v0
    return 0.0


def _scale(plant, values):
    return 0.1 * plant.motor.max_voltage


@register
class AmplifierDeadzone(Effect):
    """Amplifier dead zone: small commands do not reach the motor."""
    name = "amplifier_deadzone"
    signature = "voltage lost in a dead zone"
    acts_on = "voltage"
    params = (Param("threshold", "V", 0.0, 1e3, _scale, "command below which the output is 0"),)
    term = voltage
    places = ("voltage",)
    slots = ("threshold, V",)

    def compiled(self, values, plant):
        if plant.drive != "voltage":
            raise ValueError("amplifier_deadzone acts on a voltage; this plant is driven by a "
                             f"{plant.drive}")
        return "voltage", (float(values["threshold"]),)

    def piecewise_linear(self, values):
        """Only without a dead zone (threshold 0)."""
        return float(values["threshold"]) == 0.0

    def inapplicable(self, plant, signals):
        return "" if plant.drive == "voltage" else f"the plant is {plant.drive}-driven: there is no amplifier voltage"
