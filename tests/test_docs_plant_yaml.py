"""docs/plant-yaml.md: every YAML example loads, and together they show every key.

The examples are the documentation of the plant format; a key the loader accepts that
no example shows, or an example the loader rejects, fails here.
"""
from __future__ import annotations

import re
from pathlib import Path

import pytest

from gearbench.experiment.files import (DRIVEN_MOTOR, GEAR, LEADSCREW, LOAD, MOTOR, PLANT_TOP, SHAFT,
                                        parse_yaml, plant_from_dict)
from gearbench.plant.effects import REGISTRY
from gearbench.plant.effects.location import force_names

DOC = Path(__file__).resolve().parents[1] / "docs" / "plant-yaml.md"


def yaml_blocks(path: Path) -> list[str]:
    return re.findall(r"^```yaml\n(.*?)^```", path.read_text(encoding="utf-8"), re.S | re.M)


BLOCKS = yaml_blocks(DOC)


def test_the_doc_has_examples():
    assert len(BLOCKS) >= 8


@pytest.mark.parametrize("i", range(len(BLOCKS)))
def test_every_example_loads(i):
    raw = parse_yaml(BLOCKS[i], f"docs/plant-yaml.md block {i + 1}")
    plant = plant_from_dict(raw, label=f"docs/plant-yaml.md block {i + 1}")
    assert plant.name == raw["name"]
    assert len(plant.effects) == len(raw.get("effects") or [])


def _keys(section: str, drive: str | None = None) -> set[str]:
    out: set[str] = set()
    for text in BLOCKS:
        raw = parse_yaml(text, "doc")
        if drive is not None and (raw.get("drive", "voltage") == "voltage") != (drive == "voltage"):
            continue
        if isinstance(raw.get(section), dict):
            out |= set(raw[section])
    return out


def test_every_section_key_is_shown():
    top: set[str] = set()
    for text in BLOCKS:
        top |= set(parse_yaml(text, "doc"))
    assert set(PLANT_TOP) | {"motor", "gear", "load", "shaft", "leadscrew", "effects"} <= top
    assert set(MOTOR) <= _keys("motor", "voltage")
    assert set(DRIVEN_MOTOR) <= _keys("motor", "torque")
    assert set(GEAR) | {"rigid"} <= _keys("gear")
    assert set(LOAD) <= _keys("load")
    assert set(SHAFT) <= _keys("shaft")
    assert set(LEADSCREW) <= _keys("leadscrew")
    drives = {parse_yaml(t, "doc").get("drive", "voltage") for t in BLOCKS}
    assert drives == {"voltage", "torque", "force"}


def test_every_effect_and_parameter_is_shown():
    shown: dict[str, set[str]] = {}
    for text in BLOCKS:
        for item in parse_yaml(text, "doc").get("effects") or []:
            shown.setdefault(item["type"], set()).update(item)
    assert set(REGISTRY) <= set(shown), f"effects without an example: {set(REGISTRY) - set(shown)}"
    for name, effect in REGISTRY.items():
        for q in effect.params:
            assert q.name in shown[name] or force_names().get(q.name) in shown[name], (name, q.name)
        if "carriage" in effect.options.get("location", ()):
            assert any(force_names().get(q.name, "") in shown[name] for q in effect.params), name
