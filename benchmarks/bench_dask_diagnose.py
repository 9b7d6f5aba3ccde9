"""Benchmark: candidates per second of one rung of ``diagnose``, locally and on a Dask cluster.

The rung: the first rung's candidate fits of ``gearbench diagnose`` (every effect
of the library that can act, in every place: 15 candidates) of the bench rig
against the shipped 10 s record (``experiments/data/bench_rig_hidden.csv``, 10 001
samples), as ``diagnose`` screens them (``candidates.fit_each`` through an
``identify.executor.Executor``).  Timed four ways, each after every process that
fits has loaded the compiled models of every candidate (so the figures compare
where the fits run, not numba's disk cache):

* locally in this process (1) and on 2 forked processes (``--workers``);
* on a ``distributed.LocalCluster`` of 1 and of 2 single-threaded worker
  processes on the loopback interface (``--scheduler``), the connection made
  before the clock starts; the shared record is scattered once per map.

Every process runs BLAS on one thread (``OMP/MKL/OPENBLAS_NUM_THREADS=1``, set here
before numpy loads), as Dask's nannies set it for their workers
(``distributed.nanny.pre-spawn-environ``): the four runs then do the same
arithmetic, so they time the same work and give the same fits to the last bit.
With OpenBLAS's default of a thread per core the products of a 30 000-row
Jacobian are summed in another order, and the fits differ from a Dask worker's
in the last digits.

Keys (merged into ``results/bench.json``, read-modify-write, atomic):
``dask_diagnose_candidates_per_s_{local,dask}_{1,2}`` (candidates / wall s),
``dask_diagnose_wall_s_{local,dask}_{1,2}``, ``dask_diagnose_dask_over_local_{1,2}``
(the cluster's rate over the local one with as many processes), the case, and
``dask_diagnose_loadavg_before``/``_after`` (the 1-minute load average: the machine
is shared, and another job running meanwhile shows there).  Each run must give the
first one's fits exactly (checked).

One candidate, the shaft compliance, takes about 13 s of the rung's 22 s on one
process, which bounds what a second process or worker can gain.
"""
from __future__ import annotations

import json
import os
import time
from pathlib import Path

os.environ.update({k: "1" for k in ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS")})

from gearbench.experiment.files import load_plant
from gearbench.identify.candidates import candidates, fit_each, start_values
from gearbench.identify.executor import Executor
from gearbench.identify.scoring import Scorer
from gearbench.identify.replay import Replay
from gearbench.measure.data import read_measurement
from gearbench.plant.effects import AddedEffect
from gearbench.workers import default_workers

from bench_store import merge

REPO = Path(__file__).resolve().parents[1]
PLANT = REPO / "experiments" / "plants" / "bench_rig.yaml"
DATA = REPO / "experiments" / "data" / "bench_rig_hidden.csv"


def load_models(plant, replay, cands) -> None:
    """One replay of each candidate at its starting values: loads its compiled model in this process."""
    for c in cands:
        replay.run(plant.with_effects(AddedEffect(c.name, start_values(plant, c))))


def fits(tried) -> str:
    """The rung's fits as text (candidate, parameters, error, BIC), to check two runs are the same."""
    return json.dumps([(t.candidate.label(), t.params, t.result.error if t.ok else None,
                        t.result.bic if t.ok else None) for t in tried])


def rung(plant, replay, scorer, cands, where: Executor) -> tuple[float, list]:
    t0 = time.perf_counter()
    tried = fit_each(replay, scorer, plant, cands, where)
    return time.perf_counter() - t0, tried


def main() -> None:
    from distributed import Client, LocalCluster
    plant, data = load_plant(PLANT), read_measurement(DATA)
    replay = Replay(data)
    scorer = Scorer(replay)
    cands = candidates(plant, replay)
    load_models(plant, replay, cands)  # the forked local workers inherit them
    load_before = os.getloadavg()[0]
    walls, reference = {}, None
    for n in (1, 2):
        with Executor(workers=n) as where:
            walls[f"local_{n}"], tried = rung(plant, replay, scorer, cands, where)
        reference = reference or fits(tried)
        assert fits(tried) == reference, f"{n} local processes gave other fits"
        print(f"local, {n} process(es): {len(cands)} candidates in {walls[f'local_{n}']:.1f} s", flush=True)
    for n in (1, 2):
        with LocalCluster(n_workers=n, threads_per_worker=1, processes=True, host="127.0.0.1",
                          dashboard_address=None) as cluster:
            with Client(cluster, set_as_default=False) as client:
                client.run(load_models, plant, replay, cands)
            with Executor(scheduler=cluster.scheduler_address) as where:
                walls[f"dask_{n}"], tried = rung(plant, replay, scorer, cands, where)
        assert fits(tried) == reference, f"the cluster of {n} worker(s) gave other fits than the local run"
        print(f"Dask LocalCluster, {n} worker(s): {len(cands)} candidates in {walls[f'dask_{n}']:.1f} s", flush=True)
    out = {f"dask_diagnose_candidates_per_s_{k}": len(cands) / w for k, w in walls.items()}
    out.update({f"dask_diagnose_wall_s_{k}": w for k, w in walls.items()})
    out.update({f"dask_diagnose_dask_over_local_{n}": walls[f"local_{n}"] / walls[f"dask_{n}"] for n in (1, 2)})
    out.update({"dask_diagnose_loadavg_before": load_before, "dask_diagnose_loadavg_after": os.getloadavg()[0],
                "dask_diagnose_candidates": len(cands), "dask_diagnose_samples": int(len(data.time_s)),
                "dask_diagnose_cpu_count": default_workers(),
                "dask_diagnose_case": f"first rung's candidate fits, {PLANT.name} against {DATA.name}"})
    merge(out)
    for key, value in out.items():
        print(f"{key:>42}: {value:.4g}" if isinstance(value, float) else f"{key:>42}: {value}")


if __name__ == "__main__":
    main()
