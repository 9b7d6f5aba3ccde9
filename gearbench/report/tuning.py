"""Figures of a tuning: the tuned and untuned responses, and the objective near the optimum."""
from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure
from matplotlib.ticker import NullFormatter

from ..control.controllers import Controller
from ..simulate import simulate
from ..tuning.objective import OBJECTIVES
from .traces import trace_frame


def _label(c: Controller) -> str:
    gains = ", ".join(f"{k}={getattr(c, k):.3g}" for k in ("kp", "ki", "kd") if getattr(c, k))
    return f"{c.kind} {gains}" + ("" if c.compensator == "none" else f", {c.compensator}")


def response_figure(result) -> Figure:
    """Set point and output angle (deg), output error (deg) and voltage (V) against time, on the
    plant tuned on (the centre of the draws when robust), for the untuned controller and the best
    tuned one (``result``: a TuneResult)."""
    from ..profiles import load_profile
    prof = load_profile(result.profile)
    fig = Figure(figsize=(9, 7), layout="constrained")
    ax1, ax2, ax3 = fig.subplots(3, 1, sharex=True, gridspec_kw={"height_ratios": [3, 1.5, 1.5]})
    for i, (name, c) in enumerate((("untuned", result.baseline_controller), ("tuned", result.controller))):
        run = simulate(result.plant, c, prof.segments(), result.duration_s, result.solver)
        df = trace_frame(run, result.plant)
        if i == 0:
            ax1.plot(df["time_s"], df["setpoint_deg"], "k--", lw=1, label="set point")
        lab = f"{name}: {_label(c)} ({result.objective} {run.scores()[OBJECTIVES[result.objective][0]]:.4g} {result.unit})"
        ax1.plot(df["time_s"], df["load_angle_deg"], lw=1, color=f"C{i}", label=lab)
        ax2.plot(df["time_s"], df["setpoint_deg"] - df["load_angle_deg"], lw=0.8, color=f"C{i}")
        ax3.plot(df["time_s"], df["voltage_V"], lw=0.6, color=f"C{i}", alpha=0.8)
    ax1.set_ylabel("output angle (deg)")
    ax1.legend(loc="best", fontsize=8)
    centre = "" if result.plants == 1 else f", the centre of the {result.plants} plants drawn"
    ax1.set_title(f"{result.plant.name}: {result.profile}, untuned and tuned, on the plant tuned on{centre}", fontsize=10)
    ax2.set_ylabel("output error (deg)")
    ax3.set_ylabel("voltage (V)")
    ax3.set_xlabel("time (s)")
    for ax in (ax1, ax2, ax3):
        ax.grid(alpha=0.3)
    return fig


def slices_figure(result) -> Figure:
    """The objective against each setting of the best compensator, the others held at the
    optimum; candidates that break a limit are crosses."""
    t = result.best
    names = list(t.slices)
    fig = Figure(figsize=(3.6 * max(1, len(names)), 3.4), layout="constrained")
    axes = np.atleast_1d(fig.subplots(1, max(1, len(names))))
    for ax, name in zip(axes, names):
        pts = t.slices[name]
        x = np.array([v for v, _ in pts])
        y = np.array([e.objective for _, e in pts])
        ok = np.array([e.feasible for _, e in pts])
        ax.plot(x[ok], y[ok], "o-", ms=3, color="C0", label="within limits")
        if (~ok).any():
            ax.plot(x[~ok], y[~ok], "x", color="C3", label="breaks a limit")
        ax.axvline(t.best.settings[name], color="k", lw=0.8, ls=":")
        if name != "shift_deg":
            ax.set_xscale("log")
            ax.xaxis.set_minor_formatter(NullFormatter())
        unit = {"kp": "V/deg", "ki": "1/s", "kd": "s", "shift_deg": "deg"}[name]
        ax.set_xlabel(f"{name} ({unit})")
        ax.set_ylabel(f"{result.objective} ({result.unit})")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    stat = "" if result.plants == 1 else f", {result.robust} over {result.plants} plants"
    fig.suptitle(f"{result.plant.name}: {result.kind}, {t.compensator}{stat}", fontsize=9)
    return fig


__all__ = ["response_figure", "slices_figure"]
