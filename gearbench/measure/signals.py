"""Measured signals of a simulated run, in the measurement file's units.

The compiled core's outputs (``layout.O_*``, SI, rad) become the SPEC's
columns: angles in degrees of their own shaft, positions in mm of carriage
travel, current in A, the input in its column's unit.
"""
from __future__ import annotations

import math

import numpy as np

from .. import layout as L

DEG = 180.0 / math.pi


def per_rad(name: str, plant) -> float:
    """Signal units per rad of the shaft the signal is read on (the rotor for
    ``motor_*``, the output for ``load_*``)."""
    if name.endswith("_deg"):
        return DEG
    if name.endswith("_mm"):
        if plant.leadscrew is None:
            raise ValueError(f"{name} needs a plant with a leadscrew (a position in mm)")
        r_mm = plant.leadscrew.radius * 1e3
        return r_mm / plant.gear.ratio if name.startswith("motor") else r_mm
    raise ValueError(f"{name} is not an angle or a position")


def from_outputs(name: str, out: np.ndarray, plant) -> np.ndarray:
    """Column ``name`` from sampled outputs ``out[:, O_*]``."""
    if name == "current_A":
        return out[:, L.O_CURRENT].copy()
    if name in ("voltage_V", "drive_torque_Nm", "drive_force_N"):
        return out[:, L.O_VOLTAGE].copy()
    col = L.O_MOTOR if name.startswith("motor") else L.O_LOAD
    return out[:, col] * per_rad(name, plant)


def to_output_rad(name: str, value, plant):
    """A measured angle or position as the output angle it implies, rad."""
    v = np.asarray(value, dtype=float) / per_rad(name, plant)
    return v / plant.gear.ratio if name.startswith("motor") else v


def is_position(name: str) -> bool:
    return name.endswith("_deg") or name.endswith("_mm")
