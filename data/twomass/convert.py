"""Convert the FdiTools two-mass bench's multisine records (.mat) into gearbench measurement CSVs.

Source: HoriFujimotoLab/FdiTools (MIT, see LICENSE and README.md here), commit
5925fae7e65f091b4111b1ba123e08dd869cb590, ``Examples/private/MultisineTypeA.mat`` and
``MultisineTypeB.mat``.  The .mat files are not in this repository; the CSVs this script
writes are.  Run from anywhere, with the directory that holds the .mat files::

    python data/twomass/convert.py PATH/TO/MAT_DIR [--out data/twomass]

Each record becomes ``twomass_<A|B>.csv`` with the columns

- ``time_s``: ``time`` (µs, steps of 400) / 1e6, so 2.5 kHz, 50,000 samples (20 s);
- ``drive_torque_Nm``: the measured q-axis current ``iq_adx`` (A) times a lumped torque
  constant of 1 N m/A: the torque constant is not given by the source, so every inertia,
  stiffness and damping of a plant fitted to these files is per N m/A of the real one;
- ``motor_angle_deg``: ``theta_mx`` (rad) in degrees, less its first sample;
- ``load_angle_deg``: ``-theta_my`` (rad; the load encoder counts the other way, as the
  source's scripts take it) in degrees, less its first sample.

Every sample is kept (no decimation: the coupling's resonance at ~77 Hz and the excited band
up to 250 Hz need the 2.5 kHz rate).  Values are written with 10 significant digits (the
encoders' step is ~6e-6 rad = 3.4e-4 deg, the current's ~1e-5 A).
"""
from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

RECORDS = {"A": "MultisineTypeA.mat", "B": "MultisineTypeB.mat"}
KT_LUMPED = 1.0
"""N m per A: the torque constant assumed (not given by the source)."""
COLUMNS = ("time_s", "drive_torque_Nm", "motor_angle_deg", "load_angle_deg")


def convert(mat: Path) -> np.ndarray:
    """The record in ``mat`` as a (n, 4) array of :data:`COLUMNS`."""
    from scipy.io import loadmat

    d = loadmat(mat, squeeze_me=True)
    t = np.asarray(d["time"], dtype=float) * 1e-6
    fs = float(d["fs"])
    if not np.allclose(np.diff(t), 1.0 / fs, rtol=1e-9, atol=1e-12):
        raise ValueError(f"{mat}: time is not sampled at fs = {fs} Hz")
    iq = np.asarray(d["iq_adx"], dtype=float)
    th_m = np.asarray(d["theta_mx"], dtype=float)
    th_l = -np.asarray(d["theta_my"], dtype=float)
    deg = 180.0 / math.pi
    return np.column_stack([t - t[0], KT_LUMPED * iq, (th_m - th_m[0]) * deg, (th_l - th_l[0]) * deg])


def write_csv(rows: np.ndarray, path: Path) -> None:
    np.savetxt(path, rows, delimiter=",", header=",".join(COLUMNS), comments="", fmt="%.10g")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("mat_dir", type=Path, help="directory holding MultisineTypeA.mat and MultisineTypeB.mat")
    ap.add_argument("--out", type=Path, default=Path(__file__).resolve().parent,
                    help="where to write twomass_A.csv and twomass_B.csv (default: beside this script)")
    args = ap.parse_args(argv)
    for tag, name in RECORDS.items():
        rows = convert(args.mat_dir / name)
        out = args.out / f"twomass_{tag}.csv"
        write_csv(rows, out)
        print(f"{out}: {len(rows)} rows from {name}")


if __name__ == "__main__":
    main()
