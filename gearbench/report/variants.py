"""Tables for the translational (leadscrew) variant and the compensator comparison."""
from __future__ import annotations

import numpy as np
import pandas as pd

from ..control.controllers import kind_name

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
        lines.append(f"| {prof} | {kind_name(ctrl, kp)} | " + " | ".join(cells) + " |")
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
        lines.append(f"| {prof} | {kind_name(ctrl, kp)} | " + " | ".join(cells) + " |")
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
    ax2.set_xticklabels([f"p{p} {kind_name(c, k)}" for p, c, k in cells], rotation=30, ha="right", fontsize=8)
    for ax in (ax1, ax2):
        ax.grid(alpha=0.3, axis="y")
    fig.tight_layout()
    return fig


def trace_cell(records) -> tuple[tuple, list]:
    """The cell (profile, controller kind, gain) with the most voltage sign changes
    summed over its compensators, and its runs."""
    groups: dict = {}
    for r in records:
        groups.setdefault((r.profile, r.controller.kind, r.controller.kp), []).append(r)
    if not groups:
        raise ValueError("no runs to choose a cell from")
    cell = max(groups, key=lambda c: sum(r.result.switchings for r in groups[c]))
    return cell, groups[cell]


def compensator_trace_figure(records, plant, title: str = ""):
    """Traces of the cell (profile, controller, gain) with the most voltage sign
    changes summed over its compensators: one row per compensator, the output
    error and the motor-side error ``theta_m/N - r`` (deg, left) and the voltage
    (V, right) against time.  The runs must carry their traces (a run solved for
    its scores keeps two samples: see :func:`gearbench.runner.retrace`).
    Returns ``(figure, cell)``."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .. import layout as L

    cell, rows = trace_cell(records)
    short = [r.label for r in rows if len(r.result.time_s) < 3]
    if short:
        raise ValueError(f"runs {', '.join(short)} carry no trace (only {len(rows[0].result.time_s)} samples): "
                         "solve them again with their trace (gearbench.runner.retrace) before drawing them")
    n = plant.gear.ratio
    fig, axes = plt.subplots(len(rows), 2, figsize=(12, 1.9 * len(rows) + 0.8), sharex=True, squeeze=False)
    for (ax1, ax2), r in zip(axes, rows):
        o, t = r.result.outputs, r.result.time_s
        ax1.plot(t, np.degrees(o[:, L.O_LOAD] - o[:, L.O_SETPOINT]), lw=0.8, label="output - set point")
        ax1.plot(t, np.degrees(o[:, L.O_MOTOR] / n - o[:, L.O_SETPOINT]), lw=0.6,
                 label="motor angle / N - set point")
        ax1.set_ylabel("deg")
        comp = r.controller.effective_compensator
        ax1.set_title(f"{comp}: IAE {r.result.iae_deg_s:.2f} deg s", fontsize=9, loc="left")
        ax2.plot(t, o[:, L.O_VOLTAGE], lw=0.5, color="C2")
        ax2.set_ylabel("voltage (V)")
        ax2.set_title(f"{comp}: {r.result.switchings} voltage sign changes", fontsize=9, loc="left")
        for ax in (ax1, ax2):
            ax.grid(alpha=0.3)
    axes[0][0].legend(fontsize=7, loc="upper right")
    for ax in axes[-1]:
        ax.set_xlabel("time (s)")
    prof, kind, kp = cell
    dt = rows[0].result.time_s[1] - rows[0].result.time_s[0]
    fig.suptitle(title or f"{prof}, {kind_name(kind, kp)}: the cell with the most voltage sign changes "
                          f"(traces sampled every {dt * 1e3:.3g} ms)")
    fig.tight_layout()
    return fig, cell
