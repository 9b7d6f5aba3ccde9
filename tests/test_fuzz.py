"""Fuzz: malformed plant, experiment, profile, controller and measurement files, sweep
parameters and Python calls give the project's named error or a valid result, never
another exception.

The inputs are structured around the real schemas: a valid document of the repository
(a plant, an experiment, a profile, a controller file, a measurement record) is mutated
-- a value at any key path replaced by a wrong type (list, mapping, string, null, NaN,
infinities, huge and negative numbers, dates, bytes), keys removed, unknown keys added,
values wrapped in lists or mappings -- and then, as text, cut short, given binary bytes,
a NUL, a deep nesting, a self-referencing alias, another encoding; a record also gets
another delimiter, short and long rows, NaN and text cells, unsorted or repeated times
and renamed, repeated or missing columns.

Each input must either load into a checked object that is usable (its parameter vector
packs finite, a record's times increase) or raise the named error of its kind --
:class:`ConfigError` whose every problem names a file, :class:`MeasurementError` or
:class:`ProfileError` naming the file, :class:`SweepError` -- with a non-empty message.

The default run tries a few hundred inputs (``FAST`` examples per target); ``pytest
--runslow`` (``make test-all``) runs ``SLOW`` per target, over 10,000 in all, and prints
how many inputs gave a named error and how many a valid result.
"""
from __future__ import annotations

import collections
import copy
import math
import re
import shutil
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, given, settings, strategies as st

from gearbench import layout as L
from gearbench.control.controllers import Controller
from gearbench.experiment.controller_file import load_controller
from gearbench.experiment.files import ConfigError, load_experiment, load_plant
from gearbench.measure.data import Measurement, MeasurementError, read_measurement
from gearbench.plant.components import Plant
from gearbench.plant.pack import pack_plant, tolerance_scales
from gearbench.profiles import PROFILE_DIR, Profile, ProfileError, load_profile
from gearbench.runner import load_profiles
from gearbench.simulate import pack
from gearbench.sweep import SweepError, parse_params, plan_sweep

REPO = Path(__file__).resolve().parents[1]
PLANTS = sorted((REPO / "experiments" / "plants").glob("*.yaml"))
EXPERIMENTS = [REPO / "experiments" / n for n in ("table1.yaml", "compensators.yaml", "gain_scan.yaml",
                                                   "table1_translational.yaml")]
PROFILES = sorted(PROFILE_DIR.glob("*.yaml"))
CONTROLLER_FILE = REPO / "experiments" / "controllers" / "emps.yaml"

FAST = 60     # examples per target in the default run (7 targets: ~420 inputs)
SLOW = 1700   # per target with --runslow (7 targets: ~11,900 inputs)
COMMON = dict(deadline=None, suppress_health_check=list(HealthCheck), derandomize=False)


def fast(f):
    return settings(max_examples=FAST, **COMMON)(f)


def slow_settings():
    return settings(max_examples=SLOW, **COMMON)


def read_doc(path: Path):
    return yaml.safe_load(path.read_text())


# ---------------------------------------------------------------- the mutations

# every key of every schema, so that a key lands where it does not belong
VOCAB = sorted({
    "name", "description", "drive", "motor", "gear", "load", "shaft", "leadscrew", "effects", "type",
    "resistance", "inductance", "torque_constant", "back_emf_constant", "inertia", "damping",
    "max_voltage", "max_drive", "ratio", "backlash_deg", "mesh_stiffness", "mesh_damping",
    "contact_law", "rigid", "stiffness", "pinion_inertia", "lead_mm", "mass", "location",
    "plant", "duration_s", "solver", "profiles", "controllers", "shift", "compensator", "shift_deg",
    "initial_delta_deg", "reference", "profile_scale", "method", "rtol", "max_step_s", "output_dt_s",
    "max_steps", "kind", "kp", "ki", "kd", "band_deg", "derivative_filter_s", "segments", "sum",
    "start_s", "value_deg", "slope_deg_per_s", "kp_per_s", "kv_V_s_per_m", "kv_V_s_per_deg", "gain",
    "limit_V", "sample_time_s", "delay_samples", "p", "pi", "pid", "bang_bang", "pd", "dubowsky",
    "elasto_backlash", "rodas4", "ode45", "voltage", "torque", "force", "thesis_shift", "none",
    "coulomb_friction", "viscous_friction", "backlash", "sensor_delay", "carriage", "motor", "profile1",
    "on", "off", "true", "null", "~", "1e-6", ".nan", "-.inf", "0x10", "1_000",
})
SPECIAL_NUMBERS = [math.nan, math.inf, -math.inf, 1e308, -1e308, 5e-324, 0, 0.0, -0.0, -1, -1e-9,
                   10 ** 400, -(10 ** 400), 2 ** 63, 2 ** 64 + 1, 1e-300, 3]
SCALAR = st.one_of(
    st.none(), st.booleans(), st.sampled_from(SPECIAL_NUMBERS), st.integers(), st.floats(),
    st.text(max_size=12), st.sampled_from(VOCAB), st.dates(),
    st.binary(max_size=6),
)
BAD = st.one_of(
    SCALAR,
    st.lists(SCALAR, max_size=3),
    st.dictionaries(st.one_of(st.sampled_from(VOCAB), st.text(max_size=6), st.integers()), SCALAR, max_size=3),
)


def _paths(node, prefix=()):
    yield prefix
    if isinstance(node, dict):
        for k, v in node.items():
            yield from _paths(v, prefix + (k,))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            yield from _paths(v, prefix + (i,))


def _parent(doc, path):
    node = doc
    for k in path[:-1]:
        node = node[k]
    return node


def _get(doc, path):
    return _parent(doc, path)[path[-1]] if path else doc


def _set(doc, path, value):
    if not path:
        return value
    _parent(doc, path)[path[-1]] = value
    return doc


@st.composite
def mutated(draw, bases, max_ops: int = 3):
    """One of ``bases`` (parsed documents) with 0 to ``max_ops`` structural mutations."""
    doc = copy.deepcopy(draw(st.sampled_from(bases)))
    for _ in range(draw(st.integers(0, max_ops))):
        path = draw(st.sampled_from(list(_paths(doc))))
        op = draw(st.sampled_from(["set", "set", "set", "delete", "unknown", "wrap", "text", "number"]))
        if op == "set":
            doc = _set(doc, path, draw(BAD))
        elif op == "delete" and path:
            del _parent(doc, path)[path[-1]]
        elif op == "unknown":
            node = _get(doc, path)
            key = draw(st.one_of(st.sampled_from(VOCAB), st.text(max_size=8), st.integers(-2, 2)))
            if isinstance(node, dict):
                node[key] = draw(BAD)
            elif isinstance(node, list):
                node.insert(draw(st.integers(0, len(node))), draw(BAD))
        elif op == "wrap":
            value = _get(doc, path)
            doc = _set(doc, path, draw(st.sampled_from([[value], {"value": value}, [value, value]])))
        elif op == "text":
            doc = _set(doc, path, str(_get(doc, path)))
        elif op == "number":  # a plausible number that may break a bound or a relation
            doc = _set(doc, path, draw(st.one_of(st.sampled_from(SPECIAL_NUMBERS),
                                                 st.floats(-1e6, 1e6), st.integers(-10, 10))))
    return doc


def dump(doc) -> str:
    try:
        return yaml.safe_dump(doc, sort_keys=False, allow_unicode=True)
    except yaml.representer.RepresenterError:  # an object yaml cannot write: write its text
        return yaml.safe_dump(str(doc))


@st.composite
def as_text(draw, doc) -> bytes:
    """The document as YAML, maybe damaged as text."""
    text = dump(doc)
    op = draw(st.sampled_from(["none"] * 6 + ["bytes", "cut", "deep", "alias", "nul", "dup", "utf16",
                                              "tab", "unicode", "anchor_bomb"]))
    pos = draw(st.integers(0, len(text)))
    if op == "bytes":
        return text[:pos].encode() + draw(st.binary(min_size=1, max_size=40)) + text[pos:].encode()
    if op == "cut":
        return text[:pos].encode()
    if op == "deep":
        depth = draw(st.sampled_from([30, 200, 1000, 5000, 50000]))
        opener, closer = draw(st.sampled_from([("[", "]"), ("{a: ", "}"), ("- ", "")]))
        nest = opener * depth + "1" + closer * depth if opener != "- " else \
            "".join("  " * i + "-\n" for i in range(min(depth, 3000))) + "  " * min(depth, 3000) + "1"
        key = draw(st.sampled_from(VOCAB))
        return (text + f"\n{key}:\n" + nest + "\n" if opener == "- " else text + f"\n{key}: {nest}\n").encode()
    if op == "alias":
        key = draw(st.sampled_from(VOCAB))
        form = draw(st.sampled_from(["&a [*a]", "&a {x: *a}", "&a [1, [*a]]"]))
        return (text + f"\n{key}: {form}\n").encode()
    if op == "anchor_bomb":
        key = draw(st.sampled_from(VOCAB))
        lines = ["a0: &a0 [x, x, x, x, x, x, x, x, x]"] + \
            [f"a{i}: &a{i} [*a{i - 1}, *a{i - 1}, *a{i - 1}, *a{i - 1}, *a{i - 1}, *a{i - 1}]" for i in range(1, 9)]
        return (text + "\n" + "\n".join(lines) + f"\n{key}: *a8\n").encode()
    if op == "nul":
        return (text[:pos] + "\x00" + text[pos:]).encode()
    if op == "dup":
        lines = text.splitlines(keepends=True)
        i = draw(st.integers(0, max(len(lines) - 1, 0)))
        return "".join(lines[:i + 1] + lines[i:]).encode()
    if op == "utf16":
        return text.encode("utf-16")
    if op == "tab":
        return text.replace("  ", "\t").encode()
    if op == "unicode":
        return (text[:pos] + draw(st.text(min_size=1, max_size=10)) + text[pos:]).encode("utf-8", "surrogatepass")
    return text.encode()


# ------------------------------------------------------------------- outcomes

class Tally:
    """Outcomes per target, for the slow run's report."""

    def __init__(self):
        self.counts = collections.Counter()

    def __call__(self, outcome: str) -> None:
        self.counts[outcome] += 1

    def report(self, target: str, minimum: int) -> str:
        total = sum(self.counts.values())
        assert total >= minimum, f"{target}: only {total} inputs ran"
        assert set(self.counts) <= {"named error", "valid"}, self.counts
        return (f"{target}: {total} inputs, {self.counts['named error']} named errors, "
                f"{self.counts['valid']} valid results")


def config_error(exc: ConfigError) -> str:
    assert exc.entries and str(exc).strip()
    for file, text in exc.entries:  # every problem names its file
        assert isinstance(file, str) and file.strip() and file != "<config>", exc.entries
        assert isinstance(text, str) and text.strip(), exc.entries
    return "named error"


def finite_params(p: np.ndarray) -> bool:
    """A packed parameter vector: finite, but for the drive limit of a plant without one (inf)."""
    return bool(np.all(np.isfinite(np.delete(p, L.P_VMAX))) and p[L.P_VMAX] > 0)


def usable_plant(plant: Plant) -> None:
    assert isinstance(plant, Plant)
    for ctrl in (Controller("p", kp=50.0), Controller("bang_bang")):
        p = pack(plant, ctrl)
        assert finite_params(p), f"non-finite parameter vector for a validated plant: {p}"
    scales = tolerance_scales(plant)
    assert np.all(np.isfinite(scales)) and np.all(scales > 0), scales


@pytest.fixture(scope="module")
def work(tmp_path_factory):
    """A folder with the files a mutated reference may point to: the repository's
    plants and profiles, a binary file, a deep YAML, a directory."""
    d = tmp_path_factory.mktemp("fuzz")
    (d / "plants").mkdir()
    for p in PLANTS:
        shutil.copy(p, d / "plants" / p.name)
    (d / "profiles").mkdir()
    for p in PROFILES:
        shutil.copy(p, d / "profiles" / p.name)
    (d / "profiles" / "ramp.csv").write_text("time_s,setpoint_deg\n0,0\n1,10\n2,10\n")
    (d / "binary.yaml").write_bytes(bytes(range(256)) * 4)
    (d / "profiles" / "binary.csv").write_bytes(bytes(range(256)) * 4)
    (d / "deep.yaml").write_text("a: " + "[" * 5000 + "]" * 5000 + "\n")
    (d / "adir.yaml").mkdir()
    (d / "thesis_table1.csv").write_text("profile,controller,kp,shift,iae_deg_s\n")
    return d


FILE_REFS = ["plants/thesis_gear.yaml", "binary.yaml", "deep.yaml", "adir.yaml", "profiles/ramp.csv",
             "profiles/binary.csv", "profile1", "profile2", "profiles/profile3.yaml", "plants/bench_rig.yaml",
             "thesis_table1.csv", "/", "", "~", "plants", "~no_such_user_here/plant.yaml", "x" * 5000,
             "a\x00b.yaml", "fuzzed_experiment.yaml"]


# --------------------------------------------------------------------- plants

PLANT_DOCS = [read_doc(p) for p in PLANTS]
plant_inputs = mutated(PLANT_DOCS).flatmap(as_text)


def check_plant(work: Path, data: bytes) -> str:
    path = work / "fuzzed_plant.yaml"
    path.write_bytes(data)
    try:
        plant = load_plant(path)
    except ConfigError as exc:
        assert path.name in str(exc)
        return config_error(exc)
    usable_plant(plant)
    return "valid"


@fast
@given(data=plant_inputs)
def test_fuzz_plant_files(work, data):
    check_plant(work, data)


def test_the_base_documents_are_valid(work):
    """The mutations start from valid documents: unmutated, each one loads."""
    for doc in PLANT_DOCS:
        assert check_plant(work, dump(doc).encode()) == "valid"
    for doc in EXPERIMENT_DOCS:
        assert check_experiment(work, dump(doc).encode()) == "valid"
    for doc in VALID_PROFILE_DOCS:
        assert check_profile(work, ("yaml", dump(doc).encode())) == "valid"
    assert check_controller_file(work, dump(CONTROLLER_DOC).encode()) == "valid"


# ---------------------------------------------------------------- experiments

def _experiment_docs():
    docs = []
    for path in EXPERIMENTS:
        doc = read_doc(path)
        doc.pop("reference", None)
        docs.append(doc)
        inline = dict(doc, plant=read_doc((path.parent / doc["plant"]).resolve()))
        docs.append(inline)
    return docs


EXPERIMENT_DOCS = _experiment_docs()


@st.composite
def experiment_inputs(draw):
    doc = draw(mutated(EXPERIMENT_DOCS))
    if isinstance(doc, dict) and draw(st.booleans()):  # point a reference at another file
        key = draw(st.sampled_from(["plant", "reference", "profiles"]))
        ref = draw(st.sampled_from(FILE_REFS))
        doc[key] = [ref] if key == "profiles" and draw(st.booleans()) else ref
    return draw(as_text(doc))


def check_experiment(work: Path, data: bytes) -> str:
    path = work / "fuzzed_experiment.yaml"
    path.write_bytes(data)
    try:
        exp = load_experiment(path)
    except ConfigError as exc:
        return config_error(exc)
    usable_plant(exp.plant)
    runs = exp.runs()
    assert runs
    try:
        profiles = load_profiles(exp)
    except ProfileError as exc:
        assert str(exc).strip()
        return "named error"
    for name, ctrl in runs:
        assert isinstance(profiles[name], Profile)
        assert finite_params(pack(exp.plant, ctrl))
    return "valid"


@fast
@given(data=experiment_inputs())
def test_fuzz_experiment_files(work, data):
    check_experiment(work, data)


# ------------------------------------------------------------------- profiles

VALID_PROFILE_DOCS = [read_doc(p) for p in PROFILES] + [{"sum": ["profile1", "profile2"]}]
PROFILE_DOCS = VALID_PROFILE_DOCS + [{"sum": ["fuzzed.yaml", "profile1"]}]  # a profile that sums itself


@st.composite
def csv_profile(draw) -> bytes:
    rows = draw(st.lists(st.tuples(st.one_of(st.floats(-1, 20), st.sampled_from(["", "x", "nan", "1e999"])),
                                   st.one_of(st.floats(-90, 90), st.sampled_from(["", "nan", "inf"]))),
                         min_size=0, max_size=6))
    header = draw(st.sampled_from(["time_s,setpoint_deg", "time_s;setpoint_deg", "t,setpoint_deg",
                                   "time_s", "time_s,setpoint_deg,extra", ""]))
    text = header + "\n" + "".join(f"{a},{b}\n" for a, b in rows)
    if draw(st.booleans()):
        return text.encode()
    pos = draw(st.integers(0, len(text)))
    return text[:pos].encode() + draw(st.binary(max_size=20)) + text[pos:].encode()


profile_inputs = st.one_of(
    st.tuples(st.just("yaml"), mutated(PROFILE_DOCS).flatmap(as_text)),
    st.tuples(st.just("csv"), csv_profile()),
)


def check_profile(work: Path, item) -> str:
    kind, data = item
    path = work / "profiles" / f"fuzzed.{kind}"
    path.write_bytes(data)
    try:
        prof = load_profile(path, work / "profiles")
    except ProfileError as exc:
        assert "fuzzed" in str(exc), str(exc)  # names the file
        return "named error"
    assert isinstance(prof, Profile) and prof.start_s[0] == 0.0
    seg = prof.segments()
    assert np.all(np.diff(seg.t) > 0) and all(np.all(np.isfinite(a)) for a in seg[:3])
    assert prof.start_s[-1] < prof.duration_s
    return "valid"


@fast
@given(item=profile_inputs)
def test_fuzz_profile_files(work, item):
    check_profile(work, item)


# ----------------------------------------------------------- controller files

CONTROLLER_DOC = read_doc(CONTROLLER_FILE)
EMPS_PLANT = load_plant(REPO / "experiments" / "plants" / "emps_bare.yaml")


def check_controller_file(work: Path, data: bytes) -> str:
    path = work / "fuzzed_controller.yaml"
    path.write_bytes(data)
    try:
        ctrl = load_controller(path)
    except ConfigError as exc:
        assert path.name in str(exc)
        return config_error(exc)
    assert ctrl.sample_time_s > 0 and ctrl.delay_samples in (0, 1)
    assert finite_params(ctrl.pack(EMPS_PLANT, pack_plant(EMPS_PLANT)))
    return "valid"


@fast
@given(data=mutated([CONTROLLER_DOC]).flatmap(as_text))
def test_fuzz_controller_files(work, data):
    check_controller_file(work, data)


# --------------------------------------------------------------- measurements

INPUTS = ("voltage_V", "drive_torque_Nm", "drive_force_N")
SIGNALS = ("motor_angle_deg", "load_angle_deg", "load_position_mm", "current_A", "motor_position_mm")
CELLS = ["", " ", "nan", "NaN", "inf", "-inf", "1e999", "-1e999", "abc", "1,5", "0x10", "1_000", "True",
         "\"1\"", "١٢", "1e-400", "--1", "1.2.3", "9" * 400, "NA", "null", "#"]


@st.composite
def records(draw) -> bytes:
    """A record CSV: a valid table, then mutated cells, rows, header, delimiter, bytes."""
    n = draw(st.integers(2, 25))
    columns = ["time_s", draw(st.sampled_from(INPUTS))]
    columns += draw(st.lists(st.sampled_from(SIGNALS), min_size=1, max_size=3, unique=True))
    if draw(st.booleans()):
        columns.append(draw(st.sampled_from(["setpoint_deg", "setpoint_mm"])))
    if draw(st.booleans()):
        columns.append("disturbance_V")
    dt = draw(st.sampled_from([1e-3, 0.01, 1e-9, 1.0]))
    values = [[repr(i * dt)] + [repr(draw(st.floats(-1e3, 1e3))) for _ in columns[1:]] for i in range(n)]
    header = list(columns)
    for _ in range(draw(st.integers(0, 4))):
        op = draw(st.sampled_from(["cell", "cell", "short", "long", "swap", "repeat", "blank", "rename",
                                   "dupcol", "dropcol", "header_ws", "comment"]))
        r = draw(st.integers(0, len(values) - 1)) if values else 0
        if op == "cell" and values and values[r]:
            c = draw(st.integers(0, len(values[r]) - 1))
            values[r][c] = draw(st.one_of(st.sampled_from(CELLS), st.text(max_size=6)))
        elif op == "short" and values and values[r]:
            values[r].pop()
        elif op == "long" and values:
            values[r].append(draw(st.sampled_from(CELLS)))
        elif op == "swap" and len(values) > 1:
            s = draw(st.integers(0, len(values) - 1))
            values[r], values[s] = values[s], values[r]
        elif op == "repeat" and values:
            values.insert(r, list(values[r]))
        elif op == "blank":
            values.insert(r, [])
        elif op == "rename" and header:
            c = draw(st.integers(0, len(header) - 1))
            header[c] = draw(st.one_of(st.sampled_from(["time_ms", "t", "load_angle_rad", "Voltage_V", "",
                                                        "time_s ", "voltage_v", "current_mA"]),
                                       st.text(max_size=8)))
        elif op == "dupcol" and header:
            header.append(draw(st.sampled_from(header)))
        elif op == "dropcol" and len(header) > 1:
            c = draw(st.integers(0, len(header) - 1))
            del header[c]
            for row in values:
                if c < len(row):
                    del row[c]
        elif op == "header_ws":
            header = [f" {h} " for h in header]
        elif op == "comment":
            values.insert(r, ["# a comment"])
    sep = draw(st.sampled_from([",", ",", ",", ";", "\t", "|", " "]))
    eol = draw(st.sampled_from(["\n", "\n", "\r\n", "\r"]))
    text = eol.join([sep.join(header)] + [sep.join(row) for row in values]) + eol
    op = draw(st.sampled_from(["none"] * 5 + ["bytes", "cut", "bom", "latin1", "utf16", "nul", "empty",
                                              "binary", "quote"]))
    pos = draw(st.integers(0, len(text)))
    if op == "bytes":
        return text[:pos].encode() + draw(st.binary(min_size=1, max_size=30)) + text[pos:].encode()
    if op == "cut":
        return text[:pos].encode()
    if op == "bom":
        return b"\xef\xbb\xbf" + text.encode()
    if op == "latin1":
        return (text[:pos] + "é°µ" + text[pos:]).encode("latin-1", "replace")
    if op == "utf16":
        return text.encode("utf-16")
    if op == "nul":
        return (text[:pos] + "\x00" + text[pos:]).encode()
    if op == "empty":
        return draw(st.sampled_from([b"", b"\n", b"\n\n", b" ", eol.encode()]))
    if op == "binary":
        return draw(st.binary(min_size=1, max_size=400))
    if op == "quote":
        return (text[:pos] + '"' + text[pos:]).encode()
    return text.encode()


def check_measurement(work: Path, data: bytes) -> str:
    path = work / "fuzzed_record.csv"
    path.write_bytes(data)
    try:
        m = read_measurement(path)
    except MeasurementError as exc:
        assert str(path) in str(exc), str(exc)  # names the file
        assert exc.problems and all(p.strip() for p in exc.problems)
        return "named error"
    assert isinstance(m, Measurement)
    assert len(m.time_s) >= 2 and np.all(np.diff(m.time_s) > 0)
    for v in m.columns().values():
        assert len(v) == len(m.time_s) and np.all(np.isfinite(v))
    return "valid"


@fast
@given(data=records())
def test_fuzz_measurement_csvs(work, data):
    check_measurement(work, data)


# ------------------------------------------------------------- sweep --param

SWEEP_KEYS = ["controller.kp", "controller.ki", "controller.band_deg", "controller.shift", "shift",
              "duration_s", "solver.rtol", "solver.max_steps", "plant.gear.backlash_deg",
              "plant.motor.resistance", "controllers[0].kp", "controllers[9].kp", "profiles",
              "plant.effects", "nope.deeper", "controller.kd", "initial_delta_deg", "plant"]
SWEEP_VALUES = ["0.5,5", "linspace(0,1,3)", "logspace(-1,2,4)", "geomspace(2,32,3)", "geomspace(-1,2,3)",
                "linspace(0,1,0)", "linspace(1,2,1e9)", "logspace(400,401,2)", "on,off", "nan", "inf",
                "-5", "[1,2]", "{a: 1}", "", ",", "linspace(", "foo(1,2,3)", "1e999", "profile1,profile2",
                "'x'", "null", "linspace(0,1,2,3)", "0x10"]


SWEEP_GOOD = ["controller.kp=5,50", "controller.kp=linspace(1,100,4)", "plant.gear.backlash_deg=1,2",
              "shift=off,on", "duration_s=0.1,0.2", "solver.rtol=1e-6,1e-5", "plant.load.damping=0,1",
              "controllers[0].kp=geomspace(1,1000,3)", "profiles=profile1,profile2"]


@st.composite
def sweep_params(draw) -> list[str]:
    out = []
    for _ in range(draw(st.integers(1, 2))):
        pick = draw(st.integers(0, 3))
        if pick == 0:  # a parameter that works, so that plans are built too
            out.append(draw(st.sampled_from(SWEEP_GOOD)))
            continue
        if pick < 3:  # a known key and a value of the grammar
            key, value = draw(st.sampled_from(SWEEP_KEYS)), draw(st.sampled_from(SWEEP_VALUES))
            out.append(f"{key}={value}")
            continue
        key = draw(st.one_of(st.sampled_from(SWEEP_KEYS), st.text(max_size=10)))
        value = draw(st.one_of(st.sampled_from(SWEEP_VALUES), st.text(max_size=10)))
        out.append(draw(st.sampled_from([f"{key}={value}", f"{key}{value}", f"{key}=={value}"])))
    return out


def check_sweep(work: Path, params: list[str]) -> str:
    exp = work / "sweep_experiment.yaml"
    if not exp.exists():
        exp.write_text(f"name: fuzz\nplant: {REPO / 'experiments/plants/thesis_gear.yaml'}\nduration_s: 0.5\n"
                       "profiles: [profile2]\ncontrollers:\n  - {kind: p, kp: 50}\nshift: [off]\n")
    try:
        plan = plan_sweep(exp, parse_params(params))
    except (SweepError, ConfigError, ProfileError) as exc:  # a swept profile name may not exist
        assert str(exc).strip()
        if isinstance(exc, ConfigError):
            config_error(exc)
        return "named error"
    assert 1 <= len(plan.points)
    for point in plan.points[:3]:
        plant, ctrl = point.job[0], point.job[1]
        assert finite_params(pack(plant, ctrl))
    return "valid"


@fast
@given(params=sweep_params())
def test_fuzz_sweep_params(work, params):
    check_sweep(work, params)


# ------------------------------------------------------------- Python calls

def _api_checks_arguments() -> bool:
    """Whether Controller and Segments check their arguments (the public API's
    validation, built beside this test for the same issue)."""
    from gearbench.simulate import Segments
    try:
        Segments(np.array([0.0, 1.0]), np.array([0.0]), np.array([0.0]))
        Controller("pd")
    except ValueError:
        return True
    return False


ARG = st.one_of(st.sampled_from(SPECIAL_NUMBERS), st.floats(-1e3, 1e3), st.none(), st.text(max_size=4),
                st.lists(st.floats(0, 1), max_size=2), st.booleans())


SETTINGS = {"p": ["kp"], "pi": ["kp", "ki"], "pid": ["kp", "ki", "kd", "derivative_filter_s"],
            "bang_bang": ["band_deg"], "open": []}


@st.composite
def api_calls(draw):
    """A valid controller and set point (deg-sized, a 10 ms run), then 0-2 wrong arguments."""
    kind = draw(st.sampled_from(list(SETTINGS)))
    kw = {k: draw(st.floats(1e-3, 500)) for k in SETTINGS[kind] if draw(st.booleans()) or k == "kp"}
    if draw(st.booleans()) and kind != "open":
        kw["compensator"] = draw(st.sampled_from(["none", "thesis_shift", "setpoint_direction"]))
    n = draw(st.integers(1, 4))
    t = [0.0] + sorted(draw(st.lists(st.floats(1e-4, 0.01), min_size=n - 1, max_size=n - 1, unique=True)))
    seg = [t, draw(st.lists(st.floats(-0.3, 0.3), min_size=n, max_size=n)),
           draw(st.lists(st.floats(-5, 5), min_size=n, max_size=n))]
    for _ in range(draw(st.integers(0, 2))):
        op = draw(st.sampled_from(["kind", "setting", "foreign", "length", "value", "order"]))
        if op == "kind":
            kind = draw(st.one_of(st.sampled_from(["pd", "P", "", "bangbang"]), st.lists(st.just("p"), max_size=1),
                                  st.none(), st.integers(), st.dictionaries(st.just("p"), st.just(1))))
        elif op == "setting" and kw:
            kw[draw(st.sampled_from(sorted(kw)))] = draw(ARG)
        elif op == "foreign":
            kw[draw(st.sampled_from(["kp", "ki", "kd", "derivative_filter_s", "band_deg", "shift",
                                     "shift_deg", "compensator"]))] = draw(ARG)
        elif op == "length":
            which = draw(st.integers(0, 2))
            seg[which] = seg[which][:-1] if draw(st.booleans()) else seg[which] + [0.0]
        elif op == "value":
            which = draw(st.integers(0, 2))
            if seg[which]:
                seg[which][draw(st.integers(0, len(seg[which]) - 1))] = draw(st.sampled_from(
                    [math.nan, math.inf, -math.inf, -1.0, 1e308]))
        elif op == "order":
            seg[0] = seg[0][::-1]
    return kind, kw, seg


def check_api_call(plant: Plant, call) -> str:
    from gearbench.simulate import RunResult, Segments, SolverOptions, simulate
    kind, kw, seg = call
    try:
        ctrl = Controller(kind, **kw)
        inputs = Segments(*(np.array(a, dtype=float) for a in seg))
        run = simulate(plant, ctrl, inputs, 0.01, SolverOptions(max_steps=20000, output_dt_s=0.005))
    except ValueError as exc:
        assert str(exc).strip()
        return "named error"
    assert isinstance(run, RunResult)
    return "valid"


@fast
@given(call=api_calls())
def test_fuzz_python_calls(plant, call):
    if not _api_checks_arguments():
        pytest.skip("Controller and Segments do not check their arguments here (the public API's "
                    "validation is another part of issue 19)")
    check_api_call(plant, call)


# ------------------------------------------------------------ the slow run

TARGETS = {
    "plant files": (lambda work: check_plant, plant_inputs),
    "experiment files": (lambda work: check_experiment, experiment_inputs()),
    "profile files": (lambda work: check_profile, profile_inputs),
    "controller files": (lambda work: check_controller_file, mutated([CONTROLLER_DOC]).flatmap(as_text)),
    "measurement CSVs": (lambda work: check_measurement, records()),
    "sweep parameters": (lambda work: check_sweep, sweep_params()),
}


@pytest.mark.slow
@pytest.mark.parametrize("target", list(TARGETS))
def test_fuzz_many(work, target, capsys):
    """SLOW inputs per target; prints the count of named errors and valid results."""
    make_check, strategy = TARGETS[target]
    check, tally = make_check(work), Tally()

    @slow_settings()
    @given(item=strategy)
    def run(item):
        tally(check(work, item))

    run()
    line = tally.report(target, SLOW)
    with capsys.disabled():
        print("\nfuzz", line)


@pytest.mark.slow
def test_fuzz_many_python_calls(plant, capsys):
    if not _api_checks_arguments():
        pytest.skip("Controller and Segments do not check their arguments here")
    tally = Tally()

    @slow_settings()
    @given(call=api_calls())
    def run(call):
        tally(check_api_call(plant, call))

    run()
    line = tally.report("Python calls", SLOW)
    with capsys.disabled():
        print("\nfuzz", line)



# ------------------------------------------- the crash kinds the issue names

@pytest.mark.parametrize("kind", ["[p]", "{p: 1}", "[]", "{}"])
def test_a_controller_kind_that_is_a_list_or_mapping_is_named(tmp_path, kind):
    path = tmp_path / "exp.yaml"
    path.write_text(f"plant: {REPO / 'experiments/plants/thesis_gear.yaml'}\nduration_s: 1\n"
                    f"profiles: [profile1]\ncontrollers:\n  - {{kind: {kind}, kp: 5}}\n")
    with pytest.raises(ConfigError, match=r"exp\.yaml: controllers\[0\]\.kind must be one of bang_bang, p, pi, "
                                          r"pid \(a string\), got a (list|mapping)"):
        load_experiment(path)


@pytest.mark.parametrize("text, problem", [
    ("motor: " + "[" * 5000 + "]" * 5000, "nests lists or mappings too deeply to read"),
    ("motor: " + "[" * 40 + "]" * 40, r"motor\[0\]\[0\].* nests more than 32 levels"),
    ("motor: &a [*a]", r"motor\[0\] contains itself"),
    ("motor: &a {gear: {load: *a}}", r"motor\.gear\.load contains itself"),
    # an alias cannot smuggle depth past the check: 3 x 20 levels
    ("a: &a " + "[" * 20 + "1" + "]" * 20 + "\nb: &b " + "[" * 20 + "*a" + "]" * 20
     + "\nc: " + "[" * 20 + "*b" + "]" * 20, "nests more than 32 levels"),
    ("motor: {inertia: " + "9" * 5000 + "}", "a value cannot be read"),
])
def test_deep_or_self_referencing_yaml_is_named_at_parse_time(tmp_path, text, problem):
    path = tmp_path / "deep_plant.yaml"
    path.write_text(text + "\n")
    with pytest.raises(ConfigError, match=r"deep_plant\.yaml: .*" + problem):
        load_plant(path)


def test_a_huge_integer_is_named_with_its_key(tmp_path):
    path = tmp_path / "plant.yaml"
    doc = read_doc(REPO / "experiments/plants/thesis_gear.yaml")
    doc["motor"]["resistance"] = 10 ** 400
    path.write_text(dump(doc))
    with pytest.raises(ConfigError, match=r"plant\.yaml: motor\.resistance must be a positive number in ohm, "
                                          r"got the integer 100000\.\.\. \(401 digits\) \(too large"):
        load_plant(path)


def test_values_too_extreme_to_compute_with_are_named(tmp_path):
    """Each value passes alone; 5e-324 ohm makes the typical current infinite (found by the fuzz)."""
    path = tmp_path / "plant.yaml"
    doc = read_doc(REPO / "experiments/plants/bench_rig.yaml")
    doc["motor"]["resistance"] = 5e-324
    path.write_text(dump(doc))
    with pytest.raises(ConfigError, match=r"plant\.yaml: the plant: its values are too extreme to compute with: "
                                          r"the typical current \(motor\.max_voltage / motor\.resistance, A\) "
                                          r"and mesh deflection \(rad\) come out 0 or infinite"):
        load_plant(path)


def test_a_power_past_1e308_and_an_infinite_gain_are_named(tmp_path):
    """Found by the fuzz (2026-11-26): a lead of 1e308 mm squares past 1e308 (Python raised
    OverflowError from the plant's reflected inertia), and Kp = 1e308 V/deg is infinite in
    V/rad (the run was packed with an infinite gain)."""
    path = tmp_path / "plant.yaml"
    doc = read_doc(REPO / "experiments/plants/leadscrew_apparatus.yaml")
    doc["leadscrew"]["lead_mm"] = 1e308
    path.write_text(dump(doc))
    with pytest.raises(ConfigError, match=r"plant\.yaml: the plant: its values are too extreme to compute with: "
                                          r"a power of one of them overflows past 1e308"):
        load_plant(path)
    path = tmp_path / "exp.yaml"
    path.write_text(dump({"plant": str(REPO / "experiments/plants/thesis_gear.yaml"), "duration_s": 1,
                          "profiles": ["profile1"], "controllers": [{"kind": "p", "kp": 5}, {"kind": "p", "kp": 1e308}]}))
    with pytest.raises(ConfigError, match=r"exp\.yaml: controllers\[1\]: its values are too extreme to compute with: "
                                          r"a gain comes out infinite in SI units"):
        load_experiment(path)


@pytest.mark.parametrize("data", [bytes(range(256)) * 3, b"time_s,voltage_V,load_angle_deg\n0,1,\xff\xfe\n",
                                  "time_s,voltage_V,load_angle_deg\n0,1,2\n".encode("utf-16")])
def test_a_binary_csv_names_the_file(tmp_path, data):
    path = tmp_path / "record.csv"
    path.write_bytes(data)
    with pytest.raises(MeasurementError, match=re.escape(f"'{path}'")):  # the file, named
        read_measurement(path)


def test_a_plant_path_the_system_refuses_is_named(tmp_path):
    path = tmp_path / "exp.yaml"
    for ref in ("x" * 5000 + ".yaml", "~no_such_user_here/plant.yaml", "a\0b.yaml"):
        path.write_text(dump({"plant": ref, "duration_s": 1, "profiles": ["profile1"],
                              "controllers": [{"kind": "p", "kp": 5}]}))
        with pytest.raises(ConfigError, match=r"exp\.yaml: plant must name an existing plant file"):
            load_experiment(path)


def test_a_profile_that_sums_itself_is_named(tmp_path):
    path = tmp_path / "loop.yaml"
    path.write_text("sum: [loop.yaml, profile1]\n")
    with pytest.raises(ProfileError, match=r"loop\.yaml: sum\[0\]: .*loop\.yaml: the profile sums itself"):
        load_profile(path)


def test_a_grid_too_large_for_memory_is_refused_before_it_is_built(tmp_path):
    with pytest.raises(SweepError, match=r"whole number n from 1 to 100,000"):
        parse_params(["controller.kp=linspace(1,2,1e9)"])
    exp = tmp_path / "e.yaml"
    exp.write_text(f"plant: {REPO / 'experiments/plants/thesis_gear.yaml'}\nduration_s: 1\n"
                   "profiles: [profile1]\ncontrollers:\n  - {kind: p, kp: 5}\n")
    with pytest.raises(SweepError, match=r"the grid has 1,000,000 points \(1000 x 1000\)"):
        plan_sweep(exp, parse_params(["controller.kp=linspace(1,2,1000)", "duration_s=linspace(1,2,1000)"]))
