"""The direct method's inputs: their checks (one message per fault, as :mod:`..checks`) and
the initial guesses (the straight line, the multistart arcs, a coarse solution resampled on a
finer mesh). Split from :mod:`.direct`, which imports them all: they can be imported from there."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import checks
from ..errors import ModelError, ScenarioError, SettingsError, require_integer
from .direct_arcs import controls_from_states

__all__ = ["DirectResult", "check_free_time", "check_guess", "check_horizon", "check_model",
           "check_obstacles", "check_positive", "check_state", "distinct_guesses",
           "multistart_guesses", "resample_guess", "straight_line_guess"]  # fmt: skip

_MODELS = ("unicycle", "diff-drive")  # the direct method writes its own dynamics for these


@dataclass(frozen=True)
class DirectResult:
    """Outcome of one direct solve.

    ``controls`` are in the model's own units: ``(v, omega)`` for the unicycle,
    ``(omega_R, omega_L)`` for the diff-drive. ``states[k]`` is the state at ``t[k]``; the
    control ``controls[k]`` is held constant on ``[t[k], t[k+1]]``.
    """

    success: bool
    status: str
    message: str
    cost: float
    t: np.ndarray
    states: np.ndarray
    controls: np.ndarray
    min_clearance: float
    iterations: int
    solve_time: float
    # |x(T) - goal| of the start state driven by the returned controls exactly (each interval an
    # arc), not by the transcription's RK4 step: the check of the mesh's own error.
    end_state_error: float = math.nan
    # The horizon T of the solution (``t[-1]``): the given one, or the optimal one of a free-time
    # solve (then ``cost`` holds the price of time, ``time_weight * T``, too).
    horizon: float = math.nan


# --------------------------------------------------------------------------- validation


def check_state(value: Any, name: str) -> np.ndarray:
    return checks.vector(value, 3, name, " [x, y, heading]")


def check_horizon(value: Any) -> float:
    return checks.real(value, "horizon", gt=0)


def check_obstacles(value: Any) -> np.ndarray:
    return checks.obstacles(value)


def check_positive(
    value: Any, name: str, *, allow_zero: bool = False, error: type[ValueError] = ScenarioError
) -> float:
    bound = {"ge": 0.0} if allow_zero else {"gt": 0.0}
    return checks.real(value, name, error=error, **bound)


def check_free_time(time_weight, horizon_guess, horizon_bounds) -> tuple[float, float, tuple]:
    """The price of time ``k`` (finite, > 0), the guess of ``T`` and its bounds ``(lo, hi)``
    (``0 < lo < hi``, finite, the guess within them; ``None``: the guess / 100 to the guess *
    100) of a free-time solve."""
    k = checks.real(time_weight, "time_weight", gt=0)
    guess = checks.real(horizon_guess, "horizon_guess", gt=0, error=SettingsError)
    if horizon_bounds is None:
        return k, guess, (guess / 100.0, guess * 100.0)
    lo, hi = checks.vector(horizon_bounds, 2, "horizon_bounds", " (lo, hi)", error=SettingsError)
    if not 0.0 < lo < hi:
        raise SettingsError(f"horizon_bounds: need 0 < lo < hi, got ({lo!r}, {hi!r})")
    if not lo <= guess <= hi:
        raise SettingsError(
            f"horizon_guess: must lie within horizon_bounds ({lo:g}, {hi:g}), got {guess!r}"
        )
    return k, guess, (float(lo), float(hi))


def check_guess(value: Any, name: str, shape: tuple[int, int]) -> np.ndarray:
    arr = checks.rows(value, shape[1], name, ", ".join(["v"] * shape[1]), error=SettingsError)
    if arr.shape != shape:
        raise SettingsError(f"{name}: expected {shape[0]} rows, got {arr.shape[0]}")
    return arr


def check_model(value: Any) -> str:
    if value not in _MODELS:
        raise ModelError(f"the direct method has no model {value!r} (it has {', '.join(_MODELS)})")
    return value


# --------------------------------------------------------------------------- initial guesses


def straight_line_guess(start, goal, horizon, intervals) -> tuple[np.ndarray, np.ndarray]:
    """Straight segment from start to goal, heading interpolated linearly between the two.

    Returns ``(states (N+1, 3), controls (N, 2))`` with unicycle controls ``(v, omega)``. The
    heading is interpolated rather than taken from the chord, so the guess already meets both
    end headings without any wrapping.
    """
    start = check_state(start, "start")
    goal = check_state(goal, "goal")
    horizon = check_horizon(horizon)
    n = require_integer("intervals", intervals, 1)
    s = np.linspace(0.0, 1.0, n + 1)[:, None]
    states = start + s * (goal - start)
    return states, controls_from_states(states, horizon)


def _arc(start: np.ndarray, goal: np.ndarray, n: int, offset: float, heading: str) -> np.ndarray:
    """Chord plus a quadratic lateral bump of height ``offset`` (relative to the chord length).

    ``heading="tangent"`` follows the path tangent (unwrapped, shifted by whole turns to start
    next to the start heading); ``heading="interpolated"`` blends start to goal heading.
    """
    chord = goal[:2] - start[:2]
    length = float(np.hypot(*chord))
    if length > 1e-9:
        along, scale = chord / length, length
    else:  # start and goal coincide in position: bump sideways of the start heading
        along, scale = np.array([math.cos(start[2]), math.sin(start[2])]), 1.0
    normal = np.array([-along[1], along[0]])
    s = np.linspace(0.0, 1.0, n + 1)[:, None]
    pos = start[:2] + s * chord + offset * scale * 4.0 * s * (1.0 - s) * normal
    if heading == "interpolated":
        theta = start[2] + s[:, 0] * (goal[2] - start[2])
    else:
        tangent = chord + offset * scale * 4.0 * (1.0 - 2.0 * s) * normal
        if length <= 1e-9:
            tangent = tangent + 1e-9 * along  # keep atan2 defined on a degenerate chord
        theta = np.unwrap(np.arctan2(tangent[:, 1], tangent[:, 0]))
        theta += 2.0 * np.pi * np.round((start[2] - theta[0]) / (2.0 * np.pi))
    return np.column_stack((pos, theta))


def multistart_guesses(start, goal, intervals) -> list[np.ndarray]:
    """The deterministic set of state guesses tried by :func:`solve_direct`.

    The straight line and quadratic lateral arcs peaking at ``+-0.25, +-0.5, +-0.75, +-1.0``
    chord lengths, each once with the heading interpolated between the end headings and once
    with the heading of the path tangent (18 guesses). Both heading choices matter: with fixed
    end headings neighbouring extremals differ in how the heading turns, and the two families
    lead IPOPT to different ones (paper case 1 is found only from tangent headings). The
    offsets are dense because which guess reaches which optimum shifts with the mesh; with only
    +-0.5 and +-1.0, paper cases 3 and 4 miss their best optimum on some meshes.
    """
    start = check_state(start, "start")
    goal = check_state(goal, "goal")
    n = require_integer("intervals", intervals, 1)
    return [
        _arc(start, goal, n, offset, heading)
        for offset in _OFFSETS
        for heading in ("interpolated", "tangent")
    ]


_OFFSETS = (0.0, 0.25, -0.25, 0.5, -0.5, 0.75, -0.75, 1.0, -1.0)


def resample_guess(result: DirectResult, intervals: int) -> tuple[np.ndarray, np.ndarray]:
    """A coarse solution on a finer mesh: states linear in time, controls sampled at midpoints."""
    t = np.linspace(0.0, result.t[-1], intervals + 1)
    states = np.column_stack([np.interp(t, result.t, result.states[:, i]) for i in range(3)])
    mid = (t[:-1] + t[1:]) / 2.0
    index = np.minimum(np.searchsorted(result.t, mid, side="right") - 1, len(result.controls) - 1)
    return states, result.controls[index]


def distinct_guesses(results: list[DirectResult]) -> list[DirectResult]:
    """Successful results, cheapest first, with repeats of the same local optimum dropped."""
    kept: list[DirectResult] = []
    for r in sorted((r for r in results if r.success), key=lambda r: r.cost):
        if not any(
            abs(r.cost - k.cost) <= 1e-6 * (1.0 + abs(k.cost))
            and np.max(np.abs(r.states - k.states)) < 1e-3
            for k in kept
        ):
            kept.append(r)
    return kept
