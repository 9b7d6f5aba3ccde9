"""The identification side's shape (issue 36): small functions, no shared mutable closures, and a
ladder whose rungs are records, never edited after the climb wrote them."""
from __future__ import annotations

import ast
import dataclasses
from pathlib import Path

import pytest

import gearbench.identify as identify
from gearbench.identify import ladder

IDENTIFY = Path(identify.__file__).parent
LONGEST = 60  # lines of a function, its docstring included


def _functions():
    for path in sorted(IDENTIFY.glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                yield path.name, node


def test_no_function_of_identify_is_over_60_lines():
    long = [f"{name}:{f.name} ({f.end_lineno - f.lineno + 1} lines)" for name, f in _functions()
            if f.end_lineno - f.lineno + 1 > LONGEST]
    assert not long, long


def test_nothing_in_identify_uses_nonlocal_or_global():
    found = [f"{name}:{f.name}" for name, f in _functions()
             for n in ast.walk(f) if isinstance(n, (ast.Nonlocal, ast.Global))]
    assert not found, found


@pytest.mark.parametrize("cls", [ladder.State, ladder.Rung, ladder.Stop, ladder.Simplified, ladder.Joint,
                                 ladder.Ahead, ladder.CalibrationStep, ladder.Context])
def test_the_ladders_records_are_frozen(cls):
    assert dataclasses.is_dataclass(cls) and cls.__dataclass_params__.frozen
