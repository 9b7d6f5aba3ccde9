"""Run an experiment's matrix of simulations, collect their scores and choose its report."""
from __future__ import annotations

import re
import time
from concurrent.futures import as_completed
from dataclasses import dataclass, field, replace
from typing import Any, Callable

from .control.controllers import Controller
from .experiment.files import Experiment
from .profiles import Profile, load_profile
from .simulate import RunResult, failure_message, simulate
from .workers import process_pool, worker_count


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
        if c.compensator != "none":
            return f"{self.profile}_{c.kind}{gain}_comp-{c.compensator}"
        return f"{self.profile}_{c.kind}{gain}_shift-{'on' if c.shift else 'off'}"

    def row(self) -> dict:
        """Scores as a flat dict (one table row)."""
        c = self.controller
        return {"profile": self.profile_id, "controller": c.kind,
                "kp": c.kp if c.kind != "bang_bang" else None,
                "shift": "on" if c.effective_compensator != "none" else "off",
                **({"compensator": c.effective_compensator} if c.compensator != "none" else {}),
                **self.result.scores(), "status": self.result.status,
                "wall_s": self.wall_s}


def load_profiles(exp: Experiment) -> dict[str, Profile]:
    """Every profile the experiment names, loaded before any solving (and
    scaled by the experiment's ``profile_scale``)."""
    profiles = {name: load_profile(name, exp.base_dir) for name in exp.profiles}
    if exp.profile_scale != 1.0:
        profiles = {name: prof.scaled(exp.profile_scale) for name, prof in profiles.items()}
    return profiles


def _solve(job: tuple) -> tuple[RunResult, float]:
    plant, ctrl, segments, duration, solver, delta0 = job
    t0 = time.perf_counter()
    res = simulate(plant, ctrl, segments, duration, solver, delta0=delta0)
    return res, time.perf_counter() - t0


def run_experiment(exp: Experiment, on_done: Callable[[RunRecord], None] | None = None,
                   workers: int | None = None, keep_traces: bool = True) -> list[RunRecord]:
    """Simulate every run of ``exp``; ``on_done`` is called as each finishes.

    Without ``keep_traces`` the runs keep only their scores (the trace is
    sampled at the start and the end only): a table needs no more, and
    sampling a 10 s run every millisecond costs as much as solving it.

    Runs are spread over ``workers`` processes (default: all usable cores;
    ``gearbench.workers``, which also makes them end with this process); the
    records come back in the experiment's order whatever the finishing order.
    A run the solver cannot finish is kept with its status (its scores cover
    the part it solved) and its failure message in ``result.meta['message']``.
    """
    profiles = load_profiles(exp)
    specs = exp.runs()
    solver = exp.solver if keep_traces else replace(exp.solver, output_dt_s=exp.duration_s)
    jobs = [(exp.plant, ctrl, profiles[name].segments(), exp.duration_s, solver,
             exp.initial_delta) for name, ctrl in specs]
    workers = worker_count(workers, len(jobs))
    records: list[RunRecord | None] = [None] * len(jobs)

    def finish(i: int, res: RunResult, wall: float) -> None:
        rec = RunRecord(specs[i][0], specs[i][1], res, wall)
        res.label = rec.label
        if not res.ok:
            res.meta["message"] = failure_message(res, exp.plant.name)
        records[i] = rec
        if on_done is not None:
            on_done(rec)

    if workers <= 1:
        for i, job in enumerate(jobs):
            finish(i, *_solve(job))
    else:
        with process_pool(workers) as pool:
            futures = {pool.submit(_solve, job): i for i, job in enumerate(jobs)}
            for fut in as_completed(futures):
                finish(futures[fut], *fut.result())
    return records


def retrace(exp: Experiment, records: list[RunRecord], output_dt_s: float | None = None) -> list[RunRecord]:
    """The runs of ``records`` solved again, in this process, with their trace sampled
    every ``output_dt_s`` s (default: the experiment's ``solver.output_dt_s``).

    For a figure of a few runs of an experiment that was solved for its scores only
    (``keep_traces=False`` keeps two samples per run).  Same plant, controller,
    profile and solver settings, so the scores are the ones already reported: the
    output grid is interpolated from the steps, it does not choose them.
    """
    profiles = load_profiles(exp)
    solver = exp.solver if output_dt_s is None else replace(exp.solver, output_dt_s=output_dt_s)
    out = []
    for rec in records:
        res, wall = _solve((exp.plant, rec.controller, profiles[rec.profile].segments(), exp.duration_s, solver,
                            exp.initial_delta))
        res.label = rec.label
        if not res.ok:
            res.meta["message"] = failure_message(res, exp.plant.name)
        out.append(RunRecord(rec.profile, rec.controller, res, wall))
    return out


@dataclass
class ExperimentReport:
    """What ``gearbench run`` writes for an experiment (see :func:`experiment_report`)."""
    kind: str
    """``compensators``, ``translational`` or ``table1``."""
    runs: Any
    """Every score of every run, one row a run (a DataFrame: ``<name>_runs.csv``)."""
    columns: list[str]
    """The columns of the summary table ``<name>.csv``."""
    title: str
    markdown: str
    """``<name>.md``."""
    shown: Any
    """What the terminal shows: a ``rich.table.Table`` or text."""
    figures: dict[str, Any] = field(default_factory=dict)
    """File name -> matplotlib figure (pyplot's: close each once saved)."""


def experiment_report(exp: Experiment, records: list[RunRecord], reference=None,
                      traced: bool = False) -> ExperimentReport:
    """The report an experiment gets, built from its finished ``records``.

    * with a ``compensator`` list: per compensator the IAE (deg s) and the voltage
      sign changes, the bars ``<name>.png`` and ``<name>_traces.png``, the traces of
      the cell with the most sign changes (solved again with their trace unless
      ``traced``: the records kept their traces);
    * with a leadscrew: the carriage error, IAE in mm s;
    * else the IAE (deg s) beside ``reference`` (``report.tables.read_reference``; None: none).
    """
    from .report import tables, variants
    if exp.compensators:
        runs = variants.compensator_frame(records)
        title = f"{exp.name}: integrated absolute output error (deg s) and voltage sign changes"
        columns = variants.COMPENSATOR_COLUMNS
        figures = {f"{exp.name}.png": variants.compensator_figure(runs, title)}
        _, shown_runs = variants.trace_cell(records)
        if not traced:  # solved for their scores only: solve the shown cell again with its trace
            shown_runs = retrace(exp, shown_runs)
        figures[f"{exp.name}_traces.png"], _ = variants.compensator_trace_figure(shown_runs, exp.plant)
        return ExperimentReport("compensators", runs, columns, title,
                                variants.compensator_markdown(runs, title, exp.description),
                                runs[columns].to_string(index=False), figures)
    if exp.plant.leadscrew is not None:
        runs = variants.translational_frame(tables.records_frame(records), exp.plant)
        title = f"{exp.name}: integrated absolute carriage position error (mm s)"
        columns = variants.TRANSLATIONAL_COLUMNS
        return ExperimentReport("translational", runs, columns, title,
                                variants.translational_markdown(runs, title, exp.description),
                                runs[columns + ["impacts", "switchings", "status"]].to_string(index=False))
    runs = tables.compare(tables.records_frame(records), reference)
    title = f"{exp.name}: integrated absolute output error (deg s)"
    return ExperimentReport("table1", runs, tables.TABLE1_COLUMNS, title,
                            tables.table1_markdown(runs, title, exp.description), tables.rich_table(runs, title))
