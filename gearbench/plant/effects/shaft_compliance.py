"""``shaft_compliance``: a torsional spring-damper between rotor and pinion.

    Ts = k (theta_m - theta_p) + d (w_m - w_p),   Jr dw_m/dt = ... - Ts,   Jp dw_p/dt = Ts - ...

``stiffness`` k (N m/rad), ``damping`` d (N m s/rad), ``pinion_inertia`` Jp
(kg m^2) which comes out of the motor's inertia (the rotor keeps the rest).
On a rigid gear the pinion side carries the load too: the spring is then a
compliance between the motor and the load (EMPS: between motor and carriage).
"""
from __future__ import annotations

import math
from dataclasses import replace

from ..components import Shaft
from .base import Effect, Param, register


def _stiffness_scale(plant, values):
    # a shaft mode near 600 Hz on the rotor (the thesis's figure)
    return plant.motor_inertia_total * (2 * math.pi * 600.0) ** 2


def _damping_scale(plant, values):
    # damping ratio ~0.05 on the rotor
    return 0.1 * math.sqrt(_stiffness_scale(plant, values) * plant.motor_inertia_total)


def _pinion_scale(plant, values):
    return 0.3 * plant.motor_inertia_total


@register
class ShaftCompliance(Effect):
    """A torsional shaft between rotor and pinion."""
    name = "shaft_compliance"
    signature = "acceleration"
    acts_on = "plant structure"
    params = (
        Param("stiffness", "N m/rad", 1e-12, 1e15, _stiffness_scale, "torsional stiffness"),
        Param("damping", "N m s/rad", 0.0, 1e12, _damping_scale, "torsional damping"),
        Param("pinion_inertia", "kg m^2", 0.0, 1e6, _pinion_scale,
              "inertia beyond the spring, taken out of the motor's"),
    )

    def applicable(self, plant, signals):
        return plant.shaft is None

    def apply(self, values, plant):
        if plant.shaft is not None:
            raise ValueError("the plant already has a shaft")
        jp = float(values["pinion_inertia"])
        total = plant.motor_inertia_total
        if not 0.0 < jp < total:
            raise ValueError(f"shaft_compliance.pinion_inertia must lie in (0, {total:g}) kg m^2 "
                             f"(the motor's inertia), got {jp:g}")
        motor = replace(plant.motor, inertia=total - jp)
        return replace(plant, motor=motor, shaft=Shaft(float(values["stiffness"]),
                                                       float(values["damping"]), jp))
