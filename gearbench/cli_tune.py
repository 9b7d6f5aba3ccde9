"""``gearbench tune``: the command-line face of :func:`gearbench.tune`."""
from __future__ import annotations

import json
import sys
from pathlib import Path

import click

from .cli_common import EXIT_FAILED, _fail, console, echo_json, jsonable, stdout
from .errors import GearbenchError


def _ranges(specs: tuple[str, ...]) -> dict:
    out = {}
    for spec in specs:
        name, _, pair = spec.partition("=")
        try:
            out[name.strip()] = tuple(float(v) for v in pair.split(","))
        except ValueError:
            raise click.BadParameter(f"{spec!r}: expected NAME=LOW,HIGH (e.g. kp=1,1000)", param_hint="--range")
    return out


@click.command()
@click.argument("plant_file", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option("--controller", "kind", type=click.Choice(["p", "pi", "pid"]), default="pi", show_default=True,
              help="The law tuned: Kp (V/deg); PI adds Ki (1/s), PID Kd (s).")
@click.option("--compensator", "compensators", multiple=True, metavar="NAME",
              help="Backlash compensator tuned with it (its shift too); repeat to compare several "
                   "(none, thesis_shift, setpoint_direction, direction_feedforward, damped_feedforward). "
                   "Default: none.")
@click.option("--profile", default="profile1", show_default=True, metavar="1|2|3|FILE",
              help="Set point: the thesis's profile 1, 2 or 3, or a profile file.")
@click.option("--objective", type=click.Choice(["iae", "rms", "max"]), default="iae", show_default=True,
              help="Integrated absolute output error (deg s), its RMS (deg), or the largest error (deg).")
@click.option("--limit", "limits", default="", metavar="NAME=VALUE,...",
              help="Upper bounds on each run: voltage_sign_changes, saturated_fraction (0-1), impacts, "
                   "max_deg, rms_deg, iae_deg_s; e.g. voltage_sign_changes=20,saturated_fraction=0.1.")
@click.option("--robust", type=click.IntRange(min=0), default=0, show_default=True, metavar="N",
              help="Judge each candidate on N plants drawn from --uncertainty and the datasheet tolerances.")
@click.option("--robust-stat", type=click.Choice(["mean", "p90", "max"]), default="mean", show_default=True,
              help="The robust objective over the N plants.")
@click.option("--uncertainty", type=click.Path(exists=True, dir_okay=False, path_type=Path), default=None,
              help="gearbench fit --json's output for this plant: values, standard errors, correlations.")
@click.option("--no-tolerances", is_flag=True,
              help="With --robust, do not draw the datasheet values within their tolerances.")
@click.option("--range", "ranges", multiple=True, metavar="NAME=LOW,HIGH",
              help="Search bounds of a setting in its unit (kp V/deg, ki 1/s, kd s, shift_deg deg).")
@click.option("--workers", type=click.IntRange(min=1), default=None, help="Local processes (default: all cores).")
@click.option("--scheduler", metavar="tcp://HOST:PORT", default=None, help="Solve the runs on this Dask cluster.")
@click.option("--seed", type=int, default=0, show_default=True, help="Seed of the sample and the drawn plants.")
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="The experiment file that `gearbench run` reproduces the tuned run from "
                   "(default RESULTS/tune_<PLANT>_<PROFILE>/tuned.yaml).")
@click.option("--results", type=click.Path(file_okay=False, path_type=Path), default=Path("results"),
              show_default=True, help="Folder; tables and figures go to RESULTS/tune_<PLANT>_<PROFILE>/.")
@click.option("--json", "as_json", is_flag=True, help="Print the result as one JSON object on stdout.")
@click.option("--quiet", is_flag=True, help="No progress lines on stderr.")
def tune(plant_file, kind, compensators, profile, objective, limits, robust, robust_stat, uncertainty,
         no_tolerances, ranges, workers, scheduler, seed, output, results, as_json, quiet):
    """Tune a controller on PLANT_FILE: the best gains (and compensator shift) for the objective
    on the profile, within the limits; robust to what a fit left uncertain with --robust.

    Writes tune.md, tune.json, response.png (tuned against untuned), slices.png (the objective
    against each setting near the optimum) and the experiment file, which `gearbench run`
    reproduces the tuned run from.  Exit status 1 when no candidate holds the limits.
    """
    from .report.io import save_figure_atomic, write_text_atomic
    from .report.tuning import response_figure, slices_figure
    from .tuning.tune import tune as tune_api
    profile = f"profile{profile}" if profile in ("1", "2", "3") else profile
    say = (lambda line: None) if quiet or as_json else (lambda line: print(f"tune: {line}", file=sys.stderr,
                                                                           flush=True))
    try:
        fit = json.loads(uncertainty.read_text(encoding="utf-8")) if uncertainty else None
        r = tune_api(plant_file, kind, profile=profile, compensator=compensators or "none", objective=objective,
                     limits=limits, robust=robust, robust_stat=robust_stat, uncertainty=fit,
                     tolerances=not no_tolerances, ranges=_ranges(ranges), workers=workers, scheduler=scheduler,
                     seed=seed, progress=say)
    except (GearbenchError, OSError, json.JSONDecodeError) as exc:
        _fail(exc)
    out = results / f"tune_{plant_file.stem}_{Path(profile).stem}"
    target = output or out / "tuned.yaml"
    write_text_atomic(target, r.experiment_yaml(target.parent.resolve()))
    save_figure_atomic(response_figure(r), out / "response.png")
    save_figure_atomic(slices_figure(r), out / "slices.png")
    write_text_atomic(out / "tune.md", r.to_markdown())
    summary = {**r.to_dict(), "experiment": str(target)}
    write_text_atomic(out / "tune.json", json.dumps(jsonable(summary), indent=1) + "\n")
    if as_json:
        echo_json(summary)
    else:
        stdout().print(r.to_markdown(), highlight=False, soft_wrap=True)
        console.print(f"wrote {target}; tables and figures in {out}/")
    if not r.best.best.feasible:
        console.print("[bold red]error:[/] no candidate holds the limits; the table shows the least violation")
        sys.exit(EXIT_FAILED)


__all__ = ["tune"]
