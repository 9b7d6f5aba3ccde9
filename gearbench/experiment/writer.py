"""Write a :class:`Plant` back as a plant file (SPEC section 3), fitted values annotated.

The file reads back to the same plant (``load_plant``); standard errors of
fitted values are YAML comments beside them, so the file stays valid.
"""
from __future__ import annotations

import math

import yaml

from ..plant.components import Plant


def _num(v: float) -> str:
    return repr(float(v)) if math.isfinite(v) else ".inf"


def plant_to_dict(plant: Plant) -> dict:
    """The plant as the mapping its file holds (file conventions: motor.inertia
    includes a shaft's pinion; effects as ``{type: NAME, ...}``)."""
    m, g = plant.motor, plant.gear
    d: dict = {"name": plant.name}
    if plant.drive != "voltage":
        d["drive"] = plant.drive
        motor = {"inertia": plant.motor_inertia_total, "damping": m.damping}
        if math.isfinite(m.max_voltage):
            motor["max_drive"] = m.max_voltage
    else:
        motor = {"resistance": m.resistance, "inductance": m.inductance,
                 "torque_constant": m.torque_constant, "back_emf_constant": m.back_emf_constant,
                 "inertia": plant.motor_inertia_total, "damping": m.damping, "max_voltage": m.max_voltage}
    d["motor"] = motor
    if g.rigid:
        d["gear"] = {"ratio": g.ratio, "rigid": True}
    else:
        d["gear"] = {"ratio": g.ratio, "backlash_deg": g.backlash_deg, "mesh_stiffness": g.mesh_stiffness,
                     "mesh_damping": g.mesh_damping, "contact_law": g.contact_law}
    d["load"] = {"inertia": plant.load.inertia, "damping": plant.load.damping}
    if plant.shaft is not None:
        s = plant.shaft
        d["shaft"] = {"stiffness": s.stiffness, "damping": s.damping, "pinion_inertia": s.pinion_inertia}
    if plant.leadscrew is not None:
        ls = plant.leadscrew
        d["leadscrew"] = {"lead_mm": ls.lead_mm, "mass": ls.mass, "damping": ls.damping}
    d["effects"] = [e.to_dict() for e in plant.effects]
    return d


def plant_to_yaml(plant: Plant, stderr: dict | None = None, header: str = "") -> str:
    """YAML text of the plant; ``stderr`` maps fitted names (``leadscrew.mass``,
    ``effects[2].force``) to standard errors, written as comments."""
    stderr = stderr or {}
    text = yaml.safe_dump(plant_to_dict(plant), sort_keys=False, default_flow_style=False)
    lines = []
    section, effect_i = None, -1
    for line in text.splitlines():
        stripped = line.strip()
        indent = len(line) - len(line.lstrip())
        if indent == 0 and stripped.endswith(":"):
            section = stripped[:-1]
        key = stripped.lstrip("- ").split(":", 1)[0]
        if section == "effects" and stripped.startswith("- "):
            effect_i += 1
        name = f"effects[{effect_i}].{key}" if section == "effects" else f"{section}.{key}"
        if name in stderr and ":" in stripped:
            se = stderr[name]
            line += f"  # fitted, standard error {se:.3g}" if math.isfinite(se) else "  # fitted"
        lines.append(line)
    head = "".join(f"# {h}\n" for h in header.splitlines()) if header else ""
    return head + "\n".join(lines) + "\n"
