"""diagnose's measured breakdown and its progress off a terminal (issue 38): the ``timing`` block of
``diagnose --json`` (wall time, replays, solver steps and fits per stage and per candidate, counted
wherever the fits ran), and plain progress lines on a stderr that is not a terminal."""
from __future__ import annotations

import json
from pathlib import Path

import pandas as pd
import pytest
from click.testing import CliRunner

import gearbench as gb
from gearbench.cli import main
from gearbench.identify.progress import STAGES, PlainLines, ProgressEvent
from gearbench.identify.replay import Replay
from gearbench.identify.timing import Cost, Timing
from gearbench.measure.data import read_measurement

REPO = Path(__file__).resolve().parents[1]
RIG = REPO / "experiments" / "plants" / "bench_rig.yaml"
HIDDEN = REPO / "experiments" / "data" / "bench_rig_hidden.csv"
ONLY = ("coulomb_friction", "bias_torque")  # two rungs with a pair, a calibration and a joint refit


@pytest.fixture(scope="module")
def short(tmp_path_factory):
    """The tutorial's record cut to its first 3 s."""
    path = tmp_path_factory.mktemp("rec") / "short.csv"
    pd.read_csv(HIDDEN).iloc[:3000].to_csv(path, index=False)
    return path


@pytest.fixture(scope="module")
def runs(short):
    """The same diagnosis in this process and on two worker processes."""
    return {w: gb.diagnose(RIG, short, only=ONLY, max_steps=2, workers=w) for w in (1, 2)}


def _without_timing(d) -> str:
    j = d.to_dict()
    j.pop("timing")
    return json.dumps(j, sort_keys=True)


def test_the_timing_block_has_its_shape_and_adds_up(runs):
    t = json.loads(json.dumps(runs[1].to_dict()))["timing"]
    assert runs[1].timing == runs[1].to_dict()["timing"]
    assert set(t) == {"wall_s", "stages", "candidates"} and t["wall_s"] > 0
    for s in t["stages"]:
        assert set(s) == {"stage", "wall_s", "replays", "solver_steps", "fits"} and s["stage"] in STAGES
        assert s["wall_s"] >= 0 and all(isinstance(s[k], int) for k in ("replays", "solver_steps", "fits"))
        assert s["replays"] >= s["fits"]
        assert s["solver_steps"] > 0 or s["replays"] == 0
    names = [s["stage"] for s in t["stages"]]
    assert len(set(names)) == len(names) and {"baseline", "candidates", "pairs"} <= set(names), names
    assert sum(s["wall_s"] for s in t["stages"]) <= t["wall_s"]
    screen = next(s for s in t["stages"] if s["stage"] == "candidates")
    assert screen["fits"] > 0 and screen["replays"] > screen["fits"] and screen["solver_steps"] > screen["replays"]
    for c in t["candidates"]:
        assert set(c) == {"effect", "wall_s", "replays", "fits"} and c["wall_s"] > 0
        assert c["replays"] >= c["fits"] > 0
    effects = {c["effect"] for c in t["candidates"]}
    assert set(ONLY) <= effects and {"coulomb_friction+bias_torque", "bias_torque+coulomb_friction"} & effects
    # every fit of a candidate counts to a stage: the stages' fits hold the candidates'
    assert sum(s["fits"] for s in t["stages"]) >= sum(c["fits"] for c in t["candidates"])


def test_counts_made_in_worker_processes_come_back_and_change_nothing(runs):
    one, two = (runs[w].timing for w in (1, 2))
    count = ("stage", "replays", "solver_steps", "fits")
    assert [{k: s[k] for k in count} for s in one["stages"]] == [{k: s[k] for k in count} for s in two["stages"]]
    assert (sorted((c["effect"], c["replays"], c["fits"]) for c in one["candidates"])
            == sorted((c["effect"], c["replays"], c["fits"]) for c in two["candidates"]))
    assert _without_timing(runs[1]) == _without_timing(runs[2])


def test_a_replay_run_carries_its_solver_steps_and_a_metered_one_counts_them(short):
    plant = gb.load_plant(RIG)
    replay = Replay(read_measurement(short))
    bare = replay.run(plant)
    cost = Cost()
    run = replay.metered(cost).run(plant)
    assert run.steps == bare.steps > 0 and run.events == bare.events
    assert (cost.replays, cost.solver_steps) == (1, run.steps) and replay.meter is None
    assert all((run[k] == bare[k]).all() for k in bare)


def test_stages_nest_and_end():
    now = [0.0]
    t = Timing(clock=lambda: now[0])
    t.switch("pairs")
    now[0] = 1.0
    with t.nested():
        t.switch("candidates")
        t.replayed(10)
        now[0] = 3.0
    t.replayed(5)
    now[0] = 4.0
    t.switch(None)
    now[0] = 5.0
    r = t.report()
    assert r["wall_s"] == 5.0
    assert r["stages"] == [{"stage": "pairs", "wall_s": 2.0, "replays": 1, "solver_steps": 5, "fits": 0},
                           {"stage": "candidates", "wall_s": 2.0, "replays": 1, "solver_steps": 10, "fits": 0}]


def test_plain_lines_one_per_stage_and_at_most_one_every_few_seconds():
    now, lines = [0.0], []
    show = PlainLines(lines.append, every_s=5.0, clock=lambda: now[0])
    for i in range(10):
        now[0] = i
        show(ProgressEvent(1, "candidates", i, 9, "coulomb_friction (load)" if i else "", "", float(i)))
    now[0] = 10.0
    show(ProgressEvent(1, "joint refit", 0, 2, "", "", 10.0))
    assert lines == ["diagnose: step 1 candidates 0/9, 0 s",
                     "diagnose: step 1 candidates 5/9 (coulomb_friction (load)), 5 s",
                     "diagnose: step 1 joint refit 0/2, 10 s"]


def test_progress_lines_on_a_stderr_that_is_not_a_terminal_and_none_with_quiet(short, tmp_path):
    args = ["diagnose", str(RIG), str(short), "--only", "coulomb_friction", "--max-steps", "1",
            "--workers", "1", "--results", str(tmp_path)]
    r = CliRunner().invoke(main, args, catch_exceptions=False)
    assert r.exit_code == 0, r.output
    lines = [ln for ln in r.stderr.splitlines() if ln.startswith("diagnose: ")]
    assert lines and lines[0].startswith("diagnose: step 1 baseline 0/1, ") and lines[0].endswith(" s"), r.stderr
    assert any(ln.startswith("diagnose: step 1 candidates ") for ln in lines), lines
    assert "diagnose: " not in r.stdout
    quiet = CliRunner().invoke(main, args + ["--quiet"], catch_exceptions=False)
    assert quiet.exit_code == 0 and "diagnose: " not in quiet.stderr, quiet.stderr
