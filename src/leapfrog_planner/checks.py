"""Input checks shared by every entry point (scenario files, the problem, initial paths, the
direct method): one function per kind of value, one message per fault, ``<key>: <problem>``.

Each check raises the error class it is given (:class:`.errors.ScenarioError` by default) and
returns the value converted (floats, float arrays); integers are checked by
:func:`.errors.require_integer`, which the settings of every layer share. A scenario file's
messages add the file's name in front (see :mod:`.planning.scenario`).
"""

from __future__ import annotations

import math
import numbers
from typing import Any

import numpy as np

from .errors import ScenarioError, describe

# Bounds beyond which a value makes no physical sense for a mobile robot, in any consistent
# units, and would only overflow the arithmetic. The scenario file format documents them.
COORDINATE_MAX = 1e6  # |x|, |y| of start, goal, waypoints and obstacle centres
HEADING_MAX = 1e3  # |heading| in radians (about 160 turns)
HORIZON_RANGE = (1e-3, 1e4)  # the time horizon T
RADIUS_RANGE = (1e-6, 1e6)  # an obstacle's radius
PARAMETER_RANGE = (1e-6, 1e6)  # a positive model parameter (wheel radius, axle length)
WEIGHT_MAX = 1e12  # the obstacle weight W
EXPONENT_MAX = 16  # the penalty exponent n (the penalty is a wall well before that)
OBSTACLES_MAX = 10_000
WAYPOINTS_MAX = 1_000


def fmt_point(p) -> str:
    return "(" + ", ".join(repr(float(v)) for v in p) + ")"


def finite_number(v: Any) -> bool:
    """Whether ``v`` is a JSON number a double holds, finite (not a bool; NaN, infinities and
    integers beyond a double, as 10**400, are not)."""
    if isinstance(v, bool) or not isinstance(v, int | float):
        return False
    try:
        return math.isfinite(v)
    except OverflowError:  # an integer beyond a double
        return False


def real(value: Any, key: str, *, gt=None, ge=None, error=ScenarioError) -> float:
    """A finite real number (integers accepted, booleans not), ``> gt`` / ``>= ge`` if given."""
    if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Real):
        raise error(f"{key}: expected a number, got {describe(value)}")
    try:
        x = float(value)
    except OverflowError:
        raise error(f"{key}: must be finite, got {describe(value)} (too large)") from None
    if not math.isfinite(x):
        raise error(f"{key}: must be finite, got {x!r}")
    if gt is not None and not x > gt:
        raise error(f"{key}: must be > {gt:g}, got {x!r}")
    if ge is not None and not x >= ge:
        raise error(f"{key}: must be >= {ge:g}, got {x!r}")
    return x


def in_range(x: float, key: str, low: float, high: float, *, error=ScenarioError) -> float:
    """``x`` unless it lies outside ``[low, high]``."""
    if not low <= x <= high:
        raise error(f"{key}: must be between {low:g} and {high:g}, got {x!r}")
    return x


def magnitude(values, key: str, limit: float, *, error=ScenarioError) -> None:
    """Refuse an entry of ``values`` (``key[i]`` in messages) larger than ``limit`` in size."""
    for i, x in enumerate(np.asarray(values, dtype=float).ravel().tolist()):
        if not abs(x) <= limit:
            raise error(f"{key}[{i}]: must be at most {limit:g} in size, got {x!r}")


def vector(value: Any, n: int, key: str, what: str = "", *, error=ScenarioError) -> np.ndarray:
    """``n`` finite numbers (``what`` names them in messages, e.g. ``" [x, y, heading]"``)."""
    expected = f"{n} numbers"
    if isinstance(value, np.ndarray) and value.ndim == 1:
        if value.size == n and value.dtype.kind == "f" and np.isfinite(value).all():
            return value.astype(float, copy=True)  # the common case, checked at once
        items = list(value)
    elif isinstance(value, list | tuple):
        items = list(value)
    else:
        raise error(f"{key}: expected an array of {expected}{what}, got {describe(value)}")
    if len(items) != n:
        raise error(f"{key}: expected {expected}, got {len(items)}")
    return np.array([real(v, f"{key}[{i}]", error=error) for i, v in enumerate(items)])


def rows(value: Any, n: int, key: str, what: str, *, error=ScenarioError) -> np.ndarray:
    """An array of ``n``-vectors as a ``(k, n)`` float array (``k`` may be 0; ``what`` names
    a row's entries, e.g. ``"cx, cy, r"``)."""
    if isinstance(value, np.ndarray):
        if value.size == 0:
            return np.zeros((0, n))
        if value.ndim != 2:
            raise error(f"{key}: expected an array of [{what}] rows, got shape {value.shape}")
        if value.shape[1] == n and value.dtype.kind == "f" and np.isfinite(value).all():
            return value.astype(float, copy=True)
        items = list(value)
    elif isinstance(value, list | tuple):
        items = list(value)
    else:
        raise error(f"{key}: expected an array of [{what}] rows, got {describe(value)}")
    out = np.zeros((len(items), n))
    for i, item in enumerate(items):
        out[i] = vector(item, n, f"{key}[{i}]", f" [{what}]", error=error)
    return out


def obstacles(value: Any, key: str = "obstacles", *, error=ScenarioError) -> np.ndarray:
    """Disc obstacles as rows ``[cx, cy, r]`` with ``r > 0`` (None: no obstacles)."""
    if value is None:
        return np.zeros((0, 3))
    obs = rows(value, 3, key, "cx, cy, r", error=error)
    if obs.shape[0] > OBSTACLES_MAX:
        raise error(f"{key}: at most {OBSTACLES_MAX} obstacles, got {obs.shape[0]}")
    # All rows at once (a problem is validated at each weight of a continuation: at 1,000
    # obstacles the loop below over every row took 5 ms a time); the first bad row, if any,
    # gets the message of the row's own checks.
    low, high = RADIUS_RANGE
    r = obs[:, 2]
    good = (np.abs(obs[:, :2]) <= COORDINATE_MAX).all(axis=1) & (r > 0) & (low <= r) & (r <= high)
    for j in np.flatnonzero(~good)[:1].tolist():
        cx, cy, rj = obs[j].tolist()
        magnitude((cx, cy), f"{key}[{j}].center", COORDINATE_MAX, error=error)
        real(rj, f"{key}[{j}].radius", gt=0, error=error)
        in_range(rj, f"{key}[{j}].radius", low, high, error=error)
    return obs


def outside(
    point, key: str, obs: np.ndarray, *, error=ScenarioError, robot_radius: float = 0.0
) -> None:
    """Refuse a point strictly inside an obstacle, or a robot of ``robot_radius`` there that
    overlaps one (touching is allowed). The message gives the obstacle as written."""
    px, py = float(point[0]), float(point[1])
    for j, (cx, cy, r) in enumerate(obs.tolist()):
        if math.hypot(px - cx, py - cy) < r + robot_radius:  # Python floats: overflow gives inf
            where = fmt_point((px, py))
            what = (
                f"the robot (radius {robot_radius:g}) at {where} overlaps"
                if robot_radius
                else f"{where} is inside"
            )
            raise error(
                f"{key}: {what} obstacles[{j}] (center {fmt_point((cx, cy))}, radius {float(r)!r})"
            )
