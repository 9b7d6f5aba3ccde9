"""The ``gearbench`` command line (click)."""
from __future__ import annotations

import os
import sys

# Before numpy loads: one OpenBLAS (MKL) thread in this process and the workers it forks.  gearbench calls
# BLAS only on tiny arrays, where OpenBLAS's threads cost more than they do; once loaded, a library
# keeps the threads it started even when limited later (``gearbench.blas``).  A user's setting wins.
for _var in ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")
from dataclasses import replace
from pathlib import Path

import click

from .cli_common import (EXIT_FAILED, EXIT_HELP, Group, _fail, check, console, echo_json, interrupted,
                         is_interrupt, stdout)
from .errors import GearbenchError


@click.group(cls=Group, epilog=EXIT_HELP)
@click.version_option(package_name="gearbench")
def main() -> None:
    """gearbench: geartrains with backlash under control; models against measurements."""


@main.command()
@click.argument("experiment", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option("--results", "results_dir", type=click.Path(file_okay=False, path_type=Path),
              default=Path("results"), show_default=True, help="Folder for the tables and figures.")
@click.option("--plot", is_flag=True, help="Write a PNG per run (set point, output, motor angle/N, voltage).")
@click.option("--traces", is_flag=True, help="Write each run's trace CSV in the SPEC's measurement format.")
@click.option("--method", type=click.Choice(["rodas4", "rodas4-exp", "rosenbrock23", "ode23s", "dopri5", "ode45"]),
              default=None,
              help="Override the experiment's solver method.")
@click.option("--rtol", type=float, default=None, help="Override the experiment's relative tolerance.")
@click.option("--workers", type=click.IntRange(min=1), default=None,
              help="Processes solving the runs (default: all cores; 1 = in this process).")
@click.option("--json", "as_json", is_flag=True,
              help="Print {experiment, runs: [{label, status, message, scores...}], failed, table, files} "
                   "as one JSON object on stdout instead of the table.")
def run(experiment: Path, results_dir: Path, plot: bool, traces: bool, method: str | None,
        rtol: float | None, workers: int | None, as_json: bool) -> None:
    """Run EXPERIMENT (a YAML file): every profile x controller x shift.

    Writes RESULTS/<name>.csv (profile, controller, kp, shift, iae_deg_s,
    thesis_iae_deg_s, ratio), RESULTS/<name>_runs.csv (every score of every
    run) and RESULTS/<name>.md; the IAE is the integrated absolute output
    error in deg s.  An experiment with a ``compensator`` list writes, per
    compensator, the IAE and the voltage sign changes instead, and the figures
    RESULTS/<name>.png (bars) and RESULTS/<name>_traces.png (the traces of the
    cell with the most sign changes).

    Exit status 1 when a run fails (the solver could not finish it): the tables
    are still written, with its status, and each failed run is named on stderr
    with the likely cause.  Ctrl-C: status 130, no table written.
    """
    from rich.progress import BarColumn, Progress, TextColumn, TimeRemainingColumn

    from .experiment.files import load_experiment
    from .report import tables
    from .report.io import save_figure_atomic, write_csv_atomic, write_text_atomic
    from .report.traces import run_figure, trace_frame
    from .runner import experiment_report, load_profiles, run_experiment

    try:
        exp = load_experiment(experiment)
        load_profiles(exp)
        if exp.reference is not None:
            reference = tables.read_reference(exp.reference)
        else:
            reference = None
    except (GearbenchError, ValueError) as exc:
        # ValueError too, deliberately: a reference table without the needed columns
        # (report.tables.read_reference) or one pandas cannot parse is bad input as well
        _fail(exc)
    if method or rtol:
        exp = replace(exp, solver=replace(exp.solver, method=method or exp.solver.method,
                                          rtol=rtol or exp.solver.rtol))
    out_dir = results_dir / exp.name
    finished: list = []
    written: list[Path] = []
    total = len(exp.runs())

    try:
        with Progress(TextColumn("{task.description}"), BarColumn(), TextColumn("{task.completed}/{task.total}"),
                      TimeRemainingColumn(), console=console, transient=True) as progress:
            task = progress.add_task(f"{exp.name}", total=total)

            def done(rec):
                progress.update(task, advance=1, description=f"{exp.name}: {rec.label}")
                finished.append(rec)
                if plot:
                    import matplotlib.pyplot as plt
                    fig = run_figure(rec.result, exp.plant)
                    written.append(save_figure_atomic(fig, out_dir / "plots" / f"{rec.label}.png"))
                    plt.close(fig)
                if traces:
                    written.append(write_csv_atomic(trace_frame(rec.result, exp.plant),
                                                    out_dir / "traces" / f"{rec.label}.csv"))

            records = run_experiment(exp, on_done=done, keep_traces=plot or traces, workers=workers)
            check()  # a Ctrl-C a figure's finalizer swallowed: no table
    except (Exception, KeyboardInterrupt) as exc:
        if not is_interrupt(exc):
            raise
        interrupted(f"{len(finished)} of {total} runs of {exp.name} finished; no table written"
                    + (f"; their plots/traces are in {out_dir}" if written else ""))

    report = experiment_report(exp, records, reference, traced=plot or traces)
    for name, fig in report.figures.items():
        import matplotlib.pyplot as plt
        written.append(save_figure_atomic(fig, results_dir / name))
        plt.close(fig)
    runs, columns = report.runs, report.columns
    written.append(write_csv_atomic(runs[columns], results_dir / f"{exp.name}.csv"))
    written.append(write_csv_atomic(runs, results_dir / f"{exp.name}_runs.csv"))
    written.append(write_text_atomic(results_dir / f"{exp.name}.md", report.markdown))
    failed = [rec for rec in records if not rec.result.ok]
    if as_json:
        echo_json({"experiment": exp.name, "file": str(experiment), "runs": [
            {"label": rec.label, **rec.row(), "message": rec.result.meta.get("message", "")} for rec in records],
            "failed": [rec.label for rec in failed], "table": runs[columns].to_dict("records"),
            "files": [str(p) for p in written]})
    else:
        stdout().print(report.shown)
    wall = sum(r.wall_s for r in records)
    console.print(f"{len(records)} runs, {wall:.2f} s of solving; wrote {results_dir / exp.name}.csv/.md",
                  highlight=False)
    if failed:
        for rec in failed:
            console.print(f"[bold red]failed:[/] {rec.result.meta['message']}", highlight=False)
        console.print(f"[bold red]error:[/] {len(failed)} of {len(records)} runs failed: "
                      f"{', '.join(rec.label for rec in failed)}", highlight=False)
        sys.exit(EXIT_FAILED)


@main.command()
@click.argument("plant_file", metavar="PLANT.yaml", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option("--json", "as_json", is_flag=True, help="Print the figures as one JSON object.")
def info(plant_file: Path, as_json: bool) -> None:
    """Derived figures of a plant: mesh and shaft natural frequencies, time
    constants, stall torque, no-load speed (top speed for a leadscrew)."""
    from .experiment.files import load_plant
    from .plant.linear import plant_info

    try:
        plant = load_plant(plant_file)
    except GearbenchError as exc:
        _fail(exc)
    data = plant_info(plant)
    if as_json:
        echo_json(data, indent=2)
        return
    from rich.table import Table
    t = Table(title=f"{plant.name}")
    t.add_column("figure")
    t.add_column("value", justify="right")
    for key, value in data.items():
        if key == "modes":
            continue
        t.add_row(key, "—" if value is None else f"{value:.6g}")
    stdout().print(t)
    for mode in data["modes"]:
        stdout().print(f"engaged mode: {mode['frequency_hz']:.6g} Hz, damping ratio "
                       f"{mode['damping_ratio']:.3g}, mostly {mode['dominant_state']}")


from .cli_sweep import stability, sweep  # noqa: E402 - registered after the group exists

main.add_command(sweep)
main.add_command(stability)

from .cli_validate import validate  # noqa: E402

main.add_command(validate)

from .cli_import import import_group  # noqa: E402
main.add_command(import_group)

from .cli_synth import synth  # noqa: E402
main.add_command(synth)

from .cli_identify import compare, diagnose, fit  # noqa: E402

main.add_command(compare)
main.add_command(diagnose)
main.add_command(fit)

from .cli_tune import tune  # noqa: E402

main.add_command(tune)

if __name__ == "__main__":
    main()
