"""A sampled position-velocity controller (the EMPS benchmark's), as an object.

At each sample ``k`` (period ``Ts``) it reads the motor position referred to
the output, ``y_k``, and the set point ``r_k``::

    yf_k = (y_k + y_{k-1}) / 2                 two-tap FIR smoothing
    v_k  = (yf_k - yf_{k-1}) / Ts              velocity estimate
    c_k  = kv (kp (r_k - y_k) - v_k)           controller output, V
    u    = gain (sat(c_{k-d}, limit) + dist_k) the drive's input, held to k+1

with ``d`` = ``delay_samples`` (0 or 1).  The compiled law is the gear
model's discrete update (``plant/model.py``); this class converts the edge
units to SI at the output.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import layout as L


@dataclass(frozen=True)
class SampledPV:
    """kp_per_s (1/s); kv: V per (position unit)/s where the position unit is
    ``m`` for a leadscrew plant (``kv_V_s_per_m``) or ``deg`` of the output
    otherwise (``kv_V_s_per_deg``); gain: drive input per controller volt
    (N/V, N m/V or V/V); limit_V: saturation of ``c``; sample_time_s;
    delay_samples: 0 or 1."""
    kp_per_s: float
    kv: float
    gain: float
    limit_V: float = 10.0
    sample_time_s: float = 1e-3
    delay_samples: int = 1
    kind: str = "sampled_pv"

    def pack(self, plant, p: np.ndarray) -> np.ndarray:
        """Fill the controller slots of ``p`` (kv in V/(rad/s) at the output)."""
        per_rad = plant.leadscrew.radius if plant.leadscrew is not None else 180.0 / math.pi
        p[L.P_CTRL] = L.CTRL_SAMPLED_PV
        p[L.P_KP] = self.kp_per_s
        p[L.P_KV] = self.kv * per_rad
        p[L.P_CTRL_GAIN] = self.gain
        p[L.P_VMAX] = self.limit_V
        p[L.P_DELAY] = float(self.delay_samples)
        return p
