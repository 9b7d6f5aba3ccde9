"""diagnose's progress, time limit and Ctrl-C (issue 18): one progress stream for the whole
ladder, a time limit that stops after the rung that crosses it, and an interrupt that keeps
the ladder so far (the library raises it, the CLI prints it and exits 130)."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import psutil
import pytest

from gearbench.experiment.files import load_plant
from gearbench.identify.diagnose import DiagnosisInterrupted, diagnose
from gearbench.identify.policy import Policy
from gearbench.identify.progress import STAGES
from gearbench.identify.results import STOPPED
from gearbench.identify.replay import Replay
from gearbench.synth import excitation, synthesize
from gearbench.plant.effects import AddedEffect

REPO = Path(__file__).resolve().parents[1]
RIG = REPO / "experiments" / "plants" / "bench_rig.yaml"
ONLY = ("coulomb_friction", "load_spring", "bias_torque")
NOISE = {"motor_angle_deg": 0.02, "load_angle_deg": 0.015, "current_A": 0.008}
ONE_RUNG = Policy(pair_top=1)  # no pairs: one rung per effect


@pytest.fixture(scope="module")
def two_effects():
    """3 s of voltage steps on the bench rig with a spring and Coulomb friction at the load hidden:
    two rungs."""
    plant = load_plant(RIG)
    t, u = excitation("steps", plant, duration_s=3.0, seed=7)
    hidden = [AddedEffect("coulomb_friction", {"location": "load", "torque": 0.6}),
              AddedEffect("load_spring", {"stiffness": 3.0, "rest_angle_deg": -10.0})]
    return plant, Replay(synthesize(plant, hidden, t, u, noise=NOISE, seed=7))


@pytest.fixture(scope="module")
def followed(two_effects):
    """The diagnosis with every progress event.  No pairs (``Policy.pair_top`` 1), so the two effects take
    one rung each, a candidate screen per rung (fitted jointly as a pair, both would come in the
    first rung)."""
    plant, replay = two_effects
    events = []
    d = diagnose(plant, replay, max_steps=3, only=ONLY, workers=1, progress=events.append, policy=ONE_RUNG)
    return d, events


def test_progress_follows_every_rung_of_the_ladder(followed):
    d, events = followed
    assert [s.effect for s in d.ladder if s.action == "add"] and len(d.ladder) >= 2, d.to_json()["ladder"]
    assert {e.stage for e in events} <= set(STAGES)
    assert events[0].stage == "baseline"
    # every rung's candidates are announced and counted to the end, the last rung's included
    steps = sorted({e.step for e in events if e.stage == "candidates"})
    assert [s.action for s in d.ladder] == ["add", "add"] and steps == [1, 2], (steps, d.to_json()["ladder"])
    assert {"joint refit", "simplify", "prune"} <= {e.stage for e in events if e.step == 2}
    for k in steps:
        mine = [e for e in events if e.step == k and e.stage == "candidates"]
        assert mine[0].done == 0 and mine[-1].done == mine[-1].total == len(mine) - 1 > 0
        assert [e.done for e in mine] == list(range(len(mine)))
        named = [e for e in mine if e.done]
        assert all(e.label.split(" (")[0] in ONLY for e in named)
        assert named[-1].best and "x noise" in named[-1].best
    assert all(b.elapsed_s >= a.elapsed_s for a, b in zip(events, events[1:]))
    assert d.stopped in STOPPED and d.to_json()["stopped"] == d.stopped


def test_time_limit_stops_after_the_rung_that_crosses_it(two_effects, followed):
    plant, replay = two_effects
    full, _ = followed
    d = diagnose(plant, replay, max_steps=3, only=ONLY, workers=1, time_limit_s=0.0, policy=ONE_RUNG)
    assert d.stopped == "time limit" and "time limit" in d.reason, d.reason
    assert len(d.ladder) == 1 and d.ladder[0].effect == full.ladder[0].effect
    assert d.to_json()["stopped"] == "time limit"


def test_an_interrupt_carries_the_ladder_so_far(two_effects, followed):
    plant, replay = two_effects
    full, _ = followed

    def ctrl_c_in_step_2(e):
        if e.step == 2 and e.stage == "candidates" and e.done == 1:
            raise KeyboardInterrupt

    with pytest.raises(DiagnosisInterrupted) as stop:
        diagnose(plant, replay, max_steps=3, only=ONLY, workers=1, progress=ctrl_c_in_step_2, policy=ONE_RUNG)
    d = stop.value.diagnosis
    assert isinstance(stop.value, KeyboardInterrupt)
    assert d.stopped == "interrupted" and "step 2" in d.reason
    assert [s.effect for s in d.ladder] == [full.ladder[0].effect]
    assert d.verdict == full.ladder[0].effect


def test_ctrl_c_during_diagnose_prints_the_ladder_so_far_and_exits_130(tmp_path):
    """A real SIGINT to the process group while two workers fit candidates: exit 130, the ladder
    (so far) printed, no traceback from the parent or the workers, no file written."""
    out = tmp_path / "res"
    cmd = [sys.executable, "-m", "gearbench.cli", "diagnose", str(RIG),
           str(REPO / "experiments" / "data" / "bench_rig_hidden.csv"), "--workers", "2", "--results", str(out)]
    proc = subprocess.Popen(cmd, cwd=REPO, start_new_session=True, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env={**os.environ, "PYTHONPATH": str(REPO)},
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    deadline = time.monotonic() + 180
    while len(psutil.Process(proc.pid).children(recursive=True)) < 2:
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() < deadline, "diagnose never started its workers"
        time.sleep(0.05)
    time.sleep(0.5)
    os.killpg(proc.pid, signal.SIGINT)
    stdout, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    assert "Traceback" not in err and "KeyboardInterrupt" not in err, err
    assert "interrupted: during ladder step 1" in err and "(as given)" in err, err
    assert not out.exists() or not any(out.rglob("*.json")), list(out.rglob("*"))
