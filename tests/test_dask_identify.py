"""diagnose and fit on a Dask distributed cluster (``--scheduler``): exactly the local answer.

The cluster is a ``LocalCluster`` of two worker processes bound to the loopback
interface, no dashboard.  The record: 2.5 s of open-loop voltage steps on the
bench rig with a load-side Coulomb friction hidden; four effects are tried.

Exactly: a Dask worker runs BLAS on one thread (its nanny sets
``OPENBLAS_NUM_THREADS=1``), and so does a local diagnosis (``gearbench.blas``); on
OpenBLAS's default of one per core a long record's products are summed in another
order and the fits differ in the last digits (``benchmarks/bench_dask_diagnose.py``
checks the 10 s record).
"""
from __future__ import annotations

import contextlib
import json
import os
import socket
import subprocess
import sys
import time
from collections import Counter
from pathlib import Path

import pytest
from click.testing import CliRunner

from gearbench import api
from gearbench.cli import main
from gearbench.experiment.files import load_plant
from gearbench.identify.candidates import candidates
from gearbench.identify.diagnose import diagnose
from gearbench.identify.executor import Executor
from gearbench.identify.replay import Replay
from gearbench.synth import excitation, synthesize
from gearbench.measure.data import write_measurement
from gearbench.plant.effects import AddedEffect

distributed = pytest.importorskip("distributed")
from dask.utils import key_split  # noqa: E402 - dask comes with distributed

REPO = Path(__file__).resolve().parents[1]
RIG = REPO / "experiments" / "plants" / "bench_rig.yaml"
HIDDEN = REPO / "experiments" / "data" / "bench_rig_hidden.csv"
ONLY = ("coulomb_friction", "viscous_friction", "bias_torque", "load_spring")


@pytest.fixture(scope="module")
def cluster():
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=None) as c:
        yield c


@pytest.fixture(scope="module")
def record():
    plant = load_plant(RIG)
    t, u = excitation("steps", plant, duration_s=2.5, seed=3)
    return synthesize(plant, [AddedEffect("coulomb_friction", {"location": "load", "torque": 0.7})], t, u, seed=3)


@contextlib.contextmanager
def counting_fits(cluster):
    """Yields a Counter that, after the block, holds how many tasks of each function the cluster
    ran in it (``run_candidate``: ``candidates.run_candidate``, one candidate's fit)."""
    counts: Counter = Counter()
    with distributed.Client(cluster, set_as_default=False) as watcher, \
            distributed.get_task_stream(client=watcher) as stream:
        yield counts
    counts.update(key_split(t["key"]) for t in stream.data)


def test_dask_diagnosis_is_the_local_one_exactly(cluster, record):
    plant = load_plant(RIG)
    local = diagnose(plant, Replay(record), max_steps=2, only=ONLY, workers=2)
    seen = []
    with counting_fits(cluster) as ran:
        remote = diagnose(plant, Replay(record), max_steps=2, only=ONLY, workers=2, progress=seen.append,
                          scheduler=cluster.scheduler_address)
    assert local.verdict == "coulomb_friction"  # a diagnosis that found something, not an empty one
    # exact: the same floats, text and order (JSON text, so a NaN compares too), but for the wall times
    mine, theirs = remote.to_json(), local.to_json()
    timed = mine.pop("timing"), theirs.pop("timing")
    assert json.dumps(mine) == json.dumps(theirs)
    # the counts made in the cluster's tasks came back: the same as on local processes
    counts = [[{k: s[k] for k in ("stage", "replays", "solver_steps", "fits")} for s in t["stages"]] for t in timed]
    assert counts[0] == counts[1] and any(s["fits"] for s in counts[0])
    first = [c.label() for c in candidates(plant, Replay(record), ONLY)]
    assert ran["run_candidate"] >= len(first)  # the fits ran on the cluster
    # progress of the first screen in the order of the jobs
    assert [e.label for e in seen if e.step == 1 and e.stage == "candidates" and e.done] == first


def test_dask_fit_of_every_place_is_the_local_one_exactly(cluster, record):
    local = api.fit(RIG, record, "coulomb_friction")
    with counting_fits(cluster) as ran:
        remote = api.fit(RIG, record, "coulomb_friction", scheduler=cluster.scheduler_address)
    assert local.effect == "coulomb_friction (load)"
    assert json.dumps(remote.to_dict()) == json.dumps(local.to_dict())
    assert ran["run_candidate"] == 2  # motor and load, one task each


def _free_port() -> int:
    """A loopback port nothing listens on (bound, read, released)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.mark.parametrize("command", ["diagnose", "fit"])
def test_unreachable_scheduler_is_named_and_exits_2(record, tmp_path, monkeypatch, command):
    monkeypatch.setattr("gearbench.workers.CONNECT_TIMEOUT_S", 1)  # nothing listens: refused until the timeout
    path = write_measurement(record, tmp_path / "rig.csv")
    address = f"tcp://127.0.0.1:{_free_port()}"
    args = {"diagnose": ["--only", "bias_torque", "--results", tmp_path],
            "fit": ["--effect", "bias_torque", "-o", tmp_path / "new.yaml"]}[command]
    r = CliRunner().invoke(main, [str(a) for a in (command, RIG, path, "--scheduler", address, *args)])
    assert r.exit_code == 2, r.output
    assert f"cannot reach the Dask scheduler at {address}" in r.output
    assert not (tmp_path / "new.yaml").exists() and not (tmp_path / "diagnose_bench_rig_rig").exists()


def test_a_malformed_address_exits_2_at_once(record, tmp_path):
    """In a process of its own: a Client made from a malformed address held the interpreter's exit
    for 40 s and then printed a traceback."""
    path = write_measurement(record, tmp_path / "rig.csv")
    t0 = time.monotonic()
    r = subprocess.run([sys.executable, "-m", "gearbench.cli", "fit", str(RIG), str(path), "--effect", "bias_torque",
                        "-o", str(tmp_path / "new.yaml"), "--scheduler", "localhost"], cwd=REPO, capture_output=True,
                       text=True, timeout=120, env={**os.environ, "PYTHONPATH": str(REPO)})
    assert r.returncode == 2, r.stderr
    assert "cannot reach the Dask scheduler at localhost: missing port number" in r.stderr
    assert "Traceback" not in r.stderr and "Exception ignored" not in r.stderr, r.stderr
    assert time.monotonic() - t0 < 30


def test_the_api_names_a_scheduler_that_is_not_an_address():
    with pytest.raises(api.ConfigError, match="scheduler must be a Dask scheduler address"):
        api.fit(RIG, HIDDEN, "bias_torque", scheduler=8786)
    with pytest.raises(ValueError, match="cannot reach the Dask scheduler at tcp://127.0.0.1:port"):
        api.diagnose(RIG, HIDDEN, scheduler="tcp://127.0.0.1:port")


def _inverse(x: float) -> float:
    return 1.0 / x


def test_a_failed_task_raises_here_and_the_connection_is_closed(cluster):
    clients = set(cluster.scheduler.clients)
    with pytest.raises(ZeroDivisionError):
        with Executor(scheduler=cluster.scheduler_address) as where:
            assert set(cluster.scheduler.clients) > clients  # connected on entering
            where.map(_inverse, [1.0, 0.0, 2.0])
    deadline = time.monotonic() + 5.0
    while set(cluster.scheduler.clients) != clients and time.monotonic() < deadline:
        time.sleep(0.05)
    assert set(cluster.scheduler.clients) == clients
