"""A finished tuning: the best settings per compensator, their spread over the drawn plants,
and the experiment file that ``gearbench run`` reproduces the tuned run from."""
from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import yaml

from ..control.controllers import Controller, kind_name
from ..errors import ConfigError
from ..experiment.writer import plant_to_dict
from ..plant.components import Plant
from ..simulate import SolverOptions
from .objective import OBJECTIVES, Evaluation
from .space import TUNED


def spread(ev: Evaluation) -> dict:
    """The objective over the plants a candidate ran on: mean, standard deviation, 10th and
    90th percentiles, least and largest (NaN for runs that failed are left out)."""
    v = np.array([x for x in ev.values if not math.isnan(x)])
    if v.size == 0:
        return {}
    return {"mean": float(v.mean()), "std": float(v.std(ddof=1)) if v.size > 1 else 0.0,
            "p10": float(np.percentile(v, 10)), "p90": float(np.percentile(v, 90)),
            "min": float(v.min()), "max": float(v.max()), "plants": int(v.size)}


@dataclass
class Tuned:
    """The best controller found with one compensator: ``best`` judged on the tuning's plants,
    ``nominal`` on the nominal plant alone, ``slices`` the objective along each setting
    through it, ``candidates`` how many were solved."""
    compensator: str
    controller: Controller
    best: Evaluation
    nominal: Evaluation
    slices: dict = field(repr=False, default_factory=dict)
    candidates: int = 0

    def row(self, objective: str) -> dict:
        unit = OBJECTIVES[objective][1]
        return {"compensator": self.compensator, **self.best.settings,
                f"objective_{unit.replace(' ', '_')}": self.best.objective,
                "nominal": self.nominal.objective, "feasible": self.best.feasible,
                **{f"worst_{k}": v for k, v in self.best.limits.items()},
                "spread": spread(self.best), "candidates": self.candidates}


@dataclass
class TuneResult:
    """What :func:`gearbench.tune` found.

    Parameters
    ----------
    plant : Plant
        The plant tuned on (the centre of the draws when robust).
    plant_path : str or None
        Its file (absolute), or None for a plant given as an object or mapping.
    profile : str
        The set point followed: a name (``profile1``) or a profile file.
    duration_s : float
        Simulated time of each run, s.
    solver : SolverOptions
        The solver settings of every run.
    kind : str
        The controller kind tuned (``p``, ``pi``, ``pid``).
    objective : str
        ``iae`` (deg s), ``rms`` or ``max`` (deg).
    robust : str
        The statistic of the objective over the plants (``mean``, ``p90``, ``max``).
    limits : dict
        Upper bounds on the runs' scores (``gearbench.tuning.objective.LIMITS``).
    tuned : list of Tuned
        The best settings per compensator, in the order asked.
    baseline_controller : Controller
        The untuned controller compared with.
    baseline : Evaluation
        It, judged on the same plants.
    plants : int
        Plants each candidate ran on (1, or the robust draws).
    runs : int
        Simulations solved.
    wall_s : float
        Wall time of the tuning, s.
    profile_object : bool
        The profile was given as a ``Profile`` object (no name or file an experiment can refer to).

    Examples
    --------
    >>> import gearbench as gb
    >>> r = gb.tune("experiments/plants/thesis_gear.yaml", "p", profile="profile1", duration_s=3.0,
    ...             limits={"voltage_sign_changes": 10})
    >>> r.best.best.limits["voltage_sign_changes"] <= 10, r.experiment("experiments")["controllers"][0]["kind"]
    (True, 'p')
    """
    plant: Plant
    plant_path: str | None
    profile: str
    duration_s: float
    solver: SolverOptions
    kind: str
    objective: str
    robust: str
    limits: dict
    tuned: list
    baseline_controller: Controller
    baseline: Evaluation
    plants: int
    runs: int = 0
    wall_s: float = 0.0
    profile_object: bool = False

    @property
    def best(self) -> Tuned:
        """The compensator whose best controller has the least score (feasible before not)."""
        return min(self.tuned, key=lambda t: t.best.score)

    @property
    def controller(self) -> Controller:
        return self.best.controller

    @property
    def unit(self) -> str:
        return OBJECTIVES[self.objective][1]

    def to_dict(self) -> dict:
        """The tuning as plain values (JSON-ready); what ``gearbench tune --json`` prints."""
        b = self.best
        return {"plant": self.plant.name, "profile": self.profile, "controller": self.kind,
                "objective": self.objective, "objective_unit": self.unit, "robust": self.robust,
                "plants": self.plants, "limits": self.limits,
                "best": {"compensator": b.compensator, "settings": b.best.settings, "objective": b.best.objective,
                         "nominal_objective": b.nominal.objective, "limit_values": b.best.limits,
                         "feasible": b.best.feasible, "spread": spread(b.best)},
                "baseline": {"settings": self.baseline.settings, "compensator": self.baseline_controller.compensator,
                             "objective": self.baseline.objective, "limit_values": self.baseline.limits,
                             "feasible": self.baseline.feasible},
                "compensators": [t.row(self.objective) for t in self.tuned],
                "runs": self.runs, "wall_s": self.wall_s}

    def to_markdown(self) -> str:
        """A table per compensator: settings, objective, its spread, each limit's worst value."""
        stat = "" if self.plants == 1 else f" ({self.robust} over {self.plants} plants)"
        lines = [f"# tune: {kind_name(self.kind)} on {self.plant.name}, {self.profile}", "",
                 f"Objective: {self.objective} ({self.unit}){stat}; limits: "
                 + (", ".join(f"{k} <= {v:g}" for k, v in self.limits.items()) or "none") + ".", "",
                 "| compensator | settings | objective | nominal plant | spread p10-p90 | limits (worst) | candidates |",
                 "|---|---|---:|---:|---|---|---:|"]
        for t in self.tuned:
            s = spread(t.best)
            band = f"{s['p10']:.4g}-{s['p90']:.4g}" if self.plants > 1 and s else "-"
            lim = ", ".join(f"{k} {v:.4g}" for k, v in t.best.limits.items()) or "-"
            ok = "" if t.best.feasible else " (breaks a limit)"
            lines.append(f"| {t.compensator}{ok} | {_settings(t.best.settings)} | {t.best.objective:.4g} | "
                         f"{t.nominal.objective:.4g} | {band} | {lim} | {t.candidates} |")
        b = self.baseline
        lines += ["", f"Untuned ({_settings(b.settings)}, {self.baseline_controller.compensator}): "
                  f"{b.objective:.4g} {self.unit}. Best: {self.best.compensator}, {_settings(self.best.best.settings)}, "
                  f"{self.best.best.objective:.4g} {self.unit}. {self.runs} runs in {self.wall_s:.1f} s."]
        return "\n".join(lines) + "\n"

    def experiment(self, where: str | Path) -> dict:
        """The experiment file (as a mapping) that runs the best controller: the plant by its path
        relative to ``where`` (the folder the file goes to), or inline when it came from no file;
        the profile by its name or file (a profile made in Python has neither: save it to a file
        and tune with that)."""
        c = self.controller
        if self.profile_object:
            raise ConfigError("tune", [f"the profile {self.profile!r} was given as an object, which an experiment "
                                       "file cannot name: save it to a profile file and tune with its path"])
        plant = (os.path.relpath(self.plant_path, Path(where).resolve())
                 if self.plant_path else plant_to_dict(self.plant))
        ctrl = {"kind": c.kind, **{k: float(getattr(c, k)) for k in TUNED[c.kind]}}
        profile = (os.path.relpath(Path(self.profile).resolve(), Path(where).resolve())
                   if Path(self.profile).suffix else self.profile)
        out = {"name": f"tuned_{self.plant.name}_{self.kind}",
               "description": f"{kind_name(self.kind)} tuned by gearbench tune on {self.plant.name}, {self.profile}: "
                              f"{self.objective} {self.best.best.objective:.6g} {self.unit}",
               "plant": plant, "duration_s": float(self.duration_s),
               "solver": {"method": self.solver.method, "rtol": self.solver.rtol, "max_step_s": self.solver.max_step_s},
               "profiles": [profile], "controllers": [ctrl], "compensator": [c.compensator]}
        if c.compensator != "none" and c.shift_deg is not None:
            out["shift_deg"] = float(c.shift_deg)
        return out

    def experiment_yaml(self, where: str | Path) -> str:
        return yaml.safe_dump(self.experiment(where), sort_keys=False, default_flow_style=None)


def _settings(s: dict) -> str:
    units = {"kp": "V/deg", "ki": "1/s", "kd": "s", "shift_deg": "deg"}
    return ", ".join(f"{k.replace('_deg', '')}={v:.4g} {units.get(k, '')}".strip() for k, v in s.items())


__all__ = ["spread", "Tuned", "TuneResult"]
