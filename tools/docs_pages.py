"""Pages of the docs site that are generated at build time, so they cannot drift from the code.

Run by mkdocs-gen-files (``mkdocs.yml``: ``plugins: gen-files``) on every ``mkdocs build``:

* ``effects/<name>.md``, one page per registered effect (``gearbench.plant.effects.REGISTRY``):
  its equation and units (the effect module's docstring), where it acts, its parameters (from
  its :class:`~gearbench.plant.effects.base.Param` declarations: unit, bounds, description),
  its options, its signature (the words ``diagnose``'s explanations use,
  ``gearbench.identify.evidence.SIGNATURES``), what it is confused with (its declared
  ``confounders``, both ways, the simpler effect it reduces to, and the confusions measured
  in these docs, :data:`CONFUSIONS`), and its examples in ``docs/plant-yaml.md`` (which
  ``tests/test_docs_plant_yaml.py`` loads);
* ``effects/summary.md``: one table of them all;
* ``figures/...``: the PNGs that ``make run`` writes under ``results/``, copied as they are
  (:data:`FIGURES`), so the pages show what the code made.

Importable without mkdocs (``tests/test_docs_site.py`` renders every page).
"""
from __future__ import annotations

import inspect
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from gearbench.identify.evidence import SIGNATURES  # noqa: E402
from gearbench.plant.effects import REGISTRY, names  # noqa: E402
from gearbench.plant.effects.base import Effect  # noqa: E402

FIGURES = (
    "results/compensators.png",
    "results/gain_scan/sweep.png",
    "results/gain_scan_fine/gain_scan/sweep.png",
    "results/emps/ladder_paper_structure.png",
    "results/emps/ladder_whole_library.png",
    "results/emps/train_force.png",
    "results/emps/validation_force_zoom.png",
    "results/emps/validation_acceleration_edge.png",
    "results/twomass/frf.png",
    "results/twomass/ladder.png",
    "results/validation/convergence.png",
    "results/compare_bench_rig_bench_rig_hidden/residual_tests.png",
)
"""PNGs written by ``make run`` that the pages show, copied to ``figures/`` + the same path."""

# Confusions measured in these docs, with the page that measured them (a name not registered
# fails the build: see effect_pages).
CONFUSIONS: dict[str, list[tuple[str, str]]] = {
    "coulomb_friction": [
        ("load_spring", "on the tutorial's record a load spring fitted alone took up part of the "
                        "hidden Coulomb friction (2.34 N m/rad for 2.00), until both were refitted "
                        "together ([the tutorial](../tutorial.md))"),
    ],
    "load_spring": [
        ("bias_torque", "on EMPS, over the whole library, a load spring relaxed far outside the travel "
                        "plays the offset (a constant force) ([real data](../real-data.md)); on a "
                        "Coulomb friction plus bias record the ladder once wandered through a spring "
                        "with a rest angle of 14,814 deg, a constant torque in disguise "
                        "([how diagnose decides](../diagnose.md))"),
    ],
    "stribeck_friction": [
        ("coulomb_friction", "a mild Stribeck curve hidden with a load spring ranks below its "
                             "Coulomb form alone; diagnose pairs both so it is not lost "
                             "([speed](../speed.md))"),
    ],
    "viscous_friction": [
        ("calibration", "on practice case p04 a viscous friction first mimicked the datasheet values "
                        "that were off, and came out again once the calibration won a rung "
                        "([how diagnose decides](../diagnose.md))"),
    ],
    "sensor_delay": [
        ("coulomb_friction", "with Coulomb friction at the motor left out, a 3 ms delay on the load "
                             "angle ranked twelfth of 15 alone ([speed](../speed.md))"),
    ],
    "shaft_compliance": [
        ("calibration", "calibrated from the start, datasheet values took up part of what was missing "
                        "and the ladder went through a shaft compliance "
                        "([how diagnose decides](../diagnose.md))"),
    ],
}


def _md(text: str) -> str:
    """A docstring's reStructuredText roles and literals as Markdown."""
    text = re.sub(r":\w+:`~?\.?([^`]+)`", lambda m: f"`{m.group(1).split('.')[-1]}`", text)
    return text.replace("``", "`")


def _kind(effect: Effect) -> str:
    cls = type(effect)
    if effect.term is not None:
        where = "compiled: a term of the right-hand side, at " + ", ".join(f"`{p}`" for p in effect.places)
        if effect.state:
            where += f", with a state of its own ({effect.state}); `diagnose` tries it only with `--also {effect.name}`"
        return where
    if cls.apply is not Effect.apply:
        return "structural: it changes the plant itself"
    if cls.measure is not Effect.measure:
        return "sensor: it distorts a measured signal"
    return "unknown"


def _scale(value) -> str:
    if callable(value):
        return f"from the plant (`{getattr(value, '__name__', 'scale')}`)"
    return f"{value:g}"


def _module_doc(effect: Effect) -> tuple[str, str]:
    module = sys.modules[type(effect).__module__]
    doc = inspect.getdoc(module) or ""
    lines = doc.splitlines()
    # the first line is "``name``: what it is"; the page's title says the name
    head = lines[0].split(":", 1)[-1].strip() if lines else ""
    return head, _md("\n".join(lines[1:]).strip("\n").rstrip())


def _examples(name: str, plant_yaml: str) -> list[str]:
    """The ``- type: name`` entries of docs/plant-yaml.md's YAML blocks, with their comments."""
    out = []
    for block in re.findall(r"^```yaml\n(.*?)^```", plant_yaml, re.S | re.M):
        lines = block.splitlines()
        for i, line in enumerate(lines):
            m = re.match(r"^(\s*)- type: (\w+)", line)
            if not m or m.group(2) != name:
                continue
            indent = len(m.group(1))
            entry = [line[indent:]]
            for more in lines[i + 1:]:
                if not more.strip() or len(more) - len(more.lstrip()) <= indent:
                    break
                entry.append(more[indent:])
            out.append("\n".join(entry))
    return out


def confused_with(name: str) -> list[str]:
    """Sentences: what ``name`` is confused with, from the registry's declarations and CONFUSIONS."""
    effect = REGISTRY[name]
    out = []
    declared = set(effect.confounders)
    declaring = {n for n, e in REGISTRY.items() if name in e.confounders}
    for other in sorted(declared | declaring):
        who = "it declares" if other in declared else f"`{other}` declares"
        out.append(f"[`{other}`]({other}.md): {who} the two confounded (each alone explains part of "
                   f"the other's residual), so `diagnose` refits them as a pair whatever each ranks alone.")
    all_values = {q.name: q.scale if not callable(q.scale) else 1.0 for q in effect.params}
    simpler = effect.simpler(all_values)
    if simpler is not None and simpler[0] == name:
        out.append("Its own symmetric form: given its optional parameters it is asymmetric, and `diagnose` "
                   "drops them when the BIC says they do not pay.")
    elif simpler is not None:
        out.append(f"[`{simpler[0]}`]({simpler[0]}.md): its simpler form; `diagnose` replaces it by "
                   f"that when the BIC says the extra parameters do not pay.")
    for other, n in REGISTRY.items():
        s = n.simpler({q.name: 1.0 for q in n.params})
        if other != name and s is not None and s[0] == name:
            out.append(f"[`{other}`]({other}.md): reduces to this one (its simpler form).")
    same = [o for o, e in REGISTRY.items() if o != name and e.signature == effect.signature]
    if same:
        out.append("Same signature (" + f"`{effect.signature}`): " + ", ".join(f"[`{o}`]({o}.md)" for o in same) + ".")
    for other, words in CONFUSIONS.get(name, []):
        if other != "calibration" and other not in REGISTRY:
            raise KeyError(f"CONFUSIONS[{name!r}] names {other!r}, which is not a registered effect")
        target = "the datasheet values' calibration" if other == "calibration" else f"[`{other}`]({other}.md)"
        out.append(f"{target}: measured: {words}.")
    return out


def effect_page(name: str, plant_yaml: str) -> str:
    effect = REGISTRY[name]
    head, body = _module_doc(effect)
    cls_doc = (inspect.getdoc(type(effect)) or "").strip()
    lines = [f"# `{name}`", "", f"{_md(cls_doc)}", ""]
    lines += ["## Equation and units", "", body or _md(head), ""]
    lines += ["## Where it acts", "", f"- on the {effect.acts_on}", f"- {_kind(effect)}"]
    for key, choices in {**effect.options, **effect.settings}.items():
        lines.append(f"- `{key}`: " + " or ".join(f"`{c}`" for c in choices)
                     + (" (a setting `diagnose` does not try; the first is the default)" if key in effect.settings else ""))
    lines += ["", "## Parameters", ""]
    if effect.params:
        lines += ["| name | unit | bounds | typical | description |", "|---|---|---|---|---|"]
        for q in effect.params:
            flags = [f for f, on in (("optional", q.optional), ("whole numbers", q.integer)) if on]
            extra = f" ({', '.join(flags)})" if flags else ""
            carriage = f"; at the carriage `{q.carriage}`" if q.carriage else ""
            lines.append(f"| `{q.name}`{extra} | {q.unit} | {q.low:g} to {q.high:g} | {_scale(q.scale)} | "
                         f"{q.description}{carriage} |")
        lines += ["", "The bounds are also the fit's bounds; the typical value is where a fit starts and "
                      "what its steps scale with."]
    else:
        lines.append("None.")
    sig = SIGNATURES.get(effect.signature)
    lines += ["", "## Signature", "",
              f"`{effect.signature}`" + (f": {sig[1]}, measured on the "
                                         f"{'residual turned into a torque' if sig[0] == 'torque' else 'measured signal'}."
                                         if sig else "."),
              "", "`diagnose`'s explanation measures it on the residual the effect had to explain "
                  "([how diagnose decides](../diagnose.md#signatures))."]
    lines += ["", "## What it is confused with", ""]
    confusions = confused_with(name)
    lines += [f"- {c}" for c in confusions] if confusions else ["Nothing declared or measured."]
    examples = _examples(name, plant_yaml)
    if examples:
        lines += ["", "## In a plant file", "",
                  "From [plant files](../plant-yaml.md#effects) (each example there is loaded by the tests):", ""]
        for ex in examples:
            lines += ["```yaml", ex, "```", ""]
    module = type(effect).__module__
    lines += ["", "## Source", "", f"`{module.replace('.', '/')}.py`, class `{type(effect).__name__}`.", ""]
    return "\n".join(lines)


def summary_page() -> str:
    lines = ["# All effects at a glance", "",
             "Generated from the effect registry at build time.", "",
             "| effect | acts on | parameters | signature |", "|---|---|---|---|"]
    for name in names():
        e = REGISTRY[name]
        pars = ", ".join(f"`{q.name}` ({q.unit})" for q in e.params)
        lines.append(f"| [`{name}`]({name}.md) | {e.acts_on} | {pars} | {e.signature} |")
    return "\n".join(lines) + "\n"


def effect_pages() -> dict[str, str]:
    """Every generated Markdown page, by its path under docs/."""
    plant_yaml = (ROOT / "docs" / "plant-yaml.md").read_text(encoding="utf-8")
    pages = {f"effects/{n}.md": effect_page(n, plant_yaml) for n in names()}
    pages["effects/summary.md"] = summary_page()
    return pages


def build() -> None:
    import mkdocs_gen_files

    for path, text in effect_pages().items():
        with mkdocs_gen_files.open(path, "w") as f:
            f.write(text)
    for rel in FIGURES:
        with mkdocs_gen_files.open(f"figures/{rel}", "wb") as f:
            f.write((ROOT / rel).read_bytes())


if __name__ == "<run_path>":  # mkdocs-gen-files
    build()
