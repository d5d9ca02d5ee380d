"""The Leapfrog sweeps as an animated GIF: the junctions sweep by sweep, then the final path."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from .._atomic import write_atomic as _write_atomic
from ..planning.results import PlanResult
from ..planning.scenario import Scenario
from .style import (
    ARROW_COLOR,
    GID_HEADING,
    arrow_length,
    as_scenario,
    cost_text,
    draw_arrows,
    draw_ends,
    draw_obstacles,
    frame_axes,
    initial_junctions,
    new_figure,
    status_text,
    sweep_colors,
)

# --------------------------------------------------------------------------- animate_sweeps


def _frames(sc: Scenario, result: PlanResult) -> list[tuple[str, np.ndarray | None, str]]:
    """The animation's frames: (kind, junctions, title), the initial junctions first, then
    one per sweep, then the final path (three frames) or the status."""
    frames: list[tuple[str, np.ndarray | None, str]] = []  # (kind, X, title)
    X0 = initial_junctions(result)
    if X0 is not None:
        frames.append(
            (
                "junctions",
                X0,
                f"initial path: q = {len(X0) - 1}, J = {cost_text(result.initial_cost)}",
            )
        )
    for h in result.history:
        frames.append(
            (
                "junctions",
                np.asarray(h.X, dtype=float),
                f"sweep {h.sweep}/{len(result.history)}: q = {h.q}, J = {cost_text(h.cost)}, "
                f"jump = {h.max_costate_jump:.2g}",
            )
        )
    if result.trajectory is not None:
        final = f"final extremal: J = {cost_text(result.cost)} ({result.method})"
        frames += [("final", None, final)] * 3
    elif not frames:
        frames.append(("junctions", None, f"{status_text(result)}: nothing to animate"))
    else:
        kind, X, text = frames[-1]
        frames.append((kind, X, f"{text} — {status_text(result)}"))

    return frames


def _animation_canvas(sc: Scenario, result: PlanResult, L: float) -> tuple[Figure, Axes]:
    """The animation's figure and its (invisible) axes over a picture of the static part."""
    # The static part (obstacles, start, goal, axes and ticks) is drawn once, laid out with room
    # for a two-line title; each frame then draws only that picture and the moving artists, on
    # invisible axes at exactly the same place with the same limits.
    static = new_figure(figsize=(6.0, 5.5), dpi=80)
    ax0 = static.add_subplot()
    draw_obstacles(ax0, sc, label=False)
    draw_ends(ax0, sc, L, label=False)
    frame_axes(ax0, sc, result)
    ax0.set_title("title\nplaceholder")
    static.canvas.draw()
    static.set_layout_engine("none")  # keep the room for the title
    ax0.title.set_visible(False)
    static.canvas.draw()
    background = np.asarray(static.canvas.buffer_rgba()).copy()

    fig = new_figure(layout=None, figsize=static.get_size_inches(), dpi=static.dpi)
    fig.figimage(background, xo=0, yo=0, origin="upper", zorder=0)
    ax = fig.add_axes(ax0.get_position(), zorder=1)
    ax.set_xlim(ax0.get_xlim())
    ax.set_ylim(ax0.get_ylim())
    ax.set_aspect("auto")
    ax.set_axis_off()
    draw_ends(ax, sc, L, label=False)  # again, above the moving lines

    return fig, ax


def animate_sweeps(result: PlanResult, scenario: Scenario | str, path, *, fps: int = 4) -> Path:
    """Write an animated GIF of the junctions sweep by sweep, then the final path.

    Frame 0 shows the initial junctions, frame k the junctions after sweep k (earlier sweeps
    faint), and the last frames the final path with its heading arrows (if there is one). The
    file (extension ``.gif``) is written through a temporary file in the same folder and a
    rename. Returns the path.
    """
    from matplotlib.animation import PillowWriter

    path = Path(path)
    if path.suffix.lower() != ".gif":
        raise ValueError(f"{path.name}: an animation is written as GIF, expected a .gif file")
    if isinstance(fps, bool) or not fps > 0:
        raise ValueError(f"fps: expected a number > 0, got {fps!r}")
    sc = as_scenario(scenario)
    L = arrow_length(sc, result)
    fig, ax = _animation_canvas(sc, result, L)
    frames = _frames(sc, result)
    tr = result.trajectory
    title = ax.title
    colors = sweep_colors(max(len(frames), 1))

    def render(tmp: str) -> None:
        dynamic: list = []  # artists of the current frame
        done: list[np.ndarray] = []  # junctions shown so far, drawn faint
        writer = PillowWriter(fps=fps)
        with writer.saving(fig, tmp, dpi=fig.dpi):
            for k, (kind, X, text) in enumerate(frames):
                for a in dynamic:
                    a.remove()
                dynamic.clear()
                for old in done[-6:]:
                    dynamic += ax.plot(old[:, 0], old[:, 1], color="0.75", lw=0.8, zorder=2)
                if kind == "junctions" and X is not None:
                    dynamic += ax.plot(
                        X[:, 0], X[:, 1], "o-", color=colors[k], ms=4, lw=1.4, zorder=3
                    )
                    if X.shape[1] >= 3:
                        dynamic.append(
                            draw_arrows(
                                ax,
                                X[1:-1, :2],
                                X[1:-1, 2],
                                0.7 * L,
                                gid=GID_HEADING,
                                color=colors[k],
                            )
                        )
                    done.append(X)
                elif kind == "final" and tr is not None:
                    dynamic += ax.plot(tr.x[:, 0], tr.x[:, 1], color="black", lw=2.0, zorder=3)
                    ts = np.linspace(tr.t[0], tr.t[-1], 11)[1:-1]
                    xy = np.column_stack([np.interp(ts, tr.t, tr.x[:, i]) for i in range(2)])
                    th = np.interp(ts, tr.t, tr.x[:, 2])
                    dynamic.append(draw_arrows(ax, xy, th, L, gid=GID_HEADING, color=ARROW_COLOR))
                title.set_text(f"{sc.name}\n{text}")
                writer.grab_frame()

    _write_atomic(path, render)
    return path
