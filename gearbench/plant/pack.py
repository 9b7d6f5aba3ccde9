"""Pack a :class:`Plant` and a controller into the compiled core's arrays."""
from __future__ import annotations

import numpy as np

from .. import layout as L
from .components import Plant
from .effects.codegen import pack_effects, size, state_count, state_scales

CONTACT_LAWS = {"dubowsky": L.LAW_DUBOWSKY, "elasto_backlash": L.LAW_ELASTO,
                "linear": L.LAW_LINEAR}  # linear: unclipped, for validation only (not in plant files)


def pack_plant(plant: Plant, p: np.ndarray | None = None) -> np.ndarray:
    """Fill the plant and effect slots of a parameter vector (SI units).

    Structural effects are built into the plant first (``Plant.resolved``);
    each compiled effect adds its numbers to its block (``effects.codegen``).
    """
    if p is None:
        p = np.zeros(size())
    base = plant
    plant = plant.resolved()
    m, g = plant.motor, plant.gear
    if plant.drive == "voltage":
        p[L.P_R] = m.resistance
        p[L.P_L] = m.inductance
        p[L.P_KT] = m.torque_constant
        p[L.P_KE] = m.back_emf_constant
    else:
        p[L.P_R] = p[L.P_L] = 1.0  # unused: no electrics
        p[L.P_TORQUE_IN] = 1.0
    p[L.P_DRIVE_GAIN] = plant.drive_gain
    p[L.P_RIGID] = 1.0 if g.rigid else 0.0
    p[L.P_JM] = m.inertia
    p[L.P_BM] = m.damping
    p[L.P_VMAX] = m.max_voltage
    p[L.P_N] = g.ratio
    p[L.P_H] = g.half_clearance
    p[L.P_KMESH] = g.mesh_stiffness
    p[L.P_DMESH] = g.mesh_damping
    p[L.P_LAW] = CONTACT_LAWS[g.contact_law]
    p[L.P_JL] = plant.output_inertia
    p[L.P_BL] = plant.output_damping
    if plant.shaft is not None:
        p[L.P_HAS_SHAFT] = 1.0
        p[L.P_KS] = plant.shaft.stiffness
        p[L.P_DS] = plant.shaft.damping
        p[L.P_JP] = plant.shaft.pinion_inertia
    p[L.P_TF] = 1.0  # harmless default; controllers set their own
    p[L.P_FRIC_EPS_M] = p[L.P_FRIC_EPS_L] = 1.0  # the solver sets the real ones
    linear, curved = pack_effects(base.effects, plant, p)
    p[L.P_PWL] = 1.0 if linear and not curved else 0.0
    if linear:  # piecewise linear but for these sliding levels: their speeds' Jacobian columns only
        p[L.P_CURVED_M] = 1.0 if "motor" in curved else 0.0
        p[L.P_CURVED_L] = 1.0 if "load" in curved else 0.0
    return p


def tolerance_scales(plant: Plant) -> np.ndarray:
    """Typical magnitude of each state, used as ``atol = rtol * scale``.

    The mesh deflection is scaled by the deflection under the motor's stall
    torque (~1e-6 rad), not by the clearance: error control must see the
    contact's deflection, which sets the contact torque.
    """
    base = plant
    plant = plant.resolved()
    m, g = plant.motor, plant.gear
    stall = plant.typical_torque
    w0 = plant.typical_speed
    h = max(g.half_clearance, 1e-4)
    sc = np.ones(state_count(base.effects))
    state_scales(base.effects, plant, sc)
    sc[L.X_I] = m.max_voltage / m.resistance if plant.drive == "voltage" else 1.0
    sc[L.X_THM] = 1.0
    sc[L.X_WM] = w0
    sc[L.X_PHI] = stall / plant.shaft.stiffness if plant.shaft else 1.0
    sc[L.X_WP] = w0
    sc[L.X_DELTA] = 1.0 if g.rigid else stall * g.ratio / g.mesh_stiffness
    sc[L.X_WL] = w0 / g.ratio
    sc[L.X_ZI] = h
    sc[L.X_ZD] = h
    sc[L.X_IAE] = h
    sc[L.X_ISE] = h * h
    return sc


def rest_state(plant: Plant, delta0: float = 0.0) -> np.ndarray:
    """Everything at rest, the mesh at ``delta0`` inside its clearance (rad), the effects'
    own states at 0."""
    x = np.zeros(state_count(plant.effects))
    x[L.X_DELTA] = delta0
    return x
