"""Set-point profiles: piecewise-linear segments, stored as data, composable by sum.

A profile file (YAML) is either a list of segments::

    name: profile1
    duration_s: 10.0
    segments:              # each segment starts at start_s with value_deg
      - {start_s: 0.0, value_deg: 0.0, slope_deg_per_s: 0.0}
      - {start_s: 1.0, value_deg: 6.0, slope_deg_per_s: 15.0}   # a step, then a ramp

or the sum of other profiles (``sum: [profile1, profile2]``).  A value that
differs from where the previous segment ended is a step change.  A CSV
profile has columns ``time_s`` and ``setpoint_deg`` and is linear between
its rows.  Inside gearbench a profile is :class:`gearbench.simulate.Segments`
in SI units (s, rad, rad/s).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

from ..errors import ProfileError
from ..experiment.files import is_file
from ..simulate import Segments

PROFILE_DIR = Path(__file__).resolve().parent
"""The thesis's three profiles (``profile1`` ... ``profile3``), shipped with the package."""
SEGMENT_KEYS = {"start_s", "value_deg", "slope_deg_per_s"}


@dataclass(frozen=True)
class Profile:
    """Piecewise-linear set point in degrees and seconds.

    On ``[start_s[k], start_s[k+1])`` the set point is
    ``value_deg[k] + slope_deg_per_s[k] (t - start_s[k])``.  Made by
    :func:`load_profile` or ``gearbench.setpoint`` (which check it).

    Parameters
    ----------
    name : str
        Shown in tables and titles.
    start_s : tuple of float
        Start of each segment, s (the first 0, strictly increasing).
    value_deg : tuple of float
        Value at each segment's start, deg.
    slope_deg_per_s : tuple of float
        Slope of each segment, deg/s.
    duration_s : float
        Length of a run on this profile, s.
    description : str
        Free text.

    Examples
    --------
    >>> from gearbench import load_profile
    >>> p1 = load_profile("profile1")
    >>> p1.duration_s, float(p1(10.0))
    (10.0, 0.0)
    """
    name: str
    start_s: tuple
    value_deg: tuple
    slope_deg_per_s: tuple
    duration_s: float = 10.0
    description: str = ""

    def segments(self) -> Segments:
        """The profile in SI units for the solver."""
        return Segments(np.array(self.start_s, dtype=float),
                        np.radians(np.array(self.value_deg, dtype=float)),
                        np.radians(np.array(self.slope_deg_per_s, dtype=float)))

    def __call__(self, t) -> np.ndarray:
        """Set point at times ``t`` (s), deg; right-continuous at steps."""
        t = np.asarray(t, dtype=float)
        k = np.searchsorted(np.array(self.start_s), t, side="right") - 1
        k = np.clip(k, 0, len(self.start_s) - 1)
        st, v, s = (np.array(a)[k] for a in (self.start_s, self.value_deg, self.slope_deg_per_s))
        return v + s * (t - st)

    def end_values(self) -> np.ndarray:
        """Value each segment reaches at its end (the next segment's start), deg."""
        ends = list(self.start_s[1:]) + [self.duration_s]
        return np.array([v + s * (e - st) for st, v, s, e in
                         zip(self.start_s, self.value_deg, self.slope_deg_per_s, ends)])

    def steps(self, tol_deg: float = 1e-9) -> list[tuple[float, float]]:
        """The step changes as ``(time_s, jump_deg)``."""
        ends = self.end_values()
        return [(self.start_s[k], self.value_deg[k] - ends[k - 1])
                for k in range(1, len(self.start_s))
                if abs(self.value_deg[k] - ends[k - 1]) > tol_deg]

    def __add__(self, other: "Profile") -> "Profile":
        """Pointwise sum: the union of both profiles' corners."""
        corners = sorted(set(self.start_s) | set(other.start_s))
        values, slopes = [], []
        for t in corners:
            a, b = self._at(t), other._at(t)
            values.append(a[0] + b[0])
            slopes.append(a[1] + b[1])
        return Profile(f"{self.name}+{other.name}", tuple(corners), tuple(values), tuple(slopes),
                       max(self.duration_s, other.duration_s))

    def _at(self, t: float) -> tuple[float, float]:
        k = int(np.searchsorted(np.array(self.start_s), t, side="right")) - 1
        k = max(k, 0)
        return (self.value_deg[k] + self.slope_deg_per_s[k] * (t - self.start_s[k]),
                self.slope_deg_per_s[k])

    def scaled(self, factor: float, name: str | None = None) -> "Profile":
        """The same shape with every value and slope multiplied by ``factor``."""
        return Profile(name or self.name, self.start_s, tuple(v * factor for v in self.value_deg),
                       tuple(s * factor for s in self.slope_deg_per_s), self.duration_s,
                       self.description)


def load_profile(ref: str | Path, search_dir: Path | None = None) -> Profile:
    """Load a profile by path (YAML or CSV), or by name: a file in ``search_dir``, a built-in
    (``profile1`` ... ``profile3``, the thesis's) or a file in the working directory.

    Parameters
    ----------
    ref : str or Path
        A name (``profile1``: ``<name>.yaml``) or a file path.
    search_dir : Path, optional
        Folder searched first; then the built-in profiles and the working directory.

    Returns
    -------
    Profile
        In degrees and seconds; ``.segments()`` gives it in SI for the solver.

    Raises
    ------
    ProfileError
        Naming the file and the key (or row) that is wrong.

    Examples
    --------
    >>> from gearbench import load_profile
    >>> p3 = load_profile("profile3")
    >>> p3.name, len(p3.steps())
    ('profile3', 4)
    """
    return _load(ref, search_dir, ())


def _load(ref, search_dir: Path | None, summing: tuple) -> Profile:
    """:func:`load_profile`; ``summing``: the files whose ``sum`` led here (a loop is an error)."""
    if not isinstance(ref, (str, Path)) or not str(ref).strip():
        raise ProfileError(f"{summing[-1] if summing else 'profile'}: a profile is named by a "
                           f"non-empty string (a name or a path), got {ref!r}")
    path = _resolve(ref, search_dir)
    if path.resolve() in summing:
        raise ProfileError(f"{path}: the profile sums itself ({' -> '.join(map(str, summing))} -> {path})")
    if path.suffix.lower() == ".csv":
        return _load_csv(path)
    try:
        data = yaml.safe_load(path.read_text(encoding="utf-8"))
    except UnicodeDecodeError as exc:
        raise ProfileError(f"{path}: not UTF-8 text ({exc.reason} at byte {exc.start}): "
                           "a profile file is YAML or CSV text") from None
    except RecursionError:  # PyYAML's parser recurses once per level
        raise ProfileError(f"{path}: the YAML nests too deeply to read") from None
    except (yaml.YAMLError, ValueError) as exc:  # ValueError: a scalar yaml cannot convert
        raise ProfileError(f"{path}: not valid YAML: {exc}") from None
    if not isinstance(data, dict):
        raise ProfileError(f"{path}: a profile file is a mapping with 'segments' or 'sum'")
    unknown = set(data) - {"name", "description", "duration_s", "segments", "sum"}
    if unknown:
        raise ProfileError(f"{path}: unknown key(s) {sorted(map(repr, unknown))}; allowed: name, description, "
                           "duration_s, segments, sum")
    name = str(data.get("name", path.stem))
    if "sum" in data:
        parts = data["sum"]
        if not isinstance(parts, list) or len(parts) < 2:
            raise ProfileError(f"{path}: sum must list two or more profiles")
        chain = summing + (path.resolve(),)
        loaded = []
        for i, part in enumerate(parts):
            try:
                loaded.append(_load(part, path.parent, chain))
            except ProfileError as exc:
                raise ProfileError(f"{path}: sum[{i}]: {exc}") from None
        total = loaded[0]
        for part in loaded[1:]:
            total = total + part
        return Profile(name, total.start_s, total.value_deg, total.slope_deg_per_s,
                       total.duration_s, str(data.get("description", "")))
    duration = data.get("duration_s", 10.0)
    if not _finite_number(duration) or not duration > 0:
        raise ProfileError(f"{path}: duration_s must be a positive number of seconds, got {duration!r}")
    segs = data.get("segments")
    if not isinstance(segs, list) or not segs:
        raise ProfileError(f"{path}: segments must be a non-empty list of "
                           "{start_s, value_deg, slope_deg_per_s}")
    start, value, slope = [], [], []
    for i, seg in enumerate(segs):
        where = f"{path}: segments[{i}]"
        if not isinstance(seg, dict):
            raise ProfileError(f"{where} must be a mapping with keys {sorted(SEGMENT_KEYS)}")
        if set(seg) != SEGMENT_KEYS:
            raise ProfileError(f"{where} needs exactly the keys start_s (s), value_deg (deg), "
                               f"slope_deg_per_s (deg/s); got {sorted(map(str, seg))}")
        for key in SEGMENT_KEYS:
            v = seg[key]
            if not _finite_number(v):
                raise ProfileError(f"{where}.{key} must be a finite number, got {v!r}")
        start.append(float(seg["start_s"]))
        value.append(float(seg["value_deg"]))
        slope.append(float(seg["slope_deg_per_s"]))
    if start[0] != 0.0:
        raise ProfileError(f"{path}: segments[0].start_s must be 0")
    if any(b <= a for a, b in zip(start, start[1:])):
        raise ProfileError(f"{path}: segment start_s values must be strictly increasing")
    if start[-1] >= duration:
        raise ProfileError(f"{path}: the last segment starts at or after duration_s")
    return Profile(name, tuple(start), tuple(value), tuple(slope), float(duration),
                   str(data.get("description", "")))


def _finite_number(v) -> bool:
    """A finite int or float, not a boolean (an int beyond the largest float is not)."""
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        return False
    try:
        return math.isfinite(v)
    except OverflowError:
        return False


def _resolve(ref: str | Path, search_dir: Path | None) -> Path:
    ref = Path(ref)
    candidates = []
    for base in (search_dir, PROFILE_DIR, Path.cwd()):
        if base is None:
            continue
        candidates.append(base / ref)
        if not ref.suffix:
            candidates.append(base / f"{ref}.yaml")
    if ref.is_absolute():
        candidates.insert(0, ref)
    for c in candidates:
        if is_file(c):
            return c
    raise ProfileError(f"profile {str(ref)!r} not found (looked in: "
                       f"{', '.join(str(c.parent) for c in candidates[::2])})")


def _load_csv(path: Path) -> Profile:
    try:
        df = pd.read_csv(path)
    except Exception as exc:  # pandas raises several types for bad CSV
        raise ProfileError(f"{path}: cannot read CSV: {exc}") from None
    for col in ("time_s", "setpoint_deg"):
        if col not in df.columns:
            raise ProfileError(f"{path}: missing column {col!r} (a CSV profile needs time_s and "
                               f"setpoint_deg); found {list(df.columns)}")
    t = pd.to_numeric(df["time_s"], errors="coerce").to_numpy(float)  # text becomes NaN: reported below
    v = pd.to_numeric(df["setpoint_deg"], errors="coerce").to_numpy(float)
    bad = np.flatnonzero(~np.isfinite(t) | ~np.isfinite(v))
    if bad.size:
        raise ProfileError(f"{path}: row {bad[0] + 2} holds a missing, non-numeric or non-finite value")
    if len(t) < 2 or t[0] != 0.0:
        raise ProfileError(f"{path}: needs at least two rows starting at time_s = 0")
    dt = np.diff(t)
    if np.any(dt <= 0):
        raise ProfileError(f"{path}: time_s must increase strictly (row {int(np.argmax(dt <= 0)) + 3})")
    slopes = np.diff(v) / dt
    return Profile(path.stem, tuple(t[:-1]), tuple(v[:-1]), tuple(slopes), float(t[-1]))
