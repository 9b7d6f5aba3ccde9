"""Result tables: scores of runs, comparison with a reference (the thesis's Table I)."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from ..control.controllers import KIND_NAMES, kind_name

TABLE1_COLUMNS = ["profile", "controller", "kp", "shift", "iae_deg_s", "thesis_iae_deg_s", "ratio"]


def records_frame(records) -> pd.DataFrame:
    """One row per run with every score (see ``RunResult.scores``)."""
    return pd.DataFrame([r.row() for r in records])


def read_reference(path: str | Path) -> pd.DataFrame:
    """A reference table like the thesis's ``table1.csv``, in long form.

    Input columns: ``profile, controller, kp, iae_deg_s, iae_shifted_deg_s``;
    output: ``profile, controller, kp, shift, thesis_iae_deg_s``.
    """
    ref = pd.read_csv(path)
    need = {"profile", "controller", "kp", "iae_deg_s", "iae_shifted_deg_s"}
    missing = need - set(ref.columns)
    if missing:
        raise ValueError(f"{path}: reference table lacks column(s) {sorted(missing)}")
    off = ref.assign(shift="off", thesis_iae_deg_s=ref["iae_deg_s"])
    on = ref.assign(shift="on", thesis_iae_deg_s=ref["iae_shifted_deg_s"])
    out = pd.concat([off, on])[["profile", "controller", "kp", "shift", "thesis_iae_deg_s"]]
    return out.reset_index(drop=True)


def _key(frame: pd.DataFrame) -> pd.Series:
    kp = frame["kp"].map(lambda v: "" if v is None or (isinstance(v, float) and math.isnan(v)) else f"{float(v):g}")
    return frame["profile"].astype(str) + "|" + frame["controller"] + "|" + kp + "|" + frame["shift"]


def compare(runs: pd.DataFrame, reference: pd.DataFrame | None) -> pd.DataFrame:
    """``runs`` with the reference value and ``ratio = ours / reference`` beside each IAE."""
    out = runs.copy()
    if reference is None:
        out["thesis_iae_deg_s"] = np.nan
    else:
        lookup = dict(zip(_key(reference), reference["thesis_iae_deg_s"]))
        out["thesis_iae_deg_s"] = [lookup.get(k, np.nan) for k in _key(out)]
    out["ratio"] = out["iae_deg_s"] / out["thesis_iae_deg_s"]
    return out


def table1_markdown(table: pd.DataFrame, title: str, notes: str = "") -> str:
    """Ours beside the thesis's, one line per profile and controller."""
    lines = [f"# {title}", ""]
    if notes:
        lines += [notes.strip(), ""]
    lines += ["| profile | controller | IAE, no shift (deg s) | thesis | ratio "
              "| IAE, shift (deg s) | thesis | ratio |",
              "|---|---|---:|---:|---:|---:|---:|---:|"]
    for (prof, ctrl, kp), grp in table.groupby(["profile", "controller", "kp"], sort=False, dropna=False):
        cells = []
        for shift in ("off", "on"):
            row = grp[grp["shift"] == shift]
            if row.empty:
                cells += ["", "", ""]
                continue
            r = row.iloc[0]
            cells += [f"{r.iae_deg_s:.3f}", _fmt(r.thesis_iae_deg_s, ".3f"), _fmt(r.ratio, ".2f")]
        lines.append(f"| {prof} | {kind_name(ctrl, kp)} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def _fmt(v, spec: str) -> str:
    return "" if v is None or (isinstance(v, float) and math.isnan(v)) else format(v, spec)


def rich_table(table: pd.DataFrame, title: str):
    """The comparison as a ``rich.table.Table`` for the terminal."""
    from rich.table import Table

    t = Table(title=title)
    for col, just in (("profile", "left"), ("controller", "left"), ("shift", "left"),
                      ("IAE deg s", "right"), ("thesis", "right"), ("ratio", "right"),
                      ("impacts", "right"), ("switches", "right"), ("sat %", "right"), ("status", "left")):
        t.add_column(col, justify=just)
    for r in table.itertuples():
        name = KIND_NAMES.get(r.controller, r.controller)
        if r.controller != "bang_bang":
            name += f" {r.kp:g}"
        ratio = _fmt(r.ratio, ".2f")
        t.add_row(str(r.profile), name, r.shift, f"{r.iae_deg_s:.3f}", _fmt(r.thesis_iae_deg_s, ".3f"),
                  ratio, str(r.impacts), str(r.switchings), f"{100 * r.saturated_fraction:.0f}",
                  r.status)
    return t
