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
    max_voltage (V).  A torque- or force-driven plant (``Plant.drive``) has no
    electrics: the electrical fields are None and ``max_voltage`` is the
    drive's limit in its own unit (N m or N; inf = none).
    """
    resistance: float | None
    inductance: float | None
    torque_constant: float | None
    back_emf_constant: float | None
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
    (``dubowsky`` or ``elasto_backlash``); rigid: no mesh at all (no clearance,
    no spring: rotor and load turn as one; the ``backlash`` effect adds one).
    """
    ratio: float
    backlash_deg: float
    mesh_stiffness: float
    mesh_damping: float
    contact_law: str = "dubowsky"
    rigid: bool = False

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


FITTABLE = {  # key path -> (unit, low bound): the plant values fit and calibration may move
    "motor.inertia": ("kg m^2", 0.0), "motor.damping": ("N m s/rad", 0.0),
    "motor.resistance": ("ohm", 0.0), "motor.inductance": ("H", 0.0),
    "motor.torque_constant": ("N m/A", 0.0), "motor.back_emf_constant": ("V s/rad", 0.0),
    "gear.backlash_deg": ("deg", 0.0), "gear.mesh_stiffness": ("N m/rad", 0.0),
    "gear.mesh_damping": ("N m s/rad", 0.0), "load.inertia": ("kg m^2", 0.0),
    "load.damping": ("N m s/rad", 0.0), "leadscrew.mass": ("kg", 0.0),
    "leadscrew.damping": ("N s/m", 0.0),
}


@dataclass(frozen=True)
class Plant:
    """A motor, a gear pair with backlash, a load; optionally a shaft and a leadscrew.

    drive: what the input is: ``voltage`` (V on the motor), ``torque`` (N m a
    current-controlled drive applies to the rotor) or ``force`` (N: the drive's
    force expressed at the carriage; it acts on the rotor as ``F lead/(2 pi N)``,
    so with a rigid gear it pushes the carriage).  effects: ``AddedEffect``s.
    """
    motor: Motor
    gear: Gear
    load: Load
    shaft: Shaft | None = None
    leadscrew: Leadscrew | None = None
    effects: tuple = field(default_factory=tuple)
    name: str = "plant"
    drive: str = "voltage"
    tolerances: tuple = ()  # ((path, tolerance_pct), ...): datasheet values and how far they may be off

    def tolerance_pct(self, path: str) -> float | None:
        """The plant file's tolerance of ``path`` (``motor.resistance``), %, or None if it gives none."""
        return dict(self.tolerances).get(path)

    @property
    def motor_inertia_total(self) -> float:
        """Rotor + pinion inertia, kg m^2."""
        return self.motor.inertia + (self.shaft.pinion_inertia if self.shaft else 0.0)

    @property
    def driven_inertia(self) -> float:
        """The inertia the motor drives, at the motor: rotor, pinion and the output's reflected
        (``J_m + J_out / N^2``), kg m^2."""
        return self.motor_inertia_total + self.output_inertia / self.gear.ratio ** 2

    @property
    def driven_damping(self) -> float:
        """The viscous damping the motor drives, at the motor: the rotor's and the output's
        reflected (``b_m + b_out / N^2``), N m s/rad."""
        return self.motor.damping + self.output_damping / self.gear.ratio ** 2

    @property
    def drive_gain(self) -> float:
        """Rotor torque per unit of a torque/force input (1, or lead/(2 pi N) m/rad for N)."""
        if self.drive == "force":
            if self.leadscrew is None:
                raise ValueError("a force-driven plant needs a leadscrew")
            return self.leadscrew.radius / self.gear.ratio
        return 1.0

    @property
    def typical_torque(self) -> float:
        """A typical rotor torque, N m: the stall torque, or the drive's limit."""
        if self.drive == "voltage":
            return self.motor.stall_torque
        lim = self.motor.max_voltage * self.drive_gain
        return lim if math.isfinite(lim) else 1.0 * self.drive_gain

    @property
    def typical_speed(self) -> float:
        """A typical rotor speed, rad/s: the no-load speed, or drive limit / damping."""
        if self.drive == "voltage":
            return self.motor.no_load_speed
        b = self.driven_damping
        if b > 0.0 and math.isfinite(self.motor.max_voltage):
            return self.typical_torque / b
        return self.gear.ratio  # 1 rad/s at the output

    def with_effects(self, *added) -> "Plant":
        """This plant with more effects (``AddedEffect``s)."""
        from dataclasses import replace
        return replace(self, effects=tuple(self.effects) + tuple(added))

    def resolved(self) -> "Plant":
        """The plant with its structural effects (backlash, shaft) built in."""
        plant = self
        for e in self.effects:
            plant = e.effect.apply(e.values, plant)
        return plant

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
