"""One self-contained HTML page per ``compare``, ``diagnose`` and ``fit``, and the compact
cards a notebook shows (``_repr_html_``).

A page holds everything in one file: its figures are PNGs embedded as ``data:`` URIs, its
style sheet is inline, and it names no external script, font or image, so it opens from an
e-mail attachment with no network.  The template is a plain :class:`string.Template` and
every value put in it is escaped (:func:`html.escape`): a page is a few tables, sentences and
figures, which needs no template engine (and no dependency).

Numbers keep the units of the text outputs: errors in the compared signal's unit (deg, mm,
A, V, N), times in s, parameters in their plant-file units.
"""
from __future__ import annotations

import base64
import html
import io
import math
from pathlib import Path
from string import Template
from typing import Any, Iterable, Mapping, Sequence

EMBED_DPI = 90
"""Resolution of the figures a page embeds, dots per inch (the files beside it: 110)."""
CARD_DPI = 55
"""Resolution of a notebook card's one small figure, dots per inch."""

CSS = """
:root { --ink: #1d2330; --muted: #5d6677; --rule: #d9dde5; --band: #f4f6f9; --accent: #2f5d9e;
        --good: #2e7d32; --bad: #b3261e; }
* { box-sizing: border-box; }
body { margin: 0; font: 15px/1.45 system-ui, -apple-system, "Segoe UI", Roboto, "DejaVu Sans", sans-serif;
       color: var(--ink); background: #fff; }
main { max-width: 1180px; margin: 0 auto; padding: 22px 26px 40px; }
header.page { border-bottom: 3px solid var(--accent); margin-bottom: 14px; }
h1 { font-size: 1.55em; margin: 0 0 4px; }
h2 { font-size: 1.2em; margin: 28px 0 8px; padding-bottom: 3px; border-bottom: 1px solid var(--rule); }
h3 { font-size: 1.02em; margin: 18px 0 6px; }
p.sub { color: var(--muted); margin: 0 0 10px; }
.verdict { font-size: 1.12em; background: var(--band); border-left: 5px solid var(--accent);
           padding: 10px 14px; margin: 12px 0; }
table { border-collapse: collapse; margin: 8px 0 14px; font-size: 0.92em; }
th, td { border-bottom: 1px solid var(--rule); padding: 4px 10px; text-align: left; vertical-align: top; }
th { background: var(--band); font-weight: 600; }
td.num, th.num { text-align: right; font-variant-numeric: tabular-nums; white-space: nowrap; }
tr.total td { font-weight: 600; }
dl.files { display: grid; grid-template-columns: max-content 1fr; gap: 2px 14px; margin: 6px 0; }
dl.files dt { color: var(--muted); }
dl.files dd { margin: 0; font-family: ui-monospace, "DejaVu Sans Mono", monospace; font-size: 0.92em; }
figure { margin: 12px 0 20px; }
figure img { max-width: 100%; height: auto; border: 1px solid var(--rule); }
figcaption { color: var(--muted); font-size: 0.88em; margin-top: 3px; }
ol.explain li, ul.plain li { margin-bottom: 6px; }
.yes { color: var(--good); font-weight: 600; }
.no { color: var(--bad); font-weight: 600; }
.row { display: flex; flex-wrap: wrap; gap: 0 44px; }
.row > section { flex: 1 1 420px; min-width: 0; }
footer { margin-top: 36px; color: var(--muted); font-size: 0.82em; border-top: 1px solid var(--rule);
         padding-top: 6px; }
.card { font: 13px/1.35 system-ui, sans-serif; }
.card table { font-size: 12px; margin: 4px 0; }
.card img { max-width: 100%; height: auto; }
"""

PAGE = Template("""<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<link rel="icon" href="data:,">
<title>$title</title>
<style>$css</style>
</head>
<body>
<main>
<header class="page"><h1>$title</h1><p class="sub">$subtitle</p></header>
$body
<footer>Made by gearbench $version. Self-contained: every figure is embedded in this file.</footer>
</main>
</body>
</html>
""")


class Raw(str):
    """HTML already made (a cell or a block that must not be escaped again)."""


def esc(value: Any) -> str:
    """``value`` as text safe inside HTML (a :class:`Raw` is kept as it is)."""
    return value if isinstance(value, Raw) else html.escape(str(value), quote=True)


def num(value: Any, fmt: str = ".4g", unit: str = "") -> str:
    """A number formatted with ``fmt`` (and `` unit``), or an em dash for None or NaN."""
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "\u2014"
    try:
        text = format(value, fmt)
    except (TypeError, ValueError):
        return str(value)
    return f"{text} {unit}" if unit else text


def yes_no(flag: bool, yes: str = "yes", no: str = "no") -> Raw:
    return Raw(f'<span class="{"yes" if flag else "no"}">{esc(yes if flag else no)}</span>')


def table(headers: Sequence[str], rows: Iterable[Sequence[Any]], numeric: Sequence[int] = (),
          table_id: str = "", css_class: str = "") -> str:
    """A table: ``headers`` then ``rows`` of cells (escaped unless :class:`Raw`); the columns
    in ``numeric`` are right-aligned."""
    num_cols = set(numeric)
    attrs = (f' id="{esc(table_id)}"' if table_id else "") + (f' class="{esc(css_class)}"' if css_class else "")
    head = "".join(f'<th{" class=num" if i in num_cols else ""}>{esc(h)}</th>' for i, h in enumerate(headers))
    body = "\n".join("<tr>" + "".join(f'<td{" class=num" if i in num_cols else ""}>{esc(c)}</td>'
                                      for i, c in enumerate(r)) + "</tr>" for r in rows)
    return f"<table{attrs}>\n<thead><tr>{head}</tr></thead>\n<tbody>\n{body}\n</tbody>\n</table>"


def png(fig, dpi: int = EMBED_DPI) -> bytes:
    """The PNG bytes of a matplotlib figure."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    return buf.getvalue()


def img(image: bytes | Any, alt: str, dpi: int = EMBED_DPI) -> str:
    """An ``<img>`` whose source is the PNG itself (a ``data:`` URI); ``image`` is PNG bytes
    or a matplotlib figure (rendered at ``dpi``)."""
    data = image if isinstance(image, (bytes, bytearray)) else png(image, dpi)
    uri = "data:image/png;base64," + base64.b64encode(data).decode("ascii")
    return f'<img src="{uri}" alt="{esc(alt)}">'


def figure(image: bytes | Any, caption: str, dpi: int = EMBED_DPI) -> str:
    """A figure with its caption (see :func:`img`)."""
    return f"<figure>{img(image, caption, dpi)}<figcaption>{esc(caption)}</figcaption></figure>"


def section(title: str, *parts: str, section_id: str = "") -> str:
    sid = f' id="{esc(section_id)}"' if section_id else ""
    return f"<section{sid}>\n<h2>{esc(title)}</h2>\n" + "\n".join(p for p in parts if p) + "\n</section>"


def row(*sections: str) -> str:
    """Sections side by side where the page is wide enough (one under the other where not)."""
    return '<div class="row">' + "\n".join(s for s in sections if s) + "</div>"


def files(items: Mapping[str, Any]) -> str:
    """A definition list of what the page is about: files, plant, loop."""
    return '<dl class="files">' + "".join(f"<dt>{esc(k)}</dt><dd>{esc(v)}</dd>" for k, v in items.items()
                                          if v not in (None, "")) + "</dl>"


def page(title: str, subtitle: str, body: Sequence[str]) -> str:
    """The whole HTML document: ``body``'s blocks under a title, the style sheet inline."""
    from .. import __version__
    return PAGE.substitute(title=esc(title), subtitle=esc(subtitle), css=CSS, body="\n".join(body),
                           version=esc(__version__))


def card(*parts: str) -> str:
    """A notebook card: a small block with the page's style, no document around it."""
    return f'<div class="card"><style>{CSS}</style>' + "\n".join(parts) + "</div>"


def write(path: str | Path | None, text: str) -> str:
    """``text``, written to ``path`` atomically first when a path is given
    (:func:`gearbench.report.io.write_text_atomic`)."""
    if path is not None:
        from .io import write_text_atomic
        write_text_atomic(path, text)
    return text


# ------------------------------------------------------------ shared sections

def signals_table(rows: Sequence[Mapping], table_id: str = "") -> str:
    """Per compared signal: RMS and maximum error, noise floor (its unit), their ratio, relative %."""
    return table(["signal", "unit", "RMS error", "max error", "noise floor", "RMS / noise", "relative %"],
                 [[r["signal"], r["unit"], num(r["rms_error"]), num(r["max_error"]), num(r["noise_floor"], ".3g"),
                   num(r["ratio_to_noise"], ".3g"), num(r["relative_error_pct"], ".3g")] for r in rows],
                 numeric=(2, 3, 4, 5, 6), table_id=table_id)


def phases_table(phases: Mapping, primary: str) -> str:
    if not phases:
        return ""
    return (f"<p>Where the {esc(primary)} error sits, by phase of the motion (each phase's share of the time "
            f"and of the squared error):</p>"
            + table(["phase", "time share", "error share", "RMS"],
                    [[k, num(v["time_share"], ".1%"), num(v["error_share"], ".1%"), num(v["rms"])]
                     for k, v in phases.items()], numeric=(1, 2, 3)))


def residual_tests_block(tests: Mapping) -> str:
    """The residual tests (as MATLAB's resid), one row each, then their sentences.  ``tests``
    maps a signal to a ``ResidualTest`` or to its JSON (``white``, ``input_independent``,
    ``lag1``, ``ljung_box_p``, ``sentence``)."""
    if not tests:
        return "<p>No residual tests (the re-initialisation windows are too short for them).</p>"
    rows, sentences = [], []
    for name, t in tests.items():
        j = t if isinstance(t, Mapping) else {"input": t.input_name, "white": t.white,
                                              "input_independent": t.input_independent,
                                              "lag1": float(t.autocorrelation[1]), "ljung_box_p": t.ljung_box_p,
                                              "sentence": t.sentence()}
        p = j["ljung_box_p"]
        rows.append([name, yes_no(j["white"]), "< 1e-16" if p is not None and p < 1e-16 else num(p, ".2g"), num(j["lag1"], "+.3f"),
                     yes_no(j["input_independent"]), j.get("input", "")])
        sentences.append(f"<li>{esc(j['sentence'])}</li>")
    return (table(["signal", "white", "Ljung-Box p", "lag-1 autocorrelation", "independent of the input", "input"],
                  rows, numeric=(2, 3))
            + '<ul class="plain">' + "".join(sentences) + "</ul>")


def noise_table(noise: Mapping) -> str:
    """Per compared column its noise floor (its unit) and where it came from."""
    return (table(["signal", "noise floor", "unit", "from"],
                  [[k, num(v["floor"], ".4g"), v["unit"], "stated" if v.get("stated") else
                    f"the record ({v['rule']})" if v.get("rule") else "the record"]
                   for k, v in noise.items()], numeric=(1,))
            + "<p class=sub>Each floor is the column's noise, a standard deviation in its unit: stated (--noise, "
              "--noise-from) or read from the record (gearbench.measure.noise): 'differences', the third "
              "differences' scale (white noise assumed); on an encoder's grid of step q, 'quantum', q/sqrt(12), or "
              "'quantized differences', the noise before the rounding added to it.</p>")


def _caption(file_name: str, primary: str) -> str:
    """What a figure of :func:`gearbench.report.compare.comparison_figures` shows, from its file name."""
    name = file_name.removesuffix(".png")
    if name == "residual_tests":
        return "residual tests: each residual's autocorrelation and its cross-correlation with the input, 99 % bands"
    if name == f"{primary}_residual_vs_motion":
        return f"the {primary} residual against speed, position and direction of motion"
    return f"{name}: measured and simulated, the residual, the record's input"


def comparison_sections(cmp, what: str, images: Mapping[str, bytes] | None = None, heading: str = "",
                        table_id: str = "signals") -> list[str]:
    """The blocks of a comparison: the signals table (``table_id``), the phases, the figures of
    :func:`gearbench.report.compare.comparison_figures` (``images``: their PNGs already made,
    by file name) and the residual tests."""
    from .compare import comparison_figures
    c = cmp.figures
    made = images.items() if images is not None else comparison_figures(cmp, what)
    figs = [figure(image, _caption(name, c["primary"])) for name, image in made]
    loop = "closed loop: a controller driven by the record's set point" if cmp.closed_loop else \
        "open loop: driven by the measured input"
    head = heading or "The model against the record"
    return [section(head, f"<p>Replayed in {esc(loop)}; the residual is measured - simulated, in each signal's "
                          f"unit.</p>", signals_table(c["signals"], table_id), phases_table(c.get("phases"),
                                                                                          c["primary"]),
                    section_id="comparison"),
            section("Measured and simulated signals",
                    "<p>Each signal measured (black) and simulated (dashed), the residual under it and the record's "
                    "input below, shaded by the phase of the motion; thin vertical lines mark where the replay "
                    "re-initialised the model's angles from the record.</p>", *figs, section_id="figures"),
            section("Residual tests", residual_tests_block(c.get("residual_tests", {})), section_id="residual-tests")]


# ------------------------------------------------------------------ compare

def comparison_page(cmp, plant_file: str | Path | None = None, data_file: str | Path | None = None,
                    images: Mapping[str, bytes] | None = None) -> str:
    """The HTML page of a comparison (``gearbench compare``).

    Parameters
    ----------
    cmp : gearbench.api.Comparison
        The model against the record.
    plant_file, data_file : str or Path, optional
        The files as the user named them (default: the comparison's plant label and record source).
    images : dict of str to bytes, optional
        The figures' PNGs already made, by file name (as ``gearbench compare`` saved them);
        default: rendered here.

    Returns
    -------
    str
        The whole document.
    """
    plant_name = str(plant_file) if plant_file else (cmp.plant_label or cmp.plant.name)
    data_name = str(data_file) if data_file else cmp.data.source
    what = f"{Path(plant_name).name} against {Path(data_name).name}"
    head = files({"plant file": plant_name, "plant": cmp.plant.name, "data file": data_name,
                  "record": f"{cmp.time_s.size} samples, {num(cmp.data.duration_s, '.4g', 's')}",
                  "replay": "closed loop" if cmp.closed_loop else "open loop",
                  "primary signal": cmp.primary})
    noise = table(["signal", "noise floor", "unit"],
                  [[r["signal"], num(r["noise_floor"], ".4g"), r["unit"]] for r in cmp.signals], numeric=(1,))
    return page(f"compare: {what}", "Where the model fails against the record, signal by signal.",
                [row(section("Files", head, section_id="files"), section("Noise floors", noise, section_id="noise")),
                 *comparison_sections(cmp, what, images)])


# ----------------------------------------------------------------- diagnose

def _unit_of(effect: str, param: str) -> str:
    """The plant-file unit of an effect's parameter ('' when unknown)."""
    from ..plant.effects import REGISTRY
    cls = REGISTRY.get(effect)
    unit = next((q.unit for q in getattr(cls, "params", ()) if q.name == param), "")
    return unit.partition(" (")[0]


def _rung_plant(base, step):
    """The model after a rung, rebuilt from its ``model`` (effects as in a plant file) and its free
    plant values on the baseline plant (the datasheet values as the baseline has them)."""
    from dataclasses import replace
    from ..errors import ConfigError
    from ..experiment.files import check_effects_on
    from ..identify.fit import Free, set_values
    bare = replace(base, effects=())
    problems: list[str] = []
    effects = check_effects_on(bare, step.model, [f"effects[{i}]" for i in range(len(step.model))], problems)
    if problems:
        raise ConfigError("rung", problems)
    plant = bare.with_effects(*effects)
    frees = [Free.plant(plant, k) for k in step.plant_params]
    return set_values(plant, frees, list(step.plant_params.values())) if frees else plant


def ladder_table(d, table_id: str = "ladder") -> str:
    """The ladder: each rung's effect and parameters (value +- standard error), the error before
    and after it (RMS of the primary signal's residual), their ratio and the ratio to the noise floor."""
    unit, floor = d.unit, d.noise_floor
    rows = [["0", "(the plant as given)", "", "", num(d.baseline_error), "", num(d.baseline_error / floor, ".3g")
             if floor > 0 else ""]]
    before = d.baseline_error
    for i, s in d.rows():
        if i is None:
            cal = ", ".join(f"{k} = {num(c['value'])}" for k, c in d.calibration.items() if c["status"] == "calibrated")
            after, label, pars = s, "(datasheet values calibrated)", cal
        else:
            after = s.error
            label = ("taken out: " if s.action == "remove" else "+ ") + s.effect + (
                f" ({', '.join(map(str, s.options.values()))})" if s.options else "")
            pars = ", ".join(f"{p} = {num(v)}" + (f" \u00b1 {num(s.stderr[p], '.2g')}" if s.stderr.get(p) is not None
                                                  else "") + (f" {_unit_of(s.effect, p)}" if _unit_of(s.effect, p)
                                                              else "") for p, v in s.params.items())
        rows.append(["" if i is None else str(i), label, pars, num(before), num(after),
                     num(after / before, ".3g") if before > 0 else "", num(after / floor, ".3g") if floor > 0 else ""])
        before = after
    return table(["step", "effect", "parameters (\u00b1 standard error)", f"error before ({unit})",
                  f"error after ({unit})", "after / before", "after / noise floor"], rows, numeric=(3, 4, 5, 6),
                 table_id=table_id)


def fitted_values_block(d) -> str:
    """Each rung's fitted values with their standard errors (and the standard error relative to the
    value), the strongly correlated pairs of estimates, and the final model's effects."""
    rows, corr = [], []
    for i, s in enumerate(d.ladder, 1):
        for p, v in s.params.items():
            se = s.stderr.get(p)
            rel = abs(se / v) if se is not None and v else None
            rows.append([str(i), s.effect, p, num(v, ".6g"), num(se, ".3g"), _unit_of(s.effect, p),
                         num(rel, ".1%") if rel is not None else "\u2014"])
        corr += [[str(i), c["a"], c["b"], num(c["rho"], "+.3f")] for c in s.correlations]
    out = [table(["step", "effect", "parameter", "value", "standard error", "unit", "relative"], rows,
                 numeric=(3, 4, 6))] if rows else ["<p>No effect was added.</p>"]
    out.append("<h3>Correlated estimates</h3>")
    out.append(table(["step", "parameter", "parameter", "correlation"], corr, numeric=(3,)) if corr else
               "<p>No pair of fitted estimates correlates beyond \u00b10.9: each standard error can be read alone.</p>")
    final = [e.to_dict() for e in d.plant.effects]
    if final:
        out.append("<h3>The final model's effects (as the plant file writes them)</h3>")
        out.append(table(["effect", "values"], [[e.get("type", ""), ", ".join(
            f"{k} = {num(v, '.6g') if isinstance(v, (int, float)) and not isinstance(v, bool) else v}"
            for k, v in e.items() if k != "type")] for e in final]))
    return "\n".join(out)


def candidates_table(candidates: Sequence[Mapping], unit: str) -> str:
    """The first rung's candidates, best first: effect, place, parameters, error, BIC, status."""
    rows = []
    for c in candidates:
        pars = ", ".join(f"{k} = {num(v)}" for k, v in c["params"].items())
        rows.append([c["effect"], ", ".join(map(str, c.get("options", {}).values())), pars, num(c["error"]),
                     num(c["bic"], ".6g"), c.get("k") if c.get("k") is not None else "\u2014",
                     c["status"] + (f": {c['message']}" if c.get("message") else "")])
    return table(["effect", "place", "parameters", f"error ({unit})", "BIC", "k", "status"], rows,
                 numeric=(3, 4, 5))


def calibration_block(j: Mapping) -> str:
    cal, step = j.get("calibration") or {}, j.get("calibration_step")
    if not cal:
        return "<p>No datasheet value was calibrated (calibration off, or no value with a tolerance).</p>"
    said = (f"<p>Calibrating paid after step {step['after_step']}: the error went to "
            f"{esc(num(step['error']))} {esc(j['error_unit'])} (BIC change {esc(num(step['bic_change'], '.6g'))}).</p>"
            if step else "<p>Calibrating the datasheet values did not pay: the file's values stay.</p>")
    return said + table(["value", "file", "final", "standard error", "unit", "tolerance", "status"],
                        [[k, num(c["nominal"], ".6g"), num(c["value"], ".6g"), num(c.get("stderr"), ".3g"), c["unit"],
                          f"{c['tolerance_pct']:g} %", c["status"] + (f": {c['message']}" if c.get("message") else "")]
                         for k, c in cal.items()], numeric=(1, 2, 3))


def timing_block(timing: Mapping | None) -> str:
    """Wall time, replays, solver steps and fits per stage, then per candidate (the diagnosis
    JSON's ``timing``); '' when the diagnosis has none."""
    if not timing:
        return ""
    stages = timing.get("stages") or []
    out = [f"<p>Wall time {esc(num(timing.get('wall_s'), '.3g', 's'))}.</p>"]
    if stages:
        out.append(table(["stage", "wall time (s)", "replays", "solver steps", "fits"],
                         [[s.get("stage", ""), num(s.get("wall_s"), ".3g"), s.get("replays", ""),
                           s.get("solver_steps", ""), s.get("fits", "")] for s in stages], numeric=(1, 2, 3, 4),
                         table_id="timing"))
    cands = timing.get("candidates") or []
    if cands:
        out.append("<h3>Per candidate</h3>")
        out.append(table(["effect", "wall time (s)", "replays", "fits"],
                         [[c.get("effect", ""), num(c.get("wall_s"), ".3g"), c.get("replays", ""), c.get("fits", "")]
                          for c in cands], numeric=(1, 2, 3)))
    return "\n".join(out)


def _replay_figures(report, what: str) -> tuple[list[str], list[str]]:
    """With the report's replay: the primary residual after each rung (one figure) and the baseline's
    primary signal against the record ("before"); then the final model's comparison blocks."""
    from ..errors import GearbenchError
    from .compare import comparison_figure, rung_residuals_figure
    d, replay = report.diagnosis, report.replay
    cmp = report.comparison()
    final = cmp.figures
    p, labels = final["primary"], final.get("labels")
    sims = [("baseline (the plant as given)", replay.run(d.baseline_plant))]
    for i, s in enumerate(d.ladder, 1):
        try:
            sims.append((f"after step {i}: {'- ' if s.action == 'remove' else '+ '}{s.effect}",
                         replay.run(_rung_plant(d.baseline_plant, s))))
        except (GearbenchError, ValueError, KeyError, TypeError):
            continue  # a model the plant file cannot hold, or the solver cannot replay: its panel is left out
    res = [(label, replay.residuals(sim)[p]) for label, sim in sims]
    note = " (the datasheet values as the file has them)" if d.calibration_step is not None else ""
    unit = replay.unit(p)
    blocks = [figure(rung_residuals_figure(replay.t, res, labels, p, unit, f"{p} residual as the ladder climbs{note}"),
                     "each rung's before (the panel above) and after: the primary residual after each step"),
              figure(comparison_figure(replay.t, replay.measured(p), sims[0][1][p], labels, p, unit,
                                       title=f"before: the plant as given, {what}",
                                       reinit_s=sims[0][1].reinitialised_s),
                     f"before: {p} measured and simulated by the plant as given")]
    return blocks, comparison_sections(cmp, what, heading="The final model against the record",
                                       table_id="final-signals")


def diagnosis_page(report, plant_file: str | Path | None = None, data_file: str | Path | None = None,
                   ladder_png: bytes | None = None) -> str:
    """The HTML page of a diagnosis (``gearbench diagnose``).

    Parameters
    ----------
    report : gearbench.api.DiagnosisReport
        The diagnosis; with its ``replay`` the page also shows the signals and residuals
        (one replay of each rung's model, a second or so), without it the tables alone.
    plant_file, data_file : str or Path, optional
        The files as the user named them (default: the report's plant label and record source).
    ladder_png : bytes, optional
        The ladder figure already made (``ladder.png``); default: rendered here.

    Returns
    -------
    str
        The whole document.
    """
    from .compare import ladder_figure
    d, j = report.diagnosis, report.to_dict()
    replay = getattr(report, "replay", None)
    plant_name = str(plant_file) if plant_file else (getattr(report, "plant_label", "") or d.plant.name)
    data_name = str(data_file) if data_file else (replay.data.source if replay is not None else "")
    what = f"{Path(plant_name).name} against {Path(data_name).name}" if data_name else Path(plant_name).name
    verdict = (f"Verdict: <b>{esc(d.verdict)}</b> \u2014 " if d.verdict else "Verdict: none \u2014 ") + esc(d.reason) + "."
    head = files({"plant file": plant_name, "plant": d.baseline_plant.name, "data file": data_name,
                  "replay": None if replay is None else ("closed loop" if replay.closed_loop else "open loop"),
                  "error": j["error_metric"], "stopped": d.stopped})
    ladder = ladder_png if ladder_png is not None else ladder_figure(
        d.ladder_steps(), noise_floor=d.noise_floor, unit=d.unit, title=f"{d.plant.name}: {what}",
        calibration=j["calibration"])
    before_after, final = _replay_figures(report, what) if replay is not None else ([], [])
    explain = '<ol class="explain">' + "".join(f"<li>{esc(s.explanation)}</li>" for s in d.ladder) + "</ol>" \
        if d.ladder else "<p>No rung: nothing was added.</p>"
    not_tried = ('<ul class="plain">' + "".join(f"<li><b>{esc(k)}</b>: {esc(v)}</li>" for k, v in d.not_tried.items())
                 + "</ul>") if d.not_tried else "<p>Every effect of the library could act here.</p>"
    body = [f'<p class="verdict">{verdict}</p>',
            row(section("Files", head, section_id="files"),
                section("Noise floors", noise_table(j["noise_floors"]), section_id="noise")),
            section("The ladder", ladder_table(d), figure(ladder, "the error as effects are added"), *before_after,
                    section_id="ladder-section"),
            section("Why: the explanation of each step", explain, section_id="explanations"),
            *_missing_section(d, what),
            section("Fitted values", fitted_values_block(d), section_id="values"),
            *(final or [section("Residual tests (the final model)", residual_tests_block(j["residual_tests"]),
                                section_id="residual-tests")]),
            section("Calibration of the plant's own values", calibration_block(j), section_id="calibration"),
            section("Candidates of the first step (best first)", candidates_table(j["candidates"], d.unit),
                    section_id="candidates"),
            section("Not tried", not_tried, section_id="not-tried")]
    if j.get("timing"):
        body.append(section("Timing", timing_block(j["timing"]), section_id="timing-section"))
    return page(f"diagnose: {what}", "Which physical effect is the model missing?", body)


def _missing_section(d, what: str) -> list[str]:
    """The torque the model misses, when the ladder ended above the record's noise."""
    if d.missing is None:
        return []
    from .missing import missing_torque_figure
    return [section("The torque the model misses", f"<p>{esc(d.missing.sentence())}.</p>",
                    figure(missing_torque_figure(d.missing, what), "the final model's residual as a torque at "
                           "the output, against position, speed and time"), section_id="missing-torque")]


# ---------------------------------------------------------------------- fit

def values_table(f, table_id: str = "values") -> str:
    """A fit's values with their standard errors, units and relative standard errors."""
    rows = []
    for k, v in f.values.items():
        se = f.stderr.get(k)
        rel = abs(se / v) if se is not None and v else None
        rows.append([k, num(v, ".6g"), num(se, ".3g"), f.units.get(k, ""), num(rel, ".1%") if rel is not None
                     else "\u2014"])
    return table(["parameter", "value", "standard error", "unit", "relative"], rows, numeric=(1, 2, 4),
                 table_id=table_id)


def correlation_table(correlation: Mapping) -> str:
    """The correlation of each pair of estimates, as a matrix."""
    names = list(correlation)
    if len(names) < 2:
        return "<p>One parameter: no correlation to show.</p>"
    return table(["", *names], [[a, *(num(correlation[a].get(b), "+.3f") for b in names)] for a in names],
                 numeric=tuple(range(1, len(names) + 1)))


def _fit_replay_sections(f, what: str, plant_name: str) -> tuple[str, list[str]]:
    """With a fit's replay: the noise floors, then the plant before the fit against the record
    (one replay) and the fitted model's comparison blocks."""
    from .compare import comparison_figure
    from dataclasses import replace
    replay = f.replay
    cmp = replace(f.comparison(), plant_label=plant_name)
    c = cmp.figures
    floors = {n: {"floor": replay.noise_floor(n), "unit": replay.unit(n), "stated": n in (replay.noise_std or {})}
              for n in replay.compared()}
    out = []
    base = getattr(f, "base_plant", None)
    if base is not None:
        p = c["primary"]
        sim = replay.run(base)
        out.append(section("Before the fit", figure(comparison_figure(
            replay.t, replay.measured(p), sim[p], c.get("labels"), p, replay.unit(p),
            title=f"before: the plant without {f.effect}, {what}", reinit_s=sim.reinitialised_s),
            f"before: {p} measured and simulated by the plant without {f.effect}"), section_id="before"))
    out += comparison_sections(cmp, what, heading="The fitted model against the record", table_id="fit-signals")
    return section("Noise floors", noise_table(floors), section_id="noise"), out


def fit_page(f, plant_file: str | Path | None = None, data_file: str | Path | None = None,
             output: str | Path | None = None) -> str:
    """The HTML page of a fit (``gearbench fit``).

    Parameters
    ----------
    f : gearbench.api.FitReport
        The fit; with its ``replay`` the page also shows the fitted model against the record
        (one replay) and the plant before the effect (one more).
    plant_file, data_file : str or Path, optional
        The files as the user named them (default: the report's plant label and record source).
    output : str or Path, optional
        The plant file the fit wrote.

    Returns
    -------
    str
        The whole document.
    """
    replay = getattr(f, "replay", None)
    plant_name = str(plant_file) if plant_file else (getattr(f, "plant_label", "") or f.plant.name)
    data_name = str(data_file) if data_file else (replay.data.source if replay is not None else "")
    what = f"{Path(plant_name).name} against {Path(data_name).name}" if data_name else Path(plant_name).name
    head = files({"plant file": plant_name, "data file": data_name, "new plant file": output, "effect": f.effect,
                  "error": f"RMS of the {f.signal} residual (measured - simulated), {f.unit}",
                  "optimiser": f.message})
    said = (f'<p class="verdict">{esc(f.effect)}: the error (RMS of {esc(f.signal)}) goes from '
            f"{esc(num(f.error_before))} to {esc(num(f.error_after))} {esc(f.unit)}"
            + (f" (after / before {esc(num(f.error_after / f.error_before, '.3g'))})" if f.error_before > 0 else "")
            + ".</p>")
    tried = table(["place", "converged", "note"], [[t["effect"], yes_no(t["converged"]), t.get("note", "")]
                                                   for t in f.tried]) if f.tried else ""
    noise, against = _fit_replay_sections(f, what, plant_name) if replay is not None else ("", [])
    body = [said, row(section("Files", head, section_id="files"), noise),
            section("Fitted values", values_table(f), "<h3>Correlations of the estimates</h3>",
                    correlation_table(f.correlation), section_id="fitted"),
            section("Places tried", tried or "<p>One place.</p>", section_id="tried"), *against]
    return page(f"fit: {f.effect}, {what}", "An effect added to the plant and fitted to the record.", body)


# ------------------------------------------------------------ notebook cards

def simulation_card(sim) -> str:
    """A notebook's view of a :class:`gearbench.api.Simulation`: its scores and a small plot."""
    d = sim.to_dict()
    units = {"iae_deg_s": "deg s", "rms_deg": "deg", "max_deg": "deg", "iae_mm_s": "mm s"}
    rows = [[k, num(v, ".6g") if isinstance(v, float) else ("" if v is None else v), units.get(k, "")]
            for k, v in d.items() if k != "message" or v]
    return card(f"<b>Simulation</b> of {esc(sim.plant.name)}: {esc(sim.profile)}, {sim.time_s.size} samples",
                table(["", "value", "unit"], rows, numeric=(1,), table_id="simulation"),
                img(sim.plot(), "the run", CARD_DPI))


def comparison_card(cmp) -> str:
    """A notebook's view of a :class:`gearbench.api.Comparison`: the signals table and the
    primary signal measured against simulated."""
    return card(f"<b>Comparison</b> of {esc(cmp.plant_label or cmp.plant.name)} with {esc(Path(cmp.data.source).name)}"
                f" ({'closed' if cmp.closed_loop else 'open'} loop)", signals_table(cmp.signals, "signals"),
                img(cmp.plot(), f"{cmp.primary}: measured vs simulated", CARD_DPI))


def diagnosis_card(report) -> str:
    """A notebook's view of a :class:`gearbench.api.DiagnosisReport`: the verdict, the ladder
    table and the ladder figure."""
    d = report.diagnosis
    verdict = f"verdict <b>{esc(d.verdict)}</b>" if d.verdict else f"verdict: none. {esc(d.reason)}"
    return card(f"<b>Diagnosis</b> of {esc(d.baseline_plant.name)}: {verdict}", ladder_table(d),
                img(report.plot(), "the ladder", CARD_DPI + 15))


def fit_card(f) -> str:
    """A notebook's view of a :class:`gearbench.api.FitReport`: the values table and the error
    before and after."""
    from .compare import ladder_figure
    fig = ladder_figure([{"effect": "before", "error": f.error_before}, {"effect": f.effect, "error": f.error_after}],
                        unit=f.unit, title=f"RMS of {f.signal}")
    return card(f"<b>Fit</b> of {esc(f.effect)}: error {esc(num(f.error_before))} \u2192 {esc(num(f.error_after))} "
                f"{esc(f.unit)}", values_table(f), img(fig, "the error before and after", CARD_DPI + 15))
