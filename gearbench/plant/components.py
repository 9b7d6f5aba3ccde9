"""The plant's components as typed, immutable objects (SI units inside).

A plant file (SPEC section 3) becomes a :class:`Plant`; ``gearbench.plant.pack``
turns it into the flat parameter vector the compiled core reads.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field


@dataclass(frozen=True)
class Motor:
    """Brushed DC motor with inductance.

    ``L di/dt = u - R i - ke w``, torque ``kt i`` on the rotor.

    resistance (ohm), inductance (H), torque_constant (N m/A),
    back_emf_constant (V s/rad), inertia (kg m^2: rotor + pinion + input shaft,
    or the rotor alone when a shaft is given), damping (N m s/rad),
    max_voltage (V).
    """
    resistance: float
    inductance: float
    torque_constant: float
    back_emf_constant: float
    inertia: float
    damping: float
    max_voltage: float

    @property
    def stall_torque(self) -> float:
        """``kt Vmax / R``, N m."""
        return self.torque_constant * self.max_voltage / self.resistance

    @property
    def no_load_speed(self) -> float:
        """Steady speed at ``Vmax`` with no load, rad/s: ``kt V / (R b + kt ke)``."""
        return (self.torque_constant * self.max_voltage
                / (self.resistance * self.damping + self.torque_constant * self.back_emf_constant))


@dataclass(frozen=True)
class Gear:
    """Gear pair with backlash, every mesh quantity at the output gear.

    ratio (motor turns per output turn), backlash_deg (total clearance, deg),
    mesh_stiffness (N m/rad), mesh_damping (N m s/rad), contact_law
    (``dubowsky`` or ``elasto_backlash``).
    """
    ratio: float
    backlash_deg: float
    mesh_stiffness: float
    mesh_damping: float
    contact_law: str = "dubowsky"

    @property
    def half_clearance(self) -> float:
        """Half the total clearance, rad."""
        return math.radians(self.backlash_deg) / 2.0


@dataclass(frozen=True)
class Load:
    """Output inertia (kg m^2) and viscous damping (N m s/rad) on the output gear shaft."""
    inertia: float
    damping: float


@dataclass(frozen=True)
class Shaft:
    """Torsional shaft between rotor and pinion: stiffness (N m/rad),
    damping (N m s/rad), pinion_inertia (kg m^2, taken out of the motor's)."""
    stiffness: float
    damping: float
    pinion_inertia: float


@dataclass(frozen=True)
class Leadscrew:
    """Leadscrew turned by the output gear: ``x = theta_l lead / 2 pi``.

    lead_mm (carriage travel per screw turn, mm), mass (carriage, kg),
    damping (carriage viscous friction, N s/m).
    """
    lead_mm: float
    mass: float
    damping: float = 0.0

    @property
    def radius(self) -> float:
        """``lead / 2 pi``, m per rad."""
        return self.lead_mm * 1e-3 / (2.0 * math.pi)


@dataclass(frozen=True)
class Plant:
    """A motor, a gear pair with backlash, a load; optionally a shaft and a leadscrew."""
    motor: Motor
    gear: Gear
    load: Load
    shaft: Shaft | None = None
    leadscrew: Leadscrew | None = None
    effects: tuple = field(default_factory=tuple)
    name: str = "plant"

    @property
    def output_inertia(self) -> float:
        """Inertia on the output gear shaft incl. the reflected carriage, kg m^2."""
        j = self.load.inertia
        if self.leadscrew is not None:
            j += self.leadscrew.mass * self.leadscrew.radius ** 2
        return j

    @property
    def output_damping(self) -> float:
        """Viscous damping on the output gear shaft incl. the reflected carriage's, N m s/rad."""
        b = self.load.damping
        if self.leadscrew is not None:
            b += self.leadscrew.damping * self.leadscrew.radius ** 2
        return b
