"""Small, dependency-free checks of plain dicts parsed from YAML.

Every check appends human-readable problems to a list instead of raising, so a
file's problems can all be reported at once.  A problem names the key path
(``motor.resistance``, ``controllers[0].kp``) and what was expected, with its
unit::

    motor.resistance must be a positive number in ohm, got -2.0

The field specs (:class:`Number`, :class:`Choice`, :class:`Text`) are
declarative so the same table serves validation, error messages and help.
"""
from __future__ import annotations

import difflib
import math
import numbers
from dataclasses import dataclass
from typing import Any, Mapping

MISSING = object()


def join(where: str, key: Any) -> str:
    """Key path of ``key`` inside ``where``: ``join("plant", "motor") == "plant.motor"``."""
    key = key if isinstance(key, str) else repr(key)
    return f"{where}.{key}" if where else key


def index(where: str, i: int) -> str:
    """Key path of list item ``i``: ``index("controllers", 0) == "controllers[0]"``."""
    return f"{where}[{i}]"


def show(value: Any) -> str:
    """How a bad value is quoted in a message, with its YAML type when that is the problem."""
    if value is None:
        return "nothing (null)"
    if isinstance(value, bool) or type(value).__name__ == "bool_":
        return f"the boolean {str(bool(value)).lower()}"
    if isinstance(value, str):
        return f"the string {value!r}"
    if isinstance(value, Mapping):
        return "a mapping"
    if isinstance(value, (list, tuple)):
        return "a list"
    if isinstance(value, numbers.Real):
        if isinstance(value, int) and abs(value) >= 10 ** 21:  # a few hundred digits help nobody
            digits = str(abs(value))
            return f"the integer {'-' if value < 0 else ''}{digits[:6]}... ({len(digits)} digits)"
        return repr(float(value)) if isinstance(value, float) else repr(value)
    return f"a {type(value).__name__}"


def is_number(value: Any) -> bool:
    """A real number that is not a boolean (YAML ``true`` is not 1)."""
    return (isinstance(value, numbers.Real) and not isinstance(value, bool)
            and type(value).__name__ != "bool_")


@dataclass(frozen=True)
class Number:
    """A real number in ``unit`` (``""`` = dimensionless) within optional bounds.

    ``low``/``high`` are the bounds (``None`` = unbounded); ``low_strict`` and
    ``high_strict`` make them exclusive.  ``integer`` asks for a whole number.
    A missing optional number takes ``default``.
    """
    unit: str
    low: float | None = 0.0
    low_strict: bool = True
    high: float | None = None
    high_strict: bool = True
    required: bool = True
    default: float | None = None
    integer: bool = False

    def describe(self) -> str:
        """``a positive number in ohm``, ``a number >= 0 in N m s/rad``, ..."""
        noun = "integer" if self.integer else "number"
        if self.low == 0.0 and self.low_strict and self.high is None:
            text = f"a positive {noun}"
        elif self.low is None and self.high is None:
            text = f"a {noun}"
        else:
            parts = []
            if self.low is not None:
                parts.append(f"{'>' if self.low_strict else '>='} {self.low:g}")
            if self.high is not None:
                parts.append(f"{'<' if self.high_strict else '<='} {self.high:g}")
            text = f"a {noun} " + " and ".join(parts)
        return f"{text} in {self.unit}" if self.unit else f"{text} (dimensionless)"

    def short(self) -> str:
        """The unit alone, for lists of allowed keys."""
        return self.unit or "dimensionless"

    def check(self, value: Any, path: str, problems: list[str]) -> float | int | None:
        """The value as float (int when ``integer``), or None after recording a problem."""
        def bad() -> str:  # built only for a bad value: check runs on every simulate call
            return f"{path} must be {self.describe()}, got {show(value)}"

        if not is_number(value):
            problems.append(bad())
            return None
        try:
            x = float(value)
        except OverflowError:  # an integer beyond the largest float (YAML reads 10**400 exactly)
            problems.append(f"{bad()} (too large for a floating-point number)")
            return None
        if not math.isfinite(x):
            problems.append(f"{bad()} (not a finite number)")
            return None
        if self.integer and not x.is_integer():
            problems.append(bad())
            return None
        if self.low is not None and (x < self.low or (self.low_strict and x == self.low)):
            problems.append(bad())
            return None
        if self.high is not None and (x > self.high or (self.high_strict and x == self.high)):
            problems.append(bad())
            return None
        return int(x) if self.integer else x


@dataclass(frozen=True)
class Choice:
    """One string out of ``options``."""
    options: tuple[str, ...]
    required: bool = True
    default: str | None = None

    def describe(self) -> str:
        return "one of " + ", ".join(self.options) + " (a string)"

    def short(self) -> str:
        return "|".join(self.options)

    def check(self, value: Any, path: str, problems: list[str]) -> str | None:
        if isinstance(value, str) and value in self.options:
            return value
        problems.append(f"{path} must be {self.describe()}, got {show(value)}")
        return None


@dataclass(frozen=True)
class Text:
    """A free string (``nonempty``: not blank)."""
    required: bool = False
    default: str | None = None
    nonempty: bool = True

    def describe(self) -> str:
        return "a non-empty string" if self.nonempty else "a string"

    def short(self) -> str:
        return "string"

    def check(self, value: Any, path: str, problems: list[str]) -> str | None:
        if isinstance(value, str) and (value.strip() or not self.nonempty):
            return value
        problems.append(f"{path} must be {self.describe()}, got {show(value)}")
        return None


def unknown_key(path: str, key: Any, allowed: Mapping[str, str], context: str) -> str:
    """Problem text for a key that does not belong, listing the allowed keys with units.

    ``allowed`` maps each allowed key to a short description (its unit).
    """
    hint = ""
    if isinstance(key, str):
        close = difflib.get_close_matches(key, list(allowed), n=1)
        if close:
            hint = f" (did you mean {close[0]!r}?)"
    listing = ", ".join(f"{k} ({v})" if v else k for k, v in allowed.items()) or "none"
    return f"{path} is not {context}{hint}; allowed: {listing}"


def check_mapping(raw: Any, where: str, fields: Mapping[str, Any], problems: list[str], *,
                  context: str, extra: Mapping[str, str] | None = None) -> dict | None:
    """Check a mapping against ``fields`` (key -> :class:`Number` / :class:`Choice` / :class:`Text`).

    Parameters
    ----------
    raw : Any
        The parsed value; must be a mapping.
    where : str
        Key path of ``raw`` (``""`` at the top of a file).
    fields : Mapping
        The scalar fields this mapping may hold.
    problems : list of str
        Problems are appended here.
    context : str
        Phrase for unknown keys: ``"a motor key"`` gives
        ``motor.foo is not a motor key; allowed: ...``.
    extra : Mapping, optional
        Further allowed keys (sub-sections) that the caller checks itself,
        mapped to their short description; they are skipped here.

    Returns
    -------
    dict or None
        The checked values of ``fields`` that are valid (missing optional ones
        take their default, when it is not None), or None if ``raw`` is not a mapping.
    """
    extra = extra or {}
    if not isinstance(raw, Mapping):
        what = where or "the file"
        problems.append(f"{what} must be a mapping with keys "
                        f"{', '.join(list(fields) + list(extra))}, got {show(raw)}")
        return None
    allowed = {k: f.short() for k, f in fields.items()}
    allowed.update(extra)
    for key in raw:
        if key not in allowed:
            problems.append(unknown_key(join(where, key), key, allowed, context))
    out: dict = {}
    for key, spec in fields.items():
        path = join(where, key)
        value = raw.get(key, MISSING)
        if value is MISSING:
            if spec.required:
                problems.append(f"{path} is missing: expected {spec.describe()}")
            elif spec.default is not None:
                out[key] = spec.default
            continue
        checked = spec.check(value, path, problems)
        if checked is not None:
            out[key] = checked
    return out
