"""Plant and experiment files (SPEC section 3): read, validate, build typed objects.

Everything is checked before any solving, and every problem of a file is
reported at once in one :class:`ConfigError`, one problem per line, each naming
the file, the key path and the expected unit::

    thesis_gear.yaml: motor.resistance must be a positive number in ohm, got -2.0
    thesis_gear.yaml: load.inertia is missing: expected a positive number in kg m^2

The validators work on plain dicts (:func:`validate_plant_dict`,
:func:`validate_experiment_dict`) so that callers that edit a parsed file
(``gearbench sweep``) can re-check it.

YAML notes: ``on``/``off``/``yes``/``no`` read as booleans (YAML 1.1), numbers
such as ``1e-6`` read as floats (PyYAML alone would read them as strings), and
a key given twice in one mapping is an error.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Mapping

import numpy as np
import yaml

from ..control.controllers import COMPENSATORS, Controller
from ..errors import ConfigError
from ..plant.components import FITTABLE, Gear, Leadscrew, Load, Motor, Plant, Shaft
from ..simulate import SOLVER, SolverOptions, pack
from ..plant.effects import REGISTRY as EFFECTS
from ..plant.effects.base import AddedEffect
from ..plant.effects.location import key as effect_key
from ..plant.pack import pack_plant, tolerance_scales
from .. import layout as L
from ..schema import Choice, Number, Text, check_mapping, index, join, show, unknown_key

CONTACT_LAWS = ("dubowsky", "elasto_backlash")
INLINE = "<inline plant>"


# ---------------------------------------------------------------- YAML reading

_FLOAT_12 = re.compile(r"""^[-+]?(?:[0-9][0-9_]*(?:\.[0-9_]*)?|\.[0-9_]+)[eE][-+]?[0-9]+$""")


class _Loader(yaml.SafeLoader):
    """Safe loader that reads ``1e-6`` as a float and refuses duplicate keys."""

    def construct_mapping(self, node, deep=False):
        seen = set()
        for key_node, _ in node.value:
            if key_node.tag == "tag:yaml.org,2002:merge":
                continue
            key = self.construct_object(key_node, deep=deep)
            try:
                duplicate = key in seen
                seen.add(key)
            except TypeError:
                continue  # unhashable: the base class reports it
            if duplicate:
                raise yaml.constructor.ConstructorError(
                    None, None, f"key {key!r} appears twice in the same mapping", key_node.start_mark)
        return super().construct_mapping(node, deep=deep)


_Loader.add_implicit_resolver("tag:yaml.org,2002:float", _FLOAT_12, list("-+0123456789."))


MAX_DEPTH = 32
"""Deepest nesting of lists and mappings a file may have (gearbench's files nest four levels)."""


def _shape_problem(data: Any) -> str | None:
    """A document nested deeper than :data:`MAX_DEPTH`, or one that contains itself
    (a YAML alias inside its own anchor, ``&a [*a]``); None when neither.

    Checked once after parsing so that nothing downstream (validators, copies, hashes)
    recurses without end.  Iterative; a node shared through aliases is walked once and
    its height (levels below it) remembered, so an alias cannot smuggle in depth.
    """
    def children(node):
        if isinstance(node, Mapping):
            return iter(list(node.items()))
        if isinstance(node, list):
            return iter(list(enumerate(node)))
        return None

    if children(data) is None:
        return None
    height: dict[int, int] = {}   # finished containers: levels from the node down
    stack = [[data, "", children(data), 0]]  # node, key path, children left, tallest child
    active = {id(data)}
    too_deep = (f"nests more than {MAX_DEPTH} levels of lists or mappings; a gearbench file "
                "nests a few")
    while stack:
        frame = stack[-1]
        node, path, it = frame[0], frame[1], frame[2]
        for key, child in it:
            kids = children(child)
            if kids is None:
                continue
            where = index(path, key) if isinstance(node, list) else join(path, key)
            if id(child) in active:
                return f"{where} contains itself (a YAML alias inside its own anchor)"
            if id(child) in height:
                if len(stack) + height[id(child)] > MAX_DEPTH:
                    return f"{where[:60]}{'...' if len(where) > 60 else ''} {too_deep}"
                frame[3] = max(frame[3], height[id(child)])
                continue
            if len(stack) >= MAX_DEPTH:
                return f"{where[:60]}{'...' if len(where) > 60 else ''} {too_deep}"
            stack.append([child, where, kids, 0])
            active.add(id(child))
            break
        else:
            stack.pop()
            active.discard(id(node))
            height[id(node)] = frame[3] + 1
            if stack:
                stack[-1][3] = max(stack[-1][3], height[id(node)])
    return None


def parse_yaml(text: str, label: str) -> Any:
    """Parse YAML ``text``; a syntax error becomes a :class:`ConfigError` with its line.

    A document nested too deeply to parse, deeper than :data:`MAX_DEPTH`, or containing
    itself through an alias is refused with a :class:`ConfigError` too.

    Parameters
    ----------
    text : str
        The document.
    label : str
        File label used in messages.
    """
    try:
        data = yaml.load(text, Loader=_Loader)  # noqa: S506 - a SafeLoader subclass
    except RecursionError:  # PyYAML's parser recurses once per level
        raise ConfigError(label, "the YAML nests lists or mappings too deeply to read (hundreds of "
                                 "levels); a gearbench file nests a few") from None
    except (ValueError, OverflowError) as exc:  # a scalar PyYAML cannot convert (an int of 5000 digits)
        raise ConfigError(label, f"YAML error: a value cannot be read: {exc}") from None
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        what = exc.problem or exc.context or "malformed YAML"
        kind = "YAML error" if isinstance(exc, yaml.constructor.ConstructorError) else "YAML syntax error"
        raise ConfigError(label, f"{kind}{where}: {what}") from None
    except yaml.YAMLError as exc:
        raise ConfigError(label, f"YAML syntax error: {exc}") from None
    problem = _shape_problem(data)
    if problem:
        raise ConfigError(label, problem)
    return data


def read_yaml(path: str | Path, label: str | None = None) -> Any:
    """Read and parse a YAML file; missing, unreadable or malformed files raise :class:`ConfigError`."""
    path = Path(path)
    label = label or path.name
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ConfigError(label, f"file not found: {path.resolve()}") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(label, f"cannot read {path}: {exc}") from None
    data = parse_yaml(text, label)
    if data is None:
        raise ConfigError(label, "the file is empty")
    return data


# --------------------------------------------------------------------- plants

POS, NONNEG = {"low": 0.0, "low_strict": True}, {"low": 0.0, "low_strict": False}

MOTOR = {
    "resistance": Number("ohm", **POS),
    "inductance": Number("H", **POS),
    "torque_constant": Number("N m/A", **POS),
    "back_emf_constant": Number("V s/rad", **POS),
    "inertia": Number("kg m^2", **POS),
    "damping": Number("N m s/rad", **NONNEG),
    "max_voltage": Number("V", **POS),
}
# a torque- or force-driven plant has no electrics; max_drive limits the input (N m or N)
DRIVEN_MOTOR = {
    "inertia": Number("kg m^2", **POS),
    "damping": Number("N m s/rad", **NONNEG, required=False, default=0.0),
    "max_drive": Number("N m (torque drive) or N (force drive)", **POS, required=False),
}
GEAR = {
    "ratio": Number("motor turns per output turn", **POS),
    # at most the backlash effect's own bound: the state scales square the half clearance (rad), and
    # a clearance of 1e308 deg overflowed them to inf (found by tests/test_fuzz.py's plant files)
    "backlash_deg": Number("deg", low=0.0, low_strict=False, high_strict=False,
                           high=next(q.high for q in EFFECTS["backlash"].params if q.name == "backlash_deg")),
    "mesh_stiffness": Number("N m/rad", **POS),
    "mesh_damping": Number("N m s/rad", **NONNEG),
    "contact_law": Choice(CONTACT_LAWS, required=False, default="dubowsky"),
}
# a rigid gear has no mesh (no clearance, no spring); the backlash effect adds one
RIGID_GEAR = {"ratio": Number("motor turns per output turn", **POS),
              "rigid": Choice(("true",), required=True)}
LOAD = {"inertia": Number("kg m^2", **POS), "damping": Number("N m s/rad", **NONNEG)}
# with a rigid gear the load's inertia adds to the rotor's and may be 0 (all in a carriage)
RIGID_LOAD = {"inertia": Number("kg m^2", **NONNEG), "damping": Number("N m s/rad", **NONNEG)}
SHAFT = {
    "stiffness": Number("N m/rad", **POS),
    "damping": Number("N m s/rad", **NONNEG),
    "pinion_inertia": Number("kg m^2", **POS),
}
LEADSCREW = {
    "lead_mm": Number("mm", **POS),
    "mass": Number("kg", **NONNEG),
    "damping": Number("N s/m", **NONNEG, required=False, default=0.0),
}
DRIVES = ("voltage", "torque", "force")
PLANT_TOP = {"name": Text(), "description": Text(nonempty=False),
             "drive": Choice(DRIVES, required=False, default="voltage")}
PLANT_SECTIONS = {"motor": (MOTOR, True), "gear": (GEAR, True), "load": (LOAD, True),
                  "shaft": (SHAFT, False), "leadscrew": (LEADSCREW, False)}


TOLERANCE = Number("%", low=0.0, low_strict=False, high=100.0)


def _split_tolerances(raw: Any, section: str, where: str, fields: Mapping,
                      problems: list[str]) -> tuple[Any, dict[str, float], set]:
    """A section's mapping with each ``key: {value: V, tolerance_pct: T}`` (a datasheet value and
    how far, %, the real one may be from it; calibration stays within it, 0 holds the value)
    read as ``key: V``; ``{"section.key": T}``; and the keys whose mapping was wrong (their
    problems recorded here).  Only the values gearbench can calibrate (``FITTABLE``) take one."""
    if not isinstance(raw, Mapping):
        return raw, {}, set()
    out, tol, bad = dict(raw), {}, set()
    for key, value in raw.items():
        if not isinstance(value, Mapping) or key not in fields:
            continue
        path = f"{section}.{key}"
        here = join(where, key)
        if path not in FITTABLE:
            problems.append(f"{here}: only a number is allowed here, got {show(value)}; a "
                            f"{{value, tolerance_pct}} mapping is allowed on {', '.join(sorted(FITTABLE))}")
            bad.add(key)
            continue
        got = check_mapping(value, here, {"value": fields[key], "tolerance_pct": TOLERANCE}, problems,
                            context="a key of a value with its tolerance")
        if got is None or set(got) != {"value", "tolerance_pct"}:
            bad.add(key)
            continue
        out[key], tol[path] = got["value"], got["tolerance_pct"]
    return {k: v for k, v in out.items() if k not in bad}, tol, bad


def _check_effect(item: Any, path: str, has_leadscrew: bool, problems: list[str]) -> AddedEffect | None:
    """One ``{type: NAME, <parameters>}`` entry against the effect registry."""
    if not isinstance(item, Mapping) or not isinstance(item.get("type"), str):
        problems.append(f"{path} must be a mapping with a 'type' string naming an effect "
                        f"({', '.join(sorted(EFFECTS))}), got {show(item)}")
        return None
    name = item["type"]
    if name not in EFFECTS:
        problems.append(unknown_key(join(path, "type"), name, {k: "" for k in sorted(EFFECTS)},
                                    "a known effect"))
        return None
    effect = EFFECTS[name]
    before = len(problems)
    fields: dict[str, Any] = {}
    for opt, choices in effect.options.items():
        fields[opt] = Choice(choices, required=opt != "location", default="load")
    for opt, choices in effect.settings.items():
        fields[opt] = Choice(choices, required=False)
    loc = item.get("location")
    if loc == "carriage" and not has_leadscrew:
        problems.append(f"{join(path, 'location')}: 'carriage' needs a plant with a leadscrew")
    for q in effect.params:
        key = effect_key({"location": loc}, q.name) if "location" in effect.options else q.name
        fields[key] = Number(q.unit, low=q.low, low_strict=False, high=q.high, high_strict=False,
                             required=not q.optional, integer=q.integer)
    values = check_mapping(item, path, fields, problems, context=f"a {name} parameter",
                           extra={"type": "effect name"})
    if len(problems) > before or values is None:
        return None
    return AddedEffect(name, values)


def _check_effects(raw: Any, where: str, has_leadscrew: bool, problems: list[str]) -> tuple:
    """Check ``effects:``, a list of ``{type: NAME, <parameters>}`` (SPEC section 5)."""
    if raw is None:
        return ()
    if not isinstance(raw, list):
        problems.append(f"{where} must be a list of effects ({{type: NAME, ...}} mappings), "
                        f"got {show(raw)}")
        return ()
    found = [_check_effect(item, index(where, i), has_leadscrew, problems)
             for i, item in enumerate(raw)]
    return tuple(e for e in found if e is not None)


def _fit_effects(plant: Plant, effects, paths, problems: list[str]) -> tuple:
    """The ``effects`` that can sit on ``plant``, each added after its own effects and the
    ones before it that can: packing the plant says (e.g. no amplifier dead zone on a
    torque drive).  Each that cannot adds ``"<path>: <why>"`` to ``problems``."""
    fitted: list[AddedEffect] = []
    for effect, path in zip(effects, paths):
        try:
            pack_plant(plant.with_effects(*fitted, effect))
        except ValueError as exc:
            problems.append(f"{path}: {exc}")
            continue
        except OverflowError:  # a value near 1e308 squared: _extreme_problems says so
            pass
        fitted.append(effect)
    return tuple(fitted)


def check_effects_on(plant: Plant, items, paths, problems: list[str]) -> tuple:
    """``{type: NAME, <parameters>}`` entries added to ``plant``, checked as a plant file's
    ``effects:`` are: each against the effect registry (its type, options, parameters with
    their units and bounds), then whether it can sit on ``plant`` after the ones before it.
    Every problem goes to ``problems``, named by the entry's path in ``paths``; returns the
    effects that passed (``AddedEffect``s, in order)."""
    checked = [(effect, path) for item, path in zip(items, paths)
               if (effect := _check_effect(item, path, plant.leadscrew is not None, problems)) is not None]
    return _fit_effects(plant, [e for e, _ in checked], [p for _, p in checked], problems)


def _load_effect_modules(raw: Any, where: str, base_dir: Path | None, problems: list[str]) -> None:
    """Load ``effect_modules:``, a list of Python files (relative to the plant's file)
    whose effects the plant may then name (``plant/effects/user.py``)."""
    if raw is None:
        return
    if not isinstance(raw, list) or not all(isinstance(p, str) and p.strip() for p in raw):
        problems.append(f"{where} must be a list of Python file paths (relative to this file), "
                        f"got {show(raw)}")
        return
    from ..plant.effects.user import load
    for i, ref in enumerate(raw):
        try:
            load(_resolve(base_dir or Path.cwd(), ref))
        except ValueError as exc:
            problems.append(f"{index(where, i)}: {exc}")


def _build_plant(raw: Any, where: str, default_name: str,
                 base_dir: Path | None = None) -> tuple[Plant | None, list[str]]:
    """Check a plant mapping; return the Plant (None if any problem) and the problems.

    ``base_dir``: the folder relative ``effect_modules`` paths are taken from."""
    problems: list[str] = []
    sections = {k: "mapping" for k in PLANT_SECTIONS}
    sections["effects"] = "list"
    sections["effect_modules"] = "list of Python files"
    top = check_mapping(raw, where, PLANT_TOP, problems, context="a plant key", extra=sections)
    if top is None:
        return None, problems
    _load_effect_modules(raw.get("effect_modules"), join(where, "effect_modules"), base_dir, problems)
    drive = top.get("drive", "voltage")
    rigid = isinstance(raw.get("gear"), Mapping) and raw["gear"].get("rigid") is True
    values: dict[str, dict | None] = {}
    tolerances: dict[str, float] = {}
    for key, (fields, required) in PLANT_SECTIONS.items():
        path = join(where, key)
        if key == "motor" and drive != "voltage":
            fields = DRIVEN_MOTOR
        if key == "load" and rigid:
            fields = RIGID_LOAD
        if key == "gear" and rigid:
            fields = RIGID_GEAR
            raw = dict(raw, gear=dict(raw["gear"], rigid="true"))
        if key not in raw:
            if required:
                units = ", ".join(f"{k} ({f.short()})" for k, f in fields.items())
                problems.append(f"{path} is missing: expected a mapping with {units}")
            values[key] = None
            continue
        section, tol, bad = _split_tolerances(raw[key], key, path, fields, problems)
        tolerances.update(tol)
        got = check_mapping(section, path, {k: f for k, f in fields.items() if k not in bad}, problems,
                            context=f"a {key} key")
        values[key] = got if got is not None and set(got) >= {
            k for k, f in fields.items() if f.required} else None
    if drive == "force" and "leadscrew" not in raw:
        problems.append(f"{join(where, 'drive')}: a force-driven plant needs a leadscrew "
                        "(the force acts at the carriage)")
    effects = _check_effects(raw.get("effects"), join(where, "effects"), "leadscrew" in raw, problems)

    motor, shaft = values["motor"], values["shaft"]
    if motor and shaft and "inertia" in motor and "pinion_inertia" in shaft:
        if shaft["pinion_inertia"] >= motor["inertia"]:
            problems.append(
                f"{join(where, 'shaft.pinion_inertia')} must be smaller than "
                f"{join(where, 'motor.inertia')} (kg m^2; motor.inertia includes the pinion, "
                f"which the shaft separates out), got {shaft['pinion_inertia']!r} >= {motor['inertia']!r}")
    if problems:
        return None, problems
    if shaft:  # motor.inertia in the file is rotor + pinion; Motor.inertia is then the rotor alone
        motor = dict(motor, inertia=motor["inertia"] - shaft["pinion_inertia"])
    if drive != "voltage":
        motor = dict(resistance=None, inductance=None, torque_constant=None, back_emf_constant=None,
                     inertia=motor["inertia"], damping=motor["damping"],
                     max_voltage=motor.get("max_drive", math.inf))
    gear = values["gear"]
    if rigid:
        gear = dict(ratio=gear["ratio"], backlash_deg=0.0, mesh_stiffness=0.0, mesh_damping=0.0,
                    rigid=True)
    plant = Plant(
        motor=Motor(**motor), gear=Gear(**gear), load=Load(**values["load"]),
        shaft=Shaft(**shaft) if shaft else None,
        leadscrew=Leadscrew(**values["leadscrew"]) if values["leadscrew"] else None,
        effects=effects, name=top.get("name", default_name), drive=drive,
        tolerances=tuple(sorted(tolerances.items())))
    # effects that cannot sit on this plant (a dead zone on a force drive)
    _fit_effects(replace(plant, effects=()), effects,
                 [f"{index(join(where, 'effects'), i)} ({e.name})" for i, e in enumerate(effects)], problems)
    if not problems:
        problems += _extreme_problems(plant, where)
    return (None, problems) if problems else (plant, [])


_SCALES = {L.X_I: "current (motor.max_voltage / motor.resistance, A)", L.X_WM: "motor speed (rad/s)",
           L.X_PHI: "shaft twist (rad)", L.X_DELTA: "mesh deflection (rad)", L.X_WL: "load speed (rad/s)"}


def _computable(p: np.ndarray) -> bool:
    """The compiled core's parameters ``p`` are finite (no drive limit packs as inf, by design)."""
    return bool(np.all(np.isfinite(np.delete(p, L.P_VMAX))))


def _extreme_problems(plant: Plant, where: str) -> list[str]:
    """Values each valid alone but too extreme to compute with together (a resistance of
    5e-324 ohm makes the typical current infinite): the solver's state scales and the
    compiled core's parameters must be finite and its scales positive."""
    try:
        scales = tolerance_scales(plant)
        computable = _computable(pack_plant(plant))
    except OverflowError:  # a float power past 1e308 (a leadscrew's radius squared)
        bad = None
    else:
        bad = [name for i, name in _SCALES.items() if not (math.isfinite(scales[i]) and scales[i] > 0)]
        if not bad and computable:
            return []
    if bad is None:
        what = "a power of one of them overflows past 1e308"
    elif bad:
        what = f"the typical {' and '.join(bad)} come out 0 or infinite"
    else:
        what = "a parameter of the compiled model comes out infinite or NaN"
    return [f"{where or 'the plant'}: its values are too extreme to compute with: {what}; look for a "
            "value near 1e-308 or 1e308"]


def validate_plant_dict(d: Any, where: str = "") -> list[str]:
    """Problems of a parsed plant mapping (empty when it is valid).

    Parameters
    ----------
    d : Any
        The parsed plant (should be a mapping with ``motor``, ``gear``, ``load``, ...).
    where : str
        Key path of ``d`` inside its file, prefixed to every path
        (``"plant"`` for a plant inline in an experiment).

    Returns
    -------
    list of str
        One text per problem, naming the key path and the expected unit.
    """
    return _build_plant(d, where, "plant")[1]


def plant_from_dict(d: Any, *, name: str = "plant", label: str = INLINE, where: str = "",
                    base_dir: str | Path | None = None) -> Plant:
    """Build a :class:`Plant` from a parsed mapping, or raise :class:`ConfigError`.

    Parameters
    ----------
    d : Any
        The parsed plant mapping.
    name : str
        Plant name when ``d`` has no ``name`` key.
    label : str
        File label for messages.
    where : str
        Key path of ``d`` inside its file.
    base_dir : str or Path, optional
        Folder that relative ``effect_modules`` paths start from (default: the
        working directory).
    """
    plant, problems = _build_plant(d, where, name, Path(base_dir) if base_dir is not None else None)
    if problems:
        raise ConfigError(label, problems)
    return plant


def load_plant(source: str | Path | Mapping, *, base_dir: str | Path | None = None) -> Plant:
    """Load and validate a plant (SPEC section 3).

    Parameters
    ----------
    source : str, Path or Mapping
        A plant YAML file, or an already parsed mapping.
    base_dir : str or Path, optional
        Folder a relative ``source`` path is taken from (default: the working directory).

    Returns
    -------
    Plant
        In SI units.  ``Plant.name`` is the file's ``name`` key, else the file
        stem (``"plant"`` for a mapping).  With a ``shaft``, the file's
        ``motor.inertia`` is rotor + pinion (+ input shaft) as SPEC section 3
        says, and ``shaft.pinion_inertia`` comes out of it:
        ``Plant.motor.inertia = motor.inertia - shaft.pinion_inertia`` (the rotor
        alone), which is how the compiled core reads it.  ``description`` is
        checked but not kept (``Plant`` has no field for it).

    Raises
    ------
    ConfigError
        Listing every problem: unknown or missing keys, wrong types (a boolean
        is not a number), non-finite or unphysical values, YAML syntax errors.

    Examples
    --------
    >>> from gearbench import load_plant
    >>> load_plant("experiments/plants/thesis_gear.yaml").gear.ratio
    100.0
    >>> plant = load_plant({"name": "servo",
    ...     "motor": {"resistance": 2.5, "inductance": 1e-3, "torque_constant": 0.02,
    ...               "back_emf_constant": 0.02, "inertia": 1e-6, "damping": 1e-6, "max_voltage": 12},
    ...     "gear": {"ratio": 100, "backlash_deg": 3, "mesh_stiffness": 2.4e7, "mesh_damping": 3.4},
    ...     "load": {"inertia": 5e-5, "damping": 15}})
    >>> plant.name, plant.gear.half_clearance > 0
    ('servo', True)
    """
    if isinstance(source, Mapping):
        return plant_from_dict(source)
    path = Path(source)
    if base_dir is not None and not path.is_absolute():
        path = Path(base_dir) / path
    return plant_from_dict(read_yaml(path), name=path.stem, label=path.name, base_dir=path.parent)


# ----------------------------------------------------------------- experiments

EXPERIMENT_TOP = {
    "name": Text(),
    "description": Text(nonempty=False),
    "duration_s": Number("s", **POS),
    "shift_deg": Number("deg", **NONNEG, required=False),
    "initial_delta_deg": Number("deg", low=None, required=False, default=0.0),
    "reference": Text(),
    "profile_scale": Number("", **POS, required=False, default=1.0),
}
EXPERIMENT_SECTIONS = {"plant": "file path or mapping", "solver": "mapping",
                       "profiles": "list of names or paths", "controllers": "list of mappings",
                       "shift": "boolean or list of booleans",
                       "compensator": "compensator name or list of names"}

_KP = Number("V/deg", **POS)
CONTROLLERS = {
    "bang_bang": {"band_deg": Number("deg", **POS, required=False, default=0.25)},
    "p": {"kp": _KP},
    "pi": {"kp": _KP, "ki": Number("1/s", **NONNEG)},
    "pid": {"kp": _KP, "ki": Number("1/s", **NONNEG), "kd": Number("s", **NONNEG),
            "derivative_filter_s": Number("s", **POS, required=False, default=1e-3)},
}
"""Settings per controller kind (gains in the thesis's units, see ``Controller``).
``band_deg`` and ``derivative_filter_s`` are optional (0.25 deg, 1 ms); the gains are required."""


@dataclass(frozen=True)
class Experiment:
    """A matrix of runs: one plant, profiles x controllers x set-point shifts.

    Attributes
    ----------
    name, description : str
    plant : Plant
    plant_path : str or None
        Resolved path of the plant file; None for an inline plant.
    duration_s : float
        Simulated time of each run, s.
    solver : SolverOptions
    profiles : tuple of str
        Profile names or paths, as written (resolved by ``gearbench.profiles``).
    controllers : tuple of Controller
        As written, without the shift (see :meth:`runs`).
    shifts : tuple of bool
        Set-point shift off/on, one run each.
    shift_deg : float or None
        Size of the set-point shift, deg; None = half the clearance.
    reference : Path or None
        Reference table to compare with (resolved path).
    initial_delta_deg : float
        Where the mesh sits in its clearance at t = 0 (output deg, 0 = centred).
    base_dir : Path
        Folder of the experiment file; relative paths are taken from it.
    compensators : tuple of str
        Backlash compensators to compare (``control.controllers.COMPENSATORS``:
        ``none``, ``thesis_shift``, ...), one run each, instead of ``shifts``; empty
        when the file has no ``compensator`` key.
    profile_scale : float
        Every profile's values and slopes are multiplied by this (e.g. to fit
        the thesis's profiles to a leadscrew's travel); 1 by default.
    """
    name: str
    description: str
    plant: Plant
    plant_path: str | None
    duration_s: float
    solver: SolverOptions
    profiles: tuple[str, ...]
    controllers: tuple[Controller, ...]
    shifts: tuple[bool, ...]
    shift_deg: float | None
    reference: Path | None
    initial_delta_deg: float
    base_dir: Path
    compensators: tuple[str, ...] = ()
    profile_scale: float = 1.0

    @property
    def initial_delta(self) -> float:
        """``initial_delta_deg`` in rad (``simulate(..., delta0=...)``)."""
        return math.radians(self.initial_delta_deg)

    def runs(self) -> list[tuple[str, Controller]]:
        """Every run as ``(profile, controller)``: profiles outermost, then
        controllers, then shifts (or compensators); each controller carries its
        ``shift`` (``compensator``) and the experiment's ``shift_deg``."""
        if self.compensators:
            return [(prof, replace(ctrl, shift=False, compensator=c, shift_deg=self.shift_deg))
                    for prof in self.profiles for ctrl in self.controllers for c in self.compensators]
        return [(prof, replace(ctrl, shift=s, shift_deg=self.shift_deg))
                for prof in self.profiles for ctrl in self.controllers for s in self.shifts]


def _check_controller(raw: Any, where: str, problems: list[str]) -> Controller | None:
    if not isinstance(raw, Mapping):
        problems.append(f"{where} must be a mapping like {{kind: p, kp: 50}}, got {show(raw)}")
        return None
    kind = raw.get("kind")
    if not isinstance(kind, str) or kind not in CONTROLLERS:  # a list or mapping is not hashable
        got = "nothing" if "kind" not in raw else show(kind)
        problems.append(f"{join(where, 'kind')} must be one of {', '.join(CONTROLLERS)} "
                        f"(a string), got {got}")
        return None
    n = len(problems)
    got = check_mapping(raw, where, CONTROLLERS[kind], problems, context=f"a {kind} setting",
                        extra={"kind": "|".join(CONTROLLERS)})
    return Controller(kind, **got) if got is not None and len(problems) == n else None


def _string_list(raw: Any, where: str, what: str, one: str, problems: list[str]) -> tuple[str, ...]:
    items = [raw] if isinstance(raw, str) else raw
    if not isinstance(items, list) or not items:
        problems.append(f"{where} must be a non-empty list of {what}, got {show(raw)}")
        return ()
    out = []
    for i, item in enumerate(items):
        if isinstance(item, str) and item.strip():
            out.append(item)
        else:
            problems.append(f"{index(where, i)} must be {one} (a string), got {show(item)}")
    return tuple(out)


def _check_shifts(raw: Any, where: str, problems: list[str]) -> tuple[bool, ...]:
    items = [raw] if isinstance(raw, bool) else raw
    if not isinstance(items, list) or not items:
        problems.append(f"{where} must be a boolean (off/on) or a non-empty list of them, got {show(raw)}")
        return ()
    bad = [i for i, s in enumerate(items) if not isinstance(s, bool)]
    for i in bad:
        problems.append(f"{index(where, i)} must be a boolean (off/on), got {show(items[i])}")
    return () if bad else tuple(items)


def _check_compensators(raw: Any, where: str, problems: list[str]) -> tuple[str, ...]:
    items = [raw] if isinstance(raw, str) else raw
    allowed = ", ".join(COMPENSATORS)
    if not isinstance(items, list) or not items:
        problems.append(f"{where} must be a compensator name ({allowed}) or a non-empty list "
                        f"of them, got {show(raw)}")
        return ()
    bad = False
    for i, c in enumerate(items):
        if not isinstance(c, str) or c not in COMPENSATORS:
            problems.append(f"{index(where, i)} must be one of {allowed} (a string), got {show(c)}")
            bad = True
    if len(set(x for x in items if isinstance(x, str))) != len(items) and not bad:
        problems.append(f"{where} lists a compensator twice: {items}")
        bad = True
    return () if bad else tuple(items)


def _resolve(base_dir: Path, text: str) -> Path:
    try:
        p = Path(text).expanduser()
    except RuntimeError:  # ~user of no such user: left as written, reported as not found
        p = Path(text)
    return p if p.is_absolute() else base_dir / p


def is_file(path: Path) -> bool:
    """``path.is_file()``, but False where the system refuses the name (too long, a NUL byte)."""
    try:
        return path.is_file()
    except (OSError, ValueError):
        return False


def _experiment(raw: Any, base_dir: Path, label: str, default_name: str) -> tuple[Experiment | None, list]:
    """Check an experiment mapping; return it (None on problems) and ``(file, text)`` problems."""
    problems: list[str] = []
    other: list[tuple[str, str]] = []  # problems of a referenced plant file
    top = check_mapping(raw, "", EXPERIMENT_TOP, problems, context="an experiment key",
                        extra=EXPERIMENT_SECTIONS)
    if top is None:
        return None, [(label, p) for p in problems]

    plant, plant_path, name = None, None, top.get("name", default_name)
    ref = raw.get("plant")
    if isinstance(ref, str) and ref.strip():
        path = _resolve(base_dir, ref)
        plant_path = str(path)
        if not is_file(path):
            problems.append(f"plant must name an existing plant file (path relative to this "
                            f"file), not found: {path}")
        else:
            plant_path = str(path.resolve())
            try:
                plant = plant_from_dict(read_yaml(path, ref), name=path.stem, label=ref, base_dir=path.parent)
            except ConfigError as exc:
                other.extend(exc.entries)
    elif isinstance(ref, Mapping):
        plant, plant_problems = _build_plant(ref, "plant", name, base_dir)
        problems.extend(plant_problems)
    else:
        got = "nothing" if "plant" not in raw else show(ref)
        problems.append(f"plant must be a plant file path (relative to this file) or an inline "
                        f"plant mapping, got {got}")

    solver = check_mapping(raw.get("solver", {}), "solver", SOLVER, problems, context="a solver setting")
    if solver and "duration_s" in top and solver.get("output_dt_s", 0.0) > top["duration_s"]:
        problems.append(f"solver.output_dt_s must be at most duration_s ({top['duration_s']:g} s), "
                        f"got {solver['output_dt_s']!r}")
    if "profiles" in raw:
        profiles = _string_list(raw["profiles"], "profiles", "profile names or paths",
                                "a profile name or path", problems)
    else:
        profiles = ()
        problems.append("profiles is missing: expected a list of profile names or paths")

    controllers: list[Controller | None] = []
    ctrl_raw = raw.get("controllers")
    ctrl_items = [ctrl_raw] if isinstance(ctrl_raw, Mapping) else ctrl_raw
    if not isinstance(ctrl_items, list) or not ctrl_items:
        got = "nothing" if "controllers" not in raw else show(ctrl_raw)
        problems.append(f"controllers must be a non-empty list of controller mappings "
                        f"({{kind: bang_bang|p|pi|pid, ...}}), got {got}")
    else:
        for i, item in enumerate(ctrl_items):
            controllers.append(_check_controller(item, index("controllers", i), problems))

    shifts = _check_shifts(raw.get("shift", False), "shift", problems)
    compensators: tuple[str, ...] = ()
    if "compensator" in raw:
        compensators = _check_compensators(raw["compensator"], "compensator", problems)
        if "shift" in raw:
            problems.append("give either shift (off/on, the thesis shift) or compensator "
                            f"({', '.join(COMPENSATORS)}), not both; compensator: thesis_shift "
                            "is shift: on")

    if plant is not None:
        clearance = plant.gear.backlash_deg
        shift_deg = top.get("shift_deg")
        resolved = plant.resolved().gear.backlash_deg  # a backlash effect's clearance counts
        if shift_deg is not None and shift_deg > resolved:
            problems.append(f"shift_deg must lie between 0 and the clearance (gear.backlash_deg, or a "
                            f"backlash effect's) = {resolved:g} deg, got {shift_deg!r}")
        for i, ctrl in enumerate(controllers):
            if ctrl is None:
                continue
            # each compensator packs its own gains from the plant (Kff = N (ke + R b/kt), ...)
            extreme = [c for c in compensators or (ctrl.compensator,)
                       if not _computable(pack(plant, replace(ctrl, compensator=c)))]
            if extreme:
                with_comp = f" with compensator {', '.join(extreme)}" if compensators else ""
                problems.append(f"{index('controllers', i)}{with_comp}: its values are too extreme to compute "
                                "with: a gain comes out infinite in SI units (V/rad, 1/s, s, V s/rad); look for a "
                                "value near 1e308 in it or the plant")
        d0 = top.get("initial_delta_deg", 0.0)
        if abs(d0) > clearance / 2.0:
            problems.append(f"initial_delta_deg must lie within +-{clearance / 2.0:g} deg (half of "
                            f"gear.backlash_deg = {clearance:g} deg), got {d0!r}")

    reference = None
    if "reference" in top:
        reference = _resolve(base_dir, top["reference"])
        if not is_file(reference):
            problems.append(f"reference must be an existing file (path relative to this file), "
                            f"not found: {reference}")

    entries = [(label, p) for p in problems] + other
    if entries:
        return None, entries
    exp = Experiment(
        name=name, description=top.get("description", ""), plant=plant, plant_path=plant_path,
        duration_s=top["duration_s"], solver=SolverOptions(**solver), profiles=profiles,
        controllers=tuple(controllers), shifts=shifts, shift_deg=top.get("shift_deg"),
        reference=reference, initial_delta_deg=top.get("initial_delta_deg", 0.0),
        base_dir=base_dir, compensators=compensators,
        profile_scale=top.get("profile_scale", 1.0))
    return exp, []


def validate_experiment_dict(d: Any, base_dir: str | Path = ".", label: str = "<experiment>") -> list[str]:
    """Problems of a parsed experiment mapping, as ``file: problem`` lines (empty when valid).

    Parameters
    ----------
    d : Any
        The parsed experiment.
    base_dir : str or Path
        Folder relative paths (plant file, reference) are taken from.
    label : str
        File label for problems of the experiment itself (a referenced plant
        file's problems carry that file's label).
    """
    return [f"{f}: {t}" for f, t in _experiment(d, Path(base_dir), label, "experiment")[1]]


def experiment_from_dict(d: Any, *, base_dir: str | Path = ".", name: str = "experiment",
                         label: str = "<experiment>") -> Experiment:
    """Build an :class:`Experiment` from a parsed mapping, or raise :class:`ConfigError`.

    Parameters
    ----------
    d : Any
        The parsed experiment.
    base_dir : str or Path
        Folder relative paths are taken from; becomes ``Experiment.base_dir``.
    name : str
        Experiment name when ``d`` has no ``name`` key.
    label : str
        File label for messages.
    """
    exp, entries = _experiment(d, Path(base_dir).resolve(), label, name)
    if entries:
        raise ConfigError(label, entries)
    return exp


def load_experiment(path: str | Path) -> Experiment:
    """Load and validate an experiment file.

    Parameters
    ----------
    path : str or Path
        The experiment YAML.  Its ``plant`` is a plant file path relative to the
        experiment's folder or an inline plant mapping (key paths ``plant.motor...``);
        ``reference`` is relative to that folder too.

    Returns
    -------
    Experiment
        ``name`` defaults to the file stem; ``solver`` to ``SolverOptions()``;
        ``shift`` to off; ``initial_delta_deg`` to 0 (mesh centred) and must lie
        within +-``backlash_deg/2``; ``shift_deg`` (0 ... ``backlash_deg``) to
        None, meaning half the clearance.

    Raises
    ------
    ConfigError
        Listing every problem of the experiment and of its plant file.

    Examples
    --------
    >>> from gearbench import load_experiment
    >>> exp = load_experiment("experiments/table1.yaml")
    >>> len(exp.runs()), exp.solver.rtol
    (30, 1e-07)
    """
    path = Path(path)
    return experiment_from_dict(read_yaml(path), base_dir=path.parent, name=path.stem,
                                label=path.name)
