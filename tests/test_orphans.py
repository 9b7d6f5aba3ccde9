"""Pool workers end with their parent: a ``kill -9`` of the parent alone leaves no
worker running (nor holding the sweep store's lock), the sweep resumes and no point
is lost or stored twice; Ctrl-C reaches the workers without a traceback."""
from __future__ import annotations

import csv
import io
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import psutil
import pytest

import gearbench.sweep as sw
from gearbench import workers as W

REPO = Path(__file__).resolve().parents[1]
PLANT = REPO / "experiments" / "plants" / "thesis_gear.yaml"
GRID = "controller.kp=geomspace(2000,9000,16)"
N_POINTS = 16
ENV = {**os.environ, "PYTHONPATH": str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", "")}


def default_sigint() -> None:
    """``preexec_fn`` of a child that is sent a Ctrl-C: SIGINT at its default, as under a terminal.  A
    shell starts a background job with SIGINT ignored, the child inherits that, and Python then
    installs no KeyboardInterrupt handler: with pytest run in the background (``cmd &``, nohup), the
    Ctrl-C tests hung 25 s and failed (2026-11-29), while in the foreground they passed."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def mini(tmp_path: Path) -> Path:
    """Profile 2 for 10 s under a high P gain: it chatters at the voltage limit, so each
    point takes about half a second and the 16 points several seconds on 2 workers."""
    exp = tmp_path / "mini.yaml"
    exp.write_text(f"""
name: mini
plant: {PLANT}
duration_s: 10
profiles: [profile2]
controllers:
  - {{kind: p, kp: 50}}
shift: [off]
""")
    return exp


def alive(pid: int) -> bool:
    """A process that still runs (a zombie waiting for a reaper does not count)."""
    try:
        return psutil.Process(pid).status() != psutil.STATUS_ZOMBIE
    except psutil.NoSuchProcess:
        return False


def wait_for(predicate, timeout: float, what: str, step: float = 0.02):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        got = predicate()
        if got:
            return got
        time.sleep(step)
    raise AssertionError(f"timed out after {timeout} s waiting for {what}")


def stored_lines(path: Path) -> list[dict]:
    """Complete rows of the store (a kill may cut the last line short)."""
    if not path.exists():
        return []
    text = path.read_text()
    return list(csv.DictReader(io.StringIO(text[: text.rfind("\n") + 1])))


def kill_group(proc: subprocess.Popen) -> None:
    """Clean-up only: whatever the test left of the process group."""
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except ProcessLookupError:
        pass
    proc.wait(timeout=30)


def test_sigkill_of_the_sweep_alone_leaves_no_worker_and_the_resume_loses_nothing(tmp_path):
    exp = mini(tmp_path)
    out = tmp_path / "res"
    path = out / "mini" / "sweep.csv"
    cmd = [sys.executable, "-m", "gearbench.cli", "sweep", str(exp), "--param", GRID,
           "--results", str(out), "--workers", "2"]
    # a session of its own only so that the clean-up can reach everything; the kill below
    # goes to the parent's pid alone, as `kill -9 PID` or the OOM killer would
    proc = subprocess.Popen(cmd, start_new_session=True, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, env=ENV)
    try:
        wait_for(lambda: len(stored_lines(path)) >= 2, 120, "two stored points")
        workers = psutil.Process(proc.pid).children(recursive=True)
        assert len(workers) >= 2, workers
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(timeout=30)
        t_kill = time.monotonic()
        wait_for(lambda: not any(alive(w.pid) for w in workers), 5, "the workers to end")
        gone_s = time.monotonic() - t_kill
    finally:
        kill_group(proc)
    assert proc.returncode == -signal.SIGKILL
    assert gone_s < 5
    kept = stored_lines(path)
    assert 2 <= len(kept) < N_POINTS, "the kill should land in the middle of the sweep"
    before = path.read_text()
    finished = before[: before.rfind("\n") + 1]

    # the resume is not told "being written by another sweep": nothing holds the lock
    res = subprocess.run(cmd, capture_output=True, text=True, timeout=300, env=ENV)
    assert res.returncode == 0, res.stderr
    assert f"{len(kept)} already stored" in res.stderr, res.stderr
    assert path.read_text().startswith(finished)  # the rows stored before the kill are untouched
    final = stored_lines(path)
    plan = sw.plan_sweep(exp, sw.parse_params([GRID]))
    keys = [r["key"] for r in final]
    assert len(keys) == N_POINTS and len(set(keys)) == N_POINTS       # none duplicated
    assert set(keys) == {p.key for p in plan.points}                    # none lost
    assert all(r["status"] == "ok" for r in final)


def test_ctrl_c_reaches_the_workers_without_a_traceback(tmp_path):
    exp = mini(tmp_path)
    out = tmp_path / "res"
    path = out / "mini" / "sweep.csv"
    cmd = [sys.executable, "-m", "gearbench.cli", "sweep", str(exp), "--param", GRID,
           "--results", str(out), "--workers", "2"]
    proc = subprocess.Popen(cmd, start_new_session=True, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=ENV, preexec_fn=default_sigint)
    try:
        wait_for(lambda: len(stored_lines(path)) >= 1, 120, "a stored point")
        workers = psutil.Process(proc.pid).children(recursive=True)
        assert len(workers) >= 2, workers
        os.killpg(proc.pid, signal.SIGINT)  # what a terminal's Ctrl-C does: the whole group
        _, err = proc.communicate(timeout=60)
        wait_for(lambda: not any(alive(w.pid) for w in workers), 5, "the workers to end")
    finally:
        kill_group(proc)
    assert "Traceback" not in err, err
    assert "KeyboardInterrupt" not in err, err
    kept = stored_lines(path)
    assert len({r["key"] for r in kept}) == len(kept) >= 1


IDLE_SCRIPT = textwrap.dedent("""
    import faulthandler, os, sys, time
    from gearbench.workers import process_pool

    def pid(_):
        time.sleep(0.01)
        return os.getpid()

    try:
        with process_pool(2) as pool:
            # both workers have run a task (so their initializer, which ignores SIGINT: a Ctrl-C
            # before it is a race of the test, not of the pool), and now wait for work
            while len(set(pool.map(pid, range(8)))) < 2:
                pass
            print("ready", flush=True)
            # should it hang (it did when the test runner passed SIGINT down ignored: default_sigint),
            # the threads' stacks come out before the test gives up
            faulthandler.dump_traceback_later(25, exit=True, file=sys.stderr)
            time.sleep(60)
    except KeyboardInterrupt:
        print("interrupted", flush=True)
""")


def test_ctrl_c_with_idle_workers_prints_no_worker_traceback(tmp_path):
    """An idle worker of a plain pool, waiting on its queue, dies of Ctrl-C with a
    KeyboardInterrupt traceback each; these workers ignore SIGINT and are ended by the parent."""
    script = tmp_path / "idle.py"
    script.write_text(IDLE_SCRIPT)
    proc = subprocess.Popen([sys.executable, str(script)], start_new_session=True, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=ENV, preexec_fn=default_sigint)
    try:
        assert proc.stdout.readline().strip() == "ready"
        workers = psutil.Process(proc.pid).children(recursive=True)
        time.sleep(0.3)
        os.killpg(proc.pid, signal.SIGINT)
        out, err = proc.communicate(timeout=30)
    finally:
        kill_group(proc)
    assert out.strip() == "interrupted" and proc.returncode == 0, err
    assert "Traceback" not in err and "KeyboardInterrupt" not in err, err
    assert not any(alive(w.pid) for w in workers)


POOL_SCRIPT = textwrap.dedent("""
    import sys, time
    from gearbench.workers import process_pool

    def nap(_):
        time.sleep(60)

    with process_pool(2, watch=sys.argv[1]) as pool:
        futures = [pool.submit(nap, i) for i in range(2)]
        print(" ".join(str(p) for p in pool._processes), flush=True)
        time.sleep(60)
""")


@pytest.mark.parametrize("watch", ["auto", "poll"])
def test_pool_workers_die_with_a_sigkilled_parent(tmp_path, watch):
    """Both ways of noticing: Linux's parent-death signal and the portable getppid poll."""
    script = tmp_path / "pool.py"
    script.write_text(POOL_SCRIPT)
    proc = subprocess.Popen([sys.executable, str(script), watch], start_new_session=True,
                            stdout=subprocess.PIPE, text=True, env=ENV)
    try:
        pids = [int(p) for p in proc.stdout.readline().split()]
        assert len(pids) == 2 and all(alive(p) for p in pids)
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(timeout=30)
        wait_for(lambda: not any(alive(p) for p in pids), 3 + W.POLL_S, "the workers to end")
    finally:
        kill_group(proc)


def test_leaving_the_pool_by_an_exception_kills_its_workers_at_once():
    t0 = time.monotonic()
    with pytest.raises(RuntimeError, match="consumer gave up"):
        with W.process_pool(2) as pool:
            pool.submit(time.sleep, 60)
            pool.submit(time.sleep, 60)
            pids = list(pool._processes)
            raise RuntimeError("consumer gave up")
    assert time.monotonic() - t0 < 10           # not the 60 s the tasks would take
    assert not any(alive(p) for p in pids)


def test_worker_count_rule():
    assert W.worker_count(None, 1000) == W.default_workers()
    assert W.worker_count(8, 3) == 3          # never more workers than jobs
    assert W.worker_count(0, 5) == 1 and W.worker_count(-2, 5) == 1  # 1 = solve in this process
    assert W.worker_count(None, 0) == 1


def test_a_forked_child_does_not_keep_the_store_locked(tmp_path):
    """The child's copy of the store's descriptor is closed at the fork: once the parent
    closes the store, another sweep may open it while the child still runs."""
    store = sw.SweepStore(tmp_path / "sweep.csv", ["key", "x"])
    store.open()
    r, w = os.pipe()             # parent -> child: go
    ready_r, ready_w = os.pipe()  # child -> parent: forked (the at-fork hooks have run)
    pid = os.fork()
    if pid == 0:  # the child: wait until told to go
        os.write(ready_w, b"r")
        os.read(r, 1)
        os._exit(0)
    os.close(r)
    os.close(ready_w)
    try:
        assert os.read(ready_r, 1) == b"r"
        store.close()
        again = sw.SweepStore(tmp_path / "sweep.csv", ["key", "x"])
        again.open()   # would raise "being written by another sweep" if the child held the lock
        again.close()
    finally:
        os.write(w, b"x")
        os.close(w)
        os.close(ready_r)
        os.waitpid(pid, 0)


@pytest.mark.skipif(not (REPO / "experiments" / "data" / "bench_rig_hidden.csv").exists(),
                    reason="needs the bench-rig record")
def test_sigkill_of_diagnose_alone_leaves_no_worker(tmp_path):
    cmd = [sys.executable, "-m", "gearbench.cli", "diagnose", str(REPO / "experiments/plants/bench_rig.yaml"),
           str(REPO / "experiments/data/bench_rig_hidden.csv"), "--workers", "2", "--results", str(tmp_path)]
    proc = subprocess.Popen(cmd, start_new_session=True, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, env=ENV)
    try:
        def two_workers():
            found = psutil.Process(proc.pid).children(recursive=True)
            return found if len(found) >= 2 else None

        workers = wait_for(two_workers, 120, "diagnose's two workers", step=0.05)
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(timeout=30)
        wait_for(lambda: not any(alive(w.pid) for w in workers), 5, "the workers to end")
    finally:
        kill_group(proc)
