"""``gearbench import``: external measurements into the measurement CSV format (docs/measurements.md).

``gearbench import csv RAW.csv -o DATA.csv --columns time_s=t,... --units time=ms,...`` reads
a lab's CSV with its own column names, units, delimiter and decimal mark
(``gearbench.measure.columns``) and writes the canonical file.  The same three options
(``--columns``, ``--units``, ``--columns-file``) read a record on the fly in ``compare``,
``diagnose`` and ``fit`` (:func:`column_options`).

``gearbench import emps DATA.mat|DATA.csv -o OUT.csv`` converts a record of the EMPS benchmark
(A. Janot, M. Gautier, M. Brunot, "Data Set and Reference Models of EMPS", Workshop on Nonlinear
System Identification Benchmarks, Eindhoven, April 2019, HAL hal-02178709); see
``gearbench.measure.emps``.
"""
from __future__ import annotations

from pathlib import Path

import click

from .cli_common import _fail, echo_json
from .errors import GearbenchError

# 12 significant digits keep every value of the record: qm's 5e-8 m steps are 5e-5 mm, and the
# largest position (~246.4 mm) needs 8 digits; the EMPS CSV copies themselves hold 10.
FLOAT_FORMAT = "%.12g"




COLUMNS_HELP = ("Which file column holds each gearbench column, GEARBENCH=FILE pairs: "
                "time_s=t,voltage_V=u,load_angle_deg=theta_out (a key may be the quantity alone: time=t).")
UNITS_HELP = ("Units of the mapped columns, converted to gearbench's (pint syntax): time=ms,load_angle=rad,"
              "current=mA,motor_angle=turn/4096 (a 4096-count encoder).")
COLUMNS_FILE_HELP = ("A YAML mapping file with columns: and units: mappings (optional delimiter: and "
                     "decimal:); --columns and --units override its entries.  See docs/measurements.md.")
_META = "gearbench.columns"


def _remember(ctx: click.Context, param: click.Parameter, value):
    ctx.meta.setdefault(_META, {})[param.name] = value
    return value


def column_options(expose: bool = True):
    """Decorator adding --columns, --units and --columns-file to a command.

    ``expose=True`` passes them as ``columns``, ``units`` and ``columns_file``; with
    ``expose=False`` the command's signature is unchanged and :func:`context_column_map`
    reads them from the click context.
    """
    kw = {} if expose else {"expose_value": False, "callback": _remember}
    opts = [
        click.option("--columns", "columns", metavar="NAME=COLUMN,...", default=None, help=COLUMNS_HELP, **kw),
        click.option("--units", "units", metavar="QUANTITY=UNIT,...", default=None, help=UNITS_HELP, **kw),
        click.option("--columns-file", "columns_file", metavar="MAP.yaml", default=None,
                     type=click.Path(exists=True, dir_okay=False, path_type=Path), help=COLUMNS_FILE_HELP, **kw),
    ]

    def deco(f):
        for o in reversed(opts):
            f = o(f)
        return f
    return deco


def column_map(columns: str | None, units: str | None, columns_file: Path | None):
    """The ColumnMap the options give (None without any): the file's, overridden by the options.

    Raises MeasurementError (bad pairs, unknown columns or units) or ConfigError (a bad file).
    """
    from .measure.columns import ColumnMap, load_column_map

    if not (columns or units or columns_file):
        return None
    if not columns_file:
        return ColumnMap.build(columns, units)
    return load_column_map(columns_file, partial=True).merged(ColumnMap.build(columns, units, partial=True))


def context_column_map():
    """:func:`column_map` of the options of the running command (see ``column_options(expose=False)``)."""
    ctx = click.get_current_context(silent=True)
    given = ctx.meta.get(_META, {}) if ctx is not None else {}
    return column_map(given.get("columns"), given.get("units"), given.get("columns_file"))


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
    except (GearbenchError, OSError) as exc:  # read_emps names a broken file in an EMPSFormatError
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


@import_group.command("csv")
@click.argument("data", metavar="RAW.csv", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False, path_type=Path),
              help="Measurement CSV to write (atomically), in gearbench's columns and units.")
@column_options()
@click.option("--json", "as_json", is_flag=True,
              help="Print {output, rows, duration_s, sample_rate_hz, columns, mapped, left_out} as one JSON "
                   "object on stdout.")
def csv_(data: Path, output: Path, columns, units, columns_file, as_json: bool) -> None:
    """Import a CSV with its own column names and units as a measurement CSV.

    Every column is checked as gearbench checks its own files (finite numbers, strictly
    increasing time, one input, at least one signal) and converted to gearbench's units;
    the delimiter (comma, semicolon, tab) and decimal mark are sniffed.  File columns
    that are not mapped and not named as gearbench's are left out (and listed).

    \b
    Example:
      gearbench import csv rig.csv -o data.csv \\
        --columns time_s=t,voltage_V=u,load_angle_deg=theta_out,current_A=i \\
        --units time=ms,load_angle=rad,current=mA
    """
    from .measure.data import read_mapped, write_measurement

    if output.resolve() == data.resolve():
        _fail(ValueError(f"-o {output}: the output would overwrite the input {data}; give another path"))
    try:
        m, used, ignored = read_mapped(data, column_map(columns, units, columns_file))
        write_measurement(m, output, float_format=FLOAT_FORMAT)
    except (GearbenchError, OSError) as exc:  # MeasurementError, or ConfigError for a --columns-file
        _fail(exc)
    if as_json:
        echo_json({"output": str(output), "rows": len(m.time_s), "duration_s": m.duration_s,
                   "sample_rate_hz": 1.0 / m.sample_time_s, "columns": list(m.columns()), "mapped": list(used),
                   "left_out": list(ignored)})
        return
    click.echo(f"wrote {output}: {len(m.time_s)} rows, {m.duration_s:.6g} s at {1.0 / m.sample_time_s:.6g} Hz "
               f"(median), columns {', '.join(m.columns())}")
    for line in used:
        click.echo(f"  {line}")
    if ignored:
        click.echo(f"  left out (not mapped): {', '.join(ignored)}")
