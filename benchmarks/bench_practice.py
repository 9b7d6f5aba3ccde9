"""Benchmark: ``gearbench diagnose`` on the practice cases (issue 38): time, and right or wrong.

The practice cases (``data/cases/p01``-``p13``) come from an independent event-driven simulator
with true stick-slip friction, 10-16 s each, some with the sensors of a real rig (coloured noise,
quantized encoders, an offset, no load angle, 250 Hz): the long records the bench-rig ladder
(``bench_ladder.py``) does not see.  Each is diagnosed by ``gearbench diagnose nominal.yaml
data.csv --json`` in a fresh process (the compiled core loaded from numba's disk cache), timed
from the command's start to its exit, and scored against its ``truth.yaml``:

* ``verdict_right``: the final model's effects are the hidden ones (none for a null case);
* ``params``: per hidden parameter the final model's value (the last rung's refitted model) and
  its relative error (``clearance_deg``
  against ``backlash_deg``, ``rest_angle`` in rad against ``rest_angle_deg``);
* ``end_over_true_noise``: the model's end (the last rung's error, or the calibration's when it came
  last, else the baseline's) over the
  record's true noise on the error signal (``true_noise``, else ``noise_sigma``);
* ``timing``: the diagnosis' own breakdown (``diagnose --json``'s ``timing``).

Targets (issue 38, 2 quiet cores): each case <= 60 s, the median <= 30 s.  The machine's load
average before and after each case is stored beside it: a figure measured beside other work is
no figure of the code alone.

    python benchmarks/bench_practice.py                 # every case -> bench.json "practice"
    python benchmarks/bench_practice.py --only p01 --only p09
"""
from __future__ import annotations

import json
import math
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import click
import yaml

from bench_ladder import NEUTRAL, check_imported, gearbench

REPO = Path(__file__).resolve().parents[1]
CASES = REPO / "data" / "cases"
NAMES = sorted(p.name for p in CASES.glob("p[0-9][0-9]"))
TARGET_S, MEDIAN_TARGET_S = 60.0, 30.0
RENAMED = {"clearance_deg": "backlash_deg"}
SKIPPED = {"clearance", "location", "signal"}  # SI duplicates of a degree value, and options


def expected(truth: dict) -> list[dict]:
    """The hidden effects as ``{effect, location, params}`` in the plant file's names and units."""
    out = []
    for e in truth.get("hidden_effects") or []:
        params = {}
        for key, value in e.get("params", {}).items():
            if key in SKIPPED:
                continue
            if key == "rest_angle":
                key, value = "rest_angle_deg", math.degrees(value)
            params[RENAMED.get(key, key)] = value
        out.append({"effect": e["effect"], "location": e.get("params", {}).get("location"), "params": params})
    return out


def sensor_offsets(truth: dict) -> dict[str, float]:
    """The record's sensor offsets by signal (``realism.offset``, ``noise_model.<signal>.offset``):
    a sensor's, not a hidden effect (``data/cases/README.md``: "The encoders and the offset in p13
    are the sensors, not a hidden effect")."""
    out = dict((truth.get("realism") or {}).get("offset") or {})
    out.update({s: m["offset"] for s, m in (truth.get("noise_model") or {}).items() if "offset" in m})
    return out


def score(truth: dict, report: dict) -> dict:
    """The diagnosis against the truth: verdict, parameters, the model's end over the true noise.

    A ``sensor_offset`` of the final model on a signal whose sensor has an offset, within 15 % of
    it, is the record's sensor found (``sensors_found``), neither a hidden effect nor a false one:
    the verdict is right when the other effects are the hidden ones."""
    hidden = expected(truth)
    final = report["ladder"][-1]["model"] if report["ladder"] else []  # the final model, refitted
    offsets = sensor_offsets(truth)

    def sensor(e):
        true = offsets.get(e.get("signal"))
        return e["type"] == "sensor_offset" and true is not None and abs(e["offset"] - true) <= 0.15 * abs(true)
    sensors = [{"signal": e["signal"], "true": offsets[e["signal"]], "fitted": e["offset"]} for e in final if sensor(e)]
    found = sorted(e["type"] for e in final if not sensor(e))
    params = {}
    for h in hidden:
        e = next((e for e in final if e["type"] == h["effect"] and h["location"] in (None, e.get("location"))),
                 None)
        for key, true in h["params"].items():
            got = None if e is None else e.get(key)
            params[f"{h['effect']}.{key}"] = {"true": true, "fitted": got, "relative_error": (
                None if got is None or true == 0 else abs(got - true) / abs(true))}
    noise = truth.get("true_noise") or truth.get("noise_sigma") or {}
    signal = report["error_signal"]
    # the final model's error: the last rung's (a removal's is the model after it), or the calibration's
    # when that came after the last rung
    cal = report.get("calibration_step")
    end = report["ladder"][-1]["error"] if report["ladder"] else report["baseline_error"]
    if cal and cal["after_step"] >= len(report["ladder"]):
        end = cal["error"]
    return {"expected": sorted(h["effect"] for h in hidden), "found": found, "sensors_found": sensors,
            "verdict_right": found == sorted(h["effect"] for h in hidden), "params": params,
            "error_signal": signal, "end": end, "true_noise": noise.get(signal),
            "end_over_true_noise": end / noise[signal] if noise.get(signal) else None}


def run_case(name: str, python: str, pythonpath: str | None, timeout: float, out: Path) -> dict:
    folder = CASES / name
    truth = yaml.safe_load((folder / "truth.yaml").read_text())
    cmd, env = gearbench(python, pythonpath)
    args = cmd + ["diagnose", str(folder / "nominal.yaml"), str(folder / "data.csv"), "--json",
                  "--results", str(out / name)]
    load_before = os.getloadavg()[0]
    t0 = time.perf_counter()
    try:
        p = subprocess.run(args, env=env, capture_output=True, text=True, timeout=timeout, cwd=NEUTRAL)
    except subprocess.TimeoutExpired:
        return {"wall_s": None, "status": f"stopped after {timeout:g} s", "load_before": load_before}
    row = {"wall_s": time.perf_counter() - t0, "target_s": TARGET_S, "exit": p.returncode,
           "load_before": load_before, "load_after": os.getloadavg()[0]}
    if p.returncode != 0:
        return {**row, "status": "failed", "stderr": p.stderr[-2000:]}
    report = json.loads(p.stdout)
    return {**row, "status": "ok", "verdict": report["verdict"], "stopped": report.get("stopped"),
            "reason": report["reason"], **score(truth, report),
            "ladder": [{"effect": s["effect"], "action": s.get("action", "add"), "params": s["params"],
                        "error": s["error"]} for s in report["ladder"]],
            "final_model": report["ladder"][-1]["model"] if report["ladder"] else [],
            "calibration": {k: {"file": c["nominal"], "value": c["value"], "status": c["status"]}
                            for k, c in report.get("calibration", {}).items()},
            "timing": report.get("timing")}


def summary(rows: dict) -> dict:
    walls = [r["wall_s"] for r in rows.values() if r.get("wall_s") is not None]
    return {"cases": len(rows), "median_wall_s": statistics.median(walls) if walls else None,
            "max_wall_s": max(walls) if walls else None, "median_target_s": MEDIAN_TARGET_S,
            "within_target": sum(1 for r in rows.values() if r.get("wall_s") is not None
                                 and r["wall_s"] <= TARGET_S),
            "verdicts_right": sum(1 for r in rows.values() if r.get("verdict_right"))}


@click.command()
@click.option("--python", default=sys.executable, show_default=True, help="Interpreter that runs gearbench.")
@click.option("--pythonpath", default=None, help="A checkout whose gearbench to run instead (PYTHONPATH).")
@click.option("--label", default="", help="Stored as practice_<label> in results/bench.json (default: practice).")
@click.option("--only", "names", multiple=True, type=click.Choice(NAMES), help="Only these cases.")
@click.option("--timeout", type=float, default=900.0, show_default=True, help="Stop a diagnosis after, s.")
def main(python, pythonpath, label, names, timeout):
    from bench_store import commit_of, merge, stored
    check_imported(python, pythonpath)
    key = f"practice_{label}" if label else "practice"
    # --only measures some cases again: the others' rows stay as they were
    rows = stored(key, "cases") if names else {}
    with tempfile.TemporaryDirectory() as tmp:
        for name in names or NAMES:
            rows[name] = r = run_case(name, python, pythonpath, timeout, Path(tmp))
            r["measured"] = time.strftime("%Y-%m-%d %H:%M")
            print(f"{name}: {r['status']}, {r['wall_s'] and round(r['wall_s'], 1)} s (load {r['load_before']:.1f}); "
                  f"found {r.get('found')} expected {r.get('expected')}; end/true noise "
                  f"{r.get('end_over_true_noise') and round(r['end_over_true_noise'], 2)}", flush=True)
    merge({key: {
        "measured": time.strftime("%Y-%m-%d %H:%M"), "cpu_count": os.cpu_count(),
        "commit": commit_of(Path(pythonpath).resolve() if pythonpath else REPO),
        "other_checkout": bool(pythonpath), "summary": summary(rows), "cases": rows}})


if __name__ == "__main__":
    main()
