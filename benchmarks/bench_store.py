"""``results/bench.json``: the one file every benchmark merges its figures into.

Read, updated with one benchmark's keys, written atomically
(:func:`gearbench.report.io.write_text_atomic`), so ``make bench`` runs the
benchmarks one after the other into one file, and a benchmark run alone keeps
the others' figures.
"""
from __future__ import annotations

import json
import subprocess
from pathlib import Path

from gearbench.report.io import write_text_atomic

PATH = Path(__file__).resolve().parents[1] / "results" / "bench.json"


def stored(key: str, field: str) -> dict:
    """The rows under ``field`` of the stored ``key`` (``{}`` when there are none): what a benchmark
    run with ``--only`` keeps of the records it does not measure again."""
    return dict(json.loads(PATH.read_text()).get(key, {}).get(field, {})) if PATH.exists() else {}


def commit_of(checkout: Path) -> str | None:
    """``git describe --always --dirty`` of the checkout whose code a benchmark ran (None outside git)."""
    return subprocess.run(["git", "-C", str(checkout), "describe", "--always", "--dirty"], capture_output=True,
                          text=True).stdout.strip() or None


def merge(figures: dict) -> Path:
    """Merge ``figures`` into ``results/bench.json`` (its keys replace the stored ones); returns the path."""
    stored = json.loads(PATH.read_text()) if PATH.exists() else {}
    stored.update(figures)
    return write_text_atomic(PATH, json.dumps(stored, indent=1) + "\n")
