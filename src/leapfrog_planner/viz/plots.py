"""Figures of a planning result, in the style of the paper's figures 1 to 4.

- :func:`plot_path`: obstacles as filled discs, the optimal path with arrows for the robot's
  heading along it, start and goal marked with their headings, the initial feasible path's
  junctions (dashed) and, in the legend, the costs of the other local optima that were found.
- :func:`plot_convergence`: the junctions of every Leapfrog sweep overlaid (light to dark), next
  to the cost and the largest costate jump per sweep.
- :func:`plot_controls`: controls, costates and ``H - H(0)`` against time.
- :func:`animate_sweeps`: an animated GIF of the junctions, sweep by sweep, then the final path.
- :func:`save_figure`: PNG, PDF or SVG by extension, written atomically.

Every function also draws a failed result (``trajectory is None``): obstacles, start and goal,
the junctions that exist and a title that says the status. Figures are created without pyplot
on the Agg canvas (no window, no global state); nothing here prints or shows anything.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Circle

from .._atomic import write_atomic as _write_atomic
from ..planning.results import PlanResult
from ..planning.scenario import Scenario, load_scenario

__all__ = ["animate_sweeps", "plot_controls", "plot_convergence", "plot_path", "save_figure"]

#: File formats :func:`save_figure` writes, by (lower-case) extension.
FIGURE_FORMATS = {".png": "png", ".pdf": "pdf", ".svg": "svg"}

PATH_COLOR = "C0"
ARROW_COLOR = "0.1"
START_COLOR = "tab:green"
GOAL_COLOR = "tab:red"
INITIAL_COLOR = "0.45"
OBSTACLE_FACE = "0.72"
OBSTACLE_EDGE = "0.35"
SWEEP_CMAP = "Blues"

# gid values of the artists the functions draw, for callers (and tests) that look them up.
GID_PATH = "optimal-path"
GID_HEADING = "heading"
GID_END_HEADING = "end-heading"
GID_OBSTACLE = "obstacle"
GID_INITIAL = "initial-junctions"
GID_SWEEP = "sweep"


# --------------------------------------------------------------------------- helpers


def _new_figure(layout: str | None = "constrained", **kw) -> Figure:
    fig = Figure(layout=layout, **kw)
    FigureCanvasAgg(fig)
    return fig


def _as_scenario(scenario) -> Scenario:
    return scenario if isinstance(scenario, Scenario) else load_scenario(scenario)


def _status(result: PlanResult) -> str:
    return str(getattr(result.status, "value", result.status))


def _cost_text(cost: float) -> str:
    return f"{cost:.6g}" if np.isfinite(cost) else "n/a"


def _title(result: PlanResult, sc: Scenario) -> str:
    if result.trajectory is not None and np.isfinite(result.cost):
        return f"{sc.name} — cost J = {result.cost:.6g} ({result.method})"
    return f"{sc.name} — {_status(result)}: no optimal path ({result.method})"


def _junctions(result: PlanResult) -> np.ndarray | None:
    """The initial junction states ``(q + 1, 3)``, or None."""
    ij = result.initial_junctions
    if ij is None or len(ij) < 2 or ij[1] is None:
        return None
    X = np.asarray(ij[1], dtype=float)
    return X if X.ndim == 2 and X.shape[0] > 0 and X.shape[1] >= 2 else None


def _extent(sc: Scenario, result: PlanResult) -> tuple[float, float, float, float]:
    """Bounding box of everything drawn: end points, obstacles, junctions and the path."""
    pts = [sc.start[None, :2], sc.goal[None, :2]]
    if sc.obstacles.shape[0]:
        c, r = sc.obstacles[:, :2], sc.obstacles[:, 2:3]
        pts += [c - r, c + r]
    X = _junctions(result)
    if X is not None:
        pts.append(X[:, :2])
    for h in result.history:
        pts.append(np.asarray(h.X, dtype=float)[:, :2])
    if result.trajectory is not None:
        pts.append(result.trajectory.x[:, :2])
    p = np.concatenate(pts)
    p = p[np.all(np.isfinite(p), axis=1)]
    lo, hi = p.min(axis=0), p.max(axis=0)
    return float(lo[0]), float(hi[0]), float(lo[1]), float(hi[1])


def _arrow_length(sc: Scenario, result: PlanResult, arrows: int = 9) -> float:
    """About 7 % of the plot, but short enough that ``arrows`` arrows along the path stay apart."""
    x0, x1, y0, y1 = _extent(sc, result)
    length = 0.07 * max(x1 - x0, y1 - y0, 1e-9)
    tr = result.trajectory
    if tr is not None and arrows > 0:
        arc = float(np.sum(np.hypot(*np.diff(tr.x[:, :2], axis=0).T)))
        if np.isfinite(arc) and arc > 0:
            length = min(length, 0.5 * arc / (arrows + 1))
    return max(length, 0.02 * max(x1 - x0, y1 - y0, 1e-9))


def _path_figsize(sc: Scenario, result: PlanResult, legend_width: float) -> tuple:
    """A figure whose axes roughly follow the data's aspect ratio, plus room for the legend."""
    x0, x1, y0, y1 = _extent(sc, result)
    w, h = max(x1 - x0, 1e-9), max(y1 - y0, 1e-9)
    width = 6.0
    height = float(np.clip(width * h / w, 3.0, 7.5)) + 1.0
    return (width + legend_width, max(height, 4.0))


def _frame(ax: Axes, sc: Scenario, result: PlanResult) -> None:
    """Equal aspect and limits with room for the arrows at the edges."""
    x0, x1, y0, y1 = _extent(sc, result)
    pad = 0.12 * max(x1 - x0, y1 - y0, 1e-9)
    ax.set_xlim(x0 - pad, x1 + pad)
    ax.set_ylim(y0 - pad, y1 + pad)
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel("x")
    ax.set_ylabel("y")


def _draw_obstacles(ax: Axes, sc: Scenario, label: bool = True) -> None:
    for j, (cx, cy, r) in enumerate(sc.obstacles.tolist()):
        ax.add_patch(
            Circle(
                (cx, cy),
                r,
                facecolor=OBSTACLE_FACE,
                edgecolor=OBSTACLE_EDGE,
                lw=1.0,
                zorder=1,
                gid=GID_OBSTACLE,
                label="obstacles" if (label and j == 0) else None,
            )
        )


def _quiver(ax: Axes, xy, theta, length: float, *, gid: str, color, pivot="mid", width=0.005):
    xy = np.atleast_2d(np.asarray(xy, dtype=float))
    theta = np.atleast_1d(np.asarray(theta, dtype=float))
    return ax.quiver(
        xy[:, 0],
        xy[:, 1],
        length * np.cos(theta),
        length * np.sin(theta),
        angles="xy",
        scale_units="xy",
        scale=1.0,
        pivot=pivot,
        color=color,
        width=width,
        headwidth=4.0,
        headlength=5.0,
        headaxislength=4.5,
        zorder=4,
        gid=gid,
    )


def _draw_ends(ax: Axes, sc: Scenario, length: float, label: bool = True) -> None:
    """Start (circle) and goal (star) with their headings as arrows from the point."""
    for name, state, color, marker in (
        ("start", sc.start, START_COLOR, "o"),
        ("goal", sc.goal, GOAL_COLOR, "*"),
    ):
        x, y, th = (float(v) for v in state[:3])
        text = f"{name} ({x:.3g}, {y:.3g}, {th:.3g} rad)"
        ax.plot(
            [x],
            [y],
            ls="none",
            marker=marker,
            ms=9 if marker == "o" else 14,
            mfc=color,
            mec="black",
            mew=0.8,
            zorder=6,
            gid=name,
            label=text if label else None,
        )
        _quiver(
            ax,
            [x, y],
            th,
            1.3 * length,
            gid=GID_END_HEADING,
            color=color,
            pivot="tail",
            width=0.007,
        )


def _draw_initial(ax: Axes, result: PlanResult, label: bool = True) -> None:
    X = _junctions(result)
    if X is None:
        return
    q = X.shape[0] - 1
    text = f"initial path junctions (q = {q}, J = {_cost_text(result.initial_cost)})"
    ax.plot(
        X[:, 0],
        X[:, 1],
        ls="--",
        lw=1.0,
        color=INITIAL_COLOR,
        marker="o",
        ms=3.5,
        mfc="white",
        alpha=0.8,
        zorder=2,
        gid=GID_INITIAL,
        label=text if label else None,
    )


def _heading_proxy(label: str) -> Line2D:
    return Line2D([], [], ls="none", marker=r"$\rightarrow$", ms=12, color=ARROW_COLOR, label=label)


def _no_data(ax: Axes, text: str) -> None:
    ax.text(0.5, 0.5, text, ha="center", va="center", transform=ax.transAxes, color="0.4")


# --------------------------------------------------------------------------- plot_path


def plot_path(
    result: PlanResult,
    scenario: Scenario | str,
    ax: Axes | None = None,
    *,
    arrows: int = 9,
    show_initial: bool = True,
    show_alternatives: bool = True,
) -> Axes:
    """Draw the optimal path the way the paper does; returns the axes.

    Obstacles are filled discs (gid ``"obstacle"``), the optimal path a line (gid
    ``"optimal-path"``) with ``arrows`` heading arrows at evenly spaced interior times (one
    quiver, gid ``"heading"``; no arrows for ``arrows=0``). Start (circle) and goal (star) are
    marked with their headings (quiver gid ``"end-heading"``). With ``show_initial`` the initial
    feasible path's junctions are drawn dashed. The other local optima, found from other initial
    paths, carry only costs, not paths: with ``show_alternatives`` the legend lists their costs.

    A failed result (``trajectory is None``) draws obstacles, start, goal, the initial junctions
    and the junctions after the last sweep; the title says the status. ``scenario`` is a
    :class:`~leapfrog_planner.planning.scenario.Scenario` or a name/file for ``load_scenario``.
    """
    if isinstance(arrows, bool) or int(arrows) != arrows or arrows < 0:
        raise ValueError(f"arrows: expected an integer >= 0, got {arrows!r}")
    arrows = int(arrows)
    sc = _as_scenario(scenario)
    own = ax is None
    if own:
        ax = _new_figure(figsize=_path_figsize(sc, result, 4.2)).add_subplot()
    L = _arrow_length(sc, result, arrows)

    _draw_obstacles(ax, sc)
    if show_initial:
        _draw_initial(ax, result)
    extra: list = []
    tr = result.trajectory
    if tr is not None:
        ax.plot(
            tr.x[:, 0],
            tr.x[:, 1],
            color=PATH_COLOR,
            lw=2.2,
            zorder=3,
            gid=GID_PATH,
            label=f"optimal path (J = {_cost_text(result.cost)})",
        )
        if arrows:
            t0, t1 = float(tr.t[0]), float(tr.t[-1])
            ts = np.linspace(t0, t1, arrows + 2)[1:-1]
            xy = np.column_stack([np.interp(ts, tr.t, tr.x[:, i]) for i in range(2)])
            th = np.interp(ts, tr.t, tr.x[:, 2])
            _quiver(ax, xy, th, L, gid=GID_HEADING, color=ARROW_COLOR)
            extra.append(_heading_proxy("heading"))
    elif result.history:
        last = result.history[-1]
        X = np.asarray(last.X, dtype=float)
        ax.plot(
            X[:, 0],
            X[:, 1],
            ls="-",
            lw=1.2,
            color=PATH_COLOR,
            marker="o",
            ms=4,
            alpha=0.8,
            zorder=3,
            gid=GID_SWEEP,
            label=f"junctions after sweep {last.sweep} (q = {last.q})",
        )
    _draw_ends(ax, sc, L)

    if show_alternatives:
        for alt in result.alternatives:
            if np.isfinite(alt.cost):
                text = (
                    f"other local optimum J = {alt.cost:.6g}\n  (from {alt.label}; path not kept)"
                )
            else:
                text = f"from {alt.label}: {_status(alt)}"
            extra.append(Line2D([], [], color="0.6", lw=1.0, ls=":", alpha=0.7, label=text))

    _frame(ax, sc, result)
    ax.set_title(_title(result, sc))
    handles = ax.get_legend_handles_labels()[0] + extra
    if own:  # outside, right of the axes: inside it would hide part of the path or obstacles
        ax.figure.legend(handles=handles, fontsize="small", loc="outside right upper")
    else:
        ax.legend(handles=handles, fontsize="small", loc="best", framealpha=0.85)
    return ax


# --------------------------------------------------------------------------- plot_convergence


def _sweep_colors(n: int):
    from matplotlib import colormaps

    cmap = colormaps[SWEEP_CMAP]
    return [cmap(v) for v in np.linspace(0.3, 1.0, n)] if n else []


def plot_convergence(result: PlanResult, scenario: Scenario | str, fig=None) -> Figure:
    """Leapfrog's progress: junctions per sweep (left), cost and costate jump (right).

    Left: obstacles, start and goal, the initial junctions (dashed), the junction polyline
    after every sweep (one line each, gid ``"sweep"``, light to dark with the sweep number) and
    the final path. Right, stacked: the cost of the piecewise-optimal trajectory per sweep (the
    initial path at sweep 0, dotted lines where the number of partitions q changes, the final
    extremal's cost as a horizontal line) and the largest relative costate jump at the junctions
    per sweep (log scale). Returns the figure (a new one unless ``fig`` is given).
    """
    sc = _as_scenario(scenario)
    if fig is None:
        fig = _new_figure(figsize=(12.0, 5.5))
    gs = fig.add_gridspec(2, 2, width_ratios=(1.15, 1.0))
    ax = fig.add_subplot(gs[:, 0])
    ax_cost = fig.add_subplot(gs[0, 1])
    ax_jump = fig.add_subplot(gs[1, 1], sharex=ax_cost)
    L = _arrow_length(sc, result)
    hist = result.history

    _draw_obstacles(ax, sc)
    _draw_initial(ax, result)
    colors = _sweep_colors(len(hist))
    for h, c in zip(hist, colors, strict=True):
        X = np.asarray(h.X, dtype=float)
        ax.plot(X[:, 0], X[:, 1], color=c, lw=1.0, marker=".", ms=4, zorder=2, gid=GID_SWEEP)
    if hist:
        from matplotlib.cm import ScalarMappable
        from matplotlib.colors import LinearSegmentedColormap, Normalize

        cmap = LinearSegmentedColormap.from_list(
            "sweeps", colors if len(colors) > 1 else colors * 2
        )
        sm = ScalarMappable(norm=Normalize(1, max(len(hist), 2)), cmap=cmap)
        cb = fig.colorbar(sm, ax=ax, shrink=0.7, pad=0.02)
        cb.set_label("sweep")
    tr = result.trajectory
    if tr is not None:
        ax.plot(
            tr.x[:, 0],
            tr.x[:, 1],
            color="black",
            lw=1.8,
            zorder=3,
            gid=GID_PATH,
            label=f"final path (J = {_cost_text(result.cost)})",
        )
    _draw_ends(ax, sc, L, label=False)
    _frame(ax, sc, result)
    ax.set_title("junctions after each sweep")
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize="small", loc="best", framealpha=0.85)

    # Cost and costate jump per sweep.
    sweeps = np.array([h.sweep for h in hist], dtype=float)
    costs = np.array([h.cost for h in hist], dtype=float)
    jumps = np.array([h.max_costate_jump for h in hist], dtype=float)
    if hist:
        xs, ys = sweeps, costs
        if np.isfinite(result.initial_cost):
            xs, ys = np.r_[0.0, sweeps], np.r_[result.initial_cost, costs]
        ax_cost.plot(xs, ys, "o-", color=PATH_COLOR, ms=4, label="piecewise-optimal cost")
        if np.isfinite(result.cost):
            ax_cost.axhline(
                result.cost, color="black", ls="--", lw=1.0, label=f"final J = {result.cost:.6g}"
            )
        ok = np.isfinite(jumps) & (jumps > 0)
        ax_jump.plot(sweeps[ok], jumps[ok], "s-", color="tab:purple", ms=4)
        if ok.any():
            ax_jump.set_yscale("log")
        qs = [h.q for h in hist]
        X0 = _junctions(result)
        q0 = X0.shape[0] - 1 if X0 is not None else qs[0]
        prev_q = q0
        for h in hist:
            if h.q != prev_q:
                for a in (ax_cost, ax_jump):
                    a.axvline(h.sweep - 0.5, color="0.5", ls=":", lw=1.0)
                ax_jump.annotate(
                    f"q = {h.q}",
                    xy=(h.sweep - 0.5, 1.0),
                    xycoords=("data", "axes fraction"),
                    xytext=(3, -3),
                    textcoords="offset points",
                    va="top",
                    fontsize="small",
                    color="0.3",
                )
            prev_q = h.q
        steps = [prev for prev, nxt in zip([q0, *qs], [*qs, None], strict=True) if prev != nxt]
        ax_cost.set_title("cost per sweep (partitions q: " + " → ".join(map(str, steps)) + ")")
        ax_cost.legend(fontsize="small", loc="upper right")
    else:
        for a in (ax_cost, ax_jump):
            _no_data(a, "no sweeps")
    ax_cost.set_ylabel("cost J")
    ax_jump.set_ylabel("max costate jump")
    ax_jump.set_xlabel("sweep")
    from matplotlib.ticker import MaxNLocator

    ax_jump.xaxis.set_major_locator(MaxNLocator(integer=True))
    ax_cost.tick_params(labelbottom=False)
    for a in (ax_cost, ax_jump):
        a.grid(True, which="major", alpha=0.3)

    if result.trajectory is not None:
        head = f"cost J = {_cost_text(result.cost)}"
    else:
        head = _status(result)
    fig.suptitle(f"{sc.name} — Leapfrog convergence: {len(hist)} sweeps, {head} ({result.method})")
    return fig


# --------------------------------------------------------------------------- plot_controls


def plot_controls(result: PlanResult, fig=None) -> Figure:
    """Controls (top), costates (middle) and ``H - H(0)`` (bottom, small) against time.

    Lines are labelled with the model's control and state names. Without a trajectory (a
    failed result) the axes say so. Returns the figure (a new one unless ``fig`` is given).
    """
    if fig is None:
        fig = _new_figure(figsize=(8.0, 7.5))
    gs = fig.add_gridspec(3, 1, height_ratios=(3.0, 3.0, 1.6))
    ax_u = fig.add_subplot(gs[0])
    ax_l = fig.add_subplot(gs[1], sharex=ax_u)
    ax_h = fig.add_subplot(gs[2], sharex=ax_u)
    tr = result.trajectory
    if tr is not None:
        for i, name in enumerate(result.control_names):
            ax_u.plot(tr.t, tr.u[:, i], lw=1.6, label=name)
        for i in range(tr.lam.shape[1]):
            state = result.state_names[i] if i < len(result.state_names) else str(i + 1)
            ax_l.plot(tr.t, tr.lam[:, i], lw=1.6, label=rf"$\lambda_{{{i + 1}}}$ ({state})")
        # H at the integrator's own steps: the rows between them are interpolated (dense
        # output), whose error would show as noise several orders above the true variation.
        steps = np.asarray(tr.at_step, dtype=bool)
        if steps.sum() < 2:
            steps = np.ones_like(steps)
        t, H = tr.t[steps], np.asarray(tr.hamiltonian, dtype=float)[steps]
        ax_h.plot(t, H - H[0], ".-", color="tab:gray", lw=1.0, ms=3)
        ax_h.set_title(
            f"Hamiltonian at the integrator steps: H(0) = {H[0]:.6g},"
            f" max |H - H(0)| = {np.abs(H - H[0]).max():.2e}",
            fontsize="small",
        )
        ax_h.ticklabel_format(axis="y", style="sci", scilimits=(-2, 3))
        for a in (ax_u, ax_l):
            a.axhline(0.0, color="0.6", lw=0.6)
            a.legend(fontsize="small", loc="best")
        title = f"{result.scenario} — controls and costates, cost J = {_cost_text(result.cost)}"
    else:
        for a in (ax_u, ax_l, ax_h):
            _no_data(a, f"no trajectory ({_status(result)})")
        title = f"{result.scenario} — {_status(result)}: no trajectory"
    ax_u.set_ylabel("controls")
    ax_l.set_ylabel("costates")
    ax_h.set_ylabel("H - H(0)")
    ax_h.set_xlabel("t")
    for a in (ax_u, ax_l):
        a.tick_params(labelbottom=False)
    for a in (ax_u, ax_l, ax_h):
        a.grid(True, alpha=0.3)
    fig.suptitle(title)
    return fig


# --------------------------------------------------------------------------- animate_sweeps


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
    sc = _as_scenario(scenario)
    L = _arrow_length(sc, result)
    # The static part (obstacles, start, goal, axes and ticks) is drawn once, laid out with room
    # for a two-line title; each frame then draws only that picture and the moving artists, on
    # invisible axes at exactly the same place with the same limits.
    static = _new_figure(figsize=(6.0, 5.5), dpi=80)
    ax0 = static.add_subplot()
    _draw_obstacles(ax0, sc, label=False)
    _draw_ends(ax0, sc, L, label=False)
    _frame(ax0, sc, result)
    ax0.set_title("title\nplaceholder")
    static.canvas.draw()
    static.set_layout_engine("none")  # keep the room for the title
    ax0.title.set_visible(False)
    static.canvas.draw()
    background = np.asarray(static.canvas.buffer_rgba()).copy()

    fig = _new_figure(layout=None, figsize=static.get_size_inches(), dpi=static.dpi)
    fig.figimage(background, xo=0, yo=0, origin="upper", zorder=0)
    ax = fig.add_axes(ax0.get_position(), zorder=1)
    ax.set_xlim(ax0.get_xlim())
    ax.set_ylim(ax0.get_ylim())
    ax.set_aspect("auto")
    ax.set_axis_off()
    _draw_ends(ax, sc, L, label=False)  # again, above the moving lines

    frames: list[tuple[str, np.ndarray | None, str]] = []  # (kind, X, title)
    X0 = _junctions(result)
    if X0 is not None:
        frames.append(
            (
                "junctions",
                X0,
                f"initial path: q = {len(X0) - 1}, J = {_cost_text(result.initial_cost)}",
            )
        )
    for h in result.history:
        frames.append(
            (
                "junctions",
                np.asarray(h.X, dtype=float),
                f"sweep {h.sweep}/{len(result.history)}: q = {h.q}, J = {_cost_text(h.cost)}, "
                f"jump = {h.max_costate_jump:.2g}",
            )
        )
    tr = result.trajectory
    if tr is not None:
        final = f"final extremal: J = {_cost_text(result.cost)} ({result.method})"
        frames += [("final", None, final)] * 3
    elif not frames:
        frames.append(("junctions", None, f"{_status(result)}: nothing to animate"))
    else:
        kind, X, text = frames[-1]
        frames.append((kind, X, f"{text} — {_status(result)}"))

    title = ax.title
    colors = _sweep_colors(max(len(frames), 1))

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
                            _quiver(
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
                    dynamic.append(_quiver(ax, xy, th, L, gid=GID_HEADING, color=ARROW_COLOR))
                title.set_text(f"{sc.name}\n{text}")
                writer.grab_frame()

    _write_atomic(path, render)
    return path


# --------------------------------------------------------------------------- save_figure


def save_figure(fig: Figure, path) -> Path:
    """Save ``fig`` as PNG, PDF or SVG (chosen by the extension) atomically; returns the path.

    The file is written to a temporary file in the same folder and renamed, so ``path`` is
    either the old file or the complete new one, never half a file. The figure is closed once
    saved. An unknown extension raises ``ValueError`` before anything is written.
    """
    path = Path(path)
    fmt = FIGURE_FORMATS.get(path.suffix.lower())
    if fmt is None:
        raise ValueError(
            f"{path.name}: unknown figure format {path.suffix or '(none)'!r};"
            f" use {', '.join(FIGURE_FORMATS)}"
        )
    _write_atomic(path, lambda tmp: fig.savefig(tmp, format=fmt, dpi=150))
    plt = sys.modules.get("matplotlib.pyplot")  # only pyplot's own figures need closing
    if plt is not None:
        plt.close(fig)
    return path
