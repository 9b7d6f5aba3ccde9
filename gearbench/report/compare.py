"""Figures that compare a model with a measurement: where it fails, what it lacks, and
how the error falls as effects are added.

Each function returns a :class:`matplotlib.figure.Figure` built without pyplot (so no
figure is left open in a global registry); save it with
:func:`gearbench.report.io.save_figure_atomic`.  The residual is
``r = measured − simulated`` in the signal's unit throughout.
"""
from __future__ import annotations

from typing import Mapping, Sequence

import numpy as np
from matplotlib.figure import Figure
from matplotlib.patches import Patch

from ..measure.phases import PHASES

PHASE_COLOURS = {
    "standstill": "#9e9e9e",
    "steady motion": "#8fd18f",
    "direction reversal": "#e07070",
    "acceleration": "#f2c35b",
}
_SHADE_ALPHA = 0.25
_SCATTER_MAX = 20000            # more points only slow the file down, they add no insight
_BINS = 25


def _shade_phases(ax, t: np.ndarray, labels: np.ndarray) -> None:
    """Colour the background of ``ax`` by phase; one artist per phase, however many runs."""
    for phase in PHASES:
        sel = labels == phase
        if sel.any():
            ax.fill_between(t, 0, 1, where=sel, step="mid", color=PHASE_COLOURS[phase],
                            alpha=_SHADE_ALPHA, lw=0, transform=ax.get_xaxis_transform())


def _phase_legend(ax, labels: np.ndarray) -> None:
    handles = [Patch(color=PHASE_COLOURS[p], alpha=_SHADE_ALPHA + 0.2, label=p)
               for p in PHASES if np.any(labels == p)]
    if handles:
        ax.legend(handles=handles, loc="upper right", fontsize=7, title="phase", title_fontsize=7)


def _mark_reinitialisations(axes, reinit_s: Sequence[float]) -> None:
    """A thin vertical line at each instant the replay moved the model's angles to the record's."""
    for ax in axes:
        for t0 in reinit_s:
            ax.axvline(t0, color="#5b2c83", lw=0.6, alpha=0.7, zorder=1)


def comparison_figure(time_s, measured, simulated, labels, name: str, unit: str, title: str = "",
                      inputs: Sequence[tuple[str, object, str]] = (), reinit_s: Sequence[float] = ()) -> Figure:
    """Measured and simulated ``name`` (``unit``) against time (s), the residual
    ``measured − simulated`` below, both shaded by motion phase (``labels`` from
    :func:`gearbench.measure.phases.classify_phases`, or None for no shading), and,
    when given, the record's inputs in a panel at the bottom: ``inputs`` is a sequence
    of ``(column, values, unit)``, the first on the left axis, a second (a set point)
    on the right.  ``reinit_s``: times (s) at which the replay re-initialised the
    model's angles from the record, drawn as thin vertical lines on every panel."""
    t = np.asarray(time_s, dtype=float)
    y_m = np.asarray(measured, dtype=float)
    y_s = np.asarray(simulated, dtype=float)
    inputs = list(inputs)
    if len(inputs) > 2:
        raise ValueError(f"at most two input columns fit the input panel; got {[i[0] for i in inputs]}")
    rows = 3 if inputs else 2
    fig = Figure(figsize=(9, 7.5 if inputs else 6), layout="constrained")
    axes = fig.subplots(rows, 1, sharex=True, gridspec_kw={"height_ratios": [2, 1, 1][:rows]})
    top, bottom = axes[0], axes[1]
    top.plot(t, y_m, lw=1.0, color="k", label="measured")
    top.plot(t, y_s, lw=1.0, color="C0", ls="--", label="simulated")
    top.set_ylabel(f"{name} ({unit})")
    bottom.plot(t, y_m - y_s, lw=0.8, color="C3")
    bottom.axhline(0.0, color="k", lw=0.5)
    bottom.set_ylabel(f"residual ({unit})")
    if inputs:
        ax_u = axes[2]
        handles = []
        for k, (col, values, u_unit) in enumerate(inputs):
            ax = ax_u if k == 0 else ax_u.twinx()
            colour = "C2" if k == 0 else "C1"
            handles += ax.plot(t, np.asarray(values, dtype=float), lw=0.8, color=colour,
                               ls="-" if k == 0 else "--", drawstyle="steps-post" if k == 0 else "default",
                               label=f"{col} (measured)" if k == 0 else col)
            ax.set_ylabel(f"{col} ({u_unit})", color=colour)
        ax_u.legend(handles=handles, loc="upper left", fontsize=7)
    axes[-1].set_xlabel("time (s)")
    if labels is not None:
        labels = np.asarray(labels).astype(str)
        for ax in axes:
            _shade_phases(ax, t, labels)
        _phase_legend(bottom, labels)
    if len(reinit_s):
        _mark_reinitialisations(axes, reinit_s)
        top.plot([], [], color="#5b2c83", lw=0.6, label=f"angles re-initialised from the record ({len(reinit_s)})")
    top.legend(loc="upper left", fontsize=8)
    top.set_title(title or f"{name}: measured vs simulated")
    for ax in axes:
        ax.grid(alpha=0.3)
    return fig


def residual_tests_figure(tests: Mapping, title: str = "") -> Figure:
    """For each signal (a row), the residual's autocorrelation at lags 0..M (left) and
    its cross-correlation with the input at lags −M..M (right), dimensionless, with the
    99 % band shaded (:mod:`gearbench.identify.residuals`); the joint threshold the
    cross-correlation verdict uses is dashed; lags outside the band are red."""
    tests = dict(tests)
    if not tests:
        raise ValueError("residual_tests_figure needs the tests of at least one signal")
    fig = Figure(figsize=(11, 2.6 * len(tests) + 0.6), layout="constrained")
    axes = fig.subplots(len(tests), 2, squeeze=False)
    for (ax_a, ax_c), (name, rt) in zip(axes, tests.items()):
        pct = f"{100 * rt.confidence:g} %"
        for ax, lags, rho, band, outside in (
                (ax_a, rt.lags, rt.autocorrelation, rt.band, rt.outside_lags),
                (ax_c, rt.cross_lags, rt.cross_correlation, rt.cross_band, rt.cross_outside_lags)):
            ax.axhspan(-band, band, color="C0", alpha=0.18, lw=0, label=f"{pct} band (per lag)")
            ax.vlines(lags, 0, rho, color="k", lw=1.0)
            ax.plot(lags, rho, "o", ms=2.5, color="k")
            bad = np.isin(lags, outside)
            ax.plot(lags[bad], rho[bad], "o", ms=3.5, color="C3", label="outside the band")
            ax.axhline(0.0, color="k", lw=0.5)
            ax.grid(alpha=0.3)
        ax_c.axhline(rt.joint_threshold, color="C0", ls="--", lw=0.8,
                     label=f"joint {pct} threshold (all lags together)")
        ax_c.axhline(-rt.joint_threshold, color="C0", ls="--", lw=0.8)
        ax_a.set_ylabel(f"{name}\nautocorrelation")
        ax_a.set_title(f"±{rt.band:.3g}", loc="right", fontsize=8, color="C0")
        ax_c.set_title(f"±{rt.cross_band:.3g}", loc="right", fontsize=8, color="C0")
        p = f"p = {rt.ljung_box_p:.2g}" if rt.ljung_box_p >= 1e-16 else "p < 1e-16"
        ax_a.set_title(f"{name}: {'white' if rt.white else 'NOT white'} (Ljung-Box {p})",
                       fontsize=9, loc="left")
        ax_c.set_ylabel(f"cross-correlation\nwith {rt.input_name}")
        ax_c.set_title(f"{'independent of' if rt.input_independent else 'CORRELATED with'} {rt.input_name} "
                       f"(+ lag: input earlier)", fontsize=9, loc="left")
        dt = f" of {rt.sample_time_s * 1e3:.3g} ms" if rt.sample_time_s > 0 else ""
        ax_a.set_xlabel(f"lag (samples{dt})")
        ax_c.set_xlabel(f"lag (samples{dt})")
    # one legend for all panels, under them: the stems fill the axes, a legend inside hides some
    handles = {}
    for ax in axes.ravel():
        for h, lab in zip(*ax.get_legend_handles_labels()):
            handles.setdefault(lab, h)
    fig.legend(list(handles.values()), list(handles), loc="outside lower center", ncols=len(handles), fontsize=8)
    fig.suptitle(title or "residual tests")
    return fig


def _thin(n: int) -> np.ndarray:
    return np.arange(n) if n <= _SCATTER_MAX else np.linspace(0, n - 1, _SCATTER_MAX).astype(int)


def _binned_median(x: np.ndarray, r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Median residual in bins of equal count along ``x``: the trend a scatter hides."""
    order = np.argsort(x)
    groups = [g for g in np.array_split(order, min(_BINS, x.size)) if g.size]
    return (np.array([np.median(x[g]) for g in groups]), np.array([np.median(r[g]) for g in groups]))


_DIRECTIONS = (("negative", "C0"), ("standstill", "#7f7f7f"), ("positive", "C3"))


def _direction_groups(v: np.ndarray, v0: float) -> dict[str, np.ndarray]:
    return {"negative": v < -v0, "standstill": np.abs(v) <= v0, "positive": v > v0}


def _scatter_by_direction(ax, x: np.ndarray, r: np.ndarray, groups: dict[str, np.ndarray],
                          xlabel: str, ylabel: str) -> None:
    """Residual against ``x``, coloured by direction, with each direction's binned median:
    separate branches keep a hysteresis (friction, clearance) from averaging to zero."""
    keep = np.zeros(x.size, dtype=bool)
    keep[_thin(x.size)] = True
    for name, colour in _DIRECTIONS:
        sel = groups[name]
        if not sel.any():
            continue
        ax.plot(x[sel & keep], r[sel & keep], ".", ms=1.5, alpha=0.25, color=colour, rasterized=True)
        bx, br = _binned_median(x[sel], r[sel])
        ax.plot(bx, br, "-o", ms=2.5, lw=1.2, color=colour, label=f"{name} (median)")
    ax.axhline(0.0, color="k", lw=0.5)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.grid(alpha=0.3)
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc="best", fontsize=7)


def residual_figure(residual, speed, position, name: str, unit: str, speed_unit: str, position_unit: str,
                    standstill_speed: float | None = None) -> Figure:
    """The residual (``unit``) against speed, against position, and by direction of motion.

    What each panel shows an engineer: a step at zero speed is Coulomb friction, a
    slope against speed viscous friction, a slope against position a spring, and an
    offset whose sign follows the direction of motion a clearance.  Points are coloured
    by direction; standstill is ``|speed| ≤ standstill_speed`` (default 2 % of the peak
    speed).
    """
    r = np.asarray(residual, dtype=float)
    v = np.asarray(speed, dtype=float)
    x = np.asarray(position, dtype=float)
    if not r.shape == v.shape == x.shape:
        raise ValueError(f"residual, speed and position differ in shape: {r.shape}, {v.shape}, {x.shape}")
    v0 = standstill_speed if standstill_speed is not None else 0.02 * float(np.max(np.abs(v), initial=0.0))
    groups = _direction_groups(v, v0)
    fig = Figure(figsize=(12, 4), layout="constrained")
    ax_v, ax_x, ax_d = fig.subplots(1, 3, sharey=True)
    _scatter_by_direction(ax_v, v, r, groups, f"speed ({speed_unit})", f"residual {name} ({unit})")
    ax_v.set_title("vs speed: step at 0 → Coulomb, slope → viscous", fontsize=9)
    _scatter_by_direction(ax_x, x, r, groups, f"position ({position_unit})", "")
    ax_x.set_title("vs position: slope → spring", fontsize=9)
    # An empty group keeps its place on the axis, so the three always line up.
    data = [r[sel] if sel.any() else np.array([np.nan]) for sel in groups.values()]
    ax_d.boxplot(data, showfliers=False)
    ax_d.set_xticks([1, 2, 3], [f"{k}\n(n={int(sel.sum())})" for k, sel in groups.items()])
    ax_d.axhline(0.0, color="k", lw=0.5)
    ax_d.set_xlabel("direction of motion")
    ax_d.set_title("by direction: offset with sign → clearance", fontsize=9)
    ax_d.grid(alpha=0.3)
    return fig


def ladder_figure(steps: Sequence[Mapping], noise_floor: float | None = None, unit: str = "",
                  title: str = "", calibration: Mapping | None = None) -> Figure:
    """The error after each step of the ladder: ``steps[0]`` the baseline, then one
    ``{"effect": name, "error": value}`` per effect added (``"action": "remove"``: an
    effect taken out again, drawn hatched as ``- name``; ``"action": "calibrate"``: the
    plant's own values calibrated, drawn as a baseline); a dashed line marks the
    noise floor (the error noise alone would leave) when given.  ``unit`` labels the
    error axis, logarithmic when the errors span more than two decades.
    ``calibration`` (``diagnose --json``'s) lists each calibrated value under the bars."""
    if not steps:
        raise ValueError("a ladder needs at least its baseline step")
    removed = [i > 0 and s.get("action") == "remove" for i, s in enumerate(steps)]
    calibrated = [s.get("action") == "calibrate" for s in steps]
    names = [str(s["effect"]) if i == 0 or calibrated[i] else f"{'-' if removed[i] else '+'} {s['effect']}"
             for i, s in enumerate(steps)]
    errors = np.array([float(s["error"]) for s in steps])
    fig = Figure(figsize=(max(5.0, 1.3 * len(steps) + 2), 4), layout="constrained")
    ax = fig.subplots()
    pos = np.arange(len(steps))
    colours = ["#9e9e9e"] + ["#c8c8c8" if c else "C1" if r else "C0" for r, c in zip(removed[1:], calibrated[1:])]
    bars = ax.bar(pos, errors, color=colours, width=0.6)
    for bar, r in zip(bars, removed):
        if r:
            bar.set_hatch("//")
    ax.bar_label(bars, fmt="%.3g", fontsize=8, padding=2)
    if noise_floor is not None:
        ax.axhline(noise_floor, color="C3", ls="--", lw=1, label=f"noise floor {noise_floor:.3g}")
        ax.legend(loc="upper right", fontsize=8)
    ax.set_xticks(pos, names, rotation=20, ha="right")
    ax.set_ylabel(f"error ({unit})" if unit else "error")
    top = max(float(errors.max()), noise_floor or 0.0) or 1.0
    low = min(float(errors[errors > 0].min()) if np.any(errors > 0) else top, noise_floor or top)
    if top > 100 * low:  # errors over decades: a linear axis would hide the last steps
        ax.set_yscale("log")
        ax.set_ylim(low / 3, top * 3)
    else:
        ax.set_ylim(0, 1.15 * top)
    ax.set_title(title or "error as effects are added")
    ax.grid(axis="y", alpha=0.3)
    if calibration:
        fig.text(0.01, 0.01, "\n".join(_calibration_line(k, c) for k, c in calibration.items()),
                 fontsize=6.5, va="bottom", family="monospace")
        fig.set_figheight(4 + 0.13 * len(calibration))
        bottom = 0.13 * len(calibration) / fig.get_figheight() + 0.02  # room for the lines, in figure height
        fig.get_layout_engine().set(rect=(0, bottom, 1, 1 - bottom))
    return fig


def _calibration_line(name: str, c: Mapping) -> str:
    """``motor.resistance 1.21 -> 1.1 +- 0.0003 ohm (tolerance 20 %)``, or the file's value and
    why it stayed (``held``: the record cannot resolve it; ``file value``: calibrating did not pay)."""
    if c["status"] != "calibrated":
        why = "held, the record cannot resolve it" if c["status"] == "held" else "calibrating did not pay"
        return f"{name} {c['nominal']:.4g} {c['unit']}: the file's value ({why})"
    se = c.get("stderr")
    return (f"{name} {c['nominal']:.4g} -> {c['value']:.4g}" + (f" +- {se:.2g}" if se is not None else "")
            + f" {c['unit']} (tolerance {c['tolerance_pct']:g} %)")


def comparison_figures(cmp, what: str) -> list[tuple[str, Figure]]:
    """Every figure of a comparison, as ``gearbench compare`` saves them: ``(file name, Figure)``.

    Per compared signal, measured against simulated with the residual, the phases and the
    record's inputs (:func:`comparison_figure`); the primary signal's residual against the
    motion (:func:`residual_figure`) when the record moves; the residual tests
    (:func:`residual_tests_figure`) when they were run.

    Parameters
    ----------
    cmp : gearbench.api.Comparison
        The model against the record.
    what : str
        What the titles call the pair, e.g. ``"bench_rig.yaml against bench_rig_hidden.csv"``.

    Returns
    -------
    list of (str, matplotlib.figure.Figure)
        ``<signal>.png``, ``<primary>_residual_vs_motion.png``, ``residual_tests.png``.
    """
    from ..measure.signals import per_rad
    c, data, plant = cmp.figures, cmp.data, cmp.plant
    inputs = [] if cmp.closed_loop else [(data.input_name, data.input, data.input_unit)]
    if data.setpoint is not None:
        inputs.append((data.setpoint_name, data.setpoint, data.setpoint_name.rsplit("_", 1)[1]))
    out = []
    for row in c["signals"]:
        name = row["signal"]
        out.append((f"{name}.png", comparison_figure(
            cmp.time_s, cmp.measured(name), c["sim"][name], c.get("labels"), name, row["unit"],
            title=f"{name}: {what}", inputs=inputs, reinit_s=c.get("reinitialised_s", ()))))
    if "labels" in c:
        p = c["primary"]
        unit = next(r["unit"] for r in c["signals"] if r["signal"] == p)
        out_name, pos_unit = ("load_position_mm", "mm") if plant.leadscrew else ("load_angle_deg", "deg")
        k = per_rad(out_name, plant)
        fig = residual_figure(c["residuals"][p], k * c["speed"], k * c["position"], p, unit,
                              f"{pos_unit}/s at the output", f"{pos_unit} at the output")
        fig.suptitle(what)
        out.append((f"{p}_residual_vs_motion.png", fig))
    if c.get("residual_tests"):
        out.append(("residual_tests.png", residual_tests_figure(c["residual_tests"], f"residual tests: {what}")))
    return out


def rung_residuals_figure(time_s, residuals: Sequence[tuple[str, object]], labels, name: str, unit: str,
                          title: str = "") -> Figure:
    """The residual of ``name`` (``unit``) against time (s) as a ladder climbs, one panel per
    model: ``residuals`` is ``(label, residual)`` from the baseline to the last rung, so each
    rung's panel is its "after" and the one above its "before".  Each panel has its own scale
    (an error falling by decades would flatten the later ones) and names its RMS; the motion's
    phases are shaded when ``labels`` are given."""
    residuals = list(residuals)
    if not residuals:
        raise ValueError("rung_residuals_figure needs at least the baseline's residual")
    t = np.asarray(time_s, dtype=float)
    fig = Figure(figsize=(9, 1.5 * len(residuals) + 0.8), layout="constrained")
    axes = np.atleast_1d(fig.subplots(len(residuals), 1, sharex=True))
    for ax, (label, r) in zip(axes, residuals):
        r = np.asarray(r, dtype=float)
        ax.plot(t, r, lw=0.7, color="C3")
        ax.axhline(0.0, color="k", lw=0.5)
        ax.set_title(f"{label}: RMS {float(np.sqrt(np.mean(r ** 2))):.4g} {unit}", fontsize=9, loc="left")
        ax.set_ylabel(unit)
        ax.grid(alpha=0.3)
        if labels is not None:
            _shade_phases(ax, t, np.asarray(labels).astype(str))
    if labels is not None:
        _phase_legend(axes[0], np.asarray(labels).astype(str))
    axes[-1].set_xlabel("time (s)")
    fig.suptitle(title or f"{name} residual (measured - simulated) as effects are added")
    return fig


__all__ = ["comparison_figure", "residual_figure", "residual_tests_figure", "ladder_figure", "comparison_figures",
           "rung_residuals_figure", "PHASE_COLOURS"]
