"""A few missing samples in a record: refused, interpolated or dropped, and said where.

A replay drives the model sample by sample on a uniform time grid of step ``h`` (the median
step): the input held from each sample to the next, the noise floors read from differences
of neighbouring samples.  A sample is missing when a cell is empty (``NaN``) or when a row
is: a time step of ``k h`` (``k >= 2`` within 1 % of ``h``) leaves ``k - 1`` rows out.
By default a record with missing samples is refused (as it always was), naming the first
one and this option; ``gaps`` (``--gaps`` on the command line) says what to do instead:

``interpolate``
    Missing rows are put back on the grid, and every run of at most :data:`MAX_RUN`
    missing samples of a column is filled: a measured signal linearly in time between the
    samples either side, an input, set point or disturbance held from the sample before
    (the zero-order hold a replay drives it by).  Missing samples at the record's start or
    end (no sample on one side) are dropped with their rows.  A longer run is refused,
    naming its column, first row and time.
``drop``
    The rows with a missing cell are dropped, where that leaves the grid uniform: at the
    record's start or end only.  A missing sample inside the record is refused (dropping
    it would leave a step of ``2 h``, which the replay's hold and the noise estimates do
    not know); interpolate it.

Either says what it did (:class:`Gaps`): how many samples it filled and dropped, and when.
Rows are named as the reader names them: data row ``r``, counted from 1 at the first data
row (with no blank lines, the file's line ``r + 1``).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import MeasurementError
from .names import DISTURBANCE_COLUMN, INPUT_COLUMNS, SETPOINT_COLUMNS, TIME_COLUMN

MODES = ("interpolate", "drop")
MAX_RUN = 5
"""The longest run of missing samples of one column that ``interpolate`` fills: 5 ms at 1 kHz, far
shorter than the rig's fastest mechanical time constant (66 ms on the bench rig) and a small fraction
of a replay window; a longer run is a lost stretch of record, not a dropped sample."""
GRID_TOL = 0.01
"""A time step is ``k`` sample steps when it is within this fraction of one step of ``k h``."""
HELD = frozenset(INPUT_COLUMNS) | frozenset(SETPOINT_COLUMNS) | {DISTURBANCE_COLUMN}
OPTION = "--gaps interpolate|drop (gaps= in the API)"
"""How a message names the option."""


@dataclass(frozen=True)
class Gaps:
    """What ``gaps`` did to a record: ``mode``; ``filled``, the samples (rows) it filled, at times
    ``at_s`` (s, the record's own clock); ``dropped``, the rows it dropped at the record's ends, at
    times ``dropped_at_s``; ``columns``, per column the cells it filled."""
    mode: str
    filled: int = 0
    at_s: tuple[float, ...] = ()
    dropped: int = 0
    dropped_at_s: tuple[float, ...] = ()
    columns: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        """The ``gaps`` entry of the JSON outputs."""
        return {"mode": self.mode, "filled": self.filled, "at_s": list(self.at_s), "dropped": self.dropped,
                "dropped_at_s": list(self.dropped_at_s), "columns": dict(self.columns), "max_run": MAX_RUN}

    def sentence(self) -> str:
        """One line for the console: how many and where."""
        def times(ts):
            shown = ", ".join(f"{t:.6g}" for t in ts[:8])
            return shown + (f" and {len(ts) - 8} more" if len(ts) > 8 else "")
        parts = []
        if self.filled:
            cells = ", ".join(f"{n} {k}" for k, n in self.columns.items())
            parts.append(f"filled {self.filled} missing sample(s) ({cells}) at t = {times(self.at_s)} s")
        if self.dropped:
            parts.append(f"dropped {self.dropped} row(s) at the record's ends, t = {times(self.dropped_at_s)} s")
        return f"gaps ({self.mode}): " + ("; ".join(parts) if parts else "none")


def _runs(missing: np.ndarray) -> list[tuple[int, int]]:
    """``[a, b)`` of each run of True in ``missing``."""
    edges = np.diff(np.r_[0, missing.astype(np.int8), 0])
    return list(zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)))


def _row(i: int, rows: np.ndarray) -> str:
    """Sample ``i`` of the repaired grid named by the reader's data row (a row put back: after one)."""
    r = rows[i]
    return f"data row {int(r)}" if r == int(r) else f"the row missing after data row {int(r)}"


def grid_step(t: np.ndarray) -> float:
    """The record's sample step, s: the median of its finite steps."""
    d = np.diff(t[np.isfinite(t)])
    return float(np.median(d)) if d.size else 0.0


def missing_rows(t: np.ndarray) -> list[tuple[int, int]]:
    """``(i, k)``: the time step after sample ``i`` is ``k >= 2`` sample steps (``k - 1`` rows missing)."""
    h = grid_step(t)
    if h <= 0:
        return []
    d = np.diff(t)
    k = np.rint(d / h)
    on_grid = np.abs(d - k * h) <= GRID_TOL * h
    return [(int(i), int(k[i])) for i in np.flatnonzero(on_grid & (k >= 2))]


def check_grid(t: np.ndarray, source: str = "") -> None:
    """``MeasurementError`` naming the first missing row of a record read without ``gaps``: a time step
    of two or more sample steps."""
    gaps = missing_rows(np.asarray(t, dtype=float))
    if gaps:
        i, k = gaps[0]
        h = grid_step(t)
        raise MeasurementError(
            f"measurement {source!r} is not usable: {k - 1} row(s) missing after data row {i + 1} "
            f"(time_s jumps from {t[i]:.10g} to {t[i + 1]:.10g} s, {k} steps of {h:.6g} s; "
            f"{len(gaps)} such gap(s) in all): the replay needs a uniform time grid; {OPTION} fills or drops "
            f"up to {MAX_RUN} missing samples in a row")


def _on_grid(values: dict) -> tuple[dict, np.ndarray]:
    """The columns with the missing rows put back (all cells NaN but the time), and each sample's data
    row (a fraction for one put back)."""
    t = values[TIME_COLUMN]
    n = t.size
    rows = np.arange(1, n + 1, dtype=float)
    if np.isnan(t).any():                     # a missing time: on the grid between its neighbours
        ok = np.isfinite(t)
        t = np.interp(np.arange(n), np.flatnonzero(ok), t[ok])
    gaps = missing_rows(t)
    if not gaps:
        return {**values, TIME_COLUMN: t}, rows
    h = grid_step(t)
    take, prev = [], 0
    for i, k in gaps:                         # -1: a row put back
        take += list(range(prev, i + 1)) + [-1] * (k - 1)
        prev = i + 1
    take = np.array(take + list(range(prev, n)))
    out = {name: np.where(take >= 0, (t if name == TIME_COLUMN else v)[np.maximum(take, 0)], np.nan)
           for name, v in values.items()}
    new_t, new_rows = out[TIME_COLUMN], np.where(take >= 0, rows[np.maximum(take, 0)], np.nan)
    for j in np.flatnonzero(take < 0):        # h after the sample before
        new_t[j] = new_t[j - 1] + h
        new_rows[j] = np.floor(new_rows[j - 1]) + 0.5
    out[TIME_COLUMN] = new_t
    return out, new_rows


def _refuse(problems: list[str], source: str) -> None:
    if problems:
        raise MeasurementError(f"measurement {source!r} is not usable:\n  - " + "\n  - ".join(problems), problems)


def repair(values: dict, mode: str, source: str = "") -> tuple[dict, Gaps]:
    """The columns (``{name: float array}``, ``time_s`` among them) with their missing samples filled or
    dropped by ``mode`` (module docstring), and what was done.  ``MeasurementError`` naming the column,
    row, time and this option for a run longer than :data:`MAX_RUN`, or (``drop``) inside the record."""
    if mode not in MODES:
        raise MeasurementError(f"gaps must be one of {', '.join(MODES)} (or None: refuse), got {mode!r}")
    values, rows = _on_grid({k: np.array(v, dtype=float) for k, v in values.items()})  # copies: filled here
    t = values[TIME_COLUMN]
    missing = np.column_stack([np.isnan(v) for v in values.values()]).any(axis=1)
    keep = np.ones(t.size, dtype=bool)
    if missing.any():          # the record's ends: nothing on one side, dropped in either mode
        first, last = np.flatnonzero(~missing)[[0, -1]] if (~missing).any() else (t.size, -1)
        keep[:first] = keep[last + 1:] = False
    if mode == "drop":
        _refuse([f"{b - a} row(s) with a missing sample from {_row(a, rows)} (t = {t[a]:.10g} s) are inside the "
                 f"record: --gaps drop drops rows at its start or end only (dropping these would leave the time "
                 f"grid uneven); --gaps interpolate fills up to {MAX_RUN} in a row" for a, b in _runs(missing & keep)],
                source)
    problems, cells = [], {}
    for name, v in values.items():
        for a, b in _runs(np.isnan(v) & keep):
            if b - a > MAX_RUN:
                problems.append(f"column {name!r}: {b - a} missing samples in a row from {_row(a, rows)} "
                                f"(t = {t[a]:.10g} s): more than the {MAX_RUN} that --gaps interpolate fills")
                continue
            cells[name] = cells.get(name, 0) + int(b - a)
            if name in HELD:
                v[a:b] = v[a - 1]
            else:
                v[a:b] = np.interp(t[a:b], [t[a - 1], t[b]], [v[a - 1], v[b]])
    _refuse(problems, source)
    filled = missing & keep
    report = Gaps(mode, int(filled.sum()), tuple(float(x) for x in t[filled]), int((~keep).sum()),
                  tuple(float(x) for x in t[~keep]), cells)
    return {k: v[keep] for k, v in values.items()}, report


def entry(data) -> dict:
    """``{"gaps": ...}`` for a JSON output of a record read with ``gaps`` (``Measurement.gaps``), else {}."""
    report = getattr(data, "gaps", None)
    return {"gaps": report.to_dict()} if report is not None else {}


__all__ = ["entry", "Gaps", "MODES", "MAX_RUN", "repair", "check_grid", "missing_rows", "grid_step"]
