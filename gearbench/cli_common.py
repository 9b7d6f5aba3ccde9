"""What every ``gearbench`` command shares: the consoles, errors, JSON output, exit codes, Ctrl-C.

Exit status of every command (``EXIT_*``):

* 0 -- everything asked for succeeded;
* 1 -- it ran, but something asked for did not succeed: a run or sweep point the
  solver could not finish, a fit that did not converge, a validation check that
  failed for a reason the report does not explain (the message names which);
* 2 -- bad input (a file, key, column or option, named with its unit), or a usage
  error from click; nothing was solved;
* 130 -- interrupted (Ctrl-C): what was finished is named, and no file is left
  half-written (every result file goes through :mod:`gearbench.report.io`, a
  temporary file renamed over the old one).

``--json`` puts one JSON object (strict: NaN and infinities become null) on stdout
and nothing else; the human text goes to stderr or is left out.
"""
from __future__ import annotations

import json
import math
import sys
from pathlib import Path
from typing import NoReturn

import click
from rich.console import Console

from .errors import SolverError
from .interrupts import check, is_interrupt, remembered  # noqa: F401 - the commands take them from here

EXIT_OK = 0
EXIT_FAILED = 1
EXIT_BAD_INPUT = 2
EXIT_INTERRUPTED = 130

EXIT_HELP = """Exit status: 0 when everything asked for succeeded; 1 when it ran but something
asked for did not (a run or sweep point the solver could not finish, a fit that did not
converge, an unexplained validation failure), named on stderr; 2 for bad input (the file,
key or option is named); 130 when interrupted (Ctrl-C), naming what was finished.
--json prints one JSON object on stdout (NaN as null) and the rest on stderr."""
"""The exit codes, as the command group's --help states them."""

PIPED_WIDTH = 1000
"""Console width when the stream is not a terminal: off a terminal rich assumes 80
columns and crops table cells (``14.1…``); no gearbench table is this wide."""


def _width(stream) -> int | None:
    """None (rich measures the terminal) on a terminal, else :data:`PIPED_WIDTH`."""
    try:
        return None if stream.isatty() else PIPED_WIDTH
    except (AttributeError, ValueError):  # a closed or replaced stream
        return PIPED_WIDTH


console = Console(stderr=True, width=_width(sys.stderr))
"""Progress, warnings and errors (stderr)."""


def stdout() -> Console:
    """A console on the current stdout (made per call: a test runner swaps sys.stdout)."""
    return Console(width=_width(sys.stdout))


def fail(exc: BaseException, code: int | None = None) -> NoReturn:
    """Print ``error: <exc>`` on stderr and exit: 1 for a run the solver could not finish
    (a :class:`gearbench.errors.SolverError`: also ``ReplayRunError`` and ``SynthRunError``), else 2
    (bad input: every other :class:`gearbench.errors.GearbenchError`, a ``ValueError``, an ``OSError``),
    unless ``code`` is given."""
    if code is None:
        code = EXIT_FAILED if isinstance(exc, SolverError) else EXIT_BAD_INPUT
    console.print(f"[bold red]error:[/] {exc}", markup=True, highlight=False)
    sys.exit(code)


_fail = fail  # the name the cli modules have always used


def jsonable(obj):
    """``obj`` with numpy scalars and arrays, tuples, paths and non-finite floats made plain JSON
    (NaN and +-inf -> None, so the output parses everywhere, jq included)."""
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple, set)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, Path):
        return str(obj)
    if hasattr(obj, "tolist") and not isinstance(obj, (str, bytes)):  # numpy scalar or array
        return jsonable(obj.tolist())
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if obj is None or isinstance(obj, (str, int, bool)):
        return obj
    try:
        import pandas as pd
        if pd.isna(obj):  # pd.NA, NaT
            return None
    except (ImportError, TypeError, ValueError):
        pass
    return str(obj)


def echo_json(obj, indent: int | None = 1) -> None:
    """Print ``obj`` as one strict JSON document on stdout."""
    click.echo(json.dumps(jsonable(obj), indent=indent, allow_nan=False))


def interrupted(finished: str) -> NoReturn:
    """End an interrupted command: say what was finished, exit 130."""
    console.print(f"[yellow]interrupted:[/] {finished}", highlight=False)
    sys.exit(EXIT_INTERRUPTED)


class Group(click.Group):
    """The command group: a Ctrl-C anywhere in a command ends it with status 130 and one
    line on stderr, instead of click's "Aborted!" and status 1 (or a traceback)."""

    def invoke(self, ctx: click.Context):
        try:
            with remembered():
                out = super().invoke(ctx)
                check()  # a Ctrl-C a finalizer swallowed: the command still ends as interrupted
                return out
        except (Exception, KeyboardInterrupt) as exc:
            if not is_interrupt(exc):
                raise
            interrupted("stopped before the command finished; files are written whole or not at "
                        "all, so none is left half-written")


def parse_noise(specs: tuple[str, ...], positive: bool = False) -> dict[str, float]:
    """``("current_A=0.01", ...)`` -> ``{"current_A": 0.01}``; ``all=STD`` sets every signal
    (the key ``"*"``), later entries win.  ``positive``: a standard deviation of 0 is refused too
    (a stated noise is a residual's weight)."""
    out: dict[str, float] = {}
    least = "> 0" if positive else ">= 0"
    for spec in specs:
        key, eq, value = spec.partition("=")
        key = key.strip()
        try:
            std = float(value)
        except ValueError:
            std = math.nan
        if not eq or not key or not (math.isfinite(std) and (std > 0 if positive else std >= 0)):
            example = "load_angle_deg=0.01" if positive else "load_angle_deg=0.01, or all=0 for none"
            raise ValueError(f"--noise {spec!r} must be SIGNAL=STD with a standard deviation {least} "
                             f"in the signal's unit (e.g. {example})")
        out["*" if key == "all" else key] = std
    return out
