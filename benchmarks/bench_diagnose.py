"""Benchmark: ``diagnose`` over the whole effect library on a 10 s record at 1 kHz.

The record is the shipped example (``experiments/data/bench_rig_hidden.csv``:
the bench rig with Coulomb friction and a return spring hidden, 10 001
samples).  Timed: the complete diagnosis (baseline, every candidate fitted on
every rung of the ladder, the final check) on all cores and, as the baseline
in the same run, on one worker, after the compiled core is loaded.

* ``diagnose_wall_s``: wall time on all cores (target: under 120 s);
* ``diagnose_wall_s_1_worker`` and ``diagnose_parallel_speedup`` (their ratio);
* ``diagnose_replays_per_s``: one open-loop replay of the record, repeated;
* ``diagnose_ladder``: the effects found, with the error after each.

Merges into ``results/bench.json`` (read-modify-write, atomic).
"""
from __future__ import annotations

import json
import os
import time
from pathlib import Path

from gearbench.experiment.files import load_plant
from gearbench.identify.diagnose import diagnose
from gearbench.identify.replay import Replay
from gearbench.measure.data import read_measurement

from bench_store import merge

REPO = Path(__file__).resolve().parents[1]
PLANT = REPO / "experiments" / "plants" / "bench_rig.yaml"
DATA = REPO / "experiments" / "data" / "bench_rig_hidden.csv"


def main() -> None:
    plant, data = load_plant(PLANT), read_measurement(DATA)
    replay = Replay(data)
    replay.run(plant)  # load the compiled core
    n = 10
    t0 = time.perf_counter()
    for _ in range(n):
        replay.run(plant)
    per_replay = (time.perf_counter() - t0) / n
    walls = {}
    for workers in (os.cpu_count() or 1, 1):
        t0 = time.perf_counter()
        d = diagnose(plant, replay, workers=workers)
        walls[workers] = time.perf_counter() - t0
        print(f"diagnose, {workers} worker(s): {walls[workers]:.1f} s; ladder "
              + " -> ".join(f"{s.effect} {s.error:.4g}" for s in d.ladder), flush=True)
    cpus = os.cpu_count() or 1
    out = {
        "diagnose_wall_s": walls[cpus], "diagnose_wall_s_1_worker": walls[1],
        "diagnose_parallel_speedup": walls[1] / walls[cpus], "diagnose_cpu_count": cpus,
        "diagnose_samples": int(len(data.time_s)), "diagnose_replay_wall_s": per_replay,
        "diagnose_replays_per_s": 1.0 / per_replay,
        "diagnose_ladder": [{"effect": s.effect, "error_deg": s.error} for s in d.ladder],
        "diagnose_noise_floor_deg": d.noise_floor,
    }
    merge(out)
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
