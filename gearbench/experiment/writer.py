"""Write a :class:`Plant` back as a plant file (docs/plant-yaml.md), fitted values annotated.

The file reads back to the same plant (``load_plant``); standard errors of
fitted values are YAML comments beside them, so the file stays valid.

:func:`plant_to_yaml` writes a plant from scratch.  :func:`update_plant_yaml`
edits the user's own file instead (``gearbench fit -o``): it loads the text with
ruamel.yaml's round-trip loader, changes only the values that the fit changed, adds
new effects at the end of ``effects:``, and so keeps every comment, the key order,
the number formats and the ``description``.
"""
from __future__ import annotations

import io
import math
import numbers
import re
from typing import Any

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
    modules = sorted({e.source for e in plant.effects if e.source})
    if modules:  # effects from files outside the package: the file names them (absolute paths)
        d["effect_modules"] = modules
    d["effects"] = [e.to_dict() for e in plant.effects]
    for path, pct in plant.tolerances:  # a datasheet value keeps its tolerance
        section, key = path.split(".")
        if key in d.get(section, {}):
            d[section][key] = {"value": d[section][key], "tolerance_pct": pct}
    return d


def plant_to_yaml(plant: Plant, stderr: dict | None = None, header: str = "", units: dict | None = None) -> str:
    """YAML text of the plant; ``stderr`` maps fitted names (``leadscrew.mass``,
    ``effects[2].force``) to standard errors, written as comments with the unit ``units``
    gives for the name."""
    stderr, units = stderr or {}, units or {}
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
            line += f"  # {_comment(se, None, units.get(name, ''))}"
        lines.append(line)
    head = "".join(f"# {h}\n" for h in header.splitlines()) if header else ""
    return head + "\n".join(lines) + "\n"


_FITTED = "fitted, standard error"
_PATH = re.compile(r"^(?:effects\[(\d+)\]|(\w+))\.(\w+)$")


def _comment(se: float | None, before: Any, unit: str = "") -> str:
    """``fitted, standard error 0.012 N m (was 0.8)``: what ``fit`` notes beside a value."""
    text = (f"{_FITTED} {se:.3g}" + (f" {unit}" if unit else "")
            if se is not None and math.isfinite(se) else "fitted")
    if isinstance(before, float):
        before = repr(float(f"{before:.6g}"))  # 6 digits, written as YAML would: 2.0, 1.15, 2.35642
    return text + (f" (was {before})" if before is not None else "")


def _note(mapping, key: str, text: str) -> None:
    """Put ``# text`` beside ``mapping[key]``; a comment the user wrote there moves to the
    next line (same column), a note an earlier fit wrote is replaced."""
    from ruamel.yaml.tokens import CommentToken

    slot = mapping.ca.items.get(key)
    old = slot[2] if slot and len(slot) > 2 else None
    if old is None or not isinstance(old, CommentToken):
        mapping.yaml_add_eol_comment(text, key)
        return
    first, nl, rest = old.value.partition("\n")
    if first.lstrip("# ").startswith(("fitted", _FITTED)):
        old.value = f"# {text}{nl}{rest}" if nl else f"# {text}\n"
    else:
        old.value = f"# {text}\n{' ' * old.column}{old.value}"


def _plain(v: Any) -> Any:
    """Python scalars for the YAML writer (a fit may hand back numpy numbers)."""
    if isinstance(v, bool) or isinstance(v, str):
        return v
    if isinstance(v, numbers.Integral):
        return int(v)
    if isinstance(v, numbers.Real):
        return float(v)
    return v


def _close(a: Any, b: Any) -> bool:
    """Equal plant-file values (floats to 12 digits: a shaft's inertia is summed and split)."""
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_close(a[k], b[k]) for k in a)
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(_close(x, y) for x, y in zip(a, b))
    if isinstance(a, float) and isinstance(b, (int, float)) and not isinstance(b, bool):
        return a == b or math.isclose(a, b, rel_tol=1e-12)
    return a == b


def _merge(target, old: dict, new: dict, notes: dict, before_key=None) -> None:
    """Change ``target`` (a ruamel mapping) where ``new`` differs from ``old``; ``notes``
    maps keys of this mapping to their fitted comment's ``(standard error, unit)``."""
    from ruamel.yaml.comments import CommentedMap

    for key in list(old):
        if key not in new and key in target:
            del target[key]
    for key, value in new.items():
        if key in ("effects", "effect_modules", "name", "description"):
            continue  # effect_modules: the file's own (relative) paths stay
        if isinstance(value, dict):
            if key not in target or not isinstance(target[key], dict):
                section = CommentedMap()
                if before_key in target:
                    target.insert(list(target).index(before_key), key, section)
                else:
                    target[key] = section
            sub = notes.get(key, {})  # a value with its tolerance: the note goes beside its value
            _merge(target[key], old.get(key, {}) if isinstance(old.get(key), dict) else {}, value,
                   sub if isinstance(sub, dict) else {"value": sub})
            continue
        changed = key not in old or not _close(old[key], value)
        if changed or (key in notes and key not in target):
            target[key] = _plain(value)  # a default the file leaves out stays out unless it changed
        if key in notes:
            was = old.get(key) if changed and key in old else None
            _note(target, key, _comment(notes[key][0], was, notes[key][1]))


def update_plant_yaml(text: str, old: Plant, new: Plant, stderr: dict | None = None, header: str = "",
                      units: dict | None = None) -> str:
    """The user's plant file ``text`` (which loads as ``old``) edited to hold ``new``.

    Parameters
    ----------
    text : str
        The original plant file.
    old, new : Plant
        The plant the file holds, and the plant to write (``old`` with fitted values and
        added effects, as ``gearbench fit`` makes it).
    stderr : dict, optional
        Standard errors by fitted name (``leadscrew.mass``, ``effects[2].force``), written
        as comments beside the values; a comment already there moves to the next line.
    header : str
        Comment lines put above the file's own.

    Returns
    -------
    str
        A plant file that loads as ``new``.  Should the edited text not load back as
        ``new`` (a structure this editor does not handle), the plant is written afresh
        by :func:`plant_to_yaml` and the header says that the comments were lost.
    """
    stderr, units = stderr or {}, units or {}
    head = "".join(f"# {h}\n" for h in header.splitlines()) if header else ""
    try:
        body = _edit(text, plant_to_dict(old), plant_to_dict(new), stderr, units)
        if _loads_as(body, new):
            return head + body
        reason = "the edited file did not load back as the fitted plant"
    except Exception as exc:  # any failure of the round trip falls back to a fresh file
        reason = f"{type(exc).__name__}: {exc}"
    note = f"the original file's comments could not be kept ({reason})"
    return plant_to_yaml(new, stderr, f"{header}\n{note}" if header else note, units)


def _edit(text: str, old: dict, new: dict, stderr: dict, units: dict) -> str:
    from ruamel.yaml import YAML
    from ruamel.yaml.comments import CommentedMap, CommentedSeq

    rt = YAML(typ="rt")
    rt.preserve_quotes = True
    rt.width = 4096  # never re-wrap the user's long lines
    if re.search(r"^[ ]+- ", text, re.M):
        rt.indent(mapping=2, sequence=4, offset=2)  # the file indents its lists: keep that
    doc = rt.load(text)
    notes: dict = {}
    for name, se in stderr.items():
        m = _PATH.match(name)
        if m and m.group(1) is None:
            notes.setdefault(m.group(2), {})[m.group(3)] = (se, units.get(name, ""))
    _merge(doc, old, new, notes, before_key="effects")

    old_eff, new_eff = old.get("effects", []), new.get("effects", [])
    if any(a.get("type") != b.get("type") for a, b in zip(old_eff, new_eff)) or len(new_eff) < len(old_eff):
        raise ValueError("the fit changed or removed an effect the file has")
    if new_eff != old_eff or "effects" not in doc:
        seq = doc.get("effects")
        if not isinstance(seq, CommentedSeq):
            seq = CommentedSeq()
            doc["effects"] = seq
        if len(new_eff) > len(seq):
            seq.fa.set_block_style()
        for i, values in enumerate(new_eff):
            eff_notes = {m.group(3): (se, units.get(name, "")) for name, se in stderr.items()
                         if (m := _PATH.match(name)) and m.group(1) == str(i)}
            if i < len(seq):
                _merge(seq[i], old_eff[i], values, eff_notes)
            else:
                item = CommentedMap((k, _plain(v)) for k, v in values.items())
                seq.append(item)
                for key, (se, unit) in eff_notes.items():
                    if key in item:
                        _note(item, key, _comment(se, None, unit))
    out = io.StringIO()
    rt.dump(doc, out)
    return out.getvalue()


def _loads_as(text: str, plant: Plant) -> bool:
    from .files import parse_yaml, plant_from_dict

    again = plant_from_dict(parse_yaml(text, "<fitted plant>"), name=plant.name)
    return _close(plant_to_dict(again), plant_to_dict(plant))
