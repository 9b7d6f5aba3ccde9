"""Benchmark: ``gearbench diagnose`` end to end, whole library, ladder to the end (issue 18).

The records are made by ``gearbench synth`` (the bench rig, 1 kHz, the mixed excitation of
the diagnose tests), then each is diagnosed by ``gearbench diagnose ... --json`` in a fresh
process, timed from the command's start to its exit (what a user waits for, the compiled
core loaded from numba's disk cache):

* ``none_16s``: 16 s, nothing hidden;
* ``one_16s``: 16 s, Coulomb friction at the load (0.6 N m);
* ``two_16s``: 16 s, a load spring (1.5 N m/rad at 5 deg) and Coulomb friction at the load (0.6 N m);
* ``backlash_16s``: 16 s, 3 deg of backlash hidden in the rig written with ``backlash_deg: 0``;
* ``two_4s``: 4 s, a 3 ms sensor delay on the load angle and Coulomb friction at the motor
  (0.02 N m);
* ``emps_library``: the EMPS training run (real measurements, ``data/emps/DATA_EMPS.mat`` through
  ``gearbench import emps``), closed loop, from the bare plant with its mass free and no
  calibration, as ``studies.emps``'s whole-library ladder;
* ``twomass``: the real two-mass bench (``data/twomass``), its record A's second period, from the
  bare plant with the rotor's inertia free, as ``studies.twomass`` diagnoses it (windows of 0.1 s
  resetting angles and speeds, the effects that bench can have, four rungs at most), but with the
  command's default workers (all cores) where the study uses one.

Each record's row keeps the diagnosis' own ``timing`` block (per stage and per candidate: wall
time, replays, solver steps, fits).  Targets: 60 s for each 16 s record, 30 s for the 4 s one, 300 s for EMPS,
60 s for the two-mass bench (issue 38).  ``--python`` and ``--pythonpath``
run the same commands with another interpreter or another checkout's ``gearbench`` (the
figure of the code before a change, measured in the same session); ``--label`` names that
run in ``results/bench.json`` (``ladder_<label>``).  A diagnosis still running after
``--timeout`` seconds is stopped and recorded as such.  ``--only`` measures some records again
and keeps the stored row's others; each record says when it was measured and at which commit.

    python benchmarks/bench_ladder.py                   # this checkout -> bench.json "ladder"
    python benchmarks/bench_ladder.py --pythonpath ../before --label before
    python benchmarks/bench_ladder.py --only two_4s     # one record again, the others kept
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

REPO = Path(__file__).resolve().parents[1]
PLANTS = REPO / "experiments" / "plants"
TARGET_S = {"16": 60.0, "4": 30.0, "emps": 300.0, "twomass": 60.0}

RECORDS = {  # name -> (plant the record is made from and diagnose is given, duration s, hidden effects)
    "none_16s": ("bench_rig.yaml", 16, []),
    "one_16s": ("bench_rig.yaml", 16, ["coulomb_friction location=load torque=0.6"]),
    "two_16s": ("bench_rig.yaml", 16,
                ["load_spring stiffness=1.5 rest_angle_deg=5", "coulomb_friction location=load torque=0.6"]),
    "backlash_16s": ("bench_rig_rigid.yaml", 16, ["backlash backlash_deg=3"]),
    "two_4s": ("bench_rig.yaml", 4,
               ["sensor_delay signal=load_angle_deg delay=0.003", "coulomb_friction location=motor torque=0.02"]),
}
SEED = 3
EMPS = {  # name -> (plant, the benchmark's file, what diagnose is given besides)
    "emps_library": ("emps_bare.yaml", REPO / "data" / "emps" / "DATA_EMPS.mat",
                     ["--controller", str(REPO / "experiments" / "controllers" / "emps.yaml"),
                      "--free", "leadscrew.mass", "--no-calibrate"]),
}
TWOMASS = "twomass"  # studies.twomass's diagnosis (its constants: make_record, run_one)


def twomass_study():
    """``studies.twomass`` (at the repository's root, beside this folder)."""
    sys.path.insert(0, str(REPO))
    from studies import twomass
    return twomass


def gearbench(python: str, pythonpath: str | None) -> tuple[list[str], dict]:
    """The command that runs gearbench and its environment.  Run it from a folder without a
    ``gearbench`` package (``NEUTRAL``): ``python -c`` puts its working folder first on the path,
    which with this checkout as the folder ran this checkout's gearbench whatever ``--pythonpath``
    said (so the 2026-11-26 "before" figures were this code's too)."""
    env = dict(os.environ)
    if pythonpath:
        env["PYTHONPATH"] = str(Path(pythonpath).resolve())
    return [python, "-c", "from gearbench.cli import main; main()"], env


NEUTRAL = Path(tempfile.gettempdir())


def check_imported(python: str, pythonpath: str | None) -> None:
    """The commands must import the gearbench being measured: ``pythonpath``'s, else this checkout's."""
    env = gearbench(python, pythonpath)[1]
    found = Path(subprocess.run([python, "-c", "import gearbench; print(gearbench.__file__)"], env=env,
                                capture_output=True, text=True, check=True, cwd=NEUTRAL).stdout.strip()).parent
    wanted = Path(pythonpath).resolve() if pythonpath else REPO
    if found.parent != wanted:
        raise click.ClickException(f"the commands import gearbench from {found}, not from {wanted}")


def make_record(name: str, folder: Path) -> Path:
    out = folder / f"{name}.csv"
    cmd, env = gearbench(sys.executable, None)
    if name in EMPS:
        subprocess.run(cmd + ["import", "emps", str(EMPS[name][1]), "-o", str(out)], check=True, env=env,
                       capture_output=True, cwd=NEUTRAL)
        return out
    if name == TWOMASS:
        import pandas as pd
        tm = twomass_study()
        m = tm.cut(tm.load_records()["A"], tm.FIT_SLICE_S, "record A")
        pd.DataFrame({"time_s": m.time_s, m.input_name: m.input, **m.signals}).to_csv(out, index=False)
        return out
    src, duration, hidden = RECORDS[name]
    args = cmd + ["synth", str(PLANTS / src), "--excitation", "mixed", "--duration", str(duration),
                  "--seed", str(SEED), "-o", str(out)]
    for e in hidden:
        args += ["--effect", e]
    subprocess.run(args, check=True, env=env, capture_output=True, cwd=NEUTRAL)
    return out


def run_one(name: str, data: Path, python: str, pythonpath: str | None, timeout: float, out: Path) -> dict:
    if name in EMPS:
        plant, _, extra = EMPS[name]
        target, hidden = TARGET_S["emps"], []
    elif name == TWOMASS:
        tm = twomass_study()
        plant, target, hidden = tm.BARE_PLANT, TARGET_S["twomass"], []
        extra = ["--window", str(tm.WINDOW_S), "--reset-speeds", "--only", ",".join(tm.CANDIDATES),
                 "--max-steps", str(tm.MAX_STEPS)] + [a for key in tm.FREE_PLANT for a in ("--free", key)]
    else:
        plant, duration, hidden = RECORDS[name]
        target, extra = TARGET_S[str(duration)], []
    cmd, env = gearbench(python, pythonpath)
    args = cmd + ["diagnose", str(PLANTS / plant), str(data), "--json", "--results", str(out)] + extra
    t0 = time.perf_counter()
    try:
        p = subprocess.run(args, env=env, capture_output=True, text=True, timeout=timeout, cwd=NEUTRAL)
    except subprocess.TimeoutExpired:
        return {"wall_s": None, "status": f"stopped after {timeout:g} s", "hidden": hidden}
    wall = time.perf_counter() - t0
    row = {"wall_s": wall, "target_s": target, "hidden": hidden, "exit": p.returncode}
    if p.returncode != 0:
        row["status"] = "failed"
        row["stderr"] = p.stderr[-2000:]
        return row
    j = json.loads(p.stdout)
    row.update(status="ok", verdict=j["verdict"], noise_floor=j["noise_floor"], reason=j["reason"],
               stopped=j.get("stopped"), timing=j.get("timing"),
               ladder=[{"effect": s["effect"], "action": s.get("action", "add"), "options": s.get("options", {}),
                        "params": s["params"], "stderr": s["stderr"], "error": s["error"]} for s in j["ladder"]])
    return row


@click.command()
@click.option("--python", default=sys.executable, show_default=True, help="Interpreter that runs gearbench.")
@click.option("--pythonpath", default=None, help="A checkout whose gearbench to run instead (PYTHONPATH).")
@click.option("--label", default="", help="Stored as ladder_<label> in results/bench.json (default: ladder).")
@click.option("--only", "names", multiple=True, type=click.Choice(sorted(RECORDS) + sorted(EMPS) + [TWOMASS]),
              help="Only these records.")
@click.option("--timeout", type=float, default=900.0, show_default=True, help="Stop a diagnosis after, s.")
def main(python, pythonpath, label, names, timeout):
    from bench_store import commit_of, merge, stored
    check_imported(python, pythonpath)
    key = f"ladder_{label}" if label else "ladder"
    commit = commit_of(Path(pythonpath).resolve() if pythonpath else REPO)
    # --only measures some records again: the others' rows stay as they were (each says when and what)
    rows = stored(key, "records") if names else {}
    names = names or tuple(RECORDS) + tuple(EMPS) + (TWOMASS,)
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for name in names:
            data = make_record(name, tmp)
            rows[name] = r = run_one(name, data, python, pythonpath, timeout, tmp / "results")
            r["measured"], r["commit"] = time.strftime("%Y-%m-%d %H:%M"), commit
            print(f"{name}: {r['status']}, {r['wall_s'] and round(r['wall_s'], 1)} s; verdict {r.get('verdict')}; "
                  + " -> ".join(f"{'-' if s['action'] == 'remove' else ''}{s['effect']} {s['error']:.4g}"
                                for s in r.get("ladder", [])), flush=True)
    merge({key: {
        "measured": time.strftime("%Y-%m-%d %H:%M"), "cpu_count": os.cpu_count(),
        "commit": commit, "other_checkout": bool(pythonpath), "records": rows}})


if __name__ == "__main__":
    main()
