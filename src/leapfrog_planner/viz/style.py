"""What the figures share: colours, artist ids, and helpers that draw obstacles, ends,
headings and frames."""

from __future__ import annotations

import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Circle

from ..planning.outcome import unreachable
from ..planning.results import PlanResult
from ..planning.scenario import Scenario

#: File formats :func:`save_figure` writes, by (lower-case) extension.
FIGURE_FORMATS = {".png": "png", ".pdf": "pdf", ".svg": "svg"}

PATH_COLOR = "C0"
ARROW_COLOR = "0.1"
REVERSE_COLOR = "tab:orange"
REVERSE_LABEL = "reversing (v < 0)"
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
GID_MAP = "map"
GID_INITIAL = "initial-junctions"
GID_SWEEP = "sweep"
GID_REVERSING = "reversing"
GID_DIRECTION_CHANGE = "direction-change"
GID_WAYPOINT = "waypoint"
GID_ALTERNATIVE = "alternative"
GID_COLLIDING = "alternative-collides"

WAYPOINT_COLOR = "tab:purple"
COLLIDING_COLOR = "tab:red"

#: Line styles of the other local optima, in turn (the first is dotted).
ALTERNATIVE_STYLES = (":", (0, (5, 2, 1, 2)), (0, (1, 3)), (0, (6, 3)))


# --------------------------------------------------------------------------- helpers


def new_figure(layout: str | None = "constrained", **kw) -> Figure:
    fig = Figure(layout=layout, **kw)
    FigureCanvasAgg(fig)
    return fig


def drop_titles(fig: Figure) -> None:
    """No title text left on the axes of ``fig`` (a figure for a paper, whose caption says what
    they said; the caller leaves the figure's own title out)."""
    for ax in fig.axes:
        for loc in ("left", "center", "right"):
            ax.set_title("", loc=loc)


def status_text(result: PlanResult) -> str:
    return str(getattr(result.status, "value", result.status))


def cost_text(cost: float) -> str:
    return f"{cost:.6g}" if np.isfinite(cost) else "n/a"


def time_term(result: PlanResult, horizon) -> float:
    """The price of time ``k T`` of a motion of ``horizon`` when the final time is free, else 0.
    A free-time result's cost includes it; its initial path's and sweeps' costs do not."""
    f = result.free_time
    return 0.0 if f is None or horizon is None else f.time_weight * float(horizon)


def with_time(result: PlanResult, cost: float, horizon) -> str:
    """``cost`` (without the price of time) of a motion of ``horizon`` as the figures compare it
    with the result's: the price of time added and said, when the final time is free."""
    if result.free_time is None or not np.isfinite(cost):
        return cost_text(cost)
    term = time_term(result, horizon)
    return f"{cost_text(cost + term)} incl. time k T = {term:.3g}"


def answer_cost(result: PlanResult) -> str:
    """The result's cost as the legends say it (with a free final time it includes k T)."""
    if result.free_time is None or not np.isfinite(result.cost):
        return cost_text(result.cost)
    return f"{cost_text(result.cost)} incl. time k T = {result.free_time.time_cost:.3g}"


def initial_horizon(result: PlanResult):
    """The horizon of the initial path (its last junction's time), None when not known."""
    t = result.initial_junctions[0] if result.initial_junctions else None
    return None if t is None or len(t) == 0 else float(np.asarray(t, dtype=float)[-1])


def answer_head(result: PlanResult) -> str:
    """What a title says of the answer: its cost, and whether it is optimal."""
    status = status_text(result)
    if unreachable(result):
        return f"{status}: no path joins start and goal"
    if result.trajectory is None or not np.isfinite(result.cost):
        return f"{status}: no optimal path"
    if status == "converged":
        return f"cost J = {result.cost:.6g}"
    # collides: every extremal found passes through an obstacle
    return f"{status}: J = {result.cost:.6g}" + ("" if result.optimal else ", not optimal")


def path_title(result: PlanResult, sc: Scenario) -> str:
    return f"{sc.name} — {answer_head(result)} ({result.method})"


def motion_label(result: PlanResult) -> str:
    """The legend entry of the returned motion: the optimal path only when the plan converged;
    else what it is (an extremal that collides; or the result's trajectory source, such as a
    Leapfrog iterate or the initial path), not optimal."""
    cost, status = answer_cost(result), status_text(result)
    if status == "converged" and result.optimal:
        return f"optimal path (J = {cost})"
    if status == "collides" and result.optimal:  # a validated extremal through an obstacle
        return f"best extremal (J = {cost}, collides)"
    source = result.trajectory_source
    if "not optimal" not in source and "not a motion" not in source:
        source += ", not optimal"
    return f"returned {source} (J = {cost})"


def initial_junctions(result: PlanResult) -> np.ndarray | None:
    """The initial junction states ``(q + 1, 3)``, or None."""
    ij = result.initial_junctions
    if ij is None or len(ij) < 2 or ij[1] is None:
        return None
    X = np.asarray(ij[1], dtype=float)
    return X if X.ndim == 2 and X.shape[0] > 0 and X.shape[1] >= 2 else None


def view_extent(sc: Scenario, result: PlanResult) -> tuple[float, float, float, float]:
    """Bounding box of everything drawn: end points, obstacles (not a map's cells: the view
    follows the path), junctions and the path."""
    pts = [sc.start[None, :2], sc.goal[None, :2]]
    if sc.waypoints is not None:
        pts.append(np.asarray(sc.waypoints, dtype=float)[:, :2])
    if sc.obstacles.shape[0]:
        c, r = sc.obstacles[:, :2], sc.obstacles[:, 2:3]
        pts += [c - r, c + r]
    if sc.map is not None and sc.map.shapes is not None:
        xmin, xmax, ymin, ymax = sc.map.shapes.box
        pts.append(np.array([[xmin, ymin], [xmax, ymax]]))
    X = initial_junctions(result)
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


def arrow_length(sc: Scenario, result: PlanResult, arrows: int = 9) -> float:
    """About 7 % of the plot, but short enough that ``arrows`` arrows along the path stay apart."""
    x0, x1, y0, y1 = view_extent(sc, result)
    length = 0.07 * max(x1 - x0, y1 - y0, 1e-9)
    tr = result.trajectory
    if tr is not None and arrows > 0:
        arc = float(np.sum(np.hypot(*np.diff(tr.x[:, :2], axis=0).T)))
        if np.isfinite(arc) and arc > 0:
            length = min(length, 0.5 * arc / (arrows + 1))
    return max(length, 0.02 * max(x1 - x0, y1 - y0, 1e-9))


def path_figsize(sc: Scenario, result: PlanResult, legend_h: float, width: float = 6.4) -> tuple:
    """A figure ``width`` inches wide whose axes follow the data's aspect ratio (between 2 and 6.5
    inches high), with room for a title above and a legend ``legend_h`` inches high below."""
    x0, x1, y0, y1 = view_extent(sc, result)
    w, h = max(x1 - x0, 1e-9), max(y1 - y0, 1e-9)
    pad = 0.24 * max(w, h)  # frame_axes' padding on both sides
    axes_h = float(np.clip((width - 0.8) * (h + pad) / (w + pad), 2.0, 6.5))
    return (width, axes_h + 1.0 + legend_h)


def legend_below(fig: Figure, handles: list, height=None, fontsize="small", max_cols: int = 2):
    """The legend under the axes, across the figure: in as many columns as fit the figure's
    width (at most ``max_cols``). With ``height`` (a function of the legend's height in inches
    giving the figure's size) the figure is resized to make room for it."""
    renderer = fig.canvas.get_renderer()
    for ncols in range(max(1, min(max_cols, len(handles))), 0, -1):
        legend = fig.legend(
            handles=handles, loc="outside lower center", ncols=ncols, fontsize=fontsize,
            frameon=False,
        )  # fmt: skip
        box = legend.get_window_extent(renderer)
        if ncols == 1 or box.width <= 0.97 * fig.bbox.width:
            break
        legend.remove()
    if height is not None:
        fig.set_size_inches(height(box.height / fig.dpi))
    return legend


def frame_axes(ax: Axes, sc: Scenario, result: PlanResult) -> None:
    """Equal aspect and limits with room for the arrows at the edges."""
    x0, x1, y0, y1 = view_extent(sc, result)
    pad = 0.12 * max(x1 - x0, y1 - y0, 1e-9)
    ax.set_xlim(x0 - pad, x1 + pad)
    ax.set_ylim(y0 - pad, y1 + pad)
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel("x")
    ax.set_ylabel("y")


def map_grey(data: np.ndarray) -> np.ndarray:
    """The grey level (0 black .. 1 white) of each cell as map_server saves and RViz shows a
    map: free 254, occupied 0, unknown 205, values in between from white to black."""
    grey = (255.0 - np.clip(data.astype(float), 0, 100) * 2.55) / 255.0
    grey[data == 0] = 254.0 / 255.0
    grey[data < 0] = 205.0 / 255.0
    return grey


def draw_map(ax: Axes, sc: Scenario, label: bool = True) -> None:
    """The scenario's map under everything else, in the world frame (its origin's yaw turns
    it about its lower-left corner)."""
    if sc.map is None:
        return
    draw_shapes(ax, sc.map.shapes, label)
    if sc.map.file is None:  # polygons and walls alone: their grid is free, not drawn
        return
    from matplotlib.transforms import Affine2D

    occ = sc.map.occupancy
    rows, cols = occ.shape
    h, (x0, y0, yaw) = occ.resolution, occ.origin
    place = Affine2D().rotate(yaw).translate(x0, y0) + ax.transData
    ax.imshow(
        map_grey(occ.data), cmap="gray", vmin=0.0, vmax=1.0, origin="lower",
        extent=(0.0, cols * h, 0.0, rows * h), transform=place, interpolation="nearest",
        zorder=0, gid=GID_MAP,
    )  # fmt: skip


def draw_shapes(ax: Axes, shapes, label: bool = True) -> None:
    """Polygons as they are, walls as their points within half the thickness of the line (a
    band per segment and a disc at each vertex), in the discs' grey; with ``label`` the first
    of each kind in the legend."""
    if shapes is None:
        return
    from matplotlib.patches import Polygon

    style = {"facecolor": OBSTACLE_FACE, "edgecolor": "none", "zorder": 1, "gid": GID_OBSTACLE}
    for i, ring in enumerate(shapes.polygons):
        text = "polygons" if label and i == 0 else None
        ax.add_patch(
            Polygon(ring, closed=True, **{**style, "edgecolor": OBSTACLE_EDGE}, label=text)
        )
    for i, (line, thickness) in enumerate(zip(shapes.walls, shapes.thickness, strict=True)):
        half = 0.5 * thickness
        for j, (a, b) in enumerate(zip(line[:-1], line[1:], strict=True)):
            t = b - a
            n = np.array([-t[1], t[0]]) * (half / max(float(np.hypot(*t)), 1e-300))
            text = "walls" if label and i == j == 0 else None
            ax.add_patch(Polygon([a + n, b + n, b - n, a - n], closed=True, **style, label=text))
        for p in line:
            ax.add_patch(Circle(p, half, **style))


def draw_obstacles(ax: Axes, sc: Scenario, label: bool = True) -> None:
    draw_map(ax, sc, label)
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


def draw_arrows(ax: Axes, xy, theta, length: float, *, gid: str, color, pivot="mid", width=0.005):
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


def draw_ends(ax: Axes, sc: Scenario, length: float, label: bool = True) -> None:
    """Start (circle) and goal (star) with their headings as arrows from the point.

    The markers are hollow and the heading arrows lie under the path, so that a stretch of the
    path near an end (a short reverse leg at the start) stays visible."""
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
            ms=10 if marker == "o" else 15,
            mfc="none",
            mec=color,
            mew=1.8,
            zorder=6,
            gid=name,
            label=text if label else None,
        )
        arrows = draw_arrows(
            ax,
            [x, y],
            th,
            1.3 * length,
            gid=GID_END_HEADING,
            color=color,
            pivot="tail",
            width=0.007,
        )
        arrows.set_zorder(2.5)  # under the path
        arrows.set_alpha(0.8)


def draw_waypoints(ax: Axes, sc: Scenario, label: bool = True) -> None:
    """The scenario's waypoints (if any) as diamonds numbered in their order (gid
    ``"waypoint"``). The initial path passes through them; the optimal path need not."""
    if sc.waypoints is None:
        return
    W = np.asarray(sc.waypoints, dtype=float)[:, :2]
    text = "waypoint of the initial path" if W.shape[0] == 1 else "waypoints of the initial path"
    ax.plot(
        W[:, 0], W[:, 1], ls="none", marker="D", ms=7, mfc="none", mec=WAYPOINT_COLOR, mew=1.6,
        zorder=6, gid=GID_WAYPOINT, label=text if label else None,
    )  # fmt: skip
    for i, (x, y) in enumerate(W.tolist()):
        ax.annotate(
            str(i + 1), (x, y), xytext=(5, 5), textcoords="offset points", color=WAYPOINT_COLOR,
            fontsize="small", fontweight="bold", zorder=6, gid=GID_WAYPOINT,
        )  # fmt: skip


def draw_initial(ax: Axes, result: PlanResult, label: bool = True) -> None:
    X = initial_junctions(result)
    if X is None or unreachable(result):  # its ends alone, not a path: none was found
        return
    q = X.shape[0] - 1
    cost = with_time(result, result.initial_cost, initial_horizon(result))
    text = f"initial path junctions (q = {q}, J = {cost})"
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


def heading_proxy(label: str) -> Line2D:
    return Line2D([], [], ls="none", marker=r"$\rightarrow$", ms=12, color=ARROW_COLOR, label=label)


def no_data(ax: Axes, text: str) -> None:
    ax.text(0.5, 0.5, text, ha="center", va="center", transform=ax.transAxes, color="0.4")


def sweep_colors(n: int, lightest: float = 0.3):
    from matplotlib import colormaps

    cmap = colormaps[SWEEP_CMAP]
    return [cmap(v) for v in np.linspace(lightest, 1.0, n)] if n else []


# --------------------------------------------------------------------------- reversing


def forward_speed(result: PlanResult) -> np.ndarray | None:
    """The signed speed along the heading at each trajectory sample (negative: reversing).

    The control ``v`` where the model has one, else ``cos(theta) x' + sin(theta) y'`` from the
    samples. None without a trajectory."""
    tr = result.trajectory
    if tr is None or tr.t.size < 2:
        return None
    names = list(result.control_names)
    if "v" in names and tr.u.ndim == 2 and tr.u.shape[1] > names.index("v"):
        return np.asarray(tr.u[:, names.index("v")], dtype=float)
    th = tr.x[:, 2]
    dx, dy = (np.gradient(tr.x[:, i], tr.t) for i in range(2))
    return np.cos(th) * dx + np.sin(th) * dy


def reversing_runs(result: PlanResult) -> list[tuple[int, int]]:
    """Sample index ranges ``[i, j)`` where the robot drives backwards (``v < 0``)."""
    v = forward_speed(result)
    if v is None:
        return []
    rev = np.r_[False, v < 0, False].astype(int)
    edges = np.flatnonzero(np.diff(rev))
    return [(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2], strict=True)]


def draw_reversing(ax: Axes, result: PlanResult, lw: float = 2.2, zorder: float = 3.2) -> list:
    """The reversing stretches of the path over the path line: orange and dashed, on a white
    underlay that hides the path's own colour there. One labelled line (gid ``"reversing"``, NaN
    between the stretches), and a dot where the direction changes (gid ``"direction-change"``);
    nothing when the robot never reverses."""
    runs = reversing_runs(result)
    if not runs:
        return []
    tr = result.trajectory
    n = tr.t.size
    parts = []
    for a, b in runs:  # one sample either side, so that the stretch meets the forward path
        parts += [tr.x[max(a - 1, 0) : min(b + 1, n), :2], np.full((1, 2), np.nan)]
    xy = np.concatenate(parts[:-1])
    v = forward_speed(result)
    share = float(np.sum(np.diff(tr.t) * (v[:-1] < 0)) / max(tr.t[-1] - tr.t[0], 1e-300))
    label = f"{REVERSE_LABEL}: {share:.0%} of the time"
    under = ax.plot(xy[:, 0], xy[:, 1], color="white", lw=lw + 0.6, zorder=zorder - 0.05)
    over = ax.plot(xy[:, 0], xy[:, 1], color=REVERSE_COLOR, lw=lw, ls=(0, (3.0, 1.2)),
                   zorder=zorder, gid=GID_REVERSING, label=label)  # fmt: skip
    # Where the robot changes direction (a cusp): a dot that shows however short the stretch.
    cusps = sorted({i for a, b in runs for i in (a, b) if 0 < i < n})
    if cusps:
        p = tr.x[cusps, :2]
        over += ax.plot(p[:, 0], p[:, 1], ls="none", marker="o", ms=4.5, mfc=REVERSE_COLOR,
                        mec="black", mew=0.6, zorder=zorder + 0.1,
                        gid=GID_DIRECTION_CHANGE)  # fmt: skip
    return under + over


def heading_colors(result: PlanResult, ts: np.ndarray) -> list:
    """Arrow colours at times ``ts``: the reversing colour where ``v < 0``."""
    v = forward_speed(result)
    if v is None:
        return [ARROW_COLOR] * len(ts)
    vs = np.interp(ts, result.trajectory.t, v)
    return [REVERSE_COLOR if s < 0 else ARROW_COLOR for s in vs]
