"""Controller files for closed-loop replays of records (``--controller FILE``).

Only the sampled position-velocity cascade exists (the EMPS benchmark's)::

    kind: sampled_pv
    kp_per_s: 160.18          # 1/s
    kv_V_s_per_m: 243.45      # V/(m/s), leadscrew plants (kv_V_s_per_deg: rotational)
    gain: 35.15               # drive input per controller volt (N/V)
    limit_V: 10.0             # saturation, V
    sample_time_s: 0.001
    delay_samples: 0          # 0 or 1
"""
from __future__ import annotations

from pathlib import Path

from ..control.sampled import SampledPV
from ..errors import ConfigError
from ..schema import Choice, Number, check_mapping
from .files import read_yaml

FIELDS = {
    "kind": Choice(("sampled_pv",)),
    "kp_per_s": Number("1/s", low=0.0, low_strict=False),
    "kv_V_s_per_m": Number("V/(m/s)", low=0.0, low_strict=False, required=False),
    "kv_V_s_per_deg": Number("V/(deg/s)", low=0.0, low_strict=False, required=False),
    "gain": Number("input units per V (N/V, N m/V or V/V)"),
    "limit_V": Number("V", required=False, default=10.0),
    "sample_time_s": Number("s"),
    "delay_samples": Number("samples", low=0.0, low_strict=False, high=1.0, high_strict=False,
                            integer=True, required=False, default=0),
}


def load_controller(path: str | Path) -> SampledPV:
    """Read and check a controller file; a ConfigError names every bad key."""
    path = Path(path)
    raw = read_yaml(path)
    problems: list[str] = []
    v = check_mapping(raw, "", FIELDS, problems, context="a controller key")
    if v is not None and ("kv_V_s_per_m" in v) == ("kv_V_s_per_deg" in v):
        problems.append("give exactly one of kv_V_s_per_m (leadscrew plants) or kv_V_s_per_deg (rotational)")
    if problems:
        raise ConfigError(path.name, problems)
    kv = v.get("kv_V_s_per_m", v.get("kv_V_s_per_deg"))
    return SampledPV(v["kp_per_s"], kv, v["gain"], v["limit_V"], v["sample_time_s"], int(v["delay_samples"]))
