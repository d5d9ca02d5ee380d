"""A result's trajectory in other forms: at any time (interpolated), on a uniform grid with the
body velocities a ROS base takes, as CSV, as a ROS ``nav_msgs/Path`` and as an HTML summary for
notebooks. A ROS 2 bag: :mod:`.ros_bag`."""

from __future__ import annotations

import html
import json
import math
from pathlib import Path

import numpy as np

from .._atomic import write_text_atomic
from ..errors import LeapfrogError


class ExportError(LeapfrogError, ValueError):
    """A result that cannot be exported as asked (no trajectory, a bad time step)."""


def _rows(cols: dict[str, np.ndarray]) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Times strictly increasing (a junction's repeated time kept once: its later row)."""
    if not cols:
        raise ExportError("the result has no trajectory")
    t = np.asarray(cols["t"], dtype=float)
    keep = np.append(np.diff(t) > 0, True)
    return t[keep], {k: np.asarray(v, dtype=float)[keep] for k, v in cols.items() if k != "t"}


def interpolate_columns(
    cols: dict[str, np.ndarray], t, smooth: bool = True
) -> dict[str, np.ndarray]:
    """Every column at times ``t`` by a cubic through the rows: a not-a-knot cubic spline for a
    smooth extremal (fourth order: 7e-10 from a 4,001-row solve on paper case 4, where PCHIP was
    off by 3e-6 at the extrema), PCHIP when ``smooth`` is false (no overshoot at the corners of
    an initial path's turns in place)."""
    from scipy.interpolate import CubicSpline, PchipInterpolator

    times, rest = _rows(cols)
    tq = np.asarray(t, dtype=float)
    if (
        np.any(tq < times[0] - 1e-12)
        or np.any(tq > times[-1] + 1e-12)
        or not np.all(np.isfinite(tq))
    ):
        raise ExportError(f"times must lie in [{times[0]:g}, {times[-1]:g}]")
    tq = np.clip(tq, times[0], times[-1])
    out = {"t": tq}
    for k, v in rest.items():
        if not np.isfinite(v).all():  # a column not known throughout (a file's nulls): unknown
            out[k] = np.full(tq.shape, np.nan)
            continue
        out[k] = (CubicSpline(times, v) if smooth else PchipInterpolator(times, v))(tq)
    return out


def resample_columns(cols: dict[str, np.ndarray], dt: float, smooth: bool = True) -> dict:
    """Every column on ``t0, t0 + dt, ...`` up to and including the end time."""
    times, _ = _rows(cols)
    span = times[-1] - times[0]
    if not (isinstance(dt, int | float) and math.isfinite(dt) and 0 < dt <= span):
        raise ExportError(f"--dt must be > 0 and at most the horizon {span:g}, got {dt!r}")
    n = math.floor(span / dt + 1e-9)
    if n + 1 > 10_000_000:
        raise ExportError(f"--dt {dt:g} gives {n + 1} rows (at most 10,000,000)")
    grid = times[0] + dt * np.arange(n + 1)
    if times[-1] - grid[-1] > 1e-9 * max(1.0, span):
        grid = np.append(grid, times[-1])
    return interpolate_columns(cols, grid, smooth)


#: The body-frame velocities added to a motion's states and controls, named after the fields of
#: ``geometry_msgs/Twist`` that a ROS base reads on ``/cmd_vel``: ``linear_x``, the forward speed
#: (m/s), and ``angular_z``, the turn rate (rad/s, counter-clockwise).
VELOCITY_COLUMNS = ("linear_x", "angular_z")


def body_velocities(result, cols: dict[str, np.ndarray]) -> dict[str, np.ndarray] | None:
    """The forward speed and the turn rate at the rows ``cols`` (the states and controls by
    name), from the model's own right-hand side ``f(x, u)`` at the robot's parameters:
    ``linear_x = f_x cos(theta) + f_y sin(theta)``, ``angular_z = f_theta``, alike for every
    model (the unicycle's ``v``, ``omega``; the differential drive's from its wheel speeds; the
    car's ``v`` and ``v tan(delta) / L``). None for a model that is not built in or whose first
    states are not ``x, y, theta``. A motion the robot cannot make (the assisted car's, said in
    the result's message) gets what the robot's own model makes of its controls."""
    from ..compiled.kernels import model_info
    from ..errors import ModelError

    if tuple(result.state_names[:3]) != ("x", "y", "theta"):
        return None
    try:
        info = model_info(result.model)
    except ModelError:
        return None
    if info.states != tuple(result.state_names) or info.controls != tuple(result.control_names):
        return None
    given = None if result.task is None else result.task.model_parameters
    p = np.asarray(info.parameter_values(given), dtype=float)
    X = np.column_stack([np.asarray(cols[n], dtype=float) for n in info.states])
    U = np.column_stack([np.asarray(cols[n], dtype=float) for n in info.controls])
    nx, nu = info.nx, info.nu
    f, A, B, R = np.empty(nx), np.empty((nx, nx)), np.empty((nx, nu)), np.empty((nu, nu))
    rates = np.empty((X.shape[0], 3))
    for r in range(X.shape[0]):  # the model's own f(x, u): its compiled linearisation
        info.kernels.linearize(X[r], U[r], p, f, A, B, R)
        rates[r] = f[:3]
    xdot, ydot, thdot = rates.T
    th = cols["theta"]
    return {"linear_x": xdot * np.cos(th) + ydot * np.sin(th), "angular_z": np.array(thdot)}


def motion_columns(result, dt: float) -> dict[str, np.ndarray]:
    """``t``, the states, the controls and the body velocities (:data:`VELOCITY_COLUMNS`, left
    out where :func:`body_velocities` gives none) on the uniform grid of step ``dt``; the
    costates left out."""
    cols = resample_columns(result.trajectory_columns(), dt, result.optimal)
    keep = ["t", *result.state_names, *result.control_names]
    out = {k: cols[k] for k in keep}
    return out | (body_velocities(result, out) or {})


def write_csv(result, path, dt: float) -> Path:
    """``t``, the states, the controls and the body velocities (``linear_x`` in m/s,
    ``angular_z`` in rad/s: :func:`body_velocities`) every ``dt`` as CSV with a header row."""
    cols = motion_columns(result, dt)
    table = np.column_stack(list(cols.values()))
    header = ",".join(cols)

    # each number as Python writes it: the shortest text that reads back exact
    lines = [header, *(",".join(map(repr, row)) for row in table.tolist())]
    write_text_atomic(path, "\n".join(lines) + "\n")
    return Path(path)


def ros_stamp(t: float, start_ns: int = 0) -> dict:
    """A ``builtin_interfaces/Time`` as plain values: ``start_ns`` nanoseconds plus ``t``
    seconds, rounded to the nanosecond (``1 - 1e-10`` is second 1, not second 0)."""
    sec, nanosec = divmod(start_ns + round(t * 1e9), 1_000_000_000)
    return {"sec": int(sec), "nanosec": int(nanosec)}


def heading_quaternion(theta: float) -> dict:
    """The orientation of a heading ``theta`` (rad): a unit quaternion about z."""
    return {"x": 0.0, "y": 0.0, "z": math.sin(theta / 2), "w": math.cos(theta / 2)}


def ros_path(result, dt: float, frame_id: str = "map", start_ns: int = 0) -> dict:
    """A ``nav_msgs/Path`` as plain values: one ``geometry_msgs/PoseStamped`` every ``dt``,
    stamped with the time from the start (plus ``start_ns``), heading as a quaternion about z."""
    if tuple(result.state_names[:3]) != ("x", "y", "theta"):
        raise ExportError(f"a ROS path needs states x, y, theta; got {result.state_names}")
    cols = resample_columns(result.trajectory_columns(), dt, result.optimal)
    poses = [
        {
            "header": {"stamp": ros_stamp(t, start_ns), "frame_id": frame_id},
            "pose": {
                "position": {"x": x, "y": y, "z": 0.0},
                "orientation": heading_quaternion(th),
            },
        }
        for t, x, y, th in zip(*(cols[k].tolist() for k in ("t", "x", "y", "theta")), strict=True)
    ]
    return {"header": {"stamp": ros_stamp(0.0, start_ns), "frame_id": frame_id}, "poses": poses}


def _yaml(value, indent: int = 0) -> list[str]:
    """Plain values as block YAML (JSON-compatible scalars), enough for a message."""
    pad = " " * indent
    lines = []
    if isinstance(value, dict):
        for k, v in value.items():
            if isinstance(v, dict | list) and v:
                lines.append(f"{pad}{k}:")
                lines += _yaml(v, indent + 2)
            else:
                lines.append(f"{pad}{k}: {json.dumps(v)}")
    else:
        for item in value:
            sub = _yaml(item, indent + 2)
            lines.append(f"{pad}- {sub[0].lstrip()}")
            lines += sub[1:]
    return lines


def write_ros_path(result, path, dt: float, frame_id: str = "map") -> Path:
    """:func:`ros_path` as YAML (``.yaml``/``.yml``, as ``ros2 topic pub`` takes it) or JSON."""
    msg = ros_path(result, dt, frame_id)
    if Path(path).suffix.lower() in (".yaml", ".yml"):
        text = "\n".join(_yaml(msg)) + "\n"
    else:
        text = json.dumps(msg, indent=1)
    write_text_atomic(path, text)
    return Path(path)


# --------------------------------------------------------------------------- notebooks


def _svg_path(result, size: int = 320) -> str:
    """The path among the obstacles as a small inline SVG (no plotting library needed)."""
    tr, sc = result.trajectory, result.task
    if tr is None:
        return ""
    xs, ys = [tr.x[:, 0]], [tr.x[:, 1]]
    obs = np.zeros((0, 3)) if sc is None else sc.obstacles
    if obs.size:
        xs += [obs[:, 0] - obs[:, 2], obs[:, 0] + obs[:, 2]]
        ys += [obs[:, 1] - obs[:, 2], obs[:, 1] + obs[:, 2]]
    x0, x1 = min(map(np.min, xs)), max(map(np.max, xs))
    y0, y1 = min(map(np.min, ys)), max(map(np.max, ys))
    span = max(x1 - x0, y1 - y0, 1e-9) * 1.1
    cx, cy = (x0 + x1) / 2, (y0 + y1) / 2

    def px(x, y):
        return (x - cx) / span * size + size / 2, size / 2 - (y - cy) / span * size

    parts = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{size}" height="{size}">']
    parts.append(f'<rect width="{size}" height="{size}" fill="white" stroke="#ccc"/>')
    for ox, oy, r in obs.tolist():
        X, Y = px(ox, oy)
        parts.append(f'<circle cx="{X:.1f}" cy="{Y:.1f}" r="{r / span * size:.1f}" fill="#bbb"/>')
    pts = " ".join("{:.1f},{:.1f}".format(*px(x, y)) for x, y in tr.x[:, :2].tolist())
    colour = "#1f77b4" if result.optimal else "#d62728"
    parts.append(f'<polyline points="{pts}" fill="none" stroke="{colour}" stroke-width="2"/>')
    parts.append("</svg>")
    return "".join(parts)


def result_html(result) -> str:
    """A summary table and the path, for a notebook cell."""

    def fmt(v):
        return "n/a" if v is None or (isinstance(v, float) and not math.isfinite(v)) else f"{v:.6g}"

    rows = [
        ("status", str(result.status)),
        ("message", result.message),
        ("scenario", result.scenario),
        ("method", result.method),
        ("cost", fmt(result.cost)),
        ("energy / penalty", f"{fmt(result.energy)} / {fmt(result.penalty)}"),
        ("min clearance", fmt(result.min_clearance)),
        ("end-state error", fmt(result.end_state_error)),
        ("sweeps", str(result.sweeps)),
        ("wall time", f"{result.wall_time_s * 1e3:.0f} ms"),
    ]
    table = "".join(
        f"<tr><th style='text-align:left'>{html.escape(k)}</th><td>{html.escape(v)}</td></tr>"
        for k, v in rows
    )
    return (
        "<div style='display:flex;gap:1em;align-items:flex-start'>"
        f"<table>{table}</table>{_svg_path(result)}</div>"
    )
