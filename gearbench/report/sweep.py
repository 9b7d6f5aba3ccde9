"""Reports of a sweep: a table (pandas, Markdown, rich) and a figure.

IAE is the integrated absolute output error (deg s), RMS and max the output
error (deg), ``saturated_fraction`` the share of the run at the voltage limit.
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np
import pandas as pd

SCORES = ["iae_deg_s", "rms_deg", "max_deg", "saturated_s", "saturated_fraction", "impacts",
          "switchings", "steps", "wall_s"]


def _series(point, n_ctrl: int, n_shift: int, swept: set[str]) -> str:
    """Which run of the experiment a point is, leaving out what the sweep itself varies."""
    parts = [] if "profiles" in swept else [point.profile]
    if n_ctrl > 1:
        parts.append(f"controller {point.controller_index}")
    if n_shift > 1 and not swept & {"shift", "controller.shift"}:
        parts.append(f"shift {'on' if point.shift else 'off'}")
    return ", ".join(parts) or "all"


def sweep_frame(outcome) -> pd.DataFrame:
    """One row per point of the plan (grid order): the swept values (typed), the run,
    the scores (numbers) and ``status`` (``not run`` for a point without a result)."""
    plan = outcome.plan
    n_ctrl = len({p.controller_index for p in plan.points})
    n_shift = len({p.shift for p in plan.points})
    swept = {p.key for p in plan.params}
    records = []
    for point, row in zip(plan.points, outcome.rows):
        rec: dict[str, Any] = dict(point.params)
        rec.update(series=_series(point, n_ctrl, n_shift, swept), profile=point.profile,
                   controller=(row or {}).get("controller", point.controller.kind),
                   shift="on" if point.shift else "off")
        for col in SCORES:
            rec[col] = float(row[col]) if row and row.get(col, "") != "" else math.nan
        rec["linear_stable"] = (row or {}).get("linear_stable", "")
        rec["status"] = row["status"] if row else "not run"
        rec["message"] = row.get("message", "") if row else ""
        records.append(rec)
    return pd.DataFrame.from_records(records)


def _value(v: Any) -> str:
    """A swept value as written: 5000, 0.5, on."""
    if isinstance(v, bool):
        return "on" if v else "off"
    if isinstance(v, (int, float, np.integer, np.floating)):
        return f"{float(v):.12g}"
    return str(v)


def _fmt(v: Any, spec: str = ".4g") -> str:
    if isinstance(v, bool):
        return "on" if v else "off"
    if isinstance(v, (float, np.floating)):
        return "" if math.isnan(v) else format(float(v), spec)
    return str(v)


def best_rows(frame: pd.DataFrame, keys: list[str]) -> pd.DataFrame:
    """Per series, the finished point with the least IAE."""
    ok = frame[frame["status"] == "ok"]
    if ok.empty:
        return ok
    return ok.loc[ok.groupby("series", sort=False)["iae_deg_s"].idxmin()]


def summary_markdown(frame: pd.DataFrame, plan, command: str = "", figure: str = "") -> str:
    """The sweep as Markdown: what was run, every point, the best point per series, failures."""
    keys = [p.key for p in plan.params]
    grid = " x ".join(f"{len(p.values)} {p.key}" for p in plan.params)
    runs = len(plan.points) // max(1, math.prod(len(p.values) for p in plan.params))
    lines = [f"## Sweep `{plan.name}` over {', '.join(f'`{k}`' for k in keys)}", ""]
    if command:
        lines += [f"Command: `{command}`", ""]
    lines += [f"Experiment `{plan.experiment}`: {len(plan.points)} points ({grid} x {runs} "
              f"run(s) each). IAE: integrated absolute output error (deg s); RMS, max: output "
              f"error (deg); sat.: share of the run at the voltage limit; impacts: contact "
              f"onsets; switchings: sign changes of the voltage; lin. stable: the engaged, "
              f"unsaturated loop at this gain (eigenvalues, see `gearbench stability`); "
              f"solve: wall time of the point (s).", ""]
    head = keys + ["profile", "controller", "shift", "IAE (deg s)", "RMS (deg)", "max (deg)",
                   "sat. (%)", "impacts", "switchings", "lin. stable", "status", "solve (s)"]
    lines += ["| " + " | ".join(head) + " |", "|" + "---|" * len(keys) + "---|---|---|"
              + "---:|" * 6 + "---|---|---:|"]
    for r in frame.itertuples(index=False):
        d = dict(zip(frame.columns, r))
        cells = [_value(d[k]) for k in keys] + [
            str(d["profile"]), str(d["controller"]), d["shift"], _fmt(d["iae_deg_s"]),
            _fmt(d["rms_deg"]), _fmt(d["max_deg"]), _fmt(100 * d["saturated_fraction"], ".1f"),
            _fmt(d["impacts"], ".0f"), _fmt(d["switchings"], ".0f"), d["linear_stable"],
            d["status"], _fmt(d["wall_s"], ".3f")]
        lines.append("| " + " | ".join(cells) + " |")
    best = best_rows(frame, keys)
    if not best.empty:
        lines += ["", "Least IAE per run:", ""]
        for _, r in best.iterrows():
            at = ", ".join(f"{k} = {_value(r[k])}" for k in keys)
            lines.append(f"- {r['series']}: {at} (IAE {_fmt(r['iae_deg_s'])} deg s)")
    failed = frame[frame["status"] != "ok"]
    if not failed.empty:
        lines += ["", "Points without a result:", ""]
        for _, r in failed.iterrows():
            at = ", ".join(f"{k} = {_value(r[k])}" for k in keys)
            lines.append(f"- {r['series']}, {at}: {r['status']}"
                         + (f": {r['message']}" if r["message"] else ""))
    if figure:
        lines += ["", f"![IAE of the sweep]({figure})"]
    return "\n".join(lines) + "\n"


def rich_table(frame: pd.DataFrame, plan):
    """The sweep as a ``rich.table.Table`` for the terminal."""
    from rich.table import Table

    keys = [p.key for p in plan.params]
    t = Table(title=f"sweep {plan.name}: IAE in deg s, errors in deg")
    for col in keys + ["run"]:
        t.add_column(col)
    for col in ("IAE", "RMS", "max", "sat %", "impacts", "stable", "status"):
        t.add_column(col, justify="right" if col not in ("status", "stable") else "left")
    for _, r in frame.iterrows():
        style = None if r["status"] == "ok" else "red"
        t.add_row(*[_value(r[k]) for k in keys], str(r["series"]),
                  _fmt(r["iae_deg_s"]), _fmt(r["rms_deg"]), _fmt(r["max_deg"]),
                  _fmt(100 * r["saturated_fraction"], ".1f"), _fmt(r["impacts"], ".0f"),
                  r["linear_stable"], r["status"], style=style)
    return t


def _numeric(values) -> bool:
    return all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values)


def sweep_figure(frame: pd.DataFrame, plan):
    """IAE against the first swept key (one line per run and combination of the other
    keys), or, for exactly two keys, one heat map of IAE per run."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import LogNorm

    keys = [p.key for p in plan.params]
    series = list(dict.fromkeys(frame["series"]))
    if len(keys) == 2:
        kx, ky = keys
        xs, ys = plan.params[0].values, plan.params[1].values
        ncol = min(3, len(series))
        nrow = math.ceil(len(series) / ncol)
        fig, axes = plt.subplots(nrow, ncol, figsize=(4.6 * ncol, 3.8 * nrow), squeeze=False)
        finite = frame.loc[frame["status"] == "ok", "iae_deg_s"]
        positive = finite[finite > 0]
        norm = (LogNorm(positive.min(), positive.max())
                if len(positive) and positive.max() > 20 * positive.min() else None)
        for ax, name in zip(axes.flat, series):
            sub = frame[frame["series"] == name]
            z = np.full((len(ys), len(xs)), np.nan)
            for _, r in sub.iterrows():
                i, j = ys.index(r[ky]), xs.index(r[kx])
                if r["status"] == "ok":
                    z[i, j] = r["iae_deg_s"]
                else:
                    ax.text(j, i, "x", ha="center", va="center", color="red")
            im = ax.imshow(z, origin="lower", aspect="auto", norm=norm, cmap="viridis")
            ax.set_xticks(range(len(xs)), [_value(v) for v in xs], rotation=45, fontsize=7)
            ax.set_yticks(range(len(ys)), [_value(v) for v in ys], fontsize=7)
            ax.set_xlabel(kx)
            ax.set_ylabel(ky)
            ax.set_title(name, fontsize=9)
            fig.colorbar(im, ax=ax, label="IAE (deg s)")
        for ax in list(axes.flat)[len(series):]:
            ax.axis("off")
    else:
        kx = keys[0]
        xs = plan.params[0].values
        numeric = _numeric(xs)
        # IAE above, the share of time at the voltage limit below (the thesis's other criterion)
        fig, (ax, ax_sat) = plt.subplots(2, 1, figsize=(7.5, 6.5), sharex=True,
                                         gridspec_kw={"height_ratios": [2, 1]})
        others = keys[1:]
        groups = frame.groupby(["series", *others], sort=False) if others else frame.groupby("series", sort=False)
        for n, (label, sub) in enumerate(groups):
            if n >= 20:
                ax.text(0.01, 0.01, "(first 20 lines shown)", transform=ax.transAxes, fontsize=7)
                break
            label = label if isinstance(label, str) else ", ".join(
                [str(label[0])] + [f"{k}={_value(v)}" for k, v in zip(others, label[1:])])
            x = sub[kx].tolist() if numeric else [xs.index(v) for v in sub[kx]]
            ok = (sub["status"] == "ok").to_numpy()
            y = sub["iae_deg_s"].to_numpy()
            line, = ax.plot(np.asarray(x, dtype=float)[ok], y[ok], "o-", label=label)
            ax_sat.plot(np.asarray(x, dtype=float)[ok], 100 * sub["saturated_fraction"].to_numpy()[ok],
                        "o-", color=line.get_color(), ms=4)
            bad = ~ok & np.isfinite(y)
            if bad.any():
                ax.plot(np.asarray(x, dtype=float)[bad], y[bad], "x", color="red", ms=9)
            unstable = ok & (sub["linear_stable"] == "no").to_numpy()
            if unstable.any():
                ax.plot(np.asarray(x, dtype=float)[unstable], y[unstable], "o", mfc="white",
                        color=line.get_color(), ms=9)
        if numeric and min(xs) > 0 and max(xs) >= 100 * min(xs):
            ax.set_xscale("log")
        if not numeric:
            ax_sat.set_xticks(range(len(xs)), [_value(v) for v in xs])
        ax_sat.set_xlabel(kx)
        ax_sat.set_ylabel("saturated (%)")
        ax_sat.grid(alpha=0.3, which="both")
        ax.set_ylabel("IAE (deg s)")
        ax.set_title(f"{plan.name}: IAE against {kx} (open circles: linearly unstable; "
                     f"red x: failed)", fontsize=9)
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=7)
    fig.tight_layout()
    return fig
