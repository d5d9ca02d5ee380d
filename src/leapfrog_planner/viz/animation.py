"""The Leapfrog sweeps as an animated GIF: the junctions sweep by sweep, then the final path."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from .._atomic import write_atomic as _write_atomic
from ..planning.results import PlanResult
from ..planning.scenario import Scenario, as_scenario
from .style import (
    GID_HEADING,
    OBSTACLE_EDGE,
    OBSTACLE_FACE,
    REVERSE_COLOR,
    REVERSE_LABEL,
    answer_cost,
    arrow_length,
    draw_arrows,
    draw_ends,
    draw_obstacles,
    draw_reversing,
    frame_axes,
    heading_colors,
    heading_proxy,
    initial_horizon,
    initial_junctions,
    legend_below,
    new_figure,
    path_figsize,
    reversing_runs,
    status_text,
    sweep_colors,
    with_time,
)

#: The animation's width in pixels (8 inches at 100 dpi).
GIF_DPI = 100
GIF_WIDTH_IN = 8.0

# --------------------------------------------------------------------------- animate_sweeps


def _frames(sc: Scenario, result: PlanResult) -> list[tuple[str, np.ndarray | None, str]]:
    """The animation's frames: (kind, junctions, counter text), the initial junctions first,
    then one per sweep, then the final path (three frames) or the status."""
    frames: list[tuple[str, np.ndarray | None, str]] = []  # (kind, X, text)
    K = len(result.history)
    X0 = initial_junctions(result)
    if X0 is not None:
        cost = with_time(result, result.initial_cost, initial_horizon(result))
        text = f"initial path (sweep 0 of {K}), cost J = {cost}"
        frames.append(("junctions", X0, f"{text} (q = {len(X0) - 1})"))
    for h in result.history:
        frames.append(
            (
                "junctions",
                np.asarray(h.X, dtype=float),
                f"sweep {h.sweep} of {K}, cost J = {with_time(result, h.cost, h.t[-1])} "
                f"(q = {h.q}, costate jump {h.max_costate_jump:.2g})",
            )
        )
    if result.trajectory is not None:
        what = "final extremal" if result.optimal else f"{status_text(result)}, not optimal:"
        final = f"{what} after {K} sweeps, cost J = {answer_cost(result)}"
        frames += [("final", None, final)] * 3
    elif not frames:
        frames.append(("junctions", None, f"{status_text(result)}: nothing to animate"))
    else:
        kind, X, text = frames[-1]
        frames.append((kind, X, f"{text}: {status_text(result)}"))

    return frames


def _legend_handles(sc: Scenario, result: PlanResult) -> list:
    """Proxies for what the frames draw (the moving artists are not there when the legend is)."""
    current = sweep_colors(3, lightest=0.5)[1]
    handles = []
    if sc.obstacles.shape[0]:
        handles.append(Patch(facecolor=OBSTACLE_FACE, edgecolor=OBSTACLE_EDGE, label="obstacles"))
    handles += [
        Line2D([], [], ls="none", marker="o", ms=8, mfc="tab:green", mec="black", label="start"),
        Line2D([], [], ls="none", marker="*", ms=12, mfc="tab:red", mec="black", label="goal"),
        Line2D([], [], marker="o", ms=4, lw=1.4, color=current, label="junctions of this sweep"),
        Line2D([], [], lw=0.8, color="0.75", label="earlier sweeps"),
    ]
    if result.trajectory is not None:
        final = "final extremal" if result.optimal else "returned motion, not optimal"
        handles.append(Line2D([], [], lw=2.0, color="black", label=final))
        if reversing_runs(result):
            handles.append(
                Line2D([], [], lw=2.0, ls=(0, (3.0, 1.2)), color=REVERSE_COLOR, label=REVERSE_LABEL)
            )
    handles.append(heading_proxy("heading"))
    return handles


def _animation_canvas(sc: Scenario, result: PlanResult, L: float) -> tuple[Figure, Axes]:
    """The animation's figure and its (invisible) axes over a picture of the static part."""
    # The static part (obstacles, start, goal, axes, ticks and the legend) is drawn once, laid
    # out with room for a two-line title; each frame then draws only that picture and the moving
    # artists, on invisible axes at exactly the same place with the same limits.
    static = new_figure(figsize=path_figsize(sc, result, 1.0, GIF_WIDTH_IN), dpi=GIF_DPI)
    ax0 = static.add_subplot()
    draw_obstacles(ax0, sc, label=False)
    draw_ends(ax0, sc, L, label=False)
    frame_axes(ax0, sc, result)
    ax0.set_title("title\nplaceholder")
    legend_below(
        static,
        _legend_handles(sc, result),
        lambda h: path_figsize(sc, result, h + 0.3, GIF_WIDTH_IN),
    )
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


def _draw_frame(ax: Axes, result: PlanResult, frame, color, done: list, L: float) -> list:
    """The moving artists of one frame: the last few junction sets faint, then this frame's
    junctions with their headings, or the final path with reversing and headings."""
    kind, X, _ = frame
    tr = result.trajectory
    artists: list = []
    for old in done[-6:]:
        artists += ax.plot(old[:, 0], old[:, 1], color="0.75", lw=0.8, zorder=2)
    if kind == "junctions" and X is not None:
        artists += ax.plot(X[:, 0], X[:, 1], "o-", color=color, ms=4, lw=1.4, zorder=3)
        if X.shape[1] >= 3:
            artists.append(
                draw_arrows(ax, X[1:-1, :2], X[1:-1, 2], 0.7 * L, gid=GID_HEADING, color=color)
            )
        done.append(X)
    elif kind == "final" and tr is not None:
        artists += ax.plot(tr.x[:, 0], tr.x[:, 1], color="black", lw=2.0, zorder=3)
        artists += draw_reversing(ax, result, lw=2.0)
        ts = np.linspace(tr.t[0], tr.t[-1], 11)[1:-1]
        xy = np.column_stack([np.interp(ts, tr.t, tr.x[:, i]) for i in range(2)])
        th = np.interp(ts, tr.t, tr.x[:, 2])
        artists.append(
            draw_arrows(ax, xy, th, L, gid=GID_HEADING, color=heading_colors(result, ts))
        )
    return artists


def _write_gif(images: list, tmp: str, fps: float) -> None:
    """The frames (RGB arrays) as a looping GIF, all on one palette: the 256 commonest colours
    of the first, middle and last frames, exactly, each pixel mapped to its nearest (a palette per
    frame turned the legend's orange brown where no path was drawn yet; Pillow's own mapping
    turned white into light grey)."""
    from PIL import Image

    keys = [(im[..., 0] << 16) | (im[..., 1] << 8) | im[..., 2] for im in images]
    sample = np.concatenate([keys[k].ravel() for k in sorted({0, len(keys) // 2, len(keys) - 1})])
    colours, counts = np.unique(sample, return_counts=True)
    pal = colours[np.argsort(-counts, kind="stable")[:256]]
    pal_rgb = np.stack([(pal >> 16) & 255, (pal >> 8) & 255, pal & 255], axis=1)
    frames = []
    for key in keys:
        uniq, inverse = np.unique(key, return_inverse=True)
        rgb = np.stack([(uniq >> 16) & 255, (uniq >> 8) & 255, uniq & 255], axis=1)
        nearest = np.argmin(((rgb[:, None, :] - pal_rgb[None, :, :]) ** 2).sum(axis=2), axis=1)
        frame = Image.fromarray(nearest[inverse.reshape(key.shape)].astype(np.uint8))  # L, then P
        frame.putpalette(pal_rgb.astype(np.uint8).ravel().tolist())
        frames.append(frame)
    frames[0].save(
        tmp, format="GIF", save_all=True, append_images=frames[1:], loop=0,
        duration=round(1000 / fps), disposal=1,
    )  # fmt: skip


def animate_sweeps(result: PlanResult, scenario: Scenario | str, path, *, fps: int = 4) -> Path:
    """Write an animated GIF of the junctions sweep by sweep, then the final path.

    Frame 0 shows the initial junctions, frame k the junctions after sweep k (earlier sweeps
    faint), and the last frames the final path with its heading arrows (if there is one), the
    reversing stretches orange. Above the axes: the scenario and a sweep counter with the cost;
    below them a legend. 800 pixels wide. The file (extension ``.gif``) is written through a
    temporary file in the same folder and a rename. Returns the path.
    """
    path = Path(path)
    if path.suffix.lower() != ".gif":
        raise ValueError(f"{path.name}: an animation is written as GIF, expected a .gif file")
    if isinstance(fps, bool) or not fps > 0:
        raise ValueError(f"fps: expected a number > 0, got {fps!r}")
    sc = as_scenario(scenario)
    L = arrow_length(sc, result)
    fig, ax = _animation_canvas(sc, result, L)
    frames = _frames(sc, result)
    colors = sweep_colors(max(len(frames), 1), lightest=0.5)  # the first ones visible too

    images = []
    dynamic: list = []  # artists of the current frame
    done: list[np.ndarray] = []  # junctions shown so far, drawn faint
    for k, frame in enumerate(frames):
        for a in dynamic:
            a.remove()
        dynamic = _draw_frame(ax, result, frame, colors[k], done, L)
        ax.title.set_text(f"{sc.name}: Leapfrog ({result.method})\n{frame[2]}")
        fig.canvas.draw()
        images.append(np.asarray(fig.canvas.buffer_rgba())[..., :3].astype(np.int64))

    _write_atomic(path, lambda tmp: _write_gif(images, tmp, fps))
    return path
