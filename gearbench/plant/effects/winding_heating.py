"""``winding_heating``: a winding resistance that rises as the current heats it.

The winding's temperature rise ``dT`` (K, above its temperature at the record's
start) is the effect's own state, a first-order thermal model::

    R(dT)      = R (1 + alpha dT)
    tau d dT/dt = R_th R(dT) i^2 - dT
    L di/dt    = u - R i - R alpha dT i - ke w

``thermal_resistance`` R_th (K/W, winding to ambient), ``time_constant`` tau =
R_th C_th (s), optional ``temperature_coefficient`` alpha (1/K; copper's
0.00393 at 20 C when not given); ``R`` is the plant's ``motor.resistance``,
the cold value.  Held at a steady current ``i`` the winding settles at
``dT = R_th R i^2 / (1 - alpha R_th R i^2)``; over a record much shorter than
tau it warms at ``R i^2 R_th / tau`` K/s, so such a record tells mostly the
ratio R_th / tau (their correlation says so).  ``diagnose`` tries it only when
asked for (``--also winding_heating``, ``on_request``): a short record rarely carries its
drift.
"""
import numba as nb

from .base import Effect, Param, register

COPPER_ALPHA = 0.00393  # 1/K, copper's temperature coefficient of resistance at 20 C


@nb.njit(cache=True, inline="always", _nrt=False)
def heating_rate(p, o, i, dt):
    """``d dT/dt`` (K/s) at current ``i`` (A) and temperature rise ``dt`` (K); ``p[o:o + 4]`` =
    R (ohm), alpha (1/K), R_th (K/W), tau (s)."""
    r, alpha, r_th, tau = p[o], p[o + 1], p[o + 2], p[o + 3]
    return (r_th * r * (1.0 + alpha * dt) * i * i - dt) / tau


@nb.njit(cache=True, inline="always", _nrt=False)
def voltage_drop(p, o, i, dt):
    """Voltage (V) the warm winding loses beyond the cold ``R i``: ``R alpha dT i``."""
    return p[o] * p[o + 1] * dt * i


@register
class WindingHeating(Effect):
    """Winding heating: the motor's resistance rises with the heat the current puts in."""
    name = "winding_heating"
    signature = "heat put into the winding"
    acts_on = "voltage"
    params = (
        Param("thermal_resistance", "K/W", 0.0, 1e4, 5.0, "R_th: temperature rise per watt, winding to ambient"),
        Param("time_constant", "s", 1e-3, 1e7, 30.0, "tau = R_th C_th: the winding's thermal time constant"),
        Param("temperature_coefficient", "1/K", 0.0, 0.1, COPPER_ALPHA,
              "alpha: relative rise of the resistance per kelvin (copper 0.00393)", optional=True),
    )
    term = voltage_drop
    rate = heating_rate
    state = "temperature rise of the winding, K"
    places = ("winding",)
    slots = ("cold resistance, ohm", "temperature coefficient, 1/K", "thermal resistance, K/W",
             "time constant, s")
    on_request = True

    def compiled(self, values, plant):
        if plant.drive != "voltage":
            raise ValueError(f"winding_heating acts on the motor's winding; this plant is driven by a {plant.drive}")
        return "winding", (float(plant.motor.resistance), float(values.get("temperature_coefficient", COPPER_ALPHA)),
                           float(values["thermal_resistance"]), float(values["time_constant"]))

    def inapplicable(self, plant, signals):
        return "" if plant.drive == "voltage" else f"the plant is {plant.drive}-driven: there is no winding"
