"""Tables for the translational (leadscrew) variant and the compensator comparison."""
from __future__ import annotations

import math

import numpy as np
import pandas as pd

from .tables import CONTROLLER_NAMES

TRANSLATIONAL_COLUMNS = ["profile", "controller", "kp", "shift", "iae_mm_s"]
COMPENSATOR_COLUMNS = ["profile", "controller", "kp", "compensator", "iae_deg_s", "sign_changes"]


def translational_frame(runs: pd.DataFrame, plant) -> pd.DataFrame:
    """``runs`` with the carriage error ``iae_mm_s`` (mm s) = IAE (rad s) x lead / 2 pi."""
    out = runs.copy()
    out["iae_mm_s"] = np.radians(out["iae_deg_s"]) * plant.leadscrew.radius * 1e3
    return out


def translational_markdown(table: pd.DataFrame, title: str, notes: str = "") -> str:
    """The IAE (mm s) without and with the shift, each with its run's voltage sign
    changes and contact onsets (impacts), when the runs have them."""
    lines = [f"# {title}", ""]
    if notes:
        lines += [notes.strip(), ""]
    counts = {"switchings", "impacts"} <= set(table.columns)
    if counts:
        lines += ["| profile | controller | IAE, no shift (mm s) | sign changes | impacts "
                  "| IAE, shift (mm s) | sign changes | impacts |", "|---|---|" + "---:|" * 6]
    else:
        lines += ["| profile | controller | IAE, no shift (mm s) | IAE, shift (mm s) |", "|---|---|---:|---:|"]
    for (prof, ctrl, kp), grp in table.groupby(["profile", "controller", "kp"], sort=False, dropna=False):
        cells = []
        for shift in ("off", "on"):
            row = grp[grp["shift"] == shift]
            if row.empty:
                cells += ["", "", ""] if counts else [""]
                continue
            r = row.iloc[0]
            cells.append(f"{r.iae_mm_s:.4f}")
            if counts:
                cells += [str(int(r.switchings)), str(int(r.impacts))]
        lines.append(f"| {prof} | {_name(ctrl, kp)} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def compensator_frame(records) -> pd.DataFrame:
    """One row per run: ``profile, controller, kp, compensator, iae_deg_s, sign_changes`` + scores."""
    rows = []
    for r in records:
        row = r.row()
        row["compensator"] = r.controller.effective_compensator
        row["sign_changes"] = r.result.switchings
        rows.append(row)
    return pd.DataFrame(rows)


def compensator_markdown(table: pd.DataFrame, title: str, notes: str = "") -> str:
    comps = list(dict.fromkeys(table["compensator"]))
    lines = [f"# {title}", ""]
    if notes:
        lines += [notes.strip(), ""]
    head = " | ".join(f"IAE {c} (deg s) | sign changes {c}" for c in comps)
    lines += [f"| profile | controller | {head} |", "|---|---|" + "---:|" * (2 * len(comps))]
    for (prof, ctrl, kp), grp in table.groupby(["profile", "controller", "kp"], sort=False, dropna=False):
        cells = []
        for c in comps:
            row = grp[grp["compensator"] == c]
            cells += (["", ""] if row.empty else
                      [f"{row.iloc[0].iae_deg_s:.4f}", str(int(row.iloc[0].sign_changes))])
        lines.append(f"| {prof} | {_name(ctrl, kp)} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def compensator_figure(table: pd.DataFrame, title: str = ""):
    """Grouped bars: IAE (top) and voltage sign changes (bottom, log) per cell and compensator."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    comps = list(dict.fromkeys(table["compensator"]))
    cells = list(dict.fromkeys(zip(table["profile"], table["controller"], table["kp"])))
    x = np.arange(len(cells))
    w = 0.8 / len(comps)
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(11, 7), sharex=True)
    for j, c in enumerate(comps):
        sub = table[table["compensator"] == c].set_index(["profile", "controller", "kp"])
        iae = [sub.loc[cell, "iae_deg_s"] if cell in sub.index else np.nan for cell in cells]
        sw = [sub.loc[cell, "sign_changes"] if cell in sub.index else np.nan for cell in cells]
        ax1.bar(x + j * w, iae, w, label=c)
        ax2.bar(x + j * w, np.maximum(sw, 0.5), w, label=c)
    ax1.set_ylabel("IAE (deg s)")
    ax1.legend(fontsize=8)
    ax1.set_title(title)
    ax2.set_yscale("log")
    ax2.set_ylabel("voltage sign changes")
    ax2.set_xticks(x + 0.4 - w / 2)
    ax2.set_xticklabels([f"p{p} {_name(c, k)}" for p, c, k in cells], rotation=30, ha="right", fontsize=8)
    for ax in (ax1, ax2):
        ax.grid(alpha=0.3, axis="y")
    fig.tight_layout()
    return fig


def _name(ctrl, kp) -> str:
    name = CONTROLLER_NAMES.get(ctrl, ctrl)
    if kp is not None and not (isinstance(kp, float) and math.isnan(kp)):
        name += f", Kp={kp:g}"
    return name
