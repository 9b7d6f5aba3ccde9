"""Closed-loop stability of the engaged plant under P, PI or PID control.

The plant is linearised with the teeth in contact on one flank
(:func:`gearbench.plant.linear.engaged_state_space`: ``dx/dt = A x + B u``,
``u`` the motor voltage in V).  The controller sees ``y = theta_m / N`` (rad,
the motor-side angle referred to the output), the error is ``e = r - y``, and
in deviations from an equilibrium ``r = 0``.  Inside, the proportional gain is
``K = kp * 180/pi`` V/rad for ``kp`` in V/deg (the files' unit).  The voltage
saturation at ``+-max_voltage`` is **ignored** (a linearisation), as is the
clearance: this is the loop while the teeth stay in contact.

Controllers (the compiled laws of ``laws.py``, augmented states in brackets)::

    P:    u = K e
    PI:   u = K (e + Ki z),                      dz/dt = e          [z]
    PID:  u = K (e + Ki z + Kd (e - f)/Tf),      df/dt = (e - f)/Tf [z, f]

so the closed loop is ``dx_c/dt = (A0 + K b g) x_c`` with ``b = [B; 0]`` and
``g`` the controller row: it is affine in ``K`` with a rank-one ``K`` term,
hence the characteristic polynomial is

    p(s; K) = det(s I - A0 - K b g) = D(s) + K N(s)

(``D`` = ``det(sI - A0)``, ``N`` = ``det(sI - A0 - b g) - D``).  It is built
exactly in rationals.  With ``p(s) = a0 s^n + a1 s^(n-1) + ... + an`` (``a0 = 1``)
the Hurwitz criterion says every root has ``Re s < 0`` iff all Hurwitz
determinants ``Delta_1 ... Delta_n`` are positive, ``Delta_k`` the leading
``k x k`` minor of ``H[i][j] = a_(2j - i)`` (1-based; ``a_m = 0`` outside
``0..n``).  Each ``Delta_k`` is a polynomial in ``K`` of degree <= k, so the
stable gains are the ``K > 0`` where all of them are positive: an exact union
of intervals between their real roots.  :func:`eigen_scan` cross-checks with
the eigenvalues of the closed-loop matrix on a grid of gains.

The same analysis runs on the loop with the **teeth apart** (``contact=False``:
the motor, and pinion with a shaft, alone inside the clearance, states
``[i, theta_m, w_m, (phi, w_p)]``): the load no longer damps the motor there,
so that loop has a much lower gain limit, which is what makes high gains
chatter in the clearance although the engaged loop is stable.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Sequence

import numpy as np

from ..plant.components import Plant
from ..plant.linear import StateSpace, engaged_state_space
from . import polynomials as poly

DEG_PER_RAD = 180.0 / math.pi
KINDS = ("p", "pi", "pid")


@dataclass(frozen=True)
class Loop:
    """The engaged plant closed by a P, PI or PID controller, affine in the gain.

    ``matrix(K) = a0 + K * outer(b, g)`` (``K`` in V/rad); ``states`` names the rows.
    ``ki`` in 1/s, ``kd`` in s, ``tf`` (derivative filter) in s.
    """
    kind: str
    a0: np.ndarray
    b: np.ndarray
    g: np.ndarray
    states: tuple[str, ...]
    ki: float = 0.0
    kd: float = 0.0
    tf: float = 1e-3

    def matrix(self, k_v_per_rad: float) -> np.ndarray:
        return self.a0 + k_v_per_rad * np.outer(self.b, self.g)


def free_state_space(plant: Plant) -> StateSpace:
    """The motor side alone, teeth apart (no mesh torque): ``[i, theta_m, w_m, (phi, w_p)]``,
    voltage input.  ``L di/dt = u - R i - ke w_m``, ``Jm dw_m/dt = kt i - bm w_m (- Ts)``,
    with a shaft ``Ts = ks phi + ds (w_m - w_p)``, ``dphi/dt = w_m - w_p``, ``Jp dw_p/dt = Ts``."""
    m, sh = plant.motor, plant.shaft
    names = ("i", "theta_m", "w_m") + (("phi", "w_p") if sh is not None else ())
    a = np.zeros((len(names), len(names)))
    b = np.zeros(len(names))
    a[0, 0], a[0, 2], b[0] = -m.resistance / m.inductance, -m.back_emf_constant / m.inductance, \
        1.0 / m.inductance
    a[1, 2] = 1.0
    a[2, 0], a[2, 2] = m.torque_constant / m.inertia, -m.damping / m.inertia
    if sh is not None:
        twist = np.array([0.0, 0.0, sh.damping, sh.stiffness, -sh.damping])  # Ts over the states
        a[2] -= twist / m.inertia
        a[3, 2], a[3, 4] = 1.0, -1.0
        a[4] += twist / sh.pinion_inertia
    return StateSpace(a, b, names)


def closed_loop(plant: Plant, kind: str = "p", ki: float = 0.0, kd: float = 0.0,
                tf: float = 1e-3, contact: bool = True) -> Loop:
    """Build :class:`Loop` for ``kind`` in ``p``, ``pi``, ``pid`` (module docstring);
    ``contact=False``: the loop with the teeth apart (:func:`free_state_space`)."""
    if kind not in KINDS:
        raise ValueError(f"controller must be one of {', '.join(KINDS)}, got {kind!r}")
    if kind == "pid" and not tf > 0:
        raise ValueError(f"the derivative filter time constant must be positive (s), got {tf!r}")
    ss = engaged_state_space(plant) if contact else free_state_space(plant)
    n = len(ss.states)
    c = np.zeros(n)
    c[ss.states.index("theta_m")] = 1.0 / plant.gear.ratio          # y = theta_m / N
    extra = {"p": 0, "pi": 1, "pid": 2}[kind]
    m = n + extra
    a0 = np.zeros((m, m))
    a0[:n, :n] = ss.a
    b = np.zeros(m)
    b[:n] = ss.b
    g = np.zeros(m)
    g[:n] = -c                                                       # e = -y
    states = list(ss.states)
    if kind in ("pi", "pid"):
        a0[n, :n] = -c                                               # dz/dt = e
        g[n] = ki
        states.append("z")
    if kind == "pid":
        a0[n + 1, :n] = -c / tf                                      # df/dt = (e - f)/Tf
        a0[n + 1, n + 1] = -1.0 / tf
        g[:n] += -(kd / tf) * c                                      # Kd (e - f)/Tf
        g[n + 1] = -kd / tf
    return Loop(kind, a0, b, g, tuple(states), ki, kd, tf)


def _exact(m: np.ndarray) -> list[list[Fraction]]:
    return [[Fraction(float(v)) for v in row] for row in m]


@dataclass(frozen=True)
class CharPoly:
    """``p(s; K) = den(s) + K num(s)``, exact; coefficients highest power first, ``K`` in V/rad."""
    den: list
    num: list

    def coefficients(self, k: Fraction) -> list[Fraction]:
        k = Fraction(k)
        num = [Fraction(0)] * (len(self.den) - len(self.num)) + list(self.num)
        return [d + k * q for d, q in zip(self.den, num)]


def characteristic_polynomial(loop: Loop) -> CharPoly:
    """``det(sI - A0 - K b g) = D(s) + K N(s)`` exactly (rank-one ``K`` term: affine in ``K``)."""
    a0 = _exact(loop.a0)
    den = poly.charpoly(a0)
    # K = 1, with b g added exactly (not rounded through a float sum)
    bg = [[Fraction(float(bi)) * Fraction(float(gj)) for gj in loop.g] for bi in loop.b]
    at_one = poly.charpoly([[x + y for x, y in zip(ra, rb)] for ra, rb in zip(a0, bg)])
    return CharPoly(den, poly.trim([x - y for x, y in zip(at_one, den)]))


def hurwitz_matrix(coeffs: Sequence[Fraction]) -> list[list[Fraction]]:
    """``H[i][j] = a_(2j - i)`` (1-based), ``a_m = 0`` outside ``0..n``."""
    n = len(coeffs) - 1

    def a(m: int) -> Fraction:
        return coeffs[m] if 0 <= m <= n else Fraction(0)

    return [[a(2 * j - i) for j in range(1, n + 1)] for i in range(1, n + 1)]


def hurwitz_determinants(cp: CharPoly) -> list[list[Fraction]]:
    """``Delta_1(K) ... Delta_n(K)`` as exact polynomials in ``K`` (V/rad), highest power first.

    ``Delta_k`` has degree <= k in ``K``: it is evaluated exactly at ``K = 0 .. k``
    and interpolated.
    """
    n = len(cp.den) - 1
    out = []
    for k in range(1, n + 1):
        xs = [Fraction(j) for j in range(k + 1)]
        ys = []
        for x in xs:
            h = hurwitz_matrix(cp.coefficients(x))
            ys.append(poly.determinant([row[:k] for row in h[:k]]))
        out.append(poly.interpolate(xs, ys))
    return out


def routh_first_column(coeffs: Sequence[Fraction]) -> list[Fraction] | None:
    """First column of the Routh array of ``coeffs`` (exact); None if a zero appears in it
    (a root on, or symmetric about, the imaginary axis: not asymptotically stable).
    The number of sign changes in the column is the number of roots with ``Re s > 0``."""
    coeffs = [Fraction(c) for c in coeffs]
    n = len(coeffs) - 1
    rows = [coeffs[0::2], coeffs[1::2]]
    width = len(rows[0])
    rows = [r + [Fraction(0)] * (width - len(r)) for r in rows]
    for _ in range(n - 1):
        up, low = rows[-2], rows[-1]
        if low[0] == 0:
            return None
        new = [(low[0] * up[j + 1] - up[0] * low[j + 1]) / low[0] for j in range(width - 1)]
        rows.append(new + [Fraction(0)])
    col = [r[0] for r in rows[: n + 1]]
    return None if any(c == 0 for c in col) else col


def rhp_roots_routh(coeffs: Sequence[Fraction]) -> int | None:
    """Roots with ``Re s > 0`` by the Routh array's sign changes (None: a zero in the column)."""
    col = routh_first_column(coeffs)
    if col is None:
        return None
    return sum(1 for u, v in zip(col, col[1:]) if (u > 0) != (v > 0))


@dataclass(frozen=True)
class Interval:
    """Stable gains ``low < kp < high`` in V/deg (``high`` None: unbounded); ``low_by``
    / ``high_by`` name the Hurwitz determinant that vanishes at each end."""
    low: float
    high: float | None
    low_by: str = ""
    high_by: str = ""


def _all_positive(conditions: list[list[Fraction]], k: Fraction) -> bool:
    return all(poly.evaluate(c, k) > 0 for c in conditions)


def stable_intervals(cp: CharPoly) -> list[Interval]:
    """The ``kp > 0`` (V/deg) for which ``p(s; K)`` is Hurwitz, from the Hurwitz determinants.

    Break points are the positive real roots of every ``Delta_k(K)``; each piece
    between them is classified exactly at an interior rational gain.
    """
    deltas = hurwitz_determinants(cp)
    breaks: list[tuple[float, str]] = []
    for k, d in enumerate(deltas, start=1):
        breaks += [(r, f"Delta_{k}") for r in poly.positive_roots(d)]
    breaks.sort()
    edges = [(0.0, "")] + breaks + [(math.inf, "")]
    pieces = []
    for (lo, lo_by), (hi, hi_by) in zip(edges, edges[1:]):
        if hi <= lo:
            continue
        test = hi / 2 if lo == 0.0 else (2 * lo + 1 if math.isinf(hi) else math.sqrt(lo * hi))
        if _all_positive(deltas, Fraction(test)):
            pieces.append([lo, hi, lo_by, hi_by])
    merged: list[list] = []
    for piece in pieces:            # touching pieces (a determinant with an even root) merge
        if merged and merged[-1][1] == piece[0]:
            merged[-1][1], merged[-1][3] = piece[1], piece[3]
        else:
            merged.append(piece)
    to_deg = 1.0 / DEG_PER_RAD
    return [Interval(lo * to_deg, None if math.isinf(hi) else hi * to_deg, lb, hb)
            for lo, hi, lb, hb in merged]


def is_stable_kp(intervals: Sequence[Interval], kp: float) -> bool:
    return any(iv.low < kp and (iv.high is None or kp < iv.high) for iv in intervals)


def eigen_scan(loop: Loop, kps: Sequence[float]) -> np.ndarray:
    """Largest real part of the closed-loop eigenvalues (1/s) at each ``kp`` (V/deg).

    ``numpy.linalg.eigvals`` balances the matrix first, which keeps the 110 kHz mesh
    from swamping the slow loop poles.
    """
    return np.array([np.linalg.eigvals(loop.matrix(kp * DEG_PER_RAD)).real.max() for kp in kps])


def linear_stable(plant: Plant, kind: str, kp: float, ki: float = 0.0, kd: float = 0.0,
                  tf: float = 1e-3) -> bool:
    """Is the engaged, unsaturated loop asymptotically stable at ``kp`` V/deg (eigenvalues)?"""
    loop = closed_loop(plant, kind, ki, kd, tf)
    return bool(eigen_scan(loop, [kp])[0] < 0.0)


def rigid_p_bound(plant: Plant) -> float | None:
    """Upper stable P gain (V/deg) of the rigid-gear, no-clearance approximation.

    With one rigid inertia ``J = Jm + Jl/N^2`` and damping ``b = bm + bl/N^2`` at
    the motor, the loop's polynomial is the cubic
    ``L J s^3 + (L b + R J) s^2 + (R b + kt ke) s + K kt/N``, whose Routh condition
    gives ``K < N (L b + R J)(R b + kt ke) / (L J kt)``.  None with a shaft or
    leadscrew (the formula does not cover them).
    """
    if plant.shaft is not None or plant.leadscrew is not None:
        return None
    m, n = plant.motor, plant.gear.ratio
    j = plant.driven_inertia
    b = plant.driven_damping
    el, r, kt, ke = m.inductance, m.resistance, m.torque_constant, m.back_emf_constant
    k_max = n * (el * b + r * j) * (r * b + kt * ke) / (el * j * kt)
    return k_max / DEG_PER_RAD


@dataclass
class StabilityReport:
    """What ``gearbench stability`` prints (see :func:`analyse`)."""
    plant: str
    kind: str
    ki: float
    kd: float
    tf: float
    states: tuple[str, ...]
    den: list[float]
    num: list[float]
    intervals: list[Interval]
    scan_kp: np.ndarray
    scan_max_real: np.ndarray
    scan_routh: np.ndarray
    checks: list[dict] = field(default_factory=list)
    rigid_bound: float | None = None
    free_intervals: list[Interval] = field(default_factory=list)
    free_scan_agrees: int = 0

    @property
    def scan_agrees(self) -> int:
        return int(np.sum((self.scan_max_real < 0) == self.scan_routh))

    def to_dict(self) -> dict:
        return {
            "plant": self.plant, "controller": self.kind, "ki_per_s": self.ki, "kd_s": self.kd,
            "derivative_filter_s": self.tf, "states": list(self.states),
            "characteristic_polynomial": {
                "form": "p(s; K) = den(s) + K num(s), K = kp*180/pi in V/rad, highest power first",
                "den": self.den, "num": self.num},
            "stable_kp_v_per_deg": [{"low": iv.low, "high": iv.high, "low_by": iv.low_by,
                                      "high_by": iv.high_by} for iv in self.intervals],
            "eigen_scan": {"kp_min": float(self.scan_kp[0]), "kp_max": float(self.scan_kp[-1]),
                           "points": int(len(self.scan_kp)), "agree": self.scan_agrees,
                           "disagree_kp": [float(k) for k, e, r in zip(
                               self.scan_kp, self.scan_max_real, self.scan_routh) if (e < 0) != r]},
            "checks": self.checks,
            "rigid_gear_kp_max_v_per_deg": self.rigid_bound,
            "teeth_apart_stable_kp_v_per_deg": [
                {"low": iv.low, "high": iv.high, "low_by": iv.low_by, "high_by": iv.high_by}
                for iv in self.free_intervals],
            "teeth_apart_eigen_scan_agree": self.free_scan_agrees,
        }


def analyse(plant: Plant, kind: str = "p", ki: float = 0.0, kd: float = 0.0, tf: float = 1e-3,
            scan: Sequence[float] | None = None,
            check_kp: Sequence[float] = (0.5, 1.0, 5.0, 50.0, 500.0, 5000.0)) -> StabilityReport:
    """Stable ``kp`` range (V/deg) by Hurwitz determinants, cross-checked by eigenvalues;
    the same for the loop with the teeth apart (``free_intervals``).

    ``scan``: gains of the eigenvalue cross-check (default 200 log-spaced over
    1e-3 ... 1e6 V/deg); ``check_kp``: gains at which the Routh array's sign
    changes (roots in the right half plane) are set beside the eigenvalues, with
    the damping ratio ``-Re(s)/|s|`` and natural frequency ``|s|/2pi`` (Hz) of the
    dominant oscillatory pair (the complex roots with the largest real part) and
    the largest real part of the teeth-apart loop's roots (1/s).
    """
    loop = closed_loop(plant, kind, ki, kd, tf)
    cp = characteristic_polynomial(loop)
    intervals = stable_intervals(cp)
    kps = np.logspace(-3, 6, 200) if scan is None else np.asarray(scan, dtype=float)
    max_real = eigen_scan(loop, kps)
    routh = np.array([is_stable_kp(intervals, k) for k in kps])
    free = closed_loop(plant, kind, ki, kd, tf, contact=False)
    checks = []
    for kp in check_kp:
        coeffs = cp.coefficients(Fraction(kp * DEG_PER_RAD))
        lam = np.linalg.eigvals(loop.matrix(kp * DEG_PER_RAD))
        osc = lam[np.abs(lam.imag) > 1e-9 * np.abs(lam)]
        dom = osc[np.argmax(osc.real)] if len(osc) else None    # the slowest-decaying pair
        checks.append({"kp": kp, "rhp_roots_routh": rhp_roots_routh(coeffs),
                       "rhp_roots_eig": int(np.sum(lam.real > 0)),
                       "max_real_eig": float(lam.real.max()),
                       "dominant_damping_ratio": None if dom is None else float(-dom.real / abs(dom)),
                       "dominant_frequency_hz": None if dom is None else float(abs(dom) / (2 * math.pi)),
                       "max_real_eig_teeth_apart": float(eigen_scan(free, [kp])[0])})
    free_intervals = stable_intervals(characteristic_polynomial(free))
    free_agree = int(np.sum((eigen_scan(free, kps) < 0)
                            == np.array([is_stable_kp(free_intervals, k) for k in kps])))
    return StabilityReport(plant.name, kind, ki, kd, tf, loop.states,
                           [float(c) for c in cp.den], [float(c) for c in cp.num], intervals,
                           kps, max_real, routh, checks,
                           rigid_p_bound(plant) if kind == "p" else None,
                           free_intervals, free_agree)
