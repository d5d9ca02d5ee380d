"""The unicycle under the direct method's piecewise-constant controls, exactly (each interval
an arc, no steps): the end state and the clearance along the path; and the controls'
conversions, wheel speeds to and from ``(v, omega)`` and ``(v, omega)`` from a state guess."""

from __future__ import annotations

import math

import numpy as np

__all__ = ["arc_clearance", "arc_end_state", "controls_from_states", "unicycle_to_wheel",
           "wheel_to_unicycle"]  # fmt: skip

# Samples per interval used to measure clearance along the continuous path, not just at nodes.
CLEARANCE_SAMPLES = 8


def wheel_to_unicycle(controls: np.ndarray, radius: float, axle: float) -> np.ndarray:
    """Map diff-drive wheel speeds (omega_R, omega_L) to unicycle (v, omega)."""
    wr, wl = controls[:, 0], controls[:, 1]
    return np.column_stack((radius * (wr + wl) / 2.0, radius * (wr - wl) / axle))


def unicycle_to_wheel(controls: np.ndarray, radius: float, axle: float) -> np.ndarray:
    """Inverse of :func:`wheel_to_unicycle`, used to turn state guesses into wheel guesses."""
    v, omega = controls[:, 0], controls[:, 1]
    half = omega * axle / (2.0 * radius)
    return np.column_stack((v / radius + half, v / radius - half))


def controls_from_states(states: np.ndarray, horizon: float) -> np.ndarray:
    """Unicycle controls that roughly reproduce a state guess, interval by interval.

    The speed is the displacement projected on the mid-interval heading, so a guess whose heading
    points backwards along the path gives a reversing robot rather than a nonsense one.
    """
    h = horizon / (len(states) - 1)
    d = np.diff(states, axis=0)
    mid = states[:-1, 2] + d[:, 2] / 2.0
    v = (d[:, 0] * np.cos(mid) + d[:, 1] * np.sin(mid)) / h
    return np.column_stack((v, d[:, 2] / h))


def arc_end_state(x0, unicycle_controls: np.ndarray, horizon: float) -> np.ndarray:
    """End state of the unicycle under piecewise-constant ``(v, omega)``, exactly (no steps)."""
    h = horizon / len(unicycle_controls)
    x = np.array(x0, dtype=float)
    for v, om in unicycle_controls:
        chord = v * h * np.sinc(om * h / (2.0 * np.pi))
        mid = x[2] + om * h / 2.0
        x += (chord * math.cos(mid), chord * math.sin(mid), om * h)
    return x


def arc_clearance(
    states: np.ndarray, unicycle_controls: np.ndarray, horizon: float, obstacles: np.ndarray
) -> float:
    """Minimum of ``|p - c| - r`` over the path and all obstacles.

    Between nodes the path is sampled along the exact arc for the constant (v, omega) of the
    interval, so a thin obstacle cannot hide between two nodes.
    """
    if len(obstacles) == 0:
        return math.inf
    n = len(unicycle_controls)
    h = horizon / n
    tau = h * np.arange(CLEARANCE_SAMPLES) / CLEARANCE_SAMPLES  # (S,)
    x0, y0, th0 = (states[:-1, i, None] for i in range(3))  # (N, 1) each
    v, w = unicycle_controls[:, 0, None], unicycle_controls[:, 1, None]
    # Exact arc: integral of cos(th0 + w s) over [0, tau] = tau cos(th0 + w tau/2) sinc(w tau/2).
    chord = v * tau * np.sinc(w * tau / (2.0 * np.pi))
    mid = th0 + w * tau / 2.0
    xs = np.concatenate(((x0 + chord * np.cos(mid)).ravel(), states[-1:, 0]))
    ys = np.concatenate(((y0 + chord * np.sin(mid)).ravel(), states[-1:, 1]))
    dist = np.hypot(xs[:, None] - obstacles[:, 0], ys[:, None] - obstacles[:, 1])
    return float(np.min(dist - obstacles[:, 2]))
