"""Benchmark: one replay, the inner loop of every fit, on the practice records.

Each record of ``data/cases`` (p01-p04, 16 s at 1 kHz: stick-slip friction, a spring, a
clearance) replayed with its true plant as ``gearbench compare`` replays it (1 s windows,
rtol 1e-6), best of ``REPEATS`` after one warm-up run, in a fresh process that imports the
gearbench being measured (``--pythonpath``: another checkout's, for a before/after in one
session).  Also p01's plant without its Stribeck friction (the bare plant every candidate
starts from: piecewise linear, so its Jacobian is reused), and with this checkout's code p01's
plant with its Stribeck friction replaced by LuGre friction (``lugre_friction``: a state of its
own, the model with the effects' states).  Writes ``replay`` (or ``replay_<label>``) into
``results/bench.json``: seconds per replay, solver steps, rejected steps and right-hand-side
evaluations, and the commit measured.

    python benchmarks/bench_replay.py
    python benchmarks/bench_replay.py --pythonpath ../before --label before
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import click

from bench_store import commit_of, merge

REPO = Path(__file__).resolve().parents[1]
CASES = ("p01", "p02", "p03", "p04")
REPEATS = 7
LUGRE = {"type": "lugre_friction", "location": "load", "coulomb_torque": 0.025, "static_torque": 0.06,
         "stribeck_speed": 0.3, "bristle_stiffness": 60.0, "bristle_damping": 0.19}
"""p01's Stribeck friction at the load (0.025/0.06 N m, 0.3 rad/s) as LuGre bristles: 1 mrad of
presliding at breakaway, damped at about half critical with its 6e-4 kg m^2 load."""

INNER = r'''
import json, math, sys, time
from pathlib import Path
import yaml
import gearbench
import gearbench.identify.replay as replay_module
from gearbench.api import _replay
from gearbench.solver.integrate import S_FEVALS, S_REJECTED

spent = {"rejected": 0, "fevals": 0}
solve = replay_module.simulate_packed


def counted(*args, **kwargs):  # the solver's own statistics, summed over a replay's windows
    run = solve(*args, **kwargs)
    spent["rejected"] += int(run.stats[S_REJECTED])
    spent["fevals"] += int(run.stats[S_FEVALS])
    return run


replay_module.simulate_packed = counted
repo, cases, repeats, lugre = Path(sys.argv[1]), sys.argv[2].split(","), int(sys.argv[3]), json.loads(sys.argv[4])

def plant_of(case, swap=None):  # swap: the effects instead of the true ones (None: the true ones)
    raw = dict(yaml.safe_load((repo / "data" / "cases" / case / "truth.yaml").read_text())["true_plant"])
    effects = []
    for e in raw.get("effects", []):
        params = dict(e["params"])
        if "rest_angle" in params:
            params["rest_angle_deg"] = math.degrees(params.pop("rest_angle"))
        effects.append({"type": e["effect"], **params})
    raw["effects"] = effects if swap is None else swap
    return raw

out = {"imported": gearbench.__file__}
runs = [(c, c, None) for c in cases] + [("p01 bare", "p01", [])] + ([("p01 lugre", "p01", [lugre])] if lugre else [])
for label, case, swap in runs:
    plant, data, replay = _replay(plant_of(case, swap), repo / "data" / "cases" / case / "data.csv", None, 1.0, 1e-6,
                                  "bench")
    best = float("inf")
    for k in range(repeats + 1):
        spent.update(rejected=0, fevals=0)
        t0 = time.perf_counter()
        run = replay.run(plant)
        dt = time.perf_counter() - t0
        if k:
            best = min(best, dt)
    out[label] = {"wall_s": best, "steps": run.steps, **spent}
print(json.dumps(out))
'''


@click.command()
@click.option("--python", default=sys.executable, show_default=True, help="Interpreter that runs gearbench.")
@click.option("--pythonpath", default=None, help="A checkout whose gearbench to run instead (PYTHONPATH).")
@click.option("--label", default="", help="Stored as replay_<label> in results/bench.json (default: replay).")
def main(python, pythonpath, label):
    """Time a replay of each practice record with its true plant; merge into results/bench.json."""
    env = dict(os.environ)
    checkout = Path(pythonpath).resolve() if pythonpath else REPO
    env["PYTHONPATH"] = str(checkout)
    # LuGre only where the measured code has it: this checkout (another may predate it)
    lugre = json.dumps(LUGRE if (checkout / "gearbench/plant/effects/lugre_friction.py").exists() else {})
    proc = subprocess.run([python, "-c", INNER, str(REPO), ",".join(CASES), str(REPEATS), lugre], env=env,
                          capture_output=True, text=True, cwd=tempfile.gettempdir())
    if proc.returncode:
        raise click.ClickException(proc.stderr[-2000:])
    figures = json.loads(proc.stdout.strip().splitlines()[-1])
    if Path(figures.pop("imported")).parent.parent != checkout:
        raise click.ClickException(f"the run did not import the gearbench of {checkout}")
    for name, row in figures.items():
        click.echo(f"{name}: {row['wall_s'] * 1e3:.1f} ms per replay, {row['steps']} steps, "
                   f"{row['rejected']} rejected, {row['fevals']} right-hand sides")
    merge({f"replay_{label}" if label else "replay": {
        "measured": time.strftime("%Y-%m-%d %H:%M"), "commit": commit_of(checkout), "repeats": REPEATS,
        "load_before": os.getloadavg()[0], "cases": figures}})


if __name__ == "__main__":
    main()
