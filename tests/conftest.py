"""Shared helpers for the physics tests: a small test plant and free-body setups.

Everything is SI (rad, rad/s, N m, kg m^2).  The special setups build the
compiled core's parameter vector directly (``gearbench.layout.P_*``) so that a
test can switch the motor electrics off (torque input) and zero the damping.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from gearbench import layout as L
from gearbench.control.controllers import Controller
from gearbench.plant.components import Gear, Load, Motor, Plant
from gearbench.plant.pack import rest_state, tolerance_scales
from gearbench.simulate import Segments, SolverOptions, pack, simulate_packed

REPO = Path(__file__).resolve().parents[1]
DATA = REPO / "data"
"""The repository's data (Modelica references, EMPS records, practice cases): tests read only
inside the checkout."""


def small_plant(contact_law: str = "dubowsky", **gear_overrides) -> Plant:
    """A small servo: 2.5 ohm motor, 100:1 gear with 3 deg backlash, ~110 kHz mesh."""
    gear = dict(ratio=100, backlash_deg=3.0, mesh_stiffness=2.4e7, mesh_damping=3.4,
                contact_law=contact_law)
    gear.update(gear_overrides)
    return Plant(Motor(2.5, 1e-3, 0.02, 0.02, 1e-6, 1e-6, 12.0), Gear(**gear), Load(5e-5, 15.0),
                 name="test-plant")


def without_opening_rest(m):
    """Record ``m`` with its first input sample at 1 nV: the same record but one whose input does not
    start at zero, so a replay reads no opening rest (``Replay.opening_rest``) and its reset test
    has only the 21 samples' own scatter, as for a record cut from a running machine."""
    from gearbench.measure.data import from_arrays
    u = np.array(m.input, dtype=float)
    u[0] = 1e-9
    return from_arrays(m.time_s, m.input_name, u, dict(m.signals), source=f"{m.source} (no opening rest)")


def pytest_addoption(parser):
    parser.addoption("--runslow", action="store_true", default=False,
                     help="run the tests marked slow too (make test-all)")


def pytest_configure(config):
    config.addinivalue_line("markers", "slow: long tests (the 10,000-input fuzz); skipped unless --runslow")


def pytest_collection_modifyitems(config, items):
    if config.getoption("--runslow"):
        return
    skip = pytest.mark.skip(reason="slow: run with --runslow (make test-all)")
    for item in items:
        if "slow" in item.keywords:
            item.add_marker(skip)


@pytest.fixture(scope="session")
def plant() -> Plant:
    return small_plant()


def reversal_profile() -> Segments:
    """Rest 0.1 s, ramp to 20 deg at 40 deg/s, hold, ramp back to 0, hold (rad)."""
    r = math.radians
    return Segments(t=np.array([0.0, 0.1, 0.6, 0.8, 1.3]),
                    v=np.array([0.0, 0.0, r(20), r(20), 0.0]),
                    s=np.array([0.0, r(40), 0.0, -r(40), 0.0]))


def ramp_hold_ramp_profile() -> Segments:
    """10 s thesis-like run: rest 0.5 s, ramp to 90 deg at 36 deg/s, hold 2 s, ramp back (rad)."""
    r = math.radians
    return Segments(t=np.array([0.0, 0.5, 3.0, 5.0, 7.5]),
                    v=np.array([0.0, 0.0, r(90), r(90), 0.0]),
                    s=np.array([0.0, r(36), 0.0, -r(36), 0.0]))


def penetration(delta: np.ndarray, h: float) -> np.ndarray:
    """Overlap of the teeth beyond the clearance (vectorised SPEC section 2 ``p``)."""
    return np.where(delta > h, delta - h, np.where(delta < -h, delta + h, 0.0))


# ---------------------------------------------------------------------------
# Two free inertias meshing through the clearance: no motor electrics, no
# bearing damping.  The "motor" is driven by a torque input that is held at 0.
# ---------------------------------------------------------------------------

ZERO_INPUT = Segments(t=np.array([0.0]), v=np.array([0.0]), s=np.array([0.0]))


def free_pair(jm: float, jl: float, n: float, h: float, k: float, d: float,
              law: float = L.LAW_DUBOWSKY) -> np.ndarray:
    """Parameter vector for two free inertias coupled only by the mesh contact."""
    from gearbench.validation import free_pair as pair
    return pair(jm, jl, n, h, k, d, law)


def free_pair_scales(v_rel: float, n: float, k: float, jeff: float) -> np.ndarray:
    """Typical state magnitudes for a free pair hitting with relative speed ``v_rel``.

    The deflection scale is the peak penetration of an undamped impact,
    ``v / omega_n``, so error control resolves the contact itself; speeds are
    scaled by the impact speed (at the motor: ``N v``).
    """
    wn = math.sqrt(k / jeff)
    sc = np.ones(L.N_STATE)
    sc[L.X_WM] = n * v_rel
    sc[L.X_WP] = n * v_rel
    sc[L.X_WL] = v_rel
    sc[L.X_DELTA] = v_rel / wn
    return sc


def run_free_pair(p, scales, x0, t_end, rtol=1e-8, output_dt=None, method="rosenbrock23",
                  max_step=1e-3):
    opts = SolverOptions(method=method, rtol=rtol, max_step_s=max_step,
                         output_dt_s=output_dt if output_dt is not None else t_end)
    run = simulate_packed(p, scales, ZERO_INPUT, t_end, x0, opts)
    assert run.ok, f"solver failed: {run.status} at t = {run.stats[L.S_T_FAIL]}"
    return run


__all__ = ["small_plant", "reversal_profile", "ramp_hold_ramp_profile", "penetration", "free_pair", "free_pair_scales",
           "run_free_pair", "ZERO_INPUT", "Controller", "pack", "rest_state",
           "tolerance_scales", "simulate_packed", "SolverOptions", "Segments"]
