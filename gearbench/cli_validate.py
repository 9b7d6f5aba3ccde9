"""``gearbench validate``: the physics evidence (see ``gearbench.validation``)."""
from __future__ import annotations

import json
from pathlib import Path

import click
from rich.console import Console

DEFAULT = Path("experiments/validation/validation.yaml")


@click.command()
@click.option("--config", type=click.Path(exists=True, dir_okay=False, path_type=Path), default=DEFAULT,
              show_default=True, help="Validation settings (experiments/validation/validation.yaml).")
@click.option("--results", "results_dir", type=click.Path(file_okay=False, path_type=Path),
              default=Path("results"), show_default=True,
              help="Writes RESULTS/validation.md and figures under RESULTS/validation/.")
@click.option("--quick", is_flag=True, help="Reduced set (a few Table I cells, fewer tolerances) for tests.")
@click.option("--json", "as_json", is_flag=True,
              help='Print {"checks": [{"name", "passed", "measured", "expected", "unit"}, ...]}.')
def validate(config: Path, results_dir: Path, quick: bool, as_json: bool) -> None:
    """Run every physics check (contact law and restitution, Dubowsky pair, energy,
    natural frequencies and the shaft, ode23s vs ode45, convergence, motor steady
    state) and print a pass/fail table with the measured figure beside the expected one.
    Exit status 0 even when checks fail: the table is the evidence."""
    from .report.io import write_text_atomic
    from .validation import markdown, run_all

    err = Console(stderr=True)
    checks = run_all(config, results_dir, quick=quick, progress=lambda s: err.print(f"validate: {s}"))
    write_text_atomic(results_dir / ("validation_quick.md" if quick else "validation.md"),
                      markdown(checks, quick))
    if as_json:
        click.echo(json.dumps({"checks": checks}, default=float))
        return
    from rich.table import Table
    t = Table(title="gearbench validate")
    for col in ("check", "result", "measured", "expected", "unit"):
        t.add_column(col)
    for c in checks:
        m = c["measured"]
        t.add_row(c["name"], "[green]PASS[/]" if c["passed"] else "[red]FAIL[/]",
                  f"{m:.6g}" if isinstance(m, float) else str(m),
                  f"{c['expected']:.6g}" if isinstance(c["expected"], float) else str(c["expected"]), c["unit"])
    Console().print(t)
