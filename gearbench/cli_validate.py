"""``gearbench validate``: the physics evidence (see ``gearbench.validation``)."""
from __future__ import annotations

import sys
from pathlib import Path

import click

from .cli_common import EXIT_FAILED, console, echo_json, stdout

DEFAULT = Path("experiments/validation/validation.yaml")


@click.command()
@click.option("--config", type=click.Path(exists=True, dir_okay=False, path_type=Path), default=DEFAULT,
              show_default=True, help="Validation settings (experiments/validation/validation.yaml).")
@click.option("--results", "results_dir", type=click.Path(file_okay=False, path_type=Path),
              default=Path("results"), show_default=True,
              help="Writes RESULTS/validation.md and figures under RESULTS/validation/.")
@click.option("--quick", is_flag=True, help="Reduced set (a few Table I cells, fewer tolerances) for tests.")
@click.option("--json", "as_json", is_flag=True,
              help='Print {"checks": [{"name", "passed", "measured", "expected", "unit", "note", '
                   '"failure_explained"}, ...]} on stdout instead of the table.')
@click.option("--strict", is_flag=True, help="Exit 1 when any check fails, explained or not.")
def validate(config: Path, results_dir: Path, quick: bool, as_json: bool, strict: bool) -> None:
    """Run every physics check (contact law and restitution, Dubowsky pair, energy,
    natural frequencies and the shaft, ode23s vs ode45, convergence, motor steady
    state) and print a pass/fail table with the measured figure beside the expected one.

    Exit status: 0 when every check passes or fails only for a reason the report
    explains (results/validation.md, "Why the failing checks fail": today the shaft's
    effect on Table I and the informational stiff-vs-explicit row at the experiment's
    rtol); 1 when a check fails without one (named on stderr), or with --strict when any
    check fails."""
    from .report.io import write_text_atomic
    from .validation import WHY_IT_FAILS, markdown, run_all

    checks = run_all(config, results_dir, quick=quick, progress=lambda s: console.print(f"validate: {s}"))
    write_text_atomic(results_dir / ("validation_quick.md" if quick else "validation.md"),
                      markdown(checks, quick))
    for c in checks:
        # the same match as the report's "Why the failing checks fail" section
        c["failure_explained"] = not c["passed"] and any(c["name"].startswith(p) for p, _ in WHY_IT_FAILS)
    failed = [c["name"] for c in checks if not c["passed"]]
    unexplained = [c["name"] for c in checks if not c["passed"] and not c["failure_explained"]]
    if as_json:
        echo_json({"checks": checks}, indent=None)
    else:
        from rich.table import Table
        t = Table(title="gearbench validate")
        for col in ("check", "result", "measured", "expected", "unit"):
            t.add_column(col)
        for c in checks:
            m = c["measured"]
            t.add_row(c["name"], "[green]PASS[/]" if c["passed"] else "[red]FAIL[/]",
                      f"{m:.6g}" if isinstance(m, float) else str(m),
                      f"{c['expected']:.6g}" if isinstance(c["expected"], float) else str(c["expected"]),
                      c["unit"])
        stdout().print(t)
    console.print(f"{len(checks) - len(failed)} of {len(checks)} checks pass"
                  + (f"; {len(failed) - len(unexplained)} fail for the reasons the report explains"
                     if len(failed) > len(unexplained) else ""), highlight=False)
    if unexplained or (strict and failed):
        bad = unexplained if unexplained else failed
        console.print(f"[bold red]error:[/] {len(bad)} check(s) failed"
                      + ("" if unexplained else " (--strict)") + ": " + "; ".join(bad), highlight=False)
        sys.exit(EXIT_FAILED)
