"""``results/bench.json``: the one file every benchmark merges its figures into.

Read, updated with one benchmark's keys, written atomically
(:func:`gearbench.report.io.write_text_atomic`), so ``make bench`` runs the
benchmarks one after the other into one file, and a benchmark run alone keeps
the others' figures.
"""
from __future__ import annotations

import json
from pathlib import Path

from gearbench.report.io import write_text_atomic

PATH = Path(__file__).resolve().parents[1] / "results" / "bench.json"


def merge(figures: dict) -> Path:
    """Merge ``figures`` into ``results/bench.json`` (its keys replace the stored ones); returns the path."""
    stored = json.loads(PATH.read_text()) if PATH.exists() else {}
    stored.update(figures)
    return write_text_atomic(PATH, json.dumps(stored, indent=1) + "\n")
