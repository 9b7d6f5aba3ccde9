"""Measurements with any column names and units: a mapping onto gearbench's columns.

gearbench reads a record whose header names its own columns (``time_s``,
``voltage_V``, ``load_angle_deg``, ...: :data:`gearbench.measure.names.COLUMN_UNITS`).
A lab's file names them otherwise (``t``, ``u``, ``theta_out``) and may hold them in
other units (ms, rad, mA).  A :class:`ColumnMap` says, for each gearbench column,
which column of the file holds it and in which unit::

    columns: time_s=t, voltage_V=u, load_angle_deg=theta_out
    units:   time=ms, load_angle=rad

A key is a gearbench column (``load_angle_deg``) or its quantity, the name without
the unit suffix (``load_angle``; ``setpoint`` is ``setpoint_deg`` or ``setpoint_mm``
by its unit's dimension).  A unit applies to a mapped column: the file's values are
multiplied by the factor that turns that unit into the column's (``rad`` to ``deg``:
180/pi; ``ms`` to ``s``: 1e-3; ``turn/4096``, a 4096-count encoder, to ``deg``:
360/4096), which pint (https://pint.readthedocs.io) computes and checks: a unit of
the wrong dimension (``load_angle=V``) is an error.  An angle's unit must reduce to
radians (pint counts angles as dimensionless, so ``percent`` would pass a plain
dimension check).

With a mapping, file columns that are neither mapped nor named as gearbench's are
ignored (and listed, :attr:`MappedColumns.ignored`); a file column named as one of
gearbench's and not mapped is read as it is.
"""
from __future__ import annotations

import difflib
import functools
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping

import numpy as np
import pandas as pd

from ..errors import ConfigError, MeasurementError
from ..schema import show, unknown_key
from .csvformat import check_choice
from .names import COLUMN_UNITS, DISTURBANCE_COLUMN, INPUT_COLUMNS, SETPOINT_COLUMNS, SIGNAL_COLUMNS, TIME_COLUMN

#: quantity name of each column: the column's name without its unit suffix
QUANTITY = {name: name.rsplit("_", 1)[0] for name in COLUMN_UNITS}
_BY_QUANTITY: dict[str, tuple[str, ...]] = {}
for _name, _q in QUANTITY.items():
    _BY_QUANTITY[_q] = _BY_QUANTITY.get(_q, ()) + (_name,)

# What a unit of each canonical unit's dimension is called, and some that pint reads.
_KIND = {"s": "a time", "deg": "an angle", "mm": "a length", "V": "a voltage", "A": "a current",
         "N m": "a torque", "N": "a force"}
_EXAMPLES = {"s": "s, ms, us, min", "deg": "deg, rad, turn, turn/4096 (counts of a 4096-count encoder)",
             "mm": "mm, m, um, inch", "V": "V, mV", "A": "A, mA", "N m": "N*m, mN*m, N*cm, lbf*inch",
             "N": "N, kN, lbf"}
_DELIMITER_WORDS = {"comma": ",", "semicolon": ";", "tab": "\t", "\\t": "\t"}
FILE_KEYS = ("columns", "units", "delimiter", "decimal")


def needed() -> str:
    """What a record needs, with units: the text every column error ends with."""
    def show(names):
        return ", ".join(f"{n} ({COLUMN_UNITS[n]})" for n in names)
    return (f"a measurement needs {TIME_COLUMN} (s); one input of {show(INPUT_COLUMNS)}; at least one "
            f"signal of {show(SIGNAL_COLUMNS)}; optionally one set point of {show(SETPOINT_COLUMNS)} "
            f"and {DISTURBANCE_COLUMN} (V)")


def _keys_listing() -> str:
    quantities = ", ".join(dict.fromkeys(QUANTITY.values()))
    return f"gearbench's columns {', '.join(COLUMN_UNITS)} or their quantities {quantities}"


@functools.lru_cache(maxsize=1)
def _registry():
    import pint  # late: building the registry takes ~0.4 s, and only a mapping with units needs it

    ureg = pint.UnitRegistry()
    ureg.define("rev = turn")
    return ureg


@functools.lru_cache(maxsize=256)
def _parse_unit(text: str):
    """pint Quantity of ``text`` (``'ms'``, ``'turn/4096'``) or a problem string."""
    ureg = _registry()
    try:
        q = ureg.parse_expression(text)
        if not isinstance(q, ureg.Quantity):
            q = ureg.Quantity(q)
        scale = float(q.magnitude)
    except Exception as exc:  # pint raises its own errors, tokenize and syntax errors alike
        return f"unknown unit {text!r} ({type(exc).__name__}: {exc})"
    if not np.isfinite(scale) or scale == 0.0:
        return f"unit {text!r} is not a finite, non-zero scale"
    return q


def _is_angle(q) -> bool:
    ureg = _registry()
    try:
        return ureg.get_root_units(q.units)[1] == ureg.radian
    except Exception:
        return False


def _same_kind(q, target: str) -> bool:
    """Whether Quantity ``q`` converts to ``target`` (an angle must reduce to radians)."""
    if target == "deg":
        return _is_angle(q)
    return q.dimensionality == _registry().Quantity(1.0, target).dimensionality


def _kind_of(q) -> str:
    """``'a voltage'``, ``'an angle'``, ``'dimensionless'`` or pint's dimension text."""
    for target, kind in _KIND.items():
        if _same_kind(q, target):
            return kind
    return "dimensionless" if q.dimensionless else f"of dimension {q.dimensionality}"


def unit_factor(text: str, column: str) -> float:
    """The factor that turns a value in unit ``text`` into ``column``'s unit.

    ``unit_factor('rad', 'load_angle_deg') == 180/pi``; ``unit_factor('ms', 'time_s') == 1e-3``.

    Parameters
    ----------
    text : str
        A unit in pint's syntax (``'mA'``, ``'turn/4096'``, ``'N*m'``).
    column : str
        A gearbench column (:data:`gearbench.measure.names.COLUMN_UNITS`).

    Raises
    ------
    MeasurementError
        Naming the unit, the column and what its unit must be.
    """
    problem = _unit_problem(text, column)
    if isinstance(problem, str):
        raise MeasurementError(problem)
    return problem


def _unit_problem(text: Any, column: str) -> float | str:
    """The factor, or a problem string naming the unit and what the column needs."""
    target = COLUMN_UNITS[column]
    need = f"{column} needs {_KIND[target]} unit such as {_EXAMPLES[target]}"
    if not isinstance(text, str) or not text.strip():
        return f"units {QUANTITY[column]}: the unit must be a non-empty string, got {text!r}; {need}"
    q = _parse_unit(text.strip())
    if isinstance(q, str):
        return f"units {QUANTITY[column]}={text}: {q}; {need}"
    if not _same_kind(q, target):
        hint = " (write N*m: pint does not read 'Nm' as newton metres)" if text.strip() == "Nm" else ""
        return f"units {QUANTITY[column]}={text}: {text!r} is {_kind_of(q)}, not {_KIND[target]}{hint}; {need}"
    return float(q.to(target).magnitude)


def parse_pairs(text: str | None, option: str) -> dict[str, str]:
    """``'time_s=t, voltage_V=u'`` as ``{'time_s': 't', 'voltage_V': 'u'}``.

    Parameters
    ----------
    text : str or None
        Comma-separated ``KEY=VALUE`` items; blank items are skipped.
    option : str
        The option's name for messages (``'--columns'``).

    Raises
    ------
    MeasurementError
        Naming ``option`` and each item that is not ``KEY=VALUE`` or repeats a key.
    """
    out: dict[str, str] = {}
    problems = []
    for item in (text or "").split(","):
        if not item.strip():
            continue
        key, eq, value = item.partition("=")
        key, value = key.strip(), value.strip()
        if not eq or not key or not value:
            problems.append(f"{option}: {item.strip()!r} is not KEY=VALUE (e.g. "
                            f"{'time_s=t' if option == '--columns' else 'time=ms'})")
        elif key in out:
            problems.append(f"{option}: {key!r} is given twice")
        else:
            out[key] = value
    if problems:
        raise MeasurementError("; ".join(problems), problems)
    return out


@dataclass(frozen=True)
class ColumnMap:
    """Which file column holds each gearbench column, and in which unit.

    Attributes
    ----------
    columns : dict
        gearbench column (``load_angle_deg``) -> the file's column name.
    units : dict
        gearbench column -> the unit its file column is in (pint syntax: ``rad``, ``ms``,
        ``mA``, ``turn/4096``); a column without one is in gearbench's unit.
    delimiter, decimal : str or None
        Force the file's delimiter (``,`` ``;`` or tab) and decimal mark (``.`` or ``,``);
        None = sniffed (:func:`gearbench.measure.csvformat.sniff`).

    Build one with :meth:`build` (keys may be quantities, units are checked) or
    :func:`load_column_map` (a YAML file).
    """

    columns: Mapping[str, str] = field(default_factory=dict)
    units: Mapping[str, str] = field(default_factory=dict)
    delimiter: str | None = None
    decimal: str | None = None

    @property
    def empty(self) -> bool:
        return not (self.columns or self.units)

    def factor(self, column: str) -> float:
        """Multiplier from the file's unit of ``column`` to gearbench's (1 without a unit)."""
        return unit_factor(self.units[column], column) if column in self.units else 1.0

    @classmethod
    def build(cls, columns: Mapping[str, str] | str | None = None, units: Mapping[str, str] | str | None = None,
              delimiter: str | None = None, decimal: str | None = None, partial: bool = False) -> "ColumnMap":
        """A checked map from ``columns`` and ``units``, each a mapping or ``'k=v,k=v'`` text.

        Parameters
        ----------
        columns : mapping or str, optional
            gearbench column -> file column.  Keys may be gearbench columns or quantities
            (``time`` for ``time_s``); a ``setpoint`` key becomes ``setpoint_deg`` or
            ``setpoint_mm`` by its unit.
        units : mapping or str, optional
            gearbench column or quantity -> unit of the file's column (pint syntax).
        delimiter : str, optional
            ``','``, ``';'``, tab (or ``'comma'``, ``'semicolon'``, ``'tab'``); None = sniffed.
        decimal : str, optional
            ``'.'`` or ``','``; None = sniffed.
        partial : bool
            A map that will override another (:meth:`merged`), whose units may belong to
            the other's columns; the merged map is checked whole.

        Raises
        ------
        MeasurementError
            Listing every unknown key, unknown unit and unit of the wrong dimension.
        """
        problems: list[str] = []
        cols = _pairs(columns, "columns", problems)
        unit_text = _pairs(units, "units", problems)
        delimiter = _DELIMITER_WORDS.get(delimiter, delimiter) if isinstance(delimiter, str) else delimiter
        problems += [f"column mapping: {p}" for p in check_choice(delimiter, decimal)]
        resolved_units: dict[str, str] = {}
        for key, text in unit_text.items():
            name = _resolve(key, "units", problems, unit=text, mapped=cols)
            if name is None:
                continue
            if name in resolved_units:
                problems.append(f"units: {name} is given twice (as {key!r} and another key)")
                continue
            found = _unit_problem(text, name)
            if isinstance(found, str):
                problems.append(found)
            else:
                resolved_units[name] = text.strip()
        resolved_cols: dict[str, str] = {}
        for key, raw in cols.items():
            unit = next((u for k, u in unit_text.items() if _quantity(k) == _quantity(key)), None)
            name = _resolve(key, "columns", problems, unit=unit, mapped=cols)
            if name is None:
                continue
            if name in resolved_cols:
                problems.append(f"columns: {name} is mapped twice (to {resolved_cols[name]!r} and {raw!r})")
                continue
            resolved_cols[name] = raw
        if not partial:
            problems += _whole_problems(resolved_cols, resolved_units)
        if problems:
            raise MeasurementError("column mapping is not usable:\n  - " + "\n  - ".join(problems), problems)
        return cls(resolved_cols, resolved_units, delimiter, decimal)

    def merged(self, override: "ColumnMap") -> "ColumnMap":
        """This map with ``override``'s entries replacing its own (options over a file).

        Parameters
        ----------
        override : ColumnMap
            Its columns, units, delimiter and decimal mark win.

        Raises
        ------
        MeasurementError
            When the merged map gives a unit to a column it does not map, or maps one
            file column twice.
        """
        cols, units = {**self.columns, **override.columns}, {**self.units, **override.units}
        problems = _whole_problems(cols, units)
        if problems:
            raise MeasurementError("column mapping is not usable:\n  - " + "\n  - ".join(problems), problems)
        return ColumnMap(cols, units, override.delimiter or self.delimiter, override.decimal or self.decimal)

    def describe(self) -> list[str]:
        """One line per mapped column: ``load_angle_deg <- 'theta' (rad x 57.2958)``."""
        out = []
        for name, raw in self.columns.items():
            unit = self.units.get(name)
            conv = f" (in {unit}, x {self.factor(name):.6g} to {COLUMN_UNITS[name]})" if unit else ""
            out.append(f"{name} <- {raw!r}{conv}")
        return out


def _whole_problems(cols: Mapping[str, str], units: Mapping[str, str]) -> list[str]:
    """A unit needs its column mapped; a file column maps to one gearbench column."""
    problems = []
    for name in units:
        if name not in cols:
            problems.append(f"units {QUANTITY[name]}={units[name]}: no file column is mapped to "
                            f"{name}; a unit applies to a mapped column (add {name}=FILE_COLUMN to the "
                            f"columns), a column named {name} is in {COLUMN_UNITS[name]} already")
    sources: dict[str, list[str]] = {}
    for name, raw in cols.items():
        sources.setdefault(raw, []).append(name)
    for raw, names in sources.items():
        if len(names) > 1:
            problems.append(f"columns: file column {raw!r} is mapped to {' and '.join(names)}; "
                            "map each file column once")
    return problems


def _quantity(key: str) -> str:
    return QUANTITY.get(key, key)


def _pairs(value: Any, what: str, problems: list[str]) -> dict[str, str]:
    """A mapping or ``'k=v,...'`` text as a dict of strings; other types are a problem."""
    if value is None:
        return {}
    if isinstance(value, str):
        try:
            return parse_pairs(value, f"--{what}")
        except MeasurementError as exc:
            problems.extend(exc.problems)
            return {}
    if not isinstance(value, Mapping):
        problems.append(f"{what} must be a mapping of gearbench column to "
                        f"{'file column' if what == 'columns' else 'unit'} or 'KEY=VALUE,...' text, "
                        f"got a {type(value).__name__}")
        return {}
    out = {}
    for k, v in value.items():
        if not isinstance(k, str) or isinstance(v, bool) or not isinstance(v, (str, int, float)):
            problems.append(f"{what}: {k!r}: {v!r} must map a name to a "
                            f"{'file column name' if what == 'columns' else 'unit'} (a string)")
            continue
        out[k.strip()] = str(v).strip()
    return out


def _resolve(key: str, what: str, problems: list[str], unit: str | None,
             mapped: Mapping[str, str]) -> str | None:
    """gearbench column named by ``key`` (a column or a quantity), or None after a problem."""
    if key in COLUMN_UNITS:
        return key
    names = _BY_QUANTITY.get(key)
    if names and len(names) == 1:
        return names[0]
    if names:  # 'setpoint': by the unit's dimension, or by an explicit column key
        explicit = [n for n in names if n in mapped]
        if len(explicit) == 1:
            return explicit[0]
        if unit is not None:
            fits = [n for n in names if not isinstance(_unit_problem(unit, n), str)]
            if len(fits) == 1:
                return fits[0]
        options = ", ".join(f"{n} in {COLUMN_UNITS[n]}" for n in names)
        if unit is not None:
            problems.append(f"{what}: {key!r} is {' or '.join(names)} ({options}); its unit {unit!r} "
                            "fits neither")
        else:
            problems.append(f"{what}: {key!r} is {' or '.join(names)}: name the column ({options}) "
                            "or give its unit")
        return None
    close = difflib.get_close_matches(key, list(COLUMN_UNITS) + list(_BY_QUANTITY), n=1, cutoff=0.6)
    hint = f" (did you mean {close[0]!r}?)" if close else ""
    reverse = ""
    if what == "columns" and (mapped.get(key) in COLUMN_UNITS or mapped.get(key) in _BY_QUANTITY):
        reverse = f" (the form is GEARBENCH_COLUMN=FILE_COLUMN: {mapped[key]}={key}?)"
        hint = ""
    problems.append(f"{what}: {key!r} is not a gearbench column{hint}{reverse}; keys are {_keys_listing()}")
    return None


def load_column_map(path: str | Path, partial: bool = False) -> ColumnMap:
    """Read a mapping file: YAML with ``columns:`` and ``units:`` mappings, optional
    ``delimiter:`` (``,`` ``;`` ``tab``) and ``decimal:`` (``.`` or ``,``).

    Parameters
    ----------
    path : str or Path
        The YAML file.
    partial : bool
        The map will be completed by another (:meth:`ColumnMap.merged`), so a unit may
        name a column the file does not map.

    Raises
    ------
    gearbench.errors.ConfigError
        For a file that is missing, not YAML or not such a mapping (naming the key).
    MeasurementError
        For unknown columns or units (see :meth:`ColumnMap.build`).
    """
    from ..experiment.files import read_yaml

    path = Path(path)
    raw = read_yaml(path)
    problems = []
    if not isinstance(raw, Mapping):
        raise ConfigError(path.name, f"a column mapping file must be a mapping with keys {', '.join(FILE_KEYS)}, "
                                     f"got {show(raw)}")
    for key in raw:
        if key not in FILE_KEYS:
            problems.append(unknown_key(str(key), key, {k: "" for k in FILE_KEYS}, "a column mapping key"))
    for key in ("columns", "units"):
        if key in raw and not isinstance(raw[key], Mapping):
            problems.append(f"{key} must be a mapping (gearbench column: "
                            f"{'file column' if key == 'columns' else 'unit'}), got {show(raw[key])}")
    for key in ("delimiter", "decimal"):
        if key in raw and not isinstance(raw[key], str):
            problems.append(f"{key} must be a string, got {show(raw[key])}")
    if "columns" not in raw and "units" not in raw:
        problems.append("the file maps nothing: give columns: and/or units:")
    if problems:
        raise ConfigError(path.name, problems)
    try:
        return ColumnMap.build(raw.get("columns"), raw.get("units"), raw.get("delimiter"), raw.get("decimal"),
                               partial=partial)
    except MeasurementError as exc:
        raise ConfigError(path.name, exc.problems) from None


def as_column_map(columns: Any = None, units: Any = None) -> ColumnMap | None:
    """A :class:`ColumnMap` from what a caller gave, or None when both are None.

    Parameters
    ----------
    columns : ColumnMap, mapping, str or None
        A ready map, or what :meth:`ColumnMap.build` takes.
    units : mapping, str or None
        Units; with a ready map they are added to (and override) its own.
    """
    if isinstance(columns, ColumnMap):
        return columns.merged(ColumnMap.build(units=units, partial=True)) if units is not None else columns
    if columns is None and units is None:
        return None
    return ColumnMap.build(columns, units)


@dataclass(frozen=True)
class MappedColumns:
    """gearbench's columns taken from a file through a :class:`ColumnMap`.

    ``names``: the gearbench columns found, in file order (a repeated one repeated);
    ``values``/``raw``: their values in gearbench's units and the text they were read from;
    ``labels``: how messages name each (``load_angle_deg (file column 'theta')``);
    ``used``: lines saying what came from where; ``ignored``: file columns not read.
    """

    names: list[str]
    values: dict[str, np.ndarray]
    raw: dict[str, np.ndarray | None]
    labels: dict[str, str]
    used: list[str]
    ignored: list[str]


def map_columns(cmap: ColumnMap, file_names: list[str], body: pd.DataFrame, source: str,
                to_float: Callable[[pd.Series], tuple[np.ndarray, np.ndarray | None]]) -> MappedColumns:
    """Take gearbench's columns out of a file's table through ``cmap``.

    Parameters
    ----------
    cmap : ColumnMap
        The mapping (checked).
    file_names : list of str
        The file's header, one name per column of ``body``.
    body : pandas.DataFrame
        The data rows, columns numbered 0, 1, ...
    source : str
        The file, for messages.
    to_float : callable
        Turns a column into (float values with NaN where not a number, raw text or None).

    Raises
    ------
    MeasurementError
        When a mapped file column is missing or repeated, or a file column named as a
        gearbench column is also mapped from another; the message lists the file's columns.
    """
    problems = []
    where: dict[str, list[int]] = {}
    for j, raw in enumerate(file_names):
        where.setdefault(raw, []).append(j)
    found = ", ".join(repr(n) for n in file_names)
    consumed = set()
    for name, raw in cmap.columns.items():
        if raw not in where:
            close = difflib.get_close_matches(raw, [n for n in file_names if n], n=1, cutoff=0.6)
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            problems.append(f"columns {name}={raw}: the file has no column {raw!r}{hint}")
        elif len(where[raw]) > 1:
            problems.append(f"columns {name}={raw}: the file has {len(where[raw])} columns named {raw!r} "
                            f"(columns {', '.join(str(j + 1) for j in where[raw])}); cannot tell which")
        consumed.add(raw)
    for name, raw in cmap.columns.items():
        if name in where and name not in consumed:
            problems.append(f"columns {name}={raw}: the file has a column named {name} too; "
                            f"map one of them (e.g. {name}={name}) or rename the other")
    if problems:
        problems.append(f"the file's columns are {found}")
        raise MeasurementError(f"measurement {source!r} does not fit the column mapping:\n  - "
                               + "\n  - ".join(problems), problems)
    names, values, raw_text, labels, used, ignored = [], {}, {}, {}, [], []
    mapped_from = {raw: name for name, raw in cmap.columns.items()}
    for j, raw in enumerate(file_names):
        name = mapped_from.get(raw, raw if raw in COLUMN_UNITS and raw not in cmap.columns else None)
        if name is None:
            if raw:
                ignored.append(raw)
            continue
        names.append(name)
        if raw in mapped_from:
            labels[name] = f"{name!r} (file column {raw!r})"
            unit = cmap.units.get(name)
            used.append(f"{name} <- {raw!r}" + (f" in {unit} (x {cmap.factor(name):.6g})" if unit else ""))
        if names.count(name) > 1:
            continue  # data._column_problems names the repeat
        values[name], raw_text[name] = to_float(body[j])
        if name in cmap.units:
            values[name] = values[name] * cmap.factor(name)
    return MappedColumns(names, values, raw_text, labels, used, ignored)


__all__ = ["ColumnMap", "MappedColumns", "QUANTITY", "load_column_map", "map_columns", "parse_pairs",
           "unit_factor", "as_column_map", "needed"]
