"""``gearbench synth``: a synthetic measurement from a plant with hidden effects.

    gearbench synth PLANT.yaml --effect "coulomb_friction location=load torque=0.96" \\
        --excitation steps --duration 10 --seed 1 -o DATA.csv

writes DATA.csv (the SPEC's measurement format) and DATA.truth.yaml (what was
hidden), for practising ``compare``/``diagnose``/``fit`` on a record whose truth
is known.  See ``gearbench.synth``.
"""
from __future__ import annotations

import shlex
import time
from pathlib import Path

import click

from .cli_common import parse_noise, _fail, console, echo_json
from .errors import ConfigError, GearbenchError


def _number_or_text(text: str):
    """``"0.05"`` -> 0.05, ``"1000"`` -> 1000, anything else stays a string (an option)."""
    try:
        return int(text)
    except ValueError:
        pass
    try:
        x = float(text)
    except ValueError:
        return text
    return x


def parse_effect(spec: str) -> dict:
    """``"NAME key=value ..."`` -> ``{type: NAME, key: value, ...}`` (numbers converted).

    Raises ``ValueError`` for a blank spec, a token that is not ``key=value``
    or a key given twice.
    """
    try:
        tokens = shlex.split(spec)
    except ValueError as exc:
        raise ValueError(f"--effect {spec!r}: cannot split it into words: {exc}") from None
    if not tokens:
        raise ValueError("--effect needs an effect name and key=value parameters, e.g. "
                         "--effect 'coulomb_friction location=load torque=0.05'")
    name, item = tokens[0], {"type": tokens[0]}
    if "=" in name:
        raise ValueError(f"--effect {spec!r}: it must start with the effect's name, then key=value "
                         f"parameters, e.g. 'coulomb_friction location=load torque=0.05'")
    for tok in tokens[1:]:
        key, eq, value = tok.partition("=")
        key = key.strip()
        if not eq or not key or not value.strip():
            raise ValueError(f"--effect {name}: {tok!r} is not key=value (e.g. torque=0.05)")
        if key in item:
            raise ValueError(f"--effect {name}: key {key!r} is given twice")
        item[key] = _number_or_text(value.strip())
    return item


def check_effects(specs: tuple[str, ...], plant) -> list:
    """Parse and validate ``--effect`` values as a plant file's ``effects:`` entries
    (``experiment.files.check_effects_on``: the registry, then that each effect can sit
    on ``plant``, e.g. no amplifier dead zone on a torque drive).  Raises ``ConfigError``
    (label ``--effect``) listing every problem, each naming the effect and the key.
    """
    from .experiment.files import check_effects_on

    problems: list[str] = []
    items = []
    for spec in specs:
        try:
            items.append(parse_effect(spec))
        except ValueError as exc:
            problems.append(str(exc).removeprefix("--effect "))
    names = [it["type"] for it in items]
    paths = [name if names.count(name) == 1 else f"{name} (#{i + 1})" for i, name in enumerate(names)]
    hidden = check_effects_on(plant, items, paths, problems)
    if problems:
        raise ConfigError("--effect", problems)
    return list(hidden)


def _command_line(plant_file, effects, excitation, duration, sample_time, noise, signals, seed, output,
                  noise_ar1: float = 0.0) -> str:
    words = ["gearbench", "synth", str(plant_file)]
    for e in effects:
        words += ["--effect", e]
    words += ["--excitation", excitation]
    if duration is not None:
        words += ["--duration", f"{duration:g}"]
    if sample_time != 1e-3:
        words += ["--sample-time", f"{sample_time:g}"]
    for n in noise:
        words += ["--noise", n]
    if noise_ar1:
        words += ["--noise-ar1", f"{noise_ar1:g}"]
    for s in signals:
        words += ["--signal", s]
    words += ["--seed", str(seed), "-o", str(output)]
    return " ".join(shlex.quote(w) for w in words)


@click.command()
@click.argument("plant_file", metavar="PLANT.yaml", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option("--effect", "effects", multiple=True, metavar="'NAME key=value ...'",
              help="A hidden effect, as one quoted string: its name, then its parameters as in a "
                   "plant file (e.g. 'coulomb_friction location=load torque=0.05'). Repeatable.")
@click.option("--excitation", default="steps", show_default=True,
              metavar="steps|mixed|prbs|chirp|multisine|profile:N|FILE",
              help="The open-loop input: 'steps' (levels of 12-100 % of the limit, both directions, "
                   "with rests), 'mixed' (the practice cases' input: steps both ways with pauses and "
                   "direct reversals, low-level steps, three fast reversals, a slow sine period and a "
                   "triangle ramp, levels and durations jittered +-15 % by the seed), 'prbs' (+-30 % "
                   "of the limit, the sign drawn every 40 ms), 'chirp' (a logarithmic sweep, 0.2 Hz to "
                   "10 Hz or a tenth of the sample rate, peak 35 %), 'multisine' (8 log-spaced sines "
                   "over that band, random phases, peak 35 %), 'profile:N' (the "
                   "voltage a P controller applied following thesis profile N = 1, 2, 3) or a CSV with "
                   "time_s and one input column.")
@click.option("--duration", type=float, default=None,
              help="Record length, s [default: 10, mixed 16; a FILE's own length].")
@click.option("--sample-time", "sample_time", type=float, default=1e-3, show_default=True,
              help="Sample interval, s (all but a FILE).")
@click.option("--noise", "noise", multiple=True, metavar="SIGNAL=STD",
              help="Noise standard deviation of a signal in its unit [default: 0.01 deg on angles, "
                   "0.005 A on current, 0.001 mm on positions]; all=STD sets every signal. "
                   "An encoder-quantised signal gets none. Repeatable.")
@click.option("--noise-ar1", "noise_ar1", type=click.FloatRange(-1.0, 1.0, min_open=True, max_open=True),
              default=0.0, show_default=True, metavar="RHO",
              help="Colour the noise: each signal's noise an AR(1) process with lag-1 correlation RHO "
                   "(lag k: RHO^k), its standard deviation still the --noise one; 0 = white.")
@click.option("--signal", "signals", multiple=True, metavar="COLUMN",
              help="A measured column to record (repeatable) [default: motor_angle_deg, "
                   "load_angle_deg or load_position_mm, and current_A for a voltage drive].")
@click.option("--seed", type=int, default=0, show_default=True, help="Seed of the input (steps, mixed, prbs; chirp and multisine phases) and of the noise.")
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False, path_type=Path),
              help="Measurement CSV to write; the truth goes beside it as <name>.truth.yaml.")
@click.option("--json", "as_json", is_flag=True,
              help="Print {output, truth, samples, duration_s, input, signals, hidden, wall_s} as one "
                   "JSON object on stdout.")
def synth(plant_file: Path, effects: tuple[str, ...], excitation: str, duration: float | None,
          sample_time: float, noise: tuple[str, ...], noise_ar1: float, signals: tuple[str, ...], seed: int,
          output: Path, as_json: bool) -> None:
    """Synthesize a measurement: PLANT.yaml with hidden effects, driven open loop.

    The simulated record (SPEC section 3 columns: time_s, the commanded input,
    the signals with sensor effects and noise; at rest, mesh centred at the
    start) goes to OUTPUT, and what was hidden (effects and parameters,
    noise, seed, excitation, plant file) to OUTPUT with the suffix
    .truth.yaml. Both are written atomically, and neither if anything fails.
    Exit status 1 when the solver cannot finish the record, 2 for bad input.
    """
    import yaml

    from .experiment.files import load_plant
    from . import synth as S
    from .measure.data import write_measurement
    from .report.io import write_text_atomic

    start = time.perf_counter()
    truth_path = output.with_suffix(".truth.yaml")
    try:
        plant = load_plant(plant_file)
        hidden = check_effects(effects, plant)
        truth = plant.with_effects(*hidden)
        noise_given = parse_noise(noise)
        sigs = tuple(signals) or S.default_signals(plant)
        if "*" in noise_given:
            std = noise_given.pop("*")
            noise_given = {**{s: std for s in sigs}, **noise_given}
        # the controller of profile:N runs on the real rig, hidden effects and all
        t, u = S.excitation(excitation, truth, duration, sample_time, seed)
        data = S.synthesize(plant, hidden, t, u, sigs, noise_given, seed,
                            label=f"synth {plant.name} ({excitation})", noise_ar1=noise_ar1)
        exc_info: dict = {"kind": excitation, "duration_s": float(t[-1] - t[0]),
                          "samples": len(t)}
        if excitation == "steps":
            exc_info.update(sample_time_s=sample_time, seed=seed,
                            levels=f"+-{', '.join(f'{x:g}' for x in S.STEP_LEVELS)} x "
                                   f"{S.input_scale(truth):g} {data.input_unit}")
        elif excitation == "mixed":
            exc_info.update(sample_time_s=sample_time, seed=seed,
                            segments=[f"{shape} {level:+g} x {S.input_scale(truth):g} {data.input_unit}, "
                                      f"{span:g} s" for shape, level, span in S.MIXED],
                            jitter=f"each level and duration x U(1 -+ {S.MIXED_JITTER:g}), durations "
                                   "then scaled to the record's length")
        elif excitation == "prbs":
            exc_info.update(sample_time_s=sample_time, seed=seed, clock_s=S.PRBS_CLOCK_S,
                            levels=f"+-{S.PRBS_LEVEL:g} x {S.input_scale(truth):g} {data.input_unit}")
        elif excitation in S.NO_RESTS:
            f0, f1 = S.sweep_band(sample_time)
            exc_info.update(sample_time_s=sample_time, seed=seed, band_Hz=[f0, f1], fade_s=S.FADE_S,
                            peak=f"{S.SWEEP_LEVEL:g} x {S.input_scale(truth):g} {data.input_unit}")
        elif excitation.startswith("profile:"):
            ctrl = S.profile_controller(truth)
            exc_info.update(sample_time_s=sample_time, controller={
                "kind": ctrl.kind, "kp": ctrl.kp, "kp_unit": f"{data.input_unit} per output deg",
                "kd_s": ctrl.kd,
                "note": "simulated on the plant with the hidden effects; its commanded input "
                        "is replayed open loop"})
        else:
            exc_info["file"] = str(excitation)
        quantized = sorted(S.quantized_signals(truth) & set(sigs))
        notes = ["the input column is the commanded input, held from sample to sample",
                 "the record starts at rest with the mesh centred in its clearance",
                 f"solver: {S.SOLVER.method}, rtol {S.SOLVER.rtol:g}, max step {S.SOLVER.max_step_s:g} s"]
        if quantized:
            notes.append(f"{', '.join(quantized)}: encoder counts, no added noise")
        record = S.truth_dict(str(plant_file), hidden, S.resolved_noise(truth, sigs, noise_given), seed,
                              exc_info, plant_model=plant.name, data=output.name,
                              signals=list(sigs), input=data.input_name,
                              noise_ar1=noise_ar1,
                              command=_command_line(plant_file, effects, excitation, duration,
                                                    sample_time, noise, signals, seed, output, noise_ar1),
                              notes=notes)
        text = (f"# What {output.name} hides: made by gearbench synth from {plant_file}.\n"
                + yaml.safe_dump(record, sort_keys=False, allow_unicode=True, width=10_000))
    except (GearbenchError, ValueError, OSError) as exc:
        # ValueError too, deliberately: --noise (cli_common.parse_noise) and identify.synth's checks
        # of the excitation (duration, sample time, profile:N, a CSV file) and of the noise raise a
        # plain ValueError for bad input.  SynthRunError (a SolverError) exits 1, the others 2.
        _fail(exc)

    existed = output.exists()
    try:
        write_measurement(data, output)
        try:
            write_text_atomic(truth_path, text)
        except BaseException:
            if not existed:  # no data without its truth
                output.unlink(missing_ok=True)
            raise
    except (GearbenchError, OSError) as exc:  # write_measurement's MeasurementError, or the disk
        _fail(exc)
    wall = time.perf_counter() - start
    hid = "; ".join(f"{e.name}(" + ", ".join(f"{k}={v}" for k, v in e.values.items()) + ")"
                    for e in hidden) or "none"
    summary = (f"wrote {output} ({len(t)} samples, {t[-1] - t[0]:g} s, {data.input_name} + "
               f"{', '.join(sigs)}; hidden: {hid}) and {truth_path.name} in {wall:.2f} s")
    if as_json:
        echo_json({"output": str(output), "truth": str(truth_path), "samples": len(t),
                   "duration_s": float(t[-1] - t[0]), "input": data.input_name, "signals": list(sigs),
                   "hidden": [{"effect": e.name, **e.values} for e in hidden], "seed": seed,
                   "wall_s": wall})
        console.print(summary, highlight=False)
    else:
        click.echo(summary)
