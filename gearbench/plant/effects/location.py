"""Where a friction or torque effect acts, and the unit conversions it needs.

``location`` is ``motor`` (the rotor), ``load`` (the output gear shaft, the
screw in a leadscrew plant) or, for a leadscrew plant, ``carriage``: there the
parameter is a force (N) or a coefficient (N s/m) and becomes a torque ``F r``
or a coefficient ``c r^2`` at the screw, ``r = lead / 2 pi`` (m/rad).
"""
from __future__ import annotations

LOCATIONS = ("motor", "load", "carriage")


def force_names() -> dict[str, str]:
    """Each parameter's name at the carriage, from the effects' declarations
    (``Param.carriage``): ``torque`` becomes ``force``, ..."""
    from .base import REGISTRY
    return {q.name: q.carriage for e in REGISTRY.values() for q in e.params if q.carriage}


def key(values: dict, name: str) -> str:
    """The parameter's key in the file: ``torque`` becomes ``force`` at the carriage."""
    return force_names().get(name, name) if values.get("location") == "carriage" else name


def at_shaft(values: dict, plant, name: str, power: int) -> tuple[str, float]:
    """(``motor``|``load``, value of parameter ``name`` at that shaft, SI rotational).

    ``power``: how the carriage-to-screw conversion scales the value: 1 for a
    force (N -> N m), 2 for a coefficient (N s/m -> N m s/rad), -1 for a speed
    (m/s -> rad/s).
    """
    loc = values.get("location", "load")
    v = float(values[key(values, name)])
    if loc == "carriage":
        if plant.leadscrew is None:
            raise ValueError("location 'carriage' needs a plant with a leadscrew")
        return "load", v * plant.leadscrew.radius ** power
    return loc, v


def torque_scale(plant, values: dict) -> float:
    """Typical friction level at the effect's location, in its file unit (N m or N)."""
    loc = values.get("location", "load")
    t = plant.typical_torque * (1.0 if loc == "motor" else plant.gear.ratio)
    if loc == "carriage":
        t /= plant.leadscrew.radius
    return 0.1 * t


STICK_SLIP_FLOOR = 1e-3
"""A fit's lowest stick-slip friction level, as a share of :func:`torque_scale` (1e-4 of the
motor's stall torque): see :func:`stick_slip_floor`."""


def stick_slip_floor(plant, values: dict) -> float:
    """The lowest level (N m, N at the carriage) a fit gives a stick-slip friction
    (``Param.fit_low``): :data:`STICK_SLIP_FLOOR` of :func:`torque_scale`.

    Why: a fit of a friction the record does not hold walks its level towards 0, and on its way
    passes the levels of the torques a body at rest still feels (the mesh's ringing, the
    damping's), where it sticks and breaks away again at every turn of its speed.  On practice
    record p03 (the nominal plant, 16 s at 1 kHz) a Coulomb friction at the load of 3e-5 to 3e-4
    of this scale made 4,700-14,100 located events a replay (190 without it), at the motor
    3,000-21,500; at 1e-3 to 1e-1, 800-3,100 (on p09, the same plant, such replays took up to
    3.5x the bare plant's time).  The screen's fits of the frictions that lose on p03 spent most
    of their replays there (``docs/speed.md``).  No drive has so little friction against its stall
    torque (a small DC motor's no-load current is some 2-10 % of its stall current), and the scan
    starts at 1e-2 of the scale (``identify.search.SPAN``)."""
    return STICK_SLIP_FLOOR * torque_scale(plant, values)


def speed_scale(plant, values: dict) -> float:
    """Typical speed at the effect's location, rad/s (m/s at the carriage)."""
    loc = values.get("location", "load")
    w = plant.typical_speed
    if loc == "motor":
        return w
    w /= plant.gear.ratio
    return w * plant.leadscrew.radius if loc == "carriage" else w


def coefficient_scale(plant, values: dict) -> float:
    """A viscous coefficient that takes a tenth of the drive at typical speed."""
    return torque_scale(plant, values) / speed_scale(plant, values)
