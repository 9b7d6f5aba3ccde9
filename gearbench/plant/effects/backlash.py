"""``backlash``: the clearance itself, for a plant modelled as rigid.

``backlash_deg`` is the total clearance at the output gear (deg).  On a plant
with a mesh spring it sets the gear's clearance.  On a rigid gear it adds a
mesh: ``mesh_stiffness`` (N m/rad) and ``mesh_damping`` (N m s/rad) when
given, else a contact whose engaged mode rings at ``contact_frequency_hz``
(default 2 kHz, well above the 1 kHz of typical records so it does not show in
them) with damping ratio 0.5.
"""
from __future__ import annotations

import math
from dataclasses import replace

from .base import Effect, Param, lumped_rotor, register


def _clearance_scale(plant, values):
    return 1.0


@register
class Backlash(Effect):
    """The gear's clearance (total, at the output)."""
    name = "backlash"
    signature = "lost motion"
    acts_on = "plant structure"
    params = (
        Param("backlash_deg", "deg", 0.0, 90.0, _clearance_scale, "total clearance at the output gear"),
        Param("mesh_stiffness", "N m/rad", 1e-9, 1e15, 1.0, "contact stiffness (rigid plants)", optional=True),
        Param("mesh_damping", "N m s/rad", 0.0, 1e12, 1.0, "contact damping (rigid plants)", optional=True),
        Param("contact_frequency_hz", "Hz", 1.0, 1e7, 2000.0, "engaged mode of the added contact",
              optional=True),
    )

    def fit_params(self, values):
        return self.params[:1]

    def inapplicable(self, plant, signals):
        if plant.gear.backlash_deg != 0.0:
            return "the gear already has a clearance (gear.backlash_deg)"
        return lumped_rotor(plant)

    def apply(self, values, plant):
        gear = replace(plant.gear, backlash_deg=float(values["backlash_deg"]))
        if plant.gear.rigid:
            k = values.get("mesh_stiffness")
            d = values.get("mesh_damping")
            if k is None:
                # engaged mode: rotor (reflected) against load, j = series inertia at the output
                jm = plant.motor.inertia * plant.gear.ratio ** 2
                jl = plant.output_inertia
                j = jm * jl / (jm + jl)
                w = 2.0 * math.pi * float(values.get("contact_frequency_hz", 2000.0))
                k = j * w * w
                if d is None:
                    d = 2.0 * 0.5 * j * w
            gear = replace(gear, rigid=False, mesh_stiffness=float(k), mesh_damping=float(d or 0.0))
        return replace(plant, gear=gear)
