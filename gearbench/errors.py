"""The exceptions of gearbench: one family under :class:`GearbenchError`.

Every exception class of the package is defined here (``tests/test_errors.py``
holds the package to it), so any module (the solver, the file loaders, the
command line) imports them without importing the module that raises them, and
``except GearbenchError`` catches every one of them and nothing else.  Some
checks still raise a plain ``ValueError`` (an excitation file of ``synth``, an
unknown effect name); the command line reports those as bad input too.  The
one exception to the family is :class:`GearbenchInterrupt`, a
``KeyboardInterrupt``, so that code that catches ``Exception`` never catches a
Ctrl-C.

Each class keeps the built-in base it has always had, ``ValueError`` for bad
input and ``RuntimeError`` for a run that failed, so code that catches those
catches them as before, and each stays importable from the module that raises
it (``from gearbench.experiment.files import ConfigError``).

Imports nothing: every module of the package may import it.
"""
from __future__ import annotations

from typing import Any, Iterable, Sequence


class GearbenchError(Exception):
    """The base of every exception class of gearbench.

    ``except GearbenchError`` catches each of them; the message names the file,
    key, column or run, and the unit where there is one.  Each subclass is also
    the built-in exception it always was: a ``ValueError`` for bad input, a
    ``RuntimeError`` for a run that could not be done.

    See Also
    --------
    ConfigError : ValueError.  A plant, experiment, controller or column mapping
        file, or an argument of the Python API, that cannot be used; every problem
        is listed at once, each naming its key and unit.
    MeasurementError : ValueError.  A measurement record that cannot be used (a
        missing or non-numeric column, time not increasing, ...).
    CsvFormatError : ValueError.  A file that is not CSV text, or a delimiter or
        decimal mark that cannot work.
    EMPSFormatError : ValueError.  An EMPS benchmark file with a missing variable or
        column, or one of the wrong shape or value.
    ProfileError : ValueError.  A set-point profile file that cannot be used.
    SweepError : ValueError.  A sweep that cannot run: a bad ``--param``, a store of
        another sweep, a worker process that died.
    SchedulerError : ValueError.  A Dask scheduler that cannot be used: a malformed
        address, nothing answering there, dask not installed.
    FitError : ValueError.  A fit that cannot be set up (an unknown free key, a
        missing effect); :class:`NotConverged` when it did not converge (``gearbench.fit``).
    SolverError : RuntimeError.  A run the solver could not finish.
    ReplayError : RuntimeError.  A replay of a record that cannot run or failed;
        :class:`ReplayRunError`, also a :class:`SolverError`, when the solver failed.
    ReplayRunError : ReplayError and SolverError.  The solver could not finish the
        replay (the files were fine).
    SynthError : RuntimeError.  A synthesis of a record that cannot be done or failed.
    SynthRunError : SynthError and SolverError.  The solver could not finish the
        synthesis run.
    GearbenchInterrupt : Not a subclass: the family's ``KeyboardInterrupt``, a Ctrl-C
        that carries what was finished (:class:`DiagnosisInterrupted`), so that
        ``except Exception`` and ``except GearbenchError`` never catch a Ctrl-C.

    Notes
    -----
    The command line reports one as ``error: <message>`` on stderr and exits with
    status 1 for a :class:`SolverError` (a run the solver could not finish,
    ``ReplayRunError`` and ``SynthRunError`` included) and 2 for the others (bad
    input: nothing was solved).

    Examples
    --------
    >>> from gearbench import Controller, GearbenchError
    >>> try:
    ...     Controller("p", kp=-5)
    ... except GearbenchError as exc:
    ...     print(type(exc).__name__, isinstance(exc, ValueError))
    ConfigError True
    """


# ------------------------------------------------------------------ bad input (ValueError)

class ConfigError(GearbenchError, ValueError):
    """A plant or experiment file that cannot be used, with every problem found.

    Parameters
    ----------
    file : str or None
        Label of the file the problems belong to (its name).
    problems : str or iterable
        Problem texts (each naming a key path and the expected unit); an item
        may also be a ``(file, text)`` pair when problems span several files.

    Attributes
    ----------
    entries : tuple of (str, str)
        ``(file, problem)`` pairs; the message has one line ``file: problem`` each.
    """

    def __init__(self, file: str | None, problems: str | Iterable[Any]):
        items = [problems] if isinstance(problems, str) else list(problems)
        self.entries = tuple(p if isinstance(p, tuple) else (file or "<config>", p) for p in items)
        super().__init__("\n".join(f"{f}: {t}" for f, t in self.entries))

    @property
    def problems(self) -> list[str]:
        """The problem texts without the file label."""
        return [t for _, t in self.entries]

    def __reduce__(self):  # picklable for process pools / Dask
        return (ConfigError, (None, list(self.entries)))


class MeasurementError(GearbenchError, ValueError):
    """A measurement that gearbench cannot use; ``problems`` lists each reason."""

    def __init__(self, message: str, problems: Sequence[str] = ()):
        super().__init__(message)
        self.problems = list(problems) or [message]


class CsvFormatError(GearbenchError, ValueError):
    """A file that is not CSV text, or a delimiter/decimal choice that cannot work."""


class EMPSFormatError(GearbenchError, ValueError):
    """An EMPS file is missing a variable or column, or holds one of the wrong shape or value."""


class ProfileError(GearbenchError, ValueError):
    """A profile file that cannot be used; the message names the file and the key."""


class SweepError(GearbenchError, ValueError):
    """A sweep that cannot run: bad ``--param`` syntax, a store of another sweep, no scheduler."""


class SchedulerError(GearbenchError, ValueError):
    """A Dask scheduler that cannot be used: a malformed address, nothing answering there, no dask."""


class FitError(GearbenchError, ValueError):
    """A fit that cannot be set up (an unknown free key, a missing effect)."""


class NotConverged(FitError):
    """No place of an effect converged (``identify.candidates.fit_effect``, ``gearbench.fit``);
    ``tried`` holds each place's try (``identify.candidates.Tried``), the plant is unchanged."""

    def __init__(self, message: str, tried: list):
        super().__init__(message)
        self.tried = tried

    def __reduce__(self):  # picklable for process pools / Dask
        return (NotConverged, (str(self), self.tried))


# ------------------------------------------------------------------ failed runs (RuntimeError)

class SolverError(GearbenchError, RuntimeError):
    """A run the solver could not finish; the message says where and why."""


class ReplayError(GearbenchError, RuntimeError):
    """A replay that cannot run or failed; the message says which and why."""


class ReplayRunError(ReplayError, SolverError):
    """The solver could not finish the replay (the files were fine; the CLI exits 1, not 2)."""


class SynthError(GearbenchError, RuntimeError):
    """Synthesis that cannot be done or failed; the message says which run and where."""


class SynthRunError(SynthError, SolverError):
    """The solver could not finish the synthesis run (the CLI exits 1, not 2)."""


class FitSettled(GearbenchError):
    """Not a failure: raised inside a least-squares fit in place of a replay that could not change
    where it ends (``identify.fit.SecantJacobian.residual``) and caught there; it never leaves the fit."""


# ------------------------------------------------------------------ Ctrl-C (KeyboardInterrupt)

class GearbenchInterrupt(KeyboardInterrupt):
    """A Ctrl-C that carries what was finished before it: the family's one exception
    outside :class:`GearbenchError`.

    A ``KeyboardInterrupt``, so code that catches ``Exception`` (or
    ``GearbenchError``) lets it through and stops as on any Ctrl-C; code that wants
    the partial result catches the subclass (:class:`DiagnosisInterrupted`).
    """


class DiagnosisInterrupted(GearbenchInterrupt):
    """Ctrl-C during the ladder: ``diagnosis`` is the ladder as far as it got (its ``stopped`` is
    ``"interrupted"``).  A KeyboardInterrupt, so code that does not look for it stops as before.

    ``diagnosis`` is a :class:`gearbench.identify.results.Diagnosis` (not imported here:
    this module imports nothing of the package).
    """

    def __init__(self, diagnosis: Any):
        super().__init__("diagnosis interrupted")
        self.diagnosis = diagnosis


__all__ = ["GearbenchError", "ConfigError", "MeasurementError", "CsvFormatError", "EMPSFormatError",
           "ProfileError", "SweepError", "SchedulerError", "FitError", "SolverError", "ReplayError",
           "ReplayRunError", "SynthError", "SynthRunError", "GearbenchInterrupt", "DiagnosisInterrupted"]
