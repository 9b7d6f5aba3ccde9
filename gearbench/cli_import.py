"""``gearbench import``: external measurements into the measurement CSV format (SPEC section 3).

``gearbench import emps DATA.mat|DATA.csv -o OUT.csv`` converts a record of the EMPS benchmark
(A. Janot, M. Gautier, M. Brunot, "Data Set and Reference Models of EMPS", Workshop on Nonlinear
System Identification Benchmarks, Eindhoven, April 2019, HAL hal-02178709); see
``gearbench.measure.emps``.
"""
from __future__ import annotations

from pathlib import Path

import click

from .cli_common import _fail, echo_json

# 12 significant digits keep every value of the record: qm's 5e-8 m steps are 5e-5 mm, and the
# largest position (~246.4 mm) needs 8 digits; the EMPS CSV copies themselves hold 10.
FLOAT_FORMAT = "%.12g"




@click.group(name="import")
def import_group() -> None:
    """Convert external measurements into gearbench's measurement CSV."""


@import_group.command("emps")
@click.argument("data", type=click.Path(dir_okay=False, path_type=Path))
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False, path_type=Path),
              help="Measurement CSV to write (atomically).")
@click.option("--json", "as_json", is_flag=True,
              help="Print {output, rows, duration_s, sample_rate_hz, columns, position_offset_m, data} "
                   "as one JSON object on stdout.")
def emps(data: Path, output: Path, as_json: bool) -> None:
    """Import an EMPS record (DATA_EMPS*.mat or its CSV copy) as a measurement CSV.

    Columns: time_s [s] (sample index x 1 ms), drive_force_N [N] = gtau*vir (the input),
    motor_position_mm and setpoint_mm [mm] (zero at the record's first motor position) and,
    for the pulses run, disturbance_V [V] (0/5 V, already inside drive_force_N).
    """
    from .measure.emps import EMPS_CITATION, read_emps, to_measurement_frame
    from .report.io import write_csv_atomic

    try:
        frame = to_measurement_frame(read_emps(data))
        write_csv_atomic(frame, output, float_format=FLOAT_FORMAT)
    except (OSError, ValueError) as exc:
        _fail(exc)
    t = frame["time_s"].to_numpy()
    if as_json:
        echo_json({"output": str(output), "rows": len(frame), "duration_s": float(t[-1] - t[0]),
                   "sample_rate_hz": 1.0 / frame.attrs["Ts_s"], "columns": list(frame.columns),
                   "position_offset_m": frame.attrs["position_offset_m"], "data": EMPS_CITATION})
        return
    click.echo(f"wrote {output}: {len(frame)} rows, {t[-1] - t[0]:.6g} s at "
               f"{1.0 / frame.attrs['Ts_s']:.6g} Hz, columns {', '.join(frame.columns)} "
               f"(positions shifted by -{frame.attrs['position_offset_m']:.6g} m so the record "
               f"starts at 0)")
    click.echo(f"data: {EMPS_CITATION}")
