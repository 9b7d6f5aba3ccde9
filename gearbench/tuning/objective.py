"""What a tuning minimises and what it must respect.

A candidate controller is run on one plant or, when tuning robustly, on each of several
plants drawn from what the fit left uncertain.  Each run gives the scores of
:meth:`gearbench.simulate.RunResult.scores`; the objective is one of them, and the robust
statistic turns the values on the plants into the number the search minimises.  The
limits hold on every plant (the worst one is compared with the limit), so a robust
tuning never trades chatter on one plant for error on another.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Mapping, Sequence

import numpy as np

from ..errors import ConfigError

OBJECTIVES = {"iae": ("iae_deg_s", "deg s"), "rms": ("rms_deg", "deg"), "max": ("max_deg", "deg")}
"""``--objective`` -> (score, unit): the integrated absolute output error (thesis Table I),
its root mean square, or the largest error."""

LIMITS = {"voltage_sign_changes": ("switchings", ""), "saturated_fraction": ("saturated_fraction", ""),
          "impacts": ("impacts", ""), "max_deg": ("max_deg", "deg"), "rms_deg": ("rms_deg", "deg"),
          "iae_deg_s": ("iae_deg_s", "deg s")}
"""``--limit NAME=VALUE`` -> (score, unit): each an upper bound on a run's score.
``voltage_sign_changes`` counts the applied voltage's changes of sign (chatter),
``saturated_fraction`` the share of the run at the voltage limit (0-1)."""

ROBUST = ("mean", "p90", "max")
"""Robust statistics of the objective over the drawn plants: the mean, the 90th percentile
(a value exceeded on one plant in ten), the worst."""

INFEASIBLE = 1.0e9
"""The search's value of a point that breaks a limit (or whose run fails): above any
objective, and rising with the violation so the search is led back inside the limits."""


def parse_limits(text: str | Mapping[str, float] | None) -> dict[str, float]:
    """``"voltage_sign_changes=20,saturated_fraction=0.1"`` (or a mapping) as ``{name: bound}``.

    Raises
    ------
    ConfigError
        Naming each unknown limit or bad value.
    """
    if text is None or text == "":
        return {}
    problems: list[str] = []
    items = dict(text) if isinstance(text, Mapping) else {}
    if isinstance(text, str):
        for part in text.split(","):
            name, eq, value = part.partition("=")
            try:
                items[name.strip()] = float(value) if eq else None
            except ValueError:
                items[name.strip()] = value
    out = {}
    for name, value in items.items():
        if name not in LIMITS:
            problems.append(f"limit {name!r}: unknown; choose from {', '.join(LIMITS)}")
        elif not isinstance(value, (int, float)) or not math.isfinite(value) or value < 0:
            unit = LIMITS[name][1]
            problems.append(f"limit {name}: expected a number >= 0{' in ' + unit if unit else ''} "
                            f"(NAME=VALUE), got {value!r}")
        else:
            out[name] = float(value)
    if problems:
        raise ConfigError("tune", problems)
    return out


def statistic(values: Sequence[float], robust: str) -> float:
    """The robust statistic ``robust`` (:data:`ROBUST`) of ``values``; one value is itself."""
    v = np.asarray(values, dtype=float)
    if robust == "mean":
        return float(v.mean())
    if robust == "p90":
        return float(np.percentile(v, 90))
    if robust == "max":
        return float(v.max())
    raise ConfigError("tune", [f"robust statistic must be one of {', '.join(ROBUST)}, got {robust!r}"])


@dataclass(frozen=True)
class Evaluation:
    """One candidate's runs, judged.

    ``settings``: the controller settings by name; ``values``: the objective on each plant
    (NaN where the run failed); ``objective``: their robust statistic; ``limits``: each
    limit's worst value over the plants; ``violation``: the summed relative excess over
    the limits (0 when all hold); ``failed``: messages of runs the solver could not finish."""
    settings: dict
    values: tuple
    objective: float
    limits: dict
    violation: float
    failed: tuple = field(default=())

    @property
    def feasible(self) -> bool:
        return self.violation == 0.0 and not self.failed

    @property
    def score(self) -> float:
        """What the search minimises: the objective, or :data:`INFEASIBLE` plus the violation."""
        if self.failed:
            return INFEASIBLE * 2
        return self.objective if self.violation == 0.0 else INFEASIBLE * (1.0 + self.violation)


def judge(settings: Mapping[str, float], scores: Sequence[Mapping], objective: str, robust: str,
          limits: Mapping[str, float]) -> Evaluation:
    """An :class:`Evaluation` from the runs' ``scores`` (one mapping per plant; a failed run
    is ``{"failed": message}``)."""
    key = OBJECTIVES[objective][0]
    failed = tuple(s["failed"] for s in scores if "failed" in s)
    ok = [s for s in scores if "failed" not in s]
    values = tuple(float(s[key]) if "failed" not in s else math.nan for s in scores)
    worst = {name: max(float(s[LIMITS[name][0]]) for s in ok) if ok else math.nan for name in limits}
    violation = sum(max(0.0, worst[n] - b) / max(b, 1e-12) for n, b in limits.items() if ok)
    obj = statistic([v for v in values if not math.isnan(v)], robust) if ok else math.nan
    return Evaluation(dict(settings), values, obj, worst, float(violation), failed)


__all__ = ["OBJECTIVES", "LIMITS", "ROBUST", "INFEASIBLE", "parse_limits", "statistic", "Evaluation", "judge"]
