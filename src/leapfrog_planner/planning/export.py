"""A result's trajectory in other forms: at any time (interpolated), on a uniform grid, as CSV,
as a ROS ``nav_msgs/Path`` and as an HTML summary for notebooks."""

from __future__ import annotations

import html
import json
import math
from pathlib import Path

import numpy as np

from .._atomic import write_atomic
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


def _motion(result, dt: float) -> dict[str, np.ndarray]:
    """``t``, the states and the controls on the uniform grid (costates left out)."""
    cols = resample_columns(result.trajectory_columns(), dt, result.optimal)
    keep = ["t", *result.state_names, *result.control_names]
    return {k: cols[k] for k in keep}


def write_csv(result, path, dt: float) -> Path:
    """``t``, the states and the controls every ``dt`` as CSV with a header row."""
    cols = _motion(result, dt)
    table = np.column_stack(list(cols.values()))
    header = ",".join(cols)

    def write(tmp):  # each number as Python writes it: the shortest text that reads back exact
        lines = [header, *(",".join(map(repr, row)) for row in table.tolist())]
        Path(tmp).write_text("\n".join(lines) + "\n", encoding="utf-8")

    write_atomic(path, write)
    return Path(path)


def ros_path(result, dt: float, frame_id: str = "map") -> dict:
    """A ``nav_msgs/Path`` as plain values: one ``geometry_msgs/PoseStamped`` every ``dt``,
    stamped with the time from the start, heading as a quaternion about z."""
    if tuple(result.state_names[:3]) != ("x", "y", "theta"):
        raise ExportError(f"a ROS path needs states x, y, theta; got {result.state_names}")
    cols = _motion(result, dt)

    def stamp(t):
        sec = math.floor(t)
        return {"sec": int(sec), "nanosec": int(round((t - sec) * 1e9)) % 1_000_000_000}

    poses = [
        {
            "header": {"stamp": stamp(t), "frame_id": frame_id},
            "pose": {
                "position": {"x": x, "y": y, "z": 0.0},
                "orientation": {"x": 0.0, "y": 0.0, "z": math.sin(th / 2), "w": math.cos(th / 2)},
            },
        }
        for t, x, y, th in zip(*(cols[k].tolist() for k in ("t", "x", "y", "theta")), strict=True)
    ]
    return {"header": {"stamp": stamp(0.0), "frame_id": frame_id}, "poses": poses}


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
    write_atomic(path, lambda tmp: Path(tmp).write_text(text, encoding="utf-8"))
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
