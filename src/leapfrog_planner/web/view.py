"""What the page draws of a plan: the numbers, the path (fewer rows, rounded), the reversing
stretches, the other initial paths' extremals and the junctions of every Leapfrog sweep."""

from __future__ import annotations

import math

import numpy as np

from ..planning.outcome import unreachable
from ..planning.status import listed_alternatives

#: Rows of the drawn path and of the control plots (the result keeps about 1,000 and more).
PATH_ROWS = 401
#: Rows of an alternative's path (drawn faded).
ALTERNATIVE_ROWS = 151
#: Decimals kept of drawn coordinates and controls.
DECIMALS = 6


def _num(v) -> float | None:
    return None if v is None or not math.isfinite(v) else float(v)


def _rounded(a: np.ndarray) -> list:
    a = np.round(np.asarray(a, dtype=float), DECIMALS)
    return [None if not math.isfinite(v) else v for v in a.tolist()]


def _uniform(t: np.ndarray, columns: dict[str, np.ndarray], rows: int) -> dict[str, list]:
    """Every column at ``rows`` equally spaced times (linear between the result's rows, which
    lie at most 1/1000 of the horizon apart; a junction's repeated time kept once)."""
    keep = np.append(np.diff(t) > 0, True)
    t = t[keep]
    grid = np.linspace(t[0], t[-1], rows) if t.size > 1 else t
    out = {"t": _rounded(grid)}
    for k, v in columns.items():
        out[k] = _rounded(np.interp(grid, t, np.asarray(v, dtype=float)[keep]))
    return out


def _reversing(t: np.ndarray, x: np.ndarray, y: np.ndarray, theta: np.ndarray) -> list[int]:
    """1 where the robot moves backwards (its velocity against its heading: v < 0)."""
    if t.size < 2:
        return [0] * t.size
    vx, vy = np.gradient(x, t), np.gradient(y, t)
    return [int(s < 0) for s in (vx * np.cos(theta) + vy * np.sin(theta)).tolist()]


def path_view(tr, state_names, control_names, rows: int = PATH_ROWS) -> dict | None:
    """A trajectory as the page draws it: ``t``, the states and controls by name, ``reverse``."""
    if tr is None:
        return None
    cols = {n: tr.x[:, i] for i, n in enumerate(state_names)}
    cols.update({n: tr.u[:, i] for i, n in enumerate(control_names)})
    out = _uniform(np.asarray(tr.t, dtype=float), cols, rows)
    x, y = np.array(out["x"], dtype=float), np.array(out["y"], dtype=float)
    theta = np.array(out["theta"], dtype=float)
    out["reverse"] = _reversing(np.array(out["t"], dtype=float), x, y, theta)
    return out


def _sweeps(result) -> list[dict]:
    """The initial path's junctions (sweep 0), then those after each sweep, with q and cost
    (with a free final time, including the price of time k T, as the result's cost does)."""
    if unreachable(result):  # its ends alone: no path was found, none is drawn
        return []
    k = 0.0 if result.free_time is None else result.free_time.time_weight
    t0, X0 = result.initial_junctions
    cost0 = _num(result.initial_cost + k * float(t0[-1]))
    frames = [{"sweep": 0, "q": int(len(t0) - 1), "cost": cost0, "X": X0}]
    frames += [
        {"sweep": h.sweep, "q": h.q, "cost": _num(h.cost + k * float(h.t[-1])), "X": h.X}
        for h in result.history
    ]
    out = []
    for f in frames:
        X = np.asarray(f.pop("X"), dtype=float).reshape(-1, len(result.state_names))
        out.append({**f, "x": _rounded(X[:, 0]), "y": _rounded(X[:, 1])})
    return out


def result_view(result) -> dict:
    """The page's view of a :class:`~leapfrog_planner.planning.results.PlanResult`."""
    names = (result.state_names, result.control_names)
    listed, failed = listed_alternatives(result.alternatives, result)
    alternatives = [
        {
            "label": a.label,
            "status": str(a.status),
            "cost": _num(a.cost),
            "path": path_view(a.trajectory, *names, rows=ALTERNATIVE_ROWS),
        }
        for a in listed
    ]
    f = result.free_time
    return {
        "status": str(result.status),
        "success": result.success,
        "message": result.message,
        "optimal": result.optimal,
        "trajectory_source": result.trajectory_source,
        "scenario": result.scenario,
        "model": result.model,
        "state_names": list(result.state_names),
        "control_names": list(result.control_names),
        "method": result.method,
        "initial_path": result.initial_path,
        "weight": result.weight,
        "cheaper_motion": _num(result.cheaper_motion),
        "cost": _num(result.cost),
        "energy": _num(result.energy),
        "penalty": _num(result.penalty),
        "min_clearance": _num(result.min_clearance),
        "end_state_error": _num(result.end_state_error),
        "wall_time_s": result.wall_time_s,
        # with a free final time: the T chosen, its price and Pontryagin's condition k + H
        "free_time": None
        if f is None
        else {
            "horizon": f.horizon,
            "time_weight": f.time_weight,
            "condition": _num(f.condition),
            "bound": f.bound,
        },
        "sweeps": result.sweeps,
        "newton_iterations": result.newton_iterations,
        "path": path_view(result.trajectory, *names),
        "alternatives": alternatives,
        "failed_alternatives": failed,  # counted, not listed (when there are many)
        "frames": _sweeps(result),
    }
