"""``gearbench sweep`` and ``gearbench stability`` (registered on the main group in cli.py)."""
from __future__ import annotations

import os
import sys
from pathlib import Path

import click

from .cli_common import EXIT_FAILED, _fail, console, echo_json, interrupted, is_interrupt, stdout
from .errors import GearbenchError



PARAM_HELP = ("KEY=VALUES, repeatable: several make a grid. KEY is a dotted path into the "
              "experiment file (controller.kp sets kp on every controller, controllers[1].kp on "
              "one; controller.shift=off,on; plant.gear.backlash_deg; duration_s; solver.rtol). "
              "VALUES: a list (0.5,5,50), linspace(a,b,n), logspace(a,b,n) (10**a..10**b) or "
              "geomspace(a,b,n). Values are checked like the file's own, in its units.")


@click.command()
@click.argument("experiment", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option("--param", "params", multiple=True, required=True, metavar="KEY=VALUES", help=PARAM_HELP)
@click.option("--results", "results_dir", type=click.Path(file_okay=False, path_type=Path),
              default=Path("results"), show_default=True,
              help="Folder; the sweep writes RESULTS/<name>/sweep.csv, sweep.md and sweep.png.")
@click.option("--workers", type=click.IntRange(min=1), default=None,
              help="Local processes (default: all cores; 1 = in this process).")
@click.option("--scheduler", metavar="tcp://HOST:PORT", default=None,
              help="Run the points on this running Dask distributed scheduler instead.")
@click.option("--summary", "summary_path", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Also write the Markdown summary into this file, between "
                   "'<!-- gearbench:sweep NAME PARAMS begin/end -->' markers (one block per "
                   "experiment and grid); the rest of the file is kept.")
@click.option("--fresh", is_flag=True, help="Delete the stored points of this sweep and solve all again.")
@click.option("--json", "as_json", is_flag=True,
              help="Print {sweep, points, solved, reused, failed, lost, rows: [one per point and run], "
                   "files} as one JSON object on stdout instead of the table.")
def sweep(experiment: Path, params: tuple[str, ...], results_dir: Path, workers: int | None,
          scheduler: str | None, summary_path: Path | None, fresh: bool, as_json: bool) -> None:
    """Sweep EXPERIMENT's settings over a grid: one simulation per grid point and run.

    Every finished point is appended at once to RESULTS/<name>/sweep.csv (its
    parameters, profile, controller, shift, IAE in deg s, RMS and max error in
    deg, time and share saturated, impacts, switchings, steps, the linear
    verdict, status, message, solve time); running the same sweep again skips
    the stored points, so a killed sweep resumes. At the end: sweep.md (a
    table, the least IAE per run) and sweep.png (IAE against the swept key, or
    a heat map for two keys). Every grid point is validated before any solving.

    Exit status 1 when a point failed (now or in a stored earlier attempt: the
    failed points are named; --fresh solves them again) or was lost with its
    worker; 130 on Ctrl-C, with the finished points stored and no summary written.

    Example: gearbench sweep experiments/gain_scan.yaml --param controller.kp=0.5,5,50,500,5000
    """
    from rich.progress import (BarColumn, MofNCompleteColumn, Progress, TextColumn,
                               TimeElapsedColumn, TimeRemainingColumn)

    from .report import sweep as report
    from .report.io import save_figure_atomic, write_text_atomic
    from .report.markdown import update_block
    from .sweep import default_workers, parse_params, plan_sweep, run_sweep

    try:
        plan = plan_sweep(experiment, parse_params(params))
    except GearbenchError as exc:
        _fail(exc)
    command = f"gearbench sweep {experiment} " + " ".join(f"--param {p}" for p in params)
    where = f"the Dask scheduler at {scheduler}" if scheduler else \
        f"{min(workers or default_workers(), len(plan.points))} local worker(s)"

    with Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
                  TimeElapsedColumn(), TextColumn("eta"), TimeRemainingColumn(),
                  console=console, transient=True) as progress:
        task = progress.add_task(f"sweep {plan.name}", total=None)

        stored_before, solved = [0], [0]

        def start(pending: int, stored: int) -> None:
            stored_before[0] = stored
            console.print(f"sweep {plan.name}: {len(plan.points)} points, {stored} already stored, "
                          f"{pending} to solve on {where}", highlight=False)
            progress.update(task, total=pending)

        def done(point, row) -> None:
            solved[0] += 1
            at = ", ".join(f"{k}={v}" for k, v in point.params.items())
            progress.update(task, advance=1, description=f"{plan.name}: {at} {point.profile}")

        try:
            outcome = run_sweep(plan, results_dir, workers=workers, scheduler=scheduler,
                                fresh=fresh, on_start=start, on_done=done)
        except GearbenchError as exc:
            _fail(exc)
        except Exception as exc:
            # a Ctrl-C inside compiled code comes as a SystemError caused by it (run_sweep takes
            # the plain KeyboardInterrupt itself); the store holds every finished point
            if not is_interrupt(exc):
                raise
            interrupted(f"{stored_before[0] + solved[0]} of {len(plan.points)} points are stored in "
                        f"{results_dir / plan.name / 'sweep.csv'}; no summary written; run the same "
                        f"command again to resume")

    if outcome.interrupted:
        stored = sum(row is not None for row in outcome.rows)
        console.print(f"{outcome.solved} solved, {outcome.reused} reused before the interrupt",
                      highlight=False)
        # the store keeps every finished point; a summary of part of the grid is not written
        interrupted(f"{stored} of {len(plan.points)} points are stored in {outcome.csv_path}; "
                    f"no summary written; run the same command again to resume")

    frame = report.sweep_frame(outcome)
    out_dir = outcome.csv_path.parent
    import matplotlib.pyplot as plt
    fig = report.sweep_figure(frame, plan)
    png = save_figure_atomic(fig, out_dir / "sweep.png")
    plt.close(fig)
    md = write_text_atomic(out_dir / "sweep.md", report.summary_markdown(frame, plan, command, "sweep.png"))
    if summary_path is not None:
        rel = os.path.relpath(png.resolve(), summary_path.resolve().parent)
        # one block per experiment and grid, so several sweeps can share one file
        tag = f"sweep {plan.name} " + " ".join(p.replace("--", "-") for p in params)
        update_block(summary_path, tag, report.summary_markdown(frame, plan, command, rel))
    failed = frame[(frame["status"] != "ok") & (frame["status"] != "not run")]
    keys = [p.key for p in plan.params]
    failed_names = [f"{', '.join(f'{k}={row[k]}' for k in keys)} ({row['series']})" for _, row in failed.iterrows()]
    if as_json:
        echo_json({"sweep": plan.name, "file": str(experiment), "params": list(params),
                   "points": len(plan.points), "solved": outcome.solved, "reused": outcome.reused,
                   "failed": failed_names, "lost": outcome.lost, "rows": frame.to_dict("records"),
                   "files": [str(outcome.csv_path), str(md), str(png)]
                   + ([str(summary_path)] if summary_path else [])})
    else:
        stdout().print(report.rich_table(frame, plan))
    console.print(f"{outcome.solved} solved, {outcome.reused} reused, {len(failed)} failed; wrote "
                  f"{outcome.csv_path}, {out_dir / 'sweep.md'}, {png}"
                  + (f", {summary_path}" if summary_path else ""), highlight=False)
    for name, msg in zip(failed_names, failed["message"]):
        console.print(f"[bold red]failed:[/] point {name}: {msg}", highlight=False)
    for msg in outcome.lost:
        console.print(f"[red]lost:[/] {msg}", highlight=False)
    if len(failed) or outcome.lost:
        problems = [f"{len(failed)} of {len(frame)} points failed"
                    + (" (stored failures stay until --fresh)" if outcome.reused else "")] if len(failed) else []
        if outcome.lost:
            problems.append(f"{len(outcome.lost)} points were lost with their worker; run the same "
                            f"command again to solve them")
        console.print(f"[bold red]error:[/] {'; '.join(problems)}", highlight=False)
        sys.exit(EXIT_FAILED)


@click.command()
@click.argument("plant_file", metavar="PLANT.yaml", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option("--controller", "kind", type=click.Choice(["p", "pi", "pid"]), default="p",
              show_default=True, help="Controller closing the loop on theta_m/N.")
@click.option("--ki", type=click.FloatRange(min=0.0), default=0.005, show_default=True,
              help="Integral gain, 1/s (PI, PID; the thesis's 0.005).")
@click.option("--kd", type=click.FloatRange(min=0.0), default=0.001, show_default=True,
              help="Derivative gain, s (PID).")
@click.option("--derivative-filter", "tf", type=click.FloatRange(min=0.0, min_open=True), default=1e-3,
              show_default=True, help="Derivative filter time constant, s (PID).")
@click.option("--at", "at", default="0.5,1,5,50,500,5000", show_default=True, metavar="KP,...",
              help="Gains (V/deg) at which the Routh array and the eigenvalues are listed "
                   "(the default: the thesis's scan and its Kp = 1).")
@click.option("--json", "as_json", is_flag=True, help="Print the report as one JSON object.")
@click.option("--markdown", "md_path", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Also write the report into this Markdown file between "
                   "'<!-- gearbench:stability KIND begin/end -->' markers.")
def stability(plant_file: Path, kind: str, ki: float, kd: float, tf: float, at: str, as_json: bool,
              md_path: Path | None) -> None:
    """Gain range (Kp, V/deg) for which PLANT.yaml's closed loop is stable.

    The plant is linearised with the teeth in contact (engaged mesh, voltage
    input; saturation and clearance ignored) and closed by the controller on
    theta_m/N. The stable Kp interval(s) come from the Hurwitz determinants of
    the characteristic polynomial det(sI - A + B K C), computed exactly; the
    eigenvalues of the closed-loop matrix at 200 gains over 1e-3 ... 1e6 V/deg
    cross-check them, and the Routh array's sign changes are listed at the
    thesis's gains.
    """
    from .control.stability import analyse
    from .experiment.files import load_plant
    from .report.markdown import update_block
    from .report.stability import _range, rich_table, stability_markdown

    try:
        plant = load_plant(plant_file)
        gains = [float(x) for x in at.split(",")]
        if not all(g > 0 for g in gains):
            raise ValueError
    except GearbenchError as exc:
        _fail(exc)
    except ValueError:  # float() of a word, or a gain <= 0
        _fail(ValueError(f"--at must be a comma-separated list of positive gains in V/deg, got {at!r}"))
    rep = analyse(plant, kind, ki=ki if kind != "p" else 0.0, kd=kd if kind == "pid" else 0.0, tf=tf,
                  check_kp=gains)
    command = f"gearbench stability {plant_file} --controller {kind}"
    if kind in ("pi", "pid"):
        command += f" --ki {ki:g}"
    if kind == "pid":
        command += f" --kd {kd:g} --derivative-filter {tf:g}"
    if at != "0.5,1,5,50,500,5000":
        command += f" --at {at}"
    if md_path is not None:
        update_block(md_path, f"stability {kind}", stability_markdown(rep, command))
    if as_json:
        echo_json(rep.to_dict(), indent=2)
        return
    out = stdout()
    out.print(rich_table(rep))
    for iv in rep.intervals:
        out.print(f"stable (Routh-Hurwitz): [bold]{_range(iv)}[/]", highlight=False)
    if not rep.intervals:
        out.print("stable (Routh-Hurwitz): for no Kp > 0")
    scan = rep.to_dict()["eigen_scan"]
    out.print(f"eigenvalue scan: {scan['agree']}/{scan['points']} gains agree "
                    f"({scan['kp_min']:g} ... {scan['kp_max']:g} V/deg)", highlight=False)
    free = " or ".join(_range(iv) for iv in rep.free_intervals) or "no Kp > 0"
    out.print(f"teeth apart (motor alone in the clearance): stable for {free}", highlight=False)
    if rep.rigid_bound is not None:
        out.print(f"rigid-gear third-order approximation: Kp < {rep.rigid_bound:.6g} V/deg",
                        highlight=False)
