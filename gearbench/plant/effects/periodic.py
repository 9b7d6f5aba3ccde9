"""Reading a position-periodic effect off a record: the order (periods per
revolution), phase and size of a ripple that repeats with a shaft's angle.

An effect whose term is ``a sin(n theta + phi)`` (cogging, a transmission
error) has an integer ``n`` a least-squares fit cannot move; its ``estimate``
(``base.Effect.estimate``) reads ``n`` here instead: a signal that carries the
ripple (an acceleration, the gap between the motor and the load angle) is
projected on ``exp(-i k theta)`` for every order ``k`` the record can show,
over the samples where the shaft moves, and the strongest order wins.  The
projection needs no time axis: records are sampled uniformly, so derivatives
per sample differ from those per second by a constant factor.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.signal import savgol_filter

SAMPLES_PER_PERIOD = 12  # the shortest ripple period counted, in samples
MIN_SAMPLES = 200         # samples an order needs (at speeds that resolve it) to be counted


def moving(theta: np.ndarray, window: int = 21) -> tuple[np.ndarray, np.ndarray]:
    """``(speed, mask)``: the angle's smoothed change per sample and the samples
    where the shaft moves (faster than 5 % of its fastest), for angle ``theta`` (rad)."""
    w = min(window, theta.size - (1 - theta.size % 2))
    speed = savgol_filter(theta, w, 3, deriv=1)
    top = float(np.max(np.abs(speed))) if speed.size else 0.0
    return speed, np.abs(speed) > 0.05 * top


def coefficient(theta: np.ndarray, y: np.ndarray, k: int) -> complex:
    """``c_k = mean(y exp(-i k theta))``: ``y = a sin(k theta + phi)`` over whole
    periods gives ``c_k = a exp(i phi) / 2i``."""
    return complex(np.mean(y * np.exp(-1j * k * theta)))


def dominant(theta: np.ndarray, y: np.ndarray, speed: np.ndarray, mask: np.ndarray, lowest: int = 2,
             highest: int = 2000) -> tuple[int, float, float] | None:
    """``(n, a, phi_deg)``: the order with the most significant ripple of ``y``
    against ``theta`` (rad), as ``y ~ a sin(n theta + phi)``; None when no order
    has enough samples.

    Order k is read over the samples of ``mask`` slow enough to resolve it (a
    period of at least ``SAMPLES_PER_PERIOD`` samples at that ``speed``, rad per
    sample) and covering three of its periods; its significance is
    ``|c_k|`` against its noise, ``std(y) / sqrt(samples)``.
    """
    best = None
    for k in range(lowest, highest + 1):
        sel = mask & (k * np.abs(speed) < 2.0 * math.pi / SAMPLES_PER_PERIOD)
        m = int(sel.sum())
        if m < MIN_SAMPLES:
            break  # faster orders have fewer samples still
        th, v = theta[sel], y[sel] - np.mean(y[sel])
        if k * (th.max() - th.min()) < 6.0 * math.pi:
            continue
        c = coefficient(th, v, k)
        sd = float(np.std(v))
        score = abs(c) * math.sqrt(m) / sd if sd > 0 else 0.0
        if best is None or score > best[0]:
            best = (score, k, c)
    if best is None:
        return None
    z = 2j * best[2]  # a exp(i phi)
    return best[1], float(abs(z)), math.degrees(float(np.angle(z)))
