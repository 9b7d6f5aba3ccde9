"""The figure of the torque a model misses (``identify.missing``): the final model's residual as a
torque at the output against the output's position, its speed and time, each sample a dot and the
binned mean a line over them, titled with the signature it most resembles."""
from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from ..identify.missing import MissingTorque, profile

SCATTER_MAX = 20000
"""Dots drawn at most per panel (every k-th sample): more slow the file down and show nothing new."""


def missing_torque_figure(m: MissingTorque, title: str = "") -> Figure:
    """Three panels: ``m.torque`` against position (deg), speed (deg/s) and time (s)."""
    fig = Figure(figsize=(12, 3.8), layout="constrained")
    axes = fig.subplots(1, 3, sharey=True)
    every = max(1, m.torque.size // SCATTER_MAX)
    for ax, x, label in zip(axes, (m.position_deg, m.speed_deg_s, m.time_s),
                            ("output angle (deg)", "output speed (deg/s)", "time (s)")):
        ax.plot(x[::every], m.torque[::every], ".", ms=1.5, color="#9e9e9e", alpha=0.4, rasterized=True)
        p = profile(x, m.torque)
        mean = np.array([np.nan if v is None else v for v in p["mean"]])
        ax.plot(p["x"], mean, "-o", ms=3, color="#c0392b", label="binned mean")
        ax.axhline(0.0, color="k", lw=0.6)
        ax.set_xlabel(label)
        ax.grid(alpha=0.3)
    axes[0].set_ylabel(f"missing torque ({m.unit})")
    axes[0].legend(loc="best", fontsize=8)
    lo, hi = np.percentile(m.torque, [0.5, 99.5])
    pad = 0.1 * (hi - lo) or 1.0
    axes[0].set_ylim(lo - pad, hi + pad)
    head = f"{title}: " if title else ""
    fig.suptitle(f"{head}the torque the model misses most resembles '{m.resembles}' "
                 f"(correlation {m.signatures[m.resembles]:.2f})", fontsize=10)
    return fig
