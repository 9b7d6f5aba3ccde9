"""Measurement records in gearbench's CSV format (docs/measurements.md): read, check, write.

A measurement file has one row per sample and a header of column names that carry their
unit as a suffix (``time_s``, ``voltage_V``, ``load_angle_deg``, ...).  It needs

- ``time_s`` (s), strictly increasing;
- exactly one input: ``voltage_V`` (V), ``drive_torque_Nm`` (N m) or ``drive_force_N`` (N),
  held constant from each sample to the next (zero-order hold);
- at least one measured signal (:data:`SIGNAL_COLUMNS`);
- optionally one set point (:data:`SETPOINT_COLUMNS`) and ``disturbance_V`` (V), a voltage
  added to a controller's output after its saturation (the EMPS force pulses).

``setpoint_mm``, ``motor_position_mm`` and ``disturbance_V`` serve translational plants.
A file with other column names or units is read through a column mapping
(:mod:`gearbench.measure.columns`); the delimiter and decimal mark are sniffed
(:mod:`gearbench.measure.csvformat`).  Every value must be a finite
number.  A bad file is rejected before anything is returned, with one
:class:`MeasurementError` that lists every problem found and names its column or row.
Rows are counted from 1 at the first data row, so data row ``r`` is file line ``r + 1``.
"""
from __future__ import annotations

import csv
import difflib
import math
import os
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Mapping, Sequence

import numpy as np
import pandas as pd

from ..errors import CsvFormatError, MeasurementError
from ..report.io import write_csv_atomic
from .columns import as_column_map, map_columns, needed
from .csvformat import CsvFormat, sniff
from . import gaps as gaps_mod
from .names import COLUMN_UNITS, DISTURBANCE_COLUMN, INPUT_COLUMNS, SETPOINT_COLUMNS, SIGNAL_COLUMNS, TIME_COLUMN

# Suffixes an engineer uses for units; a column ending in one of these that is not ours
# is most likely a unit we do not read (``load_angle_rad``), so the message says so.
_UNIT_SUFFIXES = frozenset("""
    s ms us ns min h hr sec secs rad rads deg degs degree degrees rev revs turn turns rpm rps
    m mm cm um nm in inch inches ft mil mils v mv kv a ma n kn mn nm nmm ozin lbf lbfin lbft
    kg g lb oz hz khz w kw ohm ohms pct percent count counts cnt cnts tick ticks pulse pulses
    mps mms ins degps radps rads2 mps2
""".split())

_MIN_ROWS = 2


@dataclass(eq=False)
class Measurement:
    """One measured (or simulated) record, values in the units of its columns.

    ``input`` is the commanded value of ``input_name`` (V, N m or N); ``signals`` maps
    measured column names to their samples (deg, mm or A); ``setpoint`` is the set point
    of a closed-loop run (deg or mm, per ``setpoint_name``); ``disturbance_V`` a voltage
    added after the controller's saturation; ``source`` where the record came from.
    Built by :func:`read_measurement` or :func:`from_arrays`, it has been checked; built
    directly, it has not.
    """

    time_s: np.ndarray
    input_name: str
    input: np.ndarray
    signals: dict[str, np.ndarray]
    setpoint_name: str | None = None
    setpoint: np.ndarray | None = None
    disturbance_V: np.ndarray | None = None
    source: str = ""
    gaps: "gaps_mod.Gaps | None" = None  # what ``gaps=`` filled or dropped when it was read, if it was asked to

    @property
    def duration_s(self) -> float:
        """Record length ``t[-1] − t[0]`` (s)."""
        return float(self.time_s[-1] - self.time_s[0])

    @property
    def sample_time_s(self) -> float:
        """Median sampling interval (s); the median ignores jitter and the odd gap."""
        return float(np.median(np.diff(self.time_s)))

    @property
    def input_unit(self) -> str:
        return COLUMN_UNITS[self.input_name]

    def signal_unit(self, name: str) -> str:
        """Unit of a column of this format, e.g. ``'deg'`` for ``'load_angle_deg'``."""
        try:
            return COLUMN_UNITS[name]
        except KeyError:
            raise KeyError(f"unknown column {name!r}: gearbench reads {_known_list()}") from None

    def columns(self) -> dict[str, np.ndarray]:
        """All columns in file order: time, input, signals, set point, disturbance."""
        cols = {TIME_COLUMN: self.time_s, self.input_name: self.input, **self.signals}
        if self.setpoint is not None:
            cols[self.setpoint_name] = self.setpoint
        if self.disturbance_V is not None:
            cols[DISTURBANCE_COLUMN] = self.disturbance_V
        return cols

    def to_frame(self) -> pd.DataFrame:
        """The record as a DataFrame with the file's column names."""
        return pd.DataFrame({k: np.asarray(v, dtype=float) for k, v in self.columns().items()})


# ---------------------------------------------------------------------------
# Checks shared by files and arrays.  Each returns a list of problems (strings).
# ---------------------------------------------------------------------------

def _known_list() -> str:
    return ", ".join(f"{k} ({u})" for k, u in COLUMN_UNITS.items())


def _unknown_column(name: str) -> str:
    prefix, _, suffix = name.rpartition("_")
    looks_like_unit = bool(prefix) and (
        suffix.lower() in _UNIT_SUFFIXES or (len(suffix) <= 4 and any(c.isupper() for c in suffix)))
    what = "unknown unit or column" if looks_like_unit else "unknown column"
    hint = ""
    same_quantity = [k for k in COLUMN_UNITS if prefix and k.rpartition("_")[0] == prefix]
    close = same_quantity or difflib.get_close_matches(name, COLUMN_UNITS, n=1, cutoff=0.75)
    if close:
        hint = f" (did you mean {close[0]!r}, in {COLUMN_UNITS[close[0]]}?)"
    return f"{what} {name!r}{hint}: gearbench reads {_known_list()}"


def _column_problems(names: Sequence[str]) -> list[str]:
    """Names: empty, duplicated, unknown; required ``time_s``, one input, a signal."""
    problems = []
    positions: dict[str, list[int]] = {}
    for i, name in enumerate(names, start=1):
        if not name:
            problems.append(f"column {i} has no name (a stray comma in the header?)")
            continue
        positions.setdefault(name, []).append(i)
    for name, where in positions.items():
        if len(where) > 1:
            problems.append(f"column {name!r} appears {len(where)} times "
                            f"(columns {', '.join(map(str, where))})")
        if name not in COLUMN_UNITS:
            problems.append(_unknown_column(name))
    present = set(positions)
    if TIME_COLUMN not in present:
        problems.append(f"missing column {TIME_COLUMN!r} (sample time, s)")
    inputs = [c for c in INPUT_COLUMNS if c in present]
    if not inputs:
        problems.append(f"no input column: a measurement needs exactly one of {', '.join(INPUT_COLUMNS)}")
    elif len(inputs) > 1:
        problems.append(f"more than one input column ({', '.join(map(repr, inputs))}): "
                        f"a measurement needs exactly one of {', '.join(INPUT_COLUMNS)}")
    if not any(c in present for c in SIGNAL_COLUMNS):
        problems.append(f"no measured signal: a measurement needs at least one of {', '.join(SIGNAL_COLUMNS)}")
    setpoints = [c for c in SETPOINT_COLUMNS if c in present]
    if len(setpoints) > 1:
        problems.append(f"more than one set-point column ({', '.join(map(repr, setpoints))}): give one")
    return problems


def _sample_name(i: int) -> str:
    """How an array's 0-based sample ``i`` is named in messages."""
    return f"sample {i} (0-based)"


def _file_rows(lines: np.ndarray) -> Callable[[int], str]:
    """Name sample ``i`` by its place in the file: data row ``line − 1``, file line ``line``."""
    return lambda i: f"data row {int(lines[i]) - 1} (file line {int(lines[i])})"


def _value_problems(name: str, values: np.ndarray, where: Callable[[int], str],
                    raw: np.ndarray | None = None, label: str | None = None, missing_ok: bool = False) -> list[str]:
    """Non-numeric, missing, NaN or infinite entries: the first one and how many.

    ``label`` names the column in the message (default ``'name'``; a mapped column
    adds the file's name for it); ``missing_ok``: empty cells and NaN are no problem (``gaps``
    fills or drops them), text and infinities still are."""
    bad = ~np.isfinite(values)
    if missing_ok:
        texts = np.array([isinstance(x, str) and bool(x.strip()) and x.strip().lower() != "nan"
                          for x in raw]) if raw is not None else np.zeros(values.size, dtype=bool)
        bad &= ~np.isnan(values) | texts
    bad = np.flatnonzero(bad)
    if bad.size == 0:
        return []
    i = int(bad[0])
    text = raw[i] if raw is not None else None
    hint = ""
    if isinstance(text, str) and text.strip() and not _is_number(text):
        what = f"non-numeric value {text.strip()!r}"
    elif np.isnan(values[i]):
        what = "missing or NaN value"
        hint = f"; {gaps_mod.OPTION} fills or drops up to {gaps_mod.MAX_RUN} missing samples in a row"
    else:
        what = f"infinite value {values[i]}"
    more = f" ({bad.size} bad rows in all)" if bad.size > 1 else ""
    return [f"column {label or repr(name)}: {what} at {where(i)}{more}{hint}"]


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _time_problems(t: np.ndarray, where: Callable[[int], str]) -> list[str]:
    """Times must increase strictly; name the first sample that does not."""
    if t.size < 2 or not np.all(np.isfinite(t)):
        return []
    back = np.flatnonzero(np.diff(t) <= 0)
    if back.size == 0:
        return []
    i = int(back[0]) + 1
    if t[i] == t[i - 1]:
        how = f"repeated time: {where(i)} has time_s = {t[i]:.10g} s, the same as the row before"
    else:
        how = (f"decreasing time: {where(i)} has time_s = {t[i]:.10g} s "
               f"after {t[i - 1]:.10g} s in the row before")
    return [f"times are not strictly increasing: {how}"]


def _raise(problems: list[str], source: str) -> None:
    if problems:
        head = f"measurement {source!r} is not usable" if source else "measurement is not usable"
        raise MeasurementError(head + ":\n  - " + "\n  - ".join(problems), problems)


def _assemble(columns: Mapping[str, np.ndarray], source: str) -> Measurement:
    """Build a Measurement from checked columns (all known, one input)."""
    input_name = next(c for c in INPUT_COLUMNS if c in columns)
    setpoint_name = next((c for c in SETPOINT_COLUMNS if c in columns), None)
    return Measurement(
        time_s=columns[TIME_COLUMN],
        input_name=input_name,
        input=columns[input_name],
        signals={c: columns[c] for c in columns if c in SIGNAL_COLUMNS},
        setpoint_name=setpoint_name,
        setpoint=columns[setpoint_name] if setpoint_name else None,
        disturbance_V=columns.get(DISTURBANCE_COLUMN),
        source=source,
    )


def _check_and_assemble(names: Sequence[str], values: Mapping[str, np.ndarray], source: str,
                        where: Callable[[int], str], raw: Mapping[str, np.ndarray] | None = None,
                        extra: Sequence[str] = (), labels: Mapping[str, str] | None = None,
                        gaps: str | None = None) -> Measurement:
    """The checked record; ``gaps`` (``measure.gaps.MODES``) fills or drops its missing samples
    (``Measurement.gaps`` says what it did), None refuses them."""
    problems = _column_problems(names) + list(extra)
    labels = labels or {}
    n_rows = len(next(iter(values.values()))) if values else 0
    if values and n_rows < _MIN_ROWS:
        problems.append(f"{n_rows} sample(s): a measurement needs at least {_MIN_ROWS}")
    for name, v in values.items():
        problems += _value_problems(name, v, where, raw.get(name) if raw else None, labels.get(name),
                                    missing_ok=gaps is not None)
    if TIME_COLUMN in values and gaps is None:
        problems += _time_problems(values[TIME_COLUMN], where)
    _raise(problems, source)
    if gaps is None:
        return _assemble(values, source)
    values, report = gaps_mod.repair(values, gaps, source)
    problems = _time_problems(values[TIME_COLUMN], _sample_name)
    if len(values[TIME_COLUMN]) < _MIN_ROWS:
        problems.append(f"{len(values[TIME_COLUMN])} sample(s) left: a measurement needs at least {_MIN_ROWS}")
    _raise(problems, source)
    m = _assemble(values, source)
    m.gaps = report
    return m


# ---------------------------------------------------------------------------
# Files
# ---------------------------------------------------------------------------

def _read_header(path: Path, fmt: CsvFormat) -> list[str]:
    try:
        with open(path, newline="", encoding=fmt.encoding) as fh:
            first = fh.readline()
            rest = fh.read(1)
    except (UnicodeDecodeError, OSError) as exc:
        raise MeasurementError(f"measurement file '{path}': cannot read its header as {fmt.encoding} text: "
                               f"{exc}") from None
    if not first.strip():
        if not rest.strip():
            raise MeasurementError(f"measurement file '{path}' is empty")
        raise MeasurementError(f"measurement file '{path}': file line 1 is blank; it must be the header")
    try:
        return [name.strip() for name in next(csv.reader([first], delimiter=fmt.delimiter))]
    except csv.Error as exc:
        raise MeasurementError(f"measurement file '{path}': file line 1 is not a CSV header: {exc}") from None


def _read_body(path: Path, n_cols: int, fmt: CsvFormat) -> pd.DataFrame:
    """Data rows as parsed by pandas, columns numbered; blank lines kept so rows count true."""
    try:
        return pd.read_csv(path, header=None, skiprows=1, names=range(n_cols), skip_blank_lines=False,
                           skipinitialspace=True, encoding=fmt.encoding, low_memory=False,
                           sep=fmt.delimiter, decimal=fmt.decimal)
    except pd.errors.EmptyDataError:
        return pd.DataFrame(columns=range(n_cols))
    except UnicodeDecodeError as exc:
        raise MeasurementError(f"measurement file '{path}' is not {fmt.encoding} text beyond its first lines "
                               f"(byte 0x{exc.object[exc.start]:02x}): save it as UTF-8 CSV") from None
    except pd.errors.ParserError as exc:
        found = re.search(r"Expected (\d+) fields in line (\d+), saw (\d+)", str(exc))
        if found:
            # pandas counts file lines from 1 with the header as line 1, as we do.
            expected, line, seen = map(int, found.groups())
            raise MeasurementError(
                f"measurement file '{path}': data row {line - 1} (file line {line}) has {seen} fields, "
                f"the header names {expected} columns ({fmt.describe()})", ) from None
        raise MeasurementError(f"measurement file '{path}' is not a well-formed CSV table: {exc}") from None


def _to_float(column: pd.Series, decimal: str = ".") -> tuple[np.ndarray, np.ndarray | None]:
    """Float values (NaN where not a number) and, if any text was found, the raw text."""
    if pd.api.types.is_numeric_dtype(column):
        return column.to_numpy(dtype=float), None
    text = column
    if decimal == ",":  # pandas leaves a column with any non-number as text, decimal commas too
        text = column.astype("string").str.replace(",", ".", regex=False)
    try:
        values = pd.to_numeric(text, errors="coerce").to_numpy(dtype=float)
    except OverflowError:  # an integer too long for pandas' int64 path; as a float it is +-inf
        values = np.array([_float_or_nan(v) for v in text], dtype=float)
    return values, column.to_numpy(dtype=object)


def _float_or_nan(v) -> float:
    """``float(v)``; an integer beyond the float range is +-inf, a non-number NaN."""
    try:
        return float(v)
    except OverflowError:
        return math.inf if v > 0 else -math.inf
    except (TypeError, ValueError):
        return math.nan


def read_measurement(path: str | Path, columns=None, units=None, gaps: str | None = None) -> Measurement:
    """Read and check a measurement CSV (docs/measurements.md); raise :class:`MeasurementError`
    naming every bad column and the first bad row of each.

    Parameters
    ----------
    path : str or Path
        The CSV file: comma-, semicolon- or tab-separated, decimal point or (with a
        semicolon or tab) decimal comma, UTF-8 or Windows-1252; all sniffed.
    columns : ColumnMap, mapping or str, optional
        Which file column holds each gearbench column (``{'time_s': 't'}`` or
        ``'time_s=t,voltage_V=u'``); a :class:`gearbench.measure.columns.ColumnMap`
        may carry units, delimiter and decimal mark too.  Default: the file's header
        names gearbench's columns.
    units : mapping or str, optional
        The unit of each mapped column (``{'time': 'ms', 'load_angle': 'rad'}``); its
        values are converted to gearbench's units.
    gaps : {'interpolate', 'drop'}, optional
        What to do with missing samples (empty cells, rows missing from the time grid):
        :mod:`gearbench.measure.gaps`; the record's ``gaps`` says what was done.  Default:
        refuse them.
    """
    return read_mapped(path, columns, units, gaps)[0]


def read_mapped(path: str | Path, columns=None, units=None,
                gaps: str | None = None) -> tuple[Measurement, list[str], list[str]]:
    """:func:`read_measurement`, and what it did.

    Parameters
    ----------
    path, columns, units, gaps
        As for :func:`read_measurement`.

    Returns
    -------
    tuple of (Measurement, list of str, list of str)
        The record; one line per mapped column saying which file column it came from and
        the unit conversion (``load_angle_deg <- 'theta' in rad (x 57.2958)``); the file
        columns left out (neither mapped nor named as gearbench's).  Without a mapping
        both lists are empty.
    """
    if not isinstance(path, (str, os.PathLike)):
        raise MeasurementError(f"path must be a measurement file's path (str or Path), got a {type(path).__name__}")
    path = Path(path)
    if not path.exists():
        raise MeasurementError(f"measurement file '{path}' does not exist")
    if path.is_dir():
        raise MeasurementError(f"measurement file '{path}' is a directory, not a CSV file")
    cmap = None
    if columns is not None or units is not None:
        cmap = as_column_map(columns, units)
    try:
        fmt = sniff(path, cmap.delimiter if cmap else None, cmap.decimal if cmap else None)
    except CsvFormatError as exc:
        raise MeasurementError(str(exc)) from None
    names = _read_header(path, fmt)
    body = _read_body(path, len(names), fmt)
    # Blank lines carry no sample; drop them but keep every sample's own file line.
    lines = np.arange(len(body)) + 2
    filled = ~body.isna().all(axis=1).to_numpy()
    body, lines = body[filled], lines[filled]
    where = _file_rows(lines)
    used: list[str] = []
    ignored: list[str] = []
    if not len(body):
        return _check_and_assemble(names, {}, str(path), where,
                                   extra=["the file has a header but no data rows"]), used, ignored
    if cmap is not None and not cmap.empty:
        mapped = map_columns(cmap, names, body, str(path), lambda c: _to_float(c, fmt.decimal))
        used, ignored = mapped.used, mapped.ignored
        try:
            m = _check_and_assemble(mapped.names, mapped.values, str(path), where, raw=mapped.raw,
                                    labels=mapped.labels, gaps=gaps)
        except MeasurementError as exc:
            found = ", ".join(repr(n) for n in names)
            context = [f"the file's columns are {found}; mapped: {'; '.join(used) or 'none'}", needed()]
            raise MeasurementError(f"{exc}\n  - " + "\n  - ".join(context), exc.problems + context) from None
        return m, used, ignored
    values, raw = {}, {}
    for j, name in enumerate(names):
        if name in COLUMN_UNITS and names.count(name) == 1:
            values[name], raw[name] = _to_float(body[j], fmt.decimal)
    try:
        return _check_and_assemble(names, values, str(path), where, raw=raw, gaps=gaps), used, ignored
    except MeasurementError as exc:
        if not any(p.startswith("unknown") for p in exc.problems):
            raise
        hint = ("to read columns with other names or units, map them: --columns time_s=t,... "
                "--units load_angle=rad,... (docs/measurements.md)")
        raise MeasurementError(f"{exc}\n  ({hint})", exc.problems) from None


def from_frame(frame: pd.DataFrame, source: str = "", gaps: str | None = None) -> Measurement:
    """Check a DataFrame in the file's column format and make it a Measurement (``gaps``: as for
    :func:`read_measurement`)."""
    names = [str(c) for c in frame.columns]
    values, raw = {}, {}
    for j, name in enumerate(names):
        if name in COLUMN_UNITS and names.count(name) == 1:
            values[name], raw[name] = _to_float(frame.iloc[:, j])
    return _check_and_assemble(names, values, source, _sample_name, raw=raw, gaps=gaps)


def from_arrays(time_s, input_name: str, input, signals: Mapping[str, np.ndarray], setpoint=None,
                setpoint_name: str | None = None, disturbance_V=None, source: str = "") -> Measurement:
    """Make a Measurement from arrays, with the same checks as :func:`read_measurement`.

    ``input`` is in the unit of ``input_name`` (V, N m or N), each signal in the unit of
    its name, ``setpoint`` in the unit of ``setpoint_name`` (which is then required).
    """
    problems = []
    if input_name not in INPUT_COLUMNS:
        problems.append(f"input_name {input_name!r} is not an input: use one of {', '.join(INPUT_COLUMNS)}")
    for name in signals:
        if name not in SIGNAL_COLUMNS:
            problems.append(f"signal {name!r} is not a measured signal: use {', '.join(SIGNAL_COLUMNS)}")
    if setpoint is not None and setpoint_name not in SETPOINT_COLUMNS:
        problems.append(f"setpoint_name {setpoint_name!r}: a set point needs one of {', '.join(SETPOINT_COLUMNS)}")
    if setpoint is None and setpoint_name is not None:
        problems.append(f"setpoint_name {setpoint_name!r} given without set-point values")
    _raise(problems, source)

    columns = {TIME_COLUMN: time_s, input_name: input, **signals}
    if setpoint is not None:
        columns[setpoint_name] = setpoint
    if disturbance_V is not None:
        columns[DISTURBANCE_COLUMN] = disturbance_V
    values = {}
    for name, v in columns.items():
        arr = np.asarray(v)
        if arr.ndim != 1:
            problems.append(f"column {name!r} must be one-dimensional, got shape {arr.shape}")
            continue
        try:
            values[name] = arr.astype(float)
        except (TypeError, ValueError):
            problems.append(f"column {name!r} holds values that are not numbers")
    lengths = {name: len(v) for name, v in values.items()}
    n = lengths.get(TIME_COLUMN)
    for name, length in lengths.items():
        if n is not None and length != n:
            problems.append(f"column {name!r} has {length} samples, time_s has {n}")
    _raise(problems, source)
    return _check_and_assemble(list(columns), values, source, _sample_name)


def with_gaps(m: Measurement, gaps: str) -> Measurement:
    """Record ``m`` (built directly, perhaps with NaN) with its missing samples filled or dropped by
    ``gaps`` (:mod:`gearbench.measure.gaps`)."""
    cols = {k: np.asarray(v, dtype=float) for k, v in m.columns().items()}
    return _check_and_assemble(list(cols), cols, m.source, _sample_name, gaps=gaps)


def _time_format(t: np.ndarray, float_format: str) -> str:
    """``float_format`` unless it would make two times equal; then full precision."""
    written = np.array([float(float_format % v) for v in t])
    return float_format if np.all(np.diff(written) > 0) else "%.17g"


def write_measurement(frame_or_measurement, path: str | Path, float_format: str = "%.10g") -> Path:
    """Check a record and write it as a measurement CSV, atomically.

    The times are written with more digits when ``float_format`` would round two of them
    together, so that every file written can be read back.
    """
    m = frame_or_measurement
    if not isinstance(m, Measurement):
        m = from_frame(m, source=str(path))
    frame = m.to_frame()
    return write_csv_atomic(frame, path, float_format=_time_format(frame[TIME_COLUMN].to_numpy(), float_format))


__all__ = ["MeasurementError", "Measurement", "INPUT_COLUMNS", "SIGNAL_COLUMNS", "SETPOINT_COLUMNS",
           "TIME_COLUMN", "DISTURBANCE_COLUMN", "COLUMN_UNITS", "read_measurement", "read_mapped", "from_arrays",
           "from_frame", "with_gaps", "write_measurement"]
