"""Parameter sweeps: grids of an experiment's settings, solved on all cores or a Dask cluster.

A sweep takes an experiment file and one or more ``--param KEY=VALUES``.  The
grid is the Cartesian product of the values; each grid point edits the parsed
experiment (a plain dict) and is validated by the ordinary file validators
before anything is solved.  A *point* is one simulation: one grid point x one
run of the edited experiment (profile x controller x shift), so the thesis's
gain scan (5 gains x 3 profiles) has 15 points.

Keys are dotted paths into the experiment YAML:

* ``duration_s``, ``solver.rtol``, ``plant.gear.backlash_deg`` (a plant file
  named by the experiment is read and inlined first), ``profiles`` ...;
* ``controller.KEY`` sets ``KEY`` on **every** controller of the experiment's
  ``controllers`` list (a key a controller kind does not have is an error,
  so sweep ``controllers[1].kp`` to reach one controller of several);
* ``controller.shift`` (or ``shift``) sets the experiment's ``shift`` list to
  the one value (``off``/``on``).

Where a key's current value is a list and the swept value is not, the value
replaces the list by ``[value]``.

Values: ``0.5,5,50`` (YAML scalars: numbers, ``on``/``off``, words),
``linspace(a,b,n)``, ``logspace(a,b,n)`` (``n`` values ``10**a ... 10**b``,
numpy's convention), ``geomspace(a,b,n)`` (``a ... b`` geometrically), or a
mix (``0,linspace(1,2,3)``).  Generated values are rounded to 12 significant
digits so the same text always makes the same grid.

Results go to ``RESULTS/<experiment name>/sweep.csv``, one line per finished
point, appended and fsync'ed as it finishes (:class:`SweepStore`).  A point's
identity is :func:`point_key`: a hash of its parameter values, its run
(profile with its segments, controller, shift), the parsed experiment (plant
inlined, so comments do not count) and the source of the physics
(:func:`gearbench.physics_hash.physics_digest`, which keys numba's cache too),
so running the same sweep again skips every finished point and a sweep killed
at any moment resumes where it stopped.
"""
from __future__ import annotations

import copy
import csv
import hashlib
import io
import itertools
import json
import math
import os
import re
import time
import weakref
from concurrent.futures import as_completed
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Callable, Iterable, Mapping, Sequence

import numpy as np

from . import layout as L
from .control.controllers import Controller
from .errors import ConfigError, SchedulerError, SweepError
from .experiment.files import Experiment, _resolve, experiment_from_dict, is_file, parse_yaml, read_yaml
from .physics_hash import physics_digest
from .simulate import failure_message, simulate
from .workers import (dask_client, default_workers,  # noqa: F401 - default_workers re-exported
                      process_pool, worker_count)


# ------------------------------------------------------------------ grid parsing

_KEY = re.compile(r"[A-Za-z_]\w*(\[\d+\])?(\.[A-Za-z_]\w*(\[\d+\])?)*")
_CALL = re.compile(r"(\w+)\((.*)\)", re.S)
MAX_GRID = 100_000
"""Most grid points a sweep takes (each is at least one simulation; 100,000 is days of work)."""
SPACES = {
    "linspace": "n values evenly spaced from a to b",
    "logspace": "n values 10**a ... 10**b, evenly spaced in log10 (numpy's convention)",
    "geomspace": "n values from a to b, evenly spaced in log (a, b > 0)",
}


@dataclass(frozen=True)
class Param:
    """One swept key and its values, in the order given."""
    key: str
    values: tuple


def _round(x: float) -> float:
    """12 significant digits: ``linspace(0,1,11)`` gives 0.3, not 0.30000000000000004."""
    return float(f"{x:.12g}")


def _split_top(text: str) -> list[str]:
    """Split at commas outside parentheses."""
    parts, depth, cur = [], 0, []
    for ch in text:
        if ch == "(":
            depth += 1
        elif ch == ")":
            depth -= 1
            if depth < 0:
                raise SweepError(f"unbalanced ')' in {text!r}")
        if ch == "," and depth == 0:
            parts.append("".join(cur))
            cur = []
        else:
            cur.append(ch)
    if depth:
        raise SweepError(f"unbalanced '(' in {text!r}")
    parts.append("".join(cur))
    return [p.strip() for p in parts]


def _space(name: str, args: str, where: str) -> list[float]:
    usage = f"{name}(a,b,n): {SPACES.get(name, '')}"
    if name not in SPACES:
        raise SweepError(f"{where}: unknown function {name!r}; use one of "
                         + "; ".join(f"{k}(a,b,n) = {v}" for k, v in SPACES.items()))
    items = [a.strip() for a in args.split(",")]
    if len(items) != 3:
        raise SweepError(f"{where}: {name} takes 3 arguments, got {len(items)}: {usage}")
    try:
        a, b, n = (float(x) for x in items)
    except ValueError:
        raise SweepError(f"{where}: {name} arguments must be numbers, got {args!r}: {usage}") from None
    if not (math.isfinite(a) and math.isfinite(b)) or not n.is_integer() or not 1 <= n <= MAX_GRID:
        raise SweepError(f"{where}: {name} needs finite a, b and a whole number n from 1 to "
                         f"{MAX_GRID:,}, got {args!r}")
    if name == "geomspace" and (a <= 0 or b <= 0):
        raise SweepError(f"{where}: geomspace needs a, b > 0, got {args!r}")
    with np.errstate(over="ignore", invalid="ignore"):  # an overflow is reported below, as an error
        values = getattr(np, name)(a, b, int(n))
    if not np.all(np.isfinite(values)):
        raise SweepError(f"{where}: {name}({args}) overflows")
    return [_round(float(v)) for v in values]


def parse_values(spec: str, where: str = "--param") -> tuple:
    """Values of one ``--param`` (see the module docstring); raise :class:`SweepError`."""
    if not spec.strip():
        raise SweepError(f"{where}: no values after '='")
    out: list = []
    for item in _split_top(spec):
        if not item:
            raise SweepError(f"{where}: empty value in {spec!r} (two commas in a row?)")
        call = _CALL.fullmatch(item)
        if call:
            out.extend(_space(call.group(1), call.group(2), where))
            continue
        if "(" in item or ")" in item:
            raise SweepError(f"{where}: cannot read {item!r}; write a list (0.5,5,50) or "
                             f"linspace(a,b,n) / logspace(a,b,n) / geomspace(a,b,n)")
        try:
            value = parse_yaml(item, where)
        except ConfigError:
            value = None
        if not (isinstance(value, (bool, int, float, str))):
            raise SweepError(f"{where}: {item!r} is not a number, boolean (on/off) or word")
        out.append(value)
    seen = set()
    for v in out:
        k = json.dumps(_canonical(v))
        if k in seen:
            raise SweepError(f"{where}: the value {v!r} is given twice")
        seen.add(k)
    return tuple(out)


def parse_param(text: str) -> Param:
    """``"controller.kp=0.5,5,50"`` -> ``Param("controller.kp", (0.5, 5, 50))``."""
    key, sep, spec = text.partition("=")
    key = key.strip()
    if not sep:
        raise SweepError(f"--param {text!r}: expected KEY=VALUES, e.g. controller.kp=0.5,5,50")
    if not _KEY.fullmatch(key):
        raise SweepError(f"--param {text!r}: {key!r} is not a dotted key path "
                         f"(like controller.kp, plant.gear.backlash_deg or controllers[1].kp)")
    return Param(key, parse_values(spec, f"--param {key}"))


def parse_params(texts: Iterable[str]) -> list[Param]:
    params = [parse_param(t) for t in texts]
    if not params:
        raise SweepError("give at least one --param KEY=VALUES")
    keys = [p.key for p in params]
    for k in set(keys):
        if keys.count(k) > 1:
            raise SweepError(f"--param {k} is given twice; give its values in one --param")
    return params


# --------------------------------------------------------- editing the experiment

def _segments(key: str) -> list[str | int]:
    out: list[str | int] = []
    for part in key.split("."):
        m = re.fullmatch(r"(\w+)(?:\[(\d+)\])?", part)
        out.append(m.group(1))
        if m.group(2) is not None:
            out.append(int(m.group(2)))
    return out


def _set(d: Any, path: list, value: Any, full: str) -> None:
    """Set ``d[path]`` (creating mappings on the way); a list target becomes ``[value]``."""
    node = d
    for i, seg in enumerate(path[:-1]):
        nxt = path[i + 1]
        if isinstance(seg, int):
            if not isinstance(node, list) or seg >= len(node):
                raise SweepError(f"--param {full}: there is no item [{seg}] here "
                                 f"(the list has {len(node) if isinstance(node, list) else 0})")
            node = node[seg]
            continue
        if not isinstance(node, dict):
            raise SweepError(f"--param {full}: {seg!r} is not inside a mapping")
        if seg not in node or node[seg] is None:
            node[seg] = [] if isinstance(nxt, int) else {}
        node = node[seg]
    last = path[-1]
    if isinstance(last, int):
        if not isinstance(node, list) or last >= len(node):
            raise SweepError(f"--param {full}: there is no item [{last}] to set")
        node[last] = value
        return
    if not isinstance(node, dict):
        raise SweepError(f"--param {full}: {last!r} is not inside a mapping")
    node[last] = [value] if isinstance(node.get(last), list) and not isinstance(value, list) else value


def apply_point(raw: dict, values: Mapping[str, Any]) -> dict:
    """A copy of the parsed experiment ``raw`` with the swept ``values`` set (module docstring)."""
    d = copy.deepcopy(raw)
    for key, value in values.items():
        path = _segments(key)
        if path[0] == "controller":
            if path[1:] == ["shift"]:
                d["shift"] = [value]
                continue
            ctrls = d.get("controllers")
            if isinstance(ctrls, dict):
                ctrls = d["controllers"] = [ctrls]
            if not isinstance(ctrls, list) or not ctrls:
                raise SweepError(f"--param {key}: the experiment has no controllers list")
            for item in ctrls:
                _set(item, path[1:], value, key)
        else:
            _set(d, path, value, key)
    return d


def inline_plant(raw: dict, base_dir: Path) -> dict:
    """``raw`` with a plant file reference replaced by the file's mapping (so that
    ``plant.*`` keys can be swept and the plant's content enters the point keys)."""
    ref = raw.get("plant") if isinstance(raw, dict) else None
    if isinstance(ref, str) and ref.strip():
        path = _resolve(base_dir, ref)
        if is_file(path):
            plant = read_yaml(path, ref)
            if isinstance(plant, dict):
                plant.setdefault("name", path.stem)
                return dict(raw, plant=plant)
    return raw


# ------------------------------------------------------------------- point keys

def _canonical(value: Any) -> Any:
    """JSON-ready, type-stable: numbers as floats (5 and 5.0 are one point), tuples as lists."""
    if isinstance(value, bool) or value is None or isinstance(value, str):
        return value
    if isinstance(value, (int, float, np.integer, np.floating)):
        return float(value)
    if isinstance(value, Mapping):
        return {str(k): _canonical(v) for k, v in value.items()}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [_canonical(v) for v in value]
    return repr(value)


def canonical_json(value: Any) -> str:
    return json.dumps(_canonical(value), sort_keys=True, separators=(",", ":"))


def point_key(experiment_hash: str, params: Mapping[str, Any], run: Mapping[str, Any]) -> str:
    """sha256 (first 20 hex digits) of the canonical JSON of the point's parameter values,
    its run (profile + its segments, controller index, shift) and ``experiment_hash``."""
    text = canonical_json({"experiment": experiment_hash, "params": dict(params), "run": dict(run)})
    return hashlib.sha256(text.encode()).hexdigest()[:20]


# ------------------------------------------------------------------------ plan

@dataclass(frozen=True)
class Point:
    """One simulation of the sweep; ``job`` is what :func:`solve_point` gets."""
    key: str
    index: int
    params: dict
    profile: str
    controller: Controller
    controller_index: int
    shift: bool
    job: tuple = field(repr=False)


@dataclass(frozen=True)
class SweepPlan:
    """A validated sweep: its name, its swept parameters and every point, in grid order."""
    name: str
    experiment: Path
    params: tuple[Param, ...]
    points: tuple[Point, ...]
    experiment_hash: str

    @property
    def columns(self) -> list[str]:
        return ["key", *[p.key for p in self.params], *RESULT_COLUMNS]


def plan_sweep(experiment: str | Path, params: Sequence[Param]) -> SweepPlan:
    """Read ``experiment``, build every grid point and validate all of them up front.

    Raises
    ------
    ConfigError
        Every problem of every grid point, each line prefixed with the point's
        values (``with controller.kp=-1: controllers[0].kp must be a positive number
        in V/deg, got -1``), and of the experiment file itself.
    SweepError
        A key that cannot be applied (no such list item ...).
    """
    from .runner import load_profiles

    path = Path(experiment)
    base_dir = path.parent
    raw = read_yaml(path)
    experiment_from_dict(raw, base_dir=base_dir, name=path.stem, label=path.name)  # the file itself
    raw = inline_plant(raw, base_dir)
    size = math.prod(len(p.values) for p in params)
    if size > MAX_GRID:  # refused before the grid is built: it would not fit in memory
        raise SweepError(f"the grid has {size:,} points ({' x '.join(str(len(p.values)) for p in params)}); "
                         f"a sweep takes at most {MAX_GRID:,}")
    grid = list(itertools.product(*[p.values for p in params]))
    problems: list[tuple[str, str]] = []
    built: list[tuple[dict, Experiment]] = []
    for combo in grid:
        values = dict(zip([p.key for p in params], combo))
        edited = apply_point(raw, values)
        label = ", ".join(f"{k}={_show(v)}" for k, v in values.items())
        try:
            exp = experiment_from_dict(edited, base_dir=base_dir, name=path.stem, label=path.name)
        except ConfigError as exc:
            problems += [(f, f"with {label}: {t}") for f, t in exc.entries]
            continue
        built.append((values, exp))
    if problems:
        multi = [p.key for p in params if p.key.startswith("controller.") and p.key != "controller.shift"]
        if multi and isinstance(raw.get("controllers"), list) and len(raw["controllers"]) > 1:
            problems.append((path.name, f"note: {multi[0]} applies to every controller of the "
                                        f"list; use controllers[i].KEY to sweep one of them"))
        seen: list[tuple[str, str]] = []
        for p in problems:
            if p not in seen:
                seen.append(p)
        raise ConfigError(path.name, seen)

    name = built[0][1].name
    physics = physics_digest()
    exp_hash = hashlib.sha256((canonical_json(raw) + physics).encode()).hexdigest()[:16]
    points: list[Point] = []
    for values, exp in built:
        profiles = load_profiles(exp)
        for prof in exp.profiles:
            seg = profiles[prof].segments()
            for ci, ctrl in enumerate(exp.controllers):
                for shift in exp.shifts:
                    run = {"profile": prof, "segments": [seg.t, seg.v, seg.s],
                           "controller_index": ci, "shift": shift}
                    c = replace(ctrl, shift=shift, shift_deg=exp.shift_deg)
                    job = (exp.plant, c, seg, exp.duration_s, exp.solver, exp.initial_delta)
                    points.append(Point(point_key(exp_hash, values, run), len(points), values,
                                        prof, c, ci, shift, job))
    keys = [p.key for p in points]
    if len(set(keys)) != len(keys):  # e.g. profiles: [profile1, profile1]
        raise SweepError("two points of this sweep are the same run (a profile or controller "
                         "listed twice?)")
    return SweepPlan(name, path, tuple(params), tuple(points), exp_hash)


def _show(v: Any) -> str:
    if isinstance(v, bool):
        return "on" if v else "off"
    if isinstance(v, float):
        return repr(v)
    return str(v)


def controller_label(c: Controller) -> str:
    """``p(kp=50)``, ``pi(kp=50,ki=0.005)``, ``bang_bang(band_deg=0.25)``."""
    if c.kind == "bang_bang":
        return f"bang_bang(band_deg={c.band_deg:g})"
    parts = [f"kp={c.kp:g}"]
    if c.kind in ("pi", "pid"):
        parts.append(f"ki={c.ki:g}")
    if c.kind == "pid":
        parts += [f"kd={c.kd:g}", f"tf={c.derivative_filter_s:g}"]
    return f"{c.kind}({','.join(parts)})"


# -------------------------------------------------------------------- solving

RESULT_COLUMNS = ["profile", "controller", "shift", "iae_deg_s", "rms_deg", "max_deg",
                  "saturated_s", "saturated_fraction", "impacts", "switchings", "steps",
                  "linear_stable", "status", "message", "wall_s"]
"""Per point: scores (deg s, deg, s, counts), ``linear_stable`` (yes/no: the engaged,
unsaturated loop's eigenvalues; empty for bang-bang), ``status`` (``ok``, the solver's
failure, or ``error``), ``message`` (why it failed) and ``wall_s`` (solve time, s)."""


def solve_point(job: tuple) -> dict:
    """Solve one point; never raises: a failed run or an exception becomes a status + message.

    Module-level and free of global state so that a process pool or a Dask worker
    runs exactly the same call as the serial loop (identical numbers).
    """
    plant, ctrl, segments, duration, solver, delta0 = job
    t0 = time.perf_counter()
    out: dict = {"linear_stable": ""}
    try:
        if ctrl.kind in ("p", "pi", "pid"):
            from .control.stability import linear_stable
            out["linear_stable"] = "yes" if linear_stable(
                plant, ctrl.kind, ctrl.kp, ctrl.ki, ctrl.kd, ctrl.derivative_filter_s) else "no"
        res = simulate(plant, ctrl, segments, duration, solver, delta0=delta0)
        out.update(res.scores())
        out["saturated_s"] = float(res.stats[L.S_T_SAT])
        out["status"] = "ok" if res.ok else res.status
        out["message"] = "" if res.ok else failure_message(res, plant.name)
    except Exception as exc:  # noqa: BLE001 - recorded with the point, the sweep goes on
        out.update(status="error", message=f"{type(exc).__name__}: {exc}")
    out["wall_s"] = time.perf_counter() - t0
    return out


def _cell(v: Any) -> str:
    if v is None:
        return ""
    if isinstance(v, bool):
        return "on" if v else "off"
    if isinstance(v, (float, np.floating)):
        return repr(float(v))  # shortest text that reads back to the same float
    if isinstance(v, np.integer):
        return str(int(v))
    return " | ".join(str(v).splitlines())  # one record = one physical line


def make_row(point: Point, result: Mapping[str, Any]) -> dict:
    row = {"key": point.key, **{k: _cell(v) for k, v in point.params.items()},
           "profile": point.profile, "controller": controller_label(point.controller),
           "shift": _cell(point.shift)}
    for col in RESULT_COLUMNS[3:]:
        row[col] = _cell(result.get(col))
    return row


# ---------------------------------------------------------------------- store

class SweepStore:
    """Append-only CSV of finished points; safe against a kill at any moment.

    * The header is written once, through a temporary file and a rename.
    * Each finished point is one line, written with a single ``write`` on an
      ``O_APPEND`` descriptor and ``fsync``'ed before the next one is reported.
    * On opening, a last line without its newline (a write cut short by a crash
      or a full disk) is cut off, and lines with the wrong number of fields are
      ignored: neither is a finished point, and the point is solved again.
    * An exclusive ``flock`` keeps two sweeps from writing one file at once.  The
      kernel drops it when the last descriptor of the open file goes, so a lock
      whose holder died is never stale.  A forked child would hold that
      descriptor too (and keep the lock past the sweep's death): children close
      it at the fork (:func:`_close_stores_in_child`), and the pool's workers end
      with their parent anyway (``gearbench.workers``).
    """

    def __init__(self, path: str | Path, columns: Sequence[str]):
        self.path = Path(path)
        self.columns = list(columns)
        self.fd: int | None = None
        self.repaired_bytes = 0
        self.skipped_lines = 0

    def open(self) -> dict[str, dict]:
        """Lock the file (creating it with its header) and return the stored rows by key."""
        import fcntl

        from .report.io import write_text_atomic

        if not self.path.exists():
            write_text_atomic(self.path, self._line(self.columns))
        self.fd = os.open(self.path, os.O_RDWR | os.O_APPEND | os.O_CLOEXEC)
        _OPEN_STORES.add(self)
        try:
            fcntl.flock(self.fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            self.close()
            raise SweepError(f"{self.path} is being written by another sweep") from None
        with open(self.path, "rb") as fh:
            data = fh.read()
        if data and not data.endswith(b"\n"):
            cut = data.rfind(b"\n") + 1
            self.repaired_bytes = len(data) - cut
            os.ftruncate(self.fd, cut)
            os.fsync(self.fd)
            data = data[:cut]
        lines = data.decode("utf-8").splitlines()
        header = next(csv.reader([lines[0]])) if lines else []
        if header != self.columns:
            self.close()
            raise SweepError(
                f"{self.path} holds a sweep with columns {', '.join(header[1:-len(RESULT_COLUMNS)] or header)}; "
                f"this sweep has {', '.join(self.columns[1:-len(RESULT_COLUMNS)])}: "
                f"use another --results folder, or --fresh to start this file again")
        rows: dict[str, dict] = {}
        for line in lines[1:]:
            fields = next(csv.reader([line]), [])
            if len(fields) != len(self.columns) or not fields[0]:
                self.skipped_lines += 1
                continue
            rows.setdefault(fields[0], dict(zip(self.columns, fields)))
        return rows

    def _line(self, fields: Sequence[str]) -> str:
        buf = io.StringIO()
        csv.writer(buf, lineterminator="\n").writerow(fields)
        return buf.getvalue()

    def append(self, row: Mapping[str, str]) -> None:
        """Store one finished point durably (one ``write``, then ``fsync``)."""
        data = self._line([row.get(c, "") for c in self.columns]).encode("utf-8")
        n = os.write(self.fd, data)
        if n != len(data):  # a short write to a regular file: disk full
            raise OSError(f"short write to {self.path} ({n} of {len(data)} bytes)")
        os.fsync(self.fd)

    def close(self) -> None:
        if self.fd is not None:
            os.close(self.fd)  # also releases the lock
            self.fd = None
        _OPEN_STORES.discard(self)


_OPEN_STORES: "weakref.WeakSet[SweepStore]" = weakref.WeakSet()


def _close_stores_in_child() -> None:
    """In a forked child: drop the inherited store descriptors (the parent keeps its lock)."""
    for store in list(_OPEN_STORES):
        if store.fd is not None:
            try:
                os.close(store.fd)  # the child's copy only: the flock stays with the parent's
            except OSError:
                pass
            store.fd = None
    _OPEN_STORES.clear()


os.register_at_fork(after_in_child=_close_stores_in_child)


# ------------------------------------------------------------------ execution

@dataclass
class SweepOutcome:
    """What a sweep did: rows of the plan's points in grid order (None: not finished),
    how many were solved now, taken from the store, or lost to the cluster."""
    plan: SweepPlan
    csv_path: Path
    rows: list[dict | None]
    solved: int = 0
    reused: int = 0
    lost: list[str] = field(default_factory=list)
    interrupted: bool = False


def _local(points: list[Point], workers: int) -> Iterable[tuple[Point, dict]]:
    if workers <= 1:
        for p in points:
            yield p, solve_point(p.job)
        return
    # Load the compiled core here once (a very short run) so that the forked workers
    # inherit it instead of each loading it from the disk cache again.
    plant, ctrl, segments, _, solver, delta0 = points[0].job
    try:
        simulate(plant, ctrl, segments, 1e-3, replace(solver, output_dt_s=1e-3), delta0=delta0)
    except Exception:  # noqa: BLE001 - only a warm-up; the point itself reports its failure
        pass
    # the workers end with this process (gearbench.workers): a sweep killed with SIGKILL
    # leaves none behind holding the store's lock
    with process_pool(workers) as pool:
        futures = {pool.submit(solve_point, p.job): p for p in points}
        for fut in as_completed(futures):
            yield futures[fut], fut.result()


def _dask(points: list[Point], address: str, lost: list[str]) -> Iterable[tuple[Point, dict]]:
    try:
        client = dask_client(address)
    except SchedulerError as exc:
        raise SweepError(str(exc)) from None
    from distributed import as_completed as dask_completed
    try:
        futures = client.map(solve_point, [p.job for p in points],
                             key=[f"gearbench-{p.key}" for p in points], retries=1)
        by_key = {f.key: p for f, p in zip(futures, points)}
        try:
            for fut in dask_completed(futures, loop=client.loop):
                point = by_key[fut.key]
                try:
                    result = fut.result()
                except Exception as exc:  # noqa: BLE001 - a lost worker: not a result, retry next time
                    lost.append(f"{point.key}: {type(exc).__name__}: {exc}")
                    continue
                yield point, result
        finally:
            client.cancel(futures)
    finally:
        client.close()


def run_sweep(plan: SweepPlan, results_dir: str | Path = "results", *, workers: int | None = None,
              scheduler: str | None = None, fresh: bool = False,
              on_start: Callable[[int, int], None] | None = None,
              on_done: Callable[[Point, dict], None] | None = None) -> SweepOutcome:
    """Solve the plan's points that the store does not hold yet, storing each as it finishes.

    Parameters
    ----------
    plan : SweepPlan
    results_dir : str or Path
        The store is ``results_dir/<plan.name>/sweep.csv``.
    workers : int, optional
        Local processes (default: every core this process may use); 1 solves in
        this process.  Ignored with ``scheduler``.
    scheduler : str, optional
        Address of a running Dask scheduler (``tcp://HOST:PORT``); the points
        run there through ``distributed.Client.map``.
    fresh : bool
        Delete the store first and solve everything again.
    on_start : callable, optional
        ``on_start(pending, stored)`` before solving.
    on_done : callable, optional
        ``on_done(point, row)`` after each point is stored.
    """
    csv_path = Path(results_dir) / plan.name / "sweep.csv"
    if fresh and csv_path.exists():
        csv_path.unlink()
    store = SweepStore(csv_path, plan.columns)
    stored = store.open()
    outcome = SweepOutcome(plan, csv_path, [stored.get(p.key) for p in plan.points])
    pending = [p for p, row in zip(plan.points, outcome.rows) if row is None]
    outcome.reused = len(plan.points) - len(pending)
    if on_start is not None:
        on_start(len(pending), outcome.reused)
    try:
        if pending:
            if scheduler:
                stream = _dask(pending, scheduler, outcome.lost)
            else:
                stream = _local(pending, worker_count(workers, len(pending)))
            for point, result in stream:
                row = make_row(point, result)
                store.append(row)
                outcome.rows[point.index] = row
                outcome.solved += 1
                if on_done is not None:
                    on_done(point, row)
    except KeyboardInterrupt:
        outcome.interrupted = True
    except BrokenProcessPool as exc:
        raise SweepError(f"a worker process died ({exc}); the {outcome.solved} points finished "
                         f"so far are stored in {csv_path}: run the same sweep again to resume") from None
    finally:
        store.close()
    return outcome
