"""Run traces in the SPEC's measurement format (section 3), and their figures."""
from __future__ import annotations


import numpy as np
import pandas as pd

from .. import layout as L


def trace_frame(result, plant) -> pd.DataFrame:
    """A run as a measurement-format table: ``time_s, voltage_V, motor_angle_deg,
    load_angle_deg, current_A, setpoint_deg`` (+ ``load_position_mm`` for a leadscrew)."""
    o = result.outputs
    df = pd.DataFrame({
        "time_s": result.time_s,
        "voltage_V": o[:, L.O_VOLTAGE],
        "motor_angle_deg": np.degrees(o[:, L.O_MOTOR]),
        "load_angle_deg": np.degrees(o[:, L.O_LOAD]),
        "current_A": o[:, L.O_CURRENT],
        "setpoint_deg": np.degrees(o[:, L.O_SETPOINT]),
    })
    if plant.leadscrew is not None:
        df["load_position_mm"] = o[:, L.O_LOAD] * plant.leadscrew.radius * 1e3
    return df


def run_figure(result, plant, title: str = ""):
    """Set point, output, motor-side angle / N (deg) and the voltage (V) against time."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    o = result.outputs
    t = result.time_s
    n = plant.gear.ratio
    fig, (ax1, ax2, ax3) = plt.subplots(3, 1, figsize=(9, 7), sharex=True,
                                        gridspec_kw={"height_ratios": [3, 1.5, 1.5]})
    ax1.plot(t, np.degrees(o[:, L.O_SETPOINT]), "k--", lw=1, label="set point")
    ax1.plot(t, np.degrees(o[:, L.O_MOTOR]) / n, lw=1, label="motor angle / N")
    ax1.plot(t, np.degrees(o[:, L.O_LOAD]), lw=1, label="output angle")
    ax1.set_ylabel("angle (deg)")
    ax1.legend(loc="best", fontsize=8)
    ax1.set_title(title or result.label)
    ax2.plot(t, np.degrees(o[:, L.O_SETPOINT] - o[:, L.O_LOAD]), lw=0.8, color="C3")
    ax2.set_ylabel("output error (deg)")
    ax3.plot(t, o[:, L.O_VOLTAGE], lw=0.6, color="C2")
    ax3.set_ylabel("voltage (V)")
    ax3.set_xlabel("time (s)")
    for ax in (ax1, ax2, ax3):
        ax.grid(alpha=0.3)
    fig.tight_layout()
    return fig
