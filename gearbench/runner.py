"""Run an experiment's matrix of simulations and collect their scores."""
from __future__ import annotations

import re
import time
from dataclasses import dataclass
from typing import Callable

from .control.controllers import Controller
from .experiment.files import Experiment
from .profiles import Profile, load_profile
from .simulate import RunResult, failure_message, simulate


@dataclass
class RunRecord:
    """One finished run of an experiment."""
    profile: str
    controller: Controller
    result: RunResult
    wall_s: float

    @property
    def profile_id(self) -> int | str:
        """``profile3`` -> 3 (the thesis's numbering); other names unchanged."""
        m = re.fullmatch(r"profile(\d+)", self.profile)
        return int(m.group(1)) if m else self.profile

    @property
    def label(self) -> str:
        c = self.controller
        gain = f"_kp{c.kp:g}" if c.kind != "bang_bang" else ""
        return f"{self.profile}_{c.kind}{gain}_shift-{'on' if c.shift else 'off'}"

    def row(self) -> dict:
        """Scores as a flat dict (one table row)."""
        c = self.controller
        return {"profile": self.profile_id, "controller": c.kind,
                "kp": c.kp if c.kind != "bang_bang" else None,
                "shift": "on" if c.shift else "off",
                **self.result.scores(), "status": self.result.status,
                "wall_s": self.wall_s}


def load_profiles(exp: Experiment) -> dict[str, Profile]:
    """Every profile the experiment names, loaded before any solving."""
    search = exp.base_dir.parent / "profiles"
    return {name: load_profile(name, search if search.is_dir() else exp.base_dir)
            for name in exp.profiles}


def run_experiment(exp: Experiment, on_done: Callable[[RunRecord], None] | None = None
                   ) -> list[RunRecord]:
    """Simulate every run of ``exp`` in order; ``on_done`` is called after each.

    A run the solver cannot finish is kept with its status (its scores cover
    the part it solved) and its failure message in ``result.meta['message']``.
    """
    profiles = load_profiles(exp)
    records = []
    for name, ctrl in exp.runs():
        prof = profiles[name]
        t0 = time.perf_counter()
        res = simulate(exp.plant, ctrl, prof.segments(), exp.duration_s, exp.solver,
                       delta0=exp.initial_delta)
        rec = RunRecord(name, ctrl, res, time.perf_counter() - t0)
        res.label = rec.label
        if not res.ok:
            res.meta["message"] = failure_message(res, exp.plant.name)
        records.append(rec)
        if on_done is not None:
            on_done(rec)
    return records
