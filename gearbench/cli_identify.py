"""``gearbench compare``, ``diagnose`` and ``fit``: the model against a measurement."""
from __future__ import annotations

import json
import math
import sys
from contextlib import contextmanager
from pathlib import Path

import click
from rich.table import Table

from .cli_common import EXIT_FAILED, _fail, console, echo_json, interrupted, parse_noise, stdout
from .errors import DiagnosisInterrupted, GearbenchError


_common = [
    click.argument("plant_file", metavar="PLANT.yaml", type=click.Path(exists=True, dir_okay=False, path_type=Path)),
    click.argument("data_file", metavar="DATA.csv", type=click.Path(exists=True, dir_okay=False, path_type=Path)),
    click.option("--controller", "controller_file", type=click.Path(exists=True, dir_okay=False, path_type=Path),
                 help="Replay the record in closed loop with this controller (a controller file, e.g. "
                      "experiments/controllers/emps.yaml) driven by the record's set point, comparing the "
                      "simulated and measured input too.  Default: open loop, driven by the measured input."),
    click.option("--window", "window_s", type=float, default=1.0, show_default=True,
                 help="Open loop: re-initialise the model's angles from the record every WINDOW s (at the "
                      "slowest sample near each boundary), so an integrating plant does not drift; 0 = never."),
    click.option("--rtol", type=float, default=1e-6, show_default=True, help="Solver relative tolerance."),
    click.option("--noise", "noise", multiple=True, metavar="SIGNAL=STD",
                 help="The measurement noise of a compared column, a standard deviation in its unit, where you "
                      "know it (a record of the machine at rest, the sensor's datasheet); all=STD for every "
                      "column; repeatable.  It is the column's noise floor and weight, and the least drift a "
                      "window's reset acts on.  Default: read from the record's third differences, which "
                      "assumes white noise."),
    click.option("--noise-from", "noise_from", type=click.Path(exists=True, dir_okay=False, path_type=Path),
                 metavar="REST.csv",
                 help="A record of the machine at rest (same columns as DATA): each compared column's noise is "
                      "its standard deviation there (at least a count's q/sqrt(12)), white or coloured; "
                      "--noise entries win."),
]


def _remember_gaps(ctx, param, value):
    ctx.meta["gearbench.gaps"] = value
    return value


_gaps = click.option(
    "--gaps", type=click.Choice(["interpolate", "drop"]), default=None, expose_value=False, callback=_remember_gaps,
    help="A few missing samples (empty cells, rows missing from the time grid): 'interpolate' fills runs of up "
         "to 5 (signals linearly, the input held), 'drop' drops them at the record's start or end only (the "
         "replay needs a uniform time grid).  Says how many and where (the JSON's 'gaps').  Default: refuse "
         "the record, naming the first missing sample.")


def _remember_reset_speeds(ctx, param, value):
    ctx.meta["gearbench.reset_speeds"] = value
    return value


_reset_speeds = click.option(
    "--reset-speeds", is_flag=True, default=False, expose_value=False, callback=_remember_reset_speeds,
    help="Open loop: at every window seam set the model's speeds to the measured ones too (a local quartic "
         "fit of the measured angles), not only its angles, and start the model as the record's first sample "
         "has it (angles, a shaft's twist, speeds), not at rest.  For a record whose low frequencies are not "
         "excited (a multisine on a current-driven machine), where a window's speed error carried into the "
         "next drifts the angles more than the dynamics move them (docs: the two-mass bench).")


def common(f):
    from .cli_import import column_options  # --columns/--units/--columns-file: read by _setup
    f = column_options(expose=False)(f)
    f = _gaps(f)  # read by _setup from the context, like the column options
    f = _reset_speeds(f)
    for deco in reversed(_common):
        f = deco(f)
    return f




def _setup(plant_file, data_file, controller_file, window_s, rtol, noise=(), noise_from=None):
    """Plant, record and replay, every file and ``--noise`` checked before any solving (the files
    read with the column options, the replay built as the API's)."""
    from .api import _replay
    from .experiment.controller_file import load_controller
    from .experiment.files import load_plant
    from .cli_import import context_column_map
    from .measure.data import read_measurement
    gaps = click.get_current_context().meta.get("gearbench.gaps")
    plant = load_plant(plant_file)
    data = read_measurement(data_file, context_column_map(), gaps=gaps)
    if data.gaps is not None:
        console.print(data.gaps.sentence(), highlight=False)
    controller = load_controller(controller_file) if controller_file else None
    rest = None if noise_from is None else read_measurement(noise_from, context_column_map())
    return _replay(plant, data, controller, window_s, rtol, str(data_file), parse_noise(noise, positive=True), rest,
                   gaps, click.get_current_context().meta.get("gearbench.reset_speeds", False))


def _errors():
    """The errors a command reports on stderr and exits with (``cli_common.fail``): 1 for a replay the
    solver could not finish (``ReplayRunError``, a ``SolverError``), else 2 (bad input).

    ``ValueError`` too, deliberately: the commands' own option checks (``--noise``, ``--effect``'s
    parsing) and some checks of the library raise a plain ``ValueError`` for bad input: a column
    too short for a noise estimate (``measure.noise``)."""
    return (GearbenchError, ValueError)


_scheduler = click.option(
    "--scheduler", metavar="tcp://HOST:PORT", default=None,
    help="Fit the candidates on this running Dask distributed scheduler instead of local processes "
         "(one task per fit; the same answer).")


def _html_option(default: str):
    return click.option("--html", "html_file", type=click.Path(dir_okay=False, path_type=Path), default=None,
                        metavar="FILE",
                        help="Write the self-contained HTML report (every figure embedded; it opens with no "
                             f"network, from an e-mail attachment) to FILE.  Default: {default}.")


def _out_dir(results: Path, kind: str, plant_file: Path, data_file: Path) -> Path:
    """RESULTS/<kind>_<plant>_<data>: one folder per pair, so comparing two plants keeps both."""
    return results / f"{kind}_{plant_file.stem}_{data_file.stem}"


@click.command()
@common
@click.option("--results", type=click.Path(file_okay=False, path_type=Path), default=Path("results"),
              show_default=True, help="Folder; figures and tables go to RESULTS/compare_<PLANT>_<DATA>/.")
@click.option("--json", "as_json", is_flag=True, help="Print the figures as one JSON object on stdout.")
@click.option("--lags", type=click.IntRange(min=1), default=25, show_default=True,
              help="Residual tests: the largest lag, in samples, of the residual's autocorrelation (0..LAGS) "
                   "and of its cross-correlation with the input (-LAGS..LAGS).")
@_html_option("report.html beside the figures")
def compare(plant_file, data_file, controller_file, window_s, rtol, noise, noise_from, results, as_json, lags,
            html_file):
    """Drive the model as the record was driven and show where it fails.

    For each measured signal: RMS and maximum error in its unit, the noise
    floor estimated from the record, their ratio.  Where: the record cut into
    phases (standstill, steady motion, direction reversal, acceleration) with
    the share of the error each carries.  Residual tests (as MATLAB's resid):
    is each residual white, and independent of the input (the set point in
    closed loop)?  Its autocorrelation and cross-correlation with 99 % bands,
    and a sentence naming the lags that leave them.  Figures: measured vs
    simulated with the residual and the input under it, the phases shaded and
    the re-initialisations marked, one per signal; the residual against speed,
    position and direction; the residual tests.  All of it, with the noise floors, in one
    self-contained HTML page (report.html, or --html FILE).
    """
    from .api import Comparison
    from .identify.compare import comparison
    from .report.compare import comparison_figures
    from .report.html import comparison_page
    from .report.io import save_figure_atomic, write_text_atomic
    try:
        plant, data, replay = _setup(plant_file, data_file, controller_file, window_s, rtol, noise, noise_from)
        cmp = Comparison(plant, data, replay.closed_loop, comparison(replay, plant, lags=lags), replay.t,
                         plant_file.name)
    except _errors() as exc:
        _fail(exc)
    c = cmp.figures
    out = _out_dir(results, "compare", plant_file, data_file)
    # Files, not the plant's name: a plant before and after a fit has one name.
    what = f"{plant_file.name} against {data_file.name}"
    figures = [save_figure_atomic(fig, out / name) for name, fig in comparison_figures(cmp, what)]
    tests = c["residual_tests"]
    summary = {**cmp.to_dict(), "plant_file": str(plant_file), "data": str(data_file),
               "figures": [str(f) for f in figures]}
    write_text_atomic(out / "compare.md", cmp.to_markdown(what, [f.name for f in figures]))
    write_text_atomic(out / "compare.json", json.dumps(summary, indent=1) + "\n")
    page = comparison_page(cmp, plant_file, data_file, {f.name: f.read_bytes() for f in figures})
    report = write_text_atomic(html_file or out / "report.html", page)
    if as_json:
        echo_json(summary)
        return
    tab = Table(title=f"{what} ({'closed' if replay.closed_loop else 'open'} loop)")
    for col in ("signal", "unit", "RMS error", "max error", "noise floor", "RMS/noise", "relative %"):
        tab.add_column(col, justify="left" if col in ("signal", "unit") else "right", no_wrap=True)
    for r in c["signals"]:
        tab.add_row(r["signal"], r["unit"], f"{r['rms_error']:.4g}", f"{r['max_error']:.4g}",
                    f"{r['noise_floor']:.3g}", f"{r['ratio_to_noise']:.3g}", f"{r['relative_error_pct']:.3g}")
    stdout().print(tab)
    if c.get("phases"):
        tp = Table(title=f"where the {c['primary']} error sits")
        for col in ("phase", "time share", "error share", "RMS"):
            tp.add_column(col)
        for k, v in c["phases"].items():
            tp.add_row(k, f"{v['time_share']:.1%}", f"{v['error_share']:.1%}", f"{v['rms']:.4g}")
        stdout().print(tp)
    stdout().print("[bold]residual tests[/]")
    for v in tests.values():
        stdout().print(v.sentence(), highlight=False, soft_wrap=True)
    console.print(f"figures and tables in {out}/; the report: {report}")


@click.command()
@common
@click.option("--free", "free", multiple=True, metavar="KEY",
              help="A plant parameter refitted with every candidate and in the baseline (e.g. leadscrew.mass).")
@click.option("--only", "only", default="", metavar="NAME,NAME",
              help="Try only these effects (a model structure), comma-separated.")
@click.option("--also", "also", default="", metavar="NAME,NAME",
              help="Try these effects as well, which are tried only when asked for (lugre_friction, "
                   "winding_heating), comma-separated.")
@click.option("--calibrate/--no-calibrate", default=True, show_default=True,
              help="Calibrate the plant's own datasheet values within their tolerances (the plant file's "
                   "'{value, tolerance_pct}', else 20 % on resistance, torque constant, inertias, dampings): "
                   "a step that competes with the effects by the same criterion, not an effect; values the "
                   "record cannot resolve are held.")
@click.option("--max-steps", type=int, default=4, show_default=True, help="Longest ladder.")
@click.option("--time-limit", "time_limit_s", type=click.FloatRange(min=0.0), default=None, metavar="SECONDS",
              help="Start no new rung after SECONDS (the rung that crosses it finishes); the JSON's 'stopped' "
                   "is then \"time limit\".")
@click.option("--workers", type=int, default=None,
              help="Local processes (default: all cores); ignored with --scheduler.")
@_scheduler
@click.option("--quiet", is_flag=True, help="No progress display on stderr (for scripts; --json shows none either).")
@click.option("--results", type=click.Path(file_okay=False, path_type=Path), default=Path("results"),
              show_default=True, help="Folder; the ladder figure and tables go to RESULTS/diagnose_<PLANT>_<DATA>/.")
@click.option("--json", "as_json", is_flag=True,
              help="Print the SPEC's JSON object on stdout: baseline_error, noise_floor, candidates (best first "
                   "by BIC: the Bayesian information criterion n ln(RSS/n) + k ln n of the noise-weighted residuals "
                   "of every compared signal, lowest first; the places of one effect (location, signal) share the "
                   "slots their BICs earn, ordered by the evidence of each signal, sum over signals of "
                   "n_s ln(RSS_s/n_s); failed fits last with error and bic null, a status "
                   "and a message), verdict, ladder.  Every 'error' is the RMS of the primary signal's residual (measured - "
                   "simulated) in that signal's unit, the same metric and unit as baseline_error (named in "
                   "'error_signal' and 'error_unit'): the output angle or position in open loop, the input "
                   "(e.g. the drive force) in closed loop.  'stopped' says why the ladder ended: \"noise floor\", "
                   "\"nothing pays\", \"max steps\" or \"time limit\".  'noise_floors': each signal's floor, "
                   "unit and whether it was stated (--noise); 'residual_tests': the final model's, per signal "
                   "(white, input_independent, lag1, ljung_box_p, sentence); 'not_tried': the effects that "
                   "cannot act on this plant and record, each with why; 'timing': where the time went, "
                   "{wall_s, stages: [{stage, wall_s, replays, solver_steps, fits}], candidates: [{effect, "
                   "wall_s, replays, fits}]} (a replay: one simulation of the record, all its windows; "
                   "solver_steps: the integrator's accepted steps; fits: least-squares fits; a candidate's "
                   "wall_s is its own fits' time wherever they ran, pairs as \"a+b\"; docs/diagnose-json.md).")
@_html_option("report.html beside the ladder figure")
def diagnose(plant_file, data_file, controller_file, window_s, rtol, noise, noise_from, free, only, also, calibrate,
             max_steps, time_limit_s, workers, scheduler, quiet, results, as_json, html_file):
    """Which physical effect is the model missing?

    Fits every effect of the library that the plant lacks (those tried only
    when asked for, with --also), in every place it can act (a space-filling scan of its parameters, then local least squares),
    ranks them by the Bayesian information criterion (which charges
    for each added parameter, so an effect that does not help never wins;
    the places of one effect by the evidence of every signal),
    refits the best effects jointly in pairs (a pair that beats the best single
    takes two rungs),
    explains the evidence in words, and climbs the ladder: add the best,
    refit, diagnose again, until nothing more pays.  The verdict is null when
    the model already explains the record down to its noise, or when no
    candidate explains the residual.

    A progress display on stderr follows the whole ladder: the step, the stage (candidates, joint
    refit, calibration, pairs, ...), the fit just finished and the best so far; when stderr is not a
    terminal, plain lines (one per stage, at most one every 5 s otherwise; none with --quiet or
    --json).  Ctrl-C stops
    cleanly: the ladder so far is printed and the exit status is 130.

    Beside the ladder figure and the tables, one self-contained HTML page (report.html, or
    --html FILE) holds it all: the ladder with each rung's before and after, the explanations,
    the fitted values, the final model's signals and residual tests, the calibration.
    """
    from .api import diagnose_replay
    from .report.compare import ladder_figure
    from .report.html import diagnosis_page
    from .report.io import save_figure_atomic, write_text_atomic
    try:
        plant, data, replay = _setup(plant_file, data_file, controller_file, window_s, rtol, noise, noise_from)
        names, extra = (tuple(n.strip() for n in arg.split(",") if n.strip()) for arg in (only, also))
        with _ladder_progress(disable=quiet or as_json) as show:
            rep = diagnose_replay(plant, replay, free=free, only=names, also=extra, max_steps=max_steps,
                                  workers=workers, calibrate=calibrate, time_limit_s=time_limit_s, scheduler=scheduler,
                                  progress=show)
        d = rep.diagnosis
    except _errors() as exc:
        _fail(exc)
    except DiagnosisInterrupted as stop:
        _print_ladder(stop.diagnosis, console)
        interrupted(f"during ladder step {len(stop.diagnosis.ladder) + 1}; the ladder so far is above, "
                    "no file was written")
    j = d.to_json()
    out = _out_dir(results, "diagnose", plant_file, data_file)
    cal = j["calibration"]
    fig = ladder_figure(d.ladder_steps(), noise_floor=d.noise_floor, unit=d.unit,
                        title=f"{plant.name}: {data_file.name}", calibration=cal)
    ladder_png = save_figure_atomic(fig, out / "ladder.png")
    if d.missing is not None:
        from .report.missing import missing_torque_figure
        save_figure_atomic(missing_torque_figure(d.missing, f"{plant.name}: {data_file.name}"),
                           out / "missing_torque.png")
    write_text_atomic(out / "diagnose.json", json.dumps(j, indent=1) + "\n")
    write_text_atomic(out / "diagnose.md", d.to_markdown(f"diagnose {plant.name} against {data_file.name}"))
    try:
        report = write_text_atomic(html_file or out / "report.html",
                                   diagnosis_page(rep, plant_file, data_file, ladder_png.read_bytes()))
    except _errors() as exc:  # a replay of a rung's model the solver could not finish: the rest stands
        _fail(exc)
    if as_json:
        echo_json(j)
        return
    tab = Table(title=f"candidates for {plant.name} against {data_file.name} (best first)")
    for col in ("effect", "parameters", f"error ({d.unit})", "BIC"):
        tab.add_column(col)
    for t in d.tried:
        pars = ", ".join(f"{k} = {v:.4g}" for k, v in t.params.items())
        tab.add_row(t.candidate.label(), pars if t.ok else t.note[:60],
                    f"{t.result.error:.4g}" if t.ok else "—", f"{t.result.bic:.6g}" if t.ok else "—")
    stdout().print(tab)
    for name, why in d.not_tried.items():
        stdout().print(f"not tried: {name} — {why}", highlight=False)
    _print_ladder(d, stdout())
    stdout().print(f"noise floor: {d.noise_floor:.4g} {d.unit}")
    for k, c in cal.items():
        if c["status"] == "held":
            stdout().print(f"{k}: {c['message']}", highlight=False)
    if d.verdict:
        stdout().print(f"[bold]verdict: {d.verdict}[/]")
        for i, s in enumerate(d.ladder, 1):
            stdout().print(f"{i}. {s.explanation}")
    else:
        stdout().print(f"[bold]verdict: none[/] — {d.reason}")
    if d.ladder:
        stdout().print(f"stopped: {d.reason}")
    console.print(f"figures and tables in {out}/; the report: {report}")


def _print_ladder(d, where) -> None:
    """The ladder as a table on console ``where``: the baseline, each rung, the calibration."""
    cal = d.calibration
    lad = Table(title=f"the ladder: error (RMS of {d.signal}, {d.unit}) as effects are added")
    for col in ("step", "effect", "parameters", "error"):
        lad.add_column(col)
    lad.add_row("0", "(as given)", "", f"{d.baseline_error:.4g}")
    for i, s in d.rows():
        if i is None:
            lad.add_row("", "(datasheet values calibrated)", ", ".join(
                f"{k} = {c['value']:.4g}" for k, c in cal.items() if c["status"] == "calibrated"), f"{s:.4g}")
            continue
        lad.add_row(str(i), ("taken out: " if s.action == "remove" else "")
                    + s.effect + (f" ({', '.join(s.options.values())})" if s.options else ""),
                    ", ".join(f"{k} = {v:.4g}" for k, v in s.params.items()), f"{s.error:.4g}")
    where.print(lad)


@contextmanager
def _ladder_progress(disable: bool):
    """A rich progress display of the whole ladder on stderr; yields the callback ``diagnose`` takes
    (:class:`gearbench.identify.progress.ProgressEvent`), None when ``disable``.  When stderr is not a
    terminal (a CI log, ``| tee``), plain lines instead (:class:`~gearbench.identify.progress.PlainLines`:
    one per stage, at most one every 5 s otherwise)."""
    if disable:
        yield None
        return
    if not console.is_terminal:
        from .identify.progress import PlainLines
        yield PlainLines(lambda text: click.echo(text, err=True))
        return
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, SpinnerColumn, TextColumn, TimeElapsedColumn
    with Progress(SpinnerColumn(), TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
                  TimeElapsedColumn(), TextColumn("{task.fields[best]}"), console=console, transient=True) as bar:
        task = bar.add_task("diagnose", total=None, best="")

        def show(e):
            what = f"step {e.step}: {e.stage}" + (f", {e.label}" if e.label else "")
            bar.update(task, description=what, completed=e.done, total=e.total or None,
                       best=f"best so far: {e.best}" if e.best else "")
        yield show


@click.command()
@common
@click.option("--effect", "effect_spec", required=True, metavar="'NAME [key=value ...]'",
              help="The effect to add, with its options (location=..., signal=...) and optional starting values; "
                   "without a location every allowed place is tried and the best kept.")
@click.option("--free", "free", multiple=True, metavar="KEY", help="A plant parameter fitted too (e.g. load.inertia).")
@click.option("--refit", is_flag=True, help="Refit the parameters of the effects the plant already has, too.")
@click.option("--calibrate", is_flag=True,
              help="Fit the plant's own datasheet values within their tolerances too (as diagnose does); "
                   "best once the model has every effect, since beside an incomplete model they take up "
                   "part of what is missing.")
@click.option("--max-evals", type=int, default=None,
              help="Most simulations the least-squares fit may spend (default: 40 per parameter + 40).")
@_scheduler
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path), required=True,
              help="The new plant file (written only if the fit converges).")
@click.option("--json", "as_json", is_flag=True,
              help="Print {converged, effect, values, stderr, units, correlation (parameter -> parameter -> "
                   "correlation of the two estimates), numerical (how far each value moves when the fit is finished "
                   "at a hundredth of --rtol), refined (whether it was: where some move exceeds 0.3 standard "
                   "errors), error_before, error_after, error_unit, "
                   "error_signal, message (the optimiser's), output, tried} as one JSON object on stdout instead "
                   "of the table.")
@_html_option("the new plant file's name with .html (NEW.html beside NEW.yaml)")
def fit(plant_file, data_file, controller_file, window_s, rtol, noise, noise_from, effect_spec, free, refit,
        calibrate, max_evals, scheduler, output, as_json, html_file):
    """Add an effect to PLANT, fit its parameters to DATA, write NEW.yaml.

    The new plant file holds the fitted values with their standard errors (and
    units) as comments; the table lists them, then the pairs of estimates
    correlated beyond +-0.9.  The standard errors hold for residuals correlated
    in time (a prewhitened Newey-West sandwich, gearbench.identify.uncertainty).
    A fit that does not converge says so, writes nothing and exits 1.  A converged fit also
    writes a self-contained HTML report (NEW.html, or --html FILE): the values, standard errors
    and correlations, the signals before and after, the residual tests.
    """
    from .api import attempts, fit_report
    from .cli_synth import parse_effect
    from .experiment.writer import update_plant_yaml
    from .errors import NotConverged
    from .identify.candidates import check_names
    from .identify.numerics import TIGHTER
    from .identify.uncertainty import strong_correlations
    from .plant.effects import REGISTRY
    from .report.html import fit_page
    from .report.io import write_text_atomic
    try:
        plant, data, replay = _setup(plant_file, data_file, controller_file, window_s, rtol, noise, noise_from)
        item = parse_effect(effect_spec)
        name = item.pop("type")
        check_names([name], "--effect")
        opts = {k: v for k, v in item.items() if k in REGISTRY[name].options}
        start = {k: v for k, v in item.items() if k not in opts}
        with console.status(f"fitting {name}"):
            f = fit_report(plant, replay, name, opts, start, free, refit, max_evals, calibrate, scheduler)
    except NotConverged as exc:
        if as_json:
            echo_json({"converged": False, "effect": name, "output": None, "tried": attempts(exc.tried)})
        console.print(f"[bold red]error:[/] {exc} {output}: nothing written.", highlight=False)
        sys.exit(EXIT_FAILED)
    except _errors() as exc:
        _fail(exc)
    header = (f"{plant.name} + {f.effect}, fitted by gearbench fit to {data_file.name}\n"
              f"error (RMS of {f.signal}): {f.error_before:.4g} -> {f.error_after:.4g}")
    # the user's file edited in place of a fresh dump: comments, key order and description stay
    write_text_atomic(output, update_plant_yaml(plant_file.read_text(encoding="utf-8"), plant, f.plant,
                                                f.stderr, header, f.units))
    try:
        beside = output.with_suffix(".html" if output.suffix != ".html" else ".report.html")
        report = write_text_atomic(html_file or beside, fit_page(f, plant_file, data_file, output))
    except _errors() as exc:
        _fail(exc)
    if as_json:
        echo_json({"converged": True, **f.to_dict(), "output": str(output)})
        console.print(f"error (RMS of {f.signal}): {f.error_before:.4g} -> {f.error_after:.4g}; wrote {output} "
                      f"and {report}", highlight=False)
        return
    tab = Table(title=f"{f.effect} fitted to {data_file.name}")
    for col in ("parameter", "value", "standard error", "unit"):
        tab.add_column(col)
    for k, v in f.values.items():
        se = f.stderr.get(k, math.nan)
        tab.add_row(k, f"{v:.6g}", f"{se:.3g}", f.units.get(k, ""))
    stdout().print(tab)
    for a, b, rho in strong_correlations(f.correlation):
        stdout().print(f"correlated estimates: {a} and {b}, {rho:+.3f}", highlight=False)
    if f.refined:
        moved = max((abs(v) / f.stderr[k] for k, v in f.numerical.items() if f.stderr.get(k)), default=0.0)
        stdout().print(f"finished at rtol {rtol / TIGHTER:g}: the replay at rtol {rtol:g} had left the values up to "
                       f"{moved:.2g} standard errors off", highlight=False)
    stdout().print(f"error (RMS of {f.signal}): {f.error_before:.4g} -> {f.error_after:.4g}; wrote {output} and {report}",
                   highlight=False)
