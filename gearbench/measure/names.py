"""The columns of gearbench's measurement format (docs/measurements.md): their names and units.

Shared by :mod:`gearbench.measure.data` (which reads and checks a record, and re-exports
these names) and :mod:`gearbench.measure.columns` (which maps a lab's columns onto them),
so that neither imports the other for them.
"""
from __future__ import annotations

TIME_COLUMN = "time_s"
INPUT_COLUMNS = ("voltage_V", "drive_torque_Nm", "drive_force_N")
SIGNAL_COLUMNS = {
    "motor_angle_deg": "deg",
    "load_angle_deg": "deg",
    "load_position_mm": "mm",
    "current_A": "A",
    "motor_position_mm": "mm",
}
SETPOINT_COLUMNS = ("setpoint_deg", "setpoint_mm")
DISTURBANCE_COLUMN = "disturbance_V"

COLUMN_UNITS: dict[str, str] = {
    TIME_COLUMN: "s",
    "voltage_V": "V",
    "drive_torque_Nm": "N m",
    "drive_force_N": "N",
    **SIGNAL_COLUMNS,
    "setpoint_deg": "deg",
    "setpoint_mm": "mm",
    DISTURBANCE_COLUMN: "V",
}

__all__ = ["TIME_COLUMN", "INPUT_COLUMNS", "SIGNAL_COLUMNS", "SETPOINT_COLUMNS", "DISTURBANCE_COLUMN",
           "COLUMN_UNITS"]
