"""docs/measurements.md: its files, mapping, commands and printed output are the real ones.

The first ``csv`` block is the canonical record, the second a lab's file of it; the ``yaml``
block maps one onto the other, and so does the ``sh`` example's ``--columns``/``--units``.
Each ``$ gearbench ...`` example prints what the doc shows (whitespace aside: the console
wraps long lines), and the Python example runs.
"""
from __future__ import annotations

import re
import shlex
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from gearbench.cli import main
from gearbench.measure.columns import load_column_map
from gearbench.measure.data import read_measurement

DOC = Path(__file__).resolve().parents[1] / "docs" / "measurements.md"
TEXT = DOC.read_text(encoding="utf-8")


def fenced(text: str) -> list[tuple[str, str]]:
    """Every fenced block as (language, text), in order."""
    out, lang, lines = [], None, []
    for line in text.splitlines(keepends=True):
        if line.startswith("```"):
            if lang is None:
                lang, lines = line[3:].strip(), []
            else:
                out.append((lang, "".join(lines)))
                lang = None
        elif lang is not None:
            lines.append(line)
    return out


def blocks(lang: str) -> list[str]:
    return [text for kind, text in fenced(TEXT) if kind == lang]


@pytest.fixture
def files(tmp_path, monkeypatch):
    canonical, raw = blocks("csv")
    (tmp_path / "canonical.csv").write_text(canonical)
    (tmp_path / "rig_raw.csv").write_text(raw)
    (tmp_path / "rig_map.yaml").write_text(blocks("yaml")[0])
    monkeypatch.chdir(tmp_path)
    return tmp_path


def same(a, b):
    np.testing.assert_allclose(a.time_s, b.time_s, rtol=1e-9)
    np.testing.assert_allclose(a.input, b.input, rtol=1e-9)
    assert list(a.signals) == list(b.signals)
    for k in a.signals:
        np.testing.assert_allclose(a.signals[k], b.signals[k], rtol=1e-9, atol=1e-12)


def test_the_mapping_file_reads_the_lab_file_as_the_canonical_one(files):
    same(read_measurement("rig_raw.csv", load_column_map("rig_map.yaml")), read_measurement("canonical.csv"))


def test_the_command_line_mapping_reads_it_too(files):
    (sh,) = [b for b in blocks("sh") if "--columns " in b]
    args = shlex.split(sh.replace("\\\n", " "))
    columns, units = args[args.index("--columns") + 1], args[args.index("--units") + 1]
    same(read_measurement("rig_raw.csv", columns, units), read_measurement("canonical.csv"))


def _examples() -> list[tuple[str, str]]:
    """(command, expected output) for each ``$ gearbench`` line of the plain blocks."""
    out = []
    for block in blocks(""):
        for part in re.split(r"^\$ ", block, flags=re.M)[1:]:
            command, _, expected = part.partition("\n")
            out.append((command, expected))
    return out


def test_the_doc_shows_error_examples():
    assert len(_examples()) >= 3


@pytest.mark.parametrize("command, expected", _examples())
def test_each_printed_example_is_what_gearbench_prints(files, command, expected):
    args = shlex.split(command)
    assert args[0] == "gearbench"
    r = CliRunner().invoke(main, args[1:])
    assert " ".join(r.output.split()) == " ".join(expected.split())
    assert r.exit_code == (2 if expected.startswith("error:") else 0)


def test_import_prints_what_the_doc_shows(files):
    (shown,) = [b for b in blocks("") if b.startswith("wrote rig.csv")]
    (sh,) = [b for b in blocks("sh") if "import csv" in b and "--columns-file" in b]
    r = CliRunner().invoke(main, shlex.split(sh)[1:])
    assert r.exit_code == 0, r.output
    assert r.output == shown
    same(read_measurement("rig.csv"), read_measurement("canonical.csv"))


def test_the_python_example_runs(files):
    (code,) = blocks("python")
    scope: dict = {}
    exec(compile(code, str(DOC), "exec"), scope)  # noqa: S102 - the doc's own example
    assert scope["m"].signals["load_angle_deg"].shape == (5,)
