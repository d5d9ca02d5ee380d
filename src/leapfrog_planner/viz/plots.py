"""Figures of a planning result, in the style of the paper's figures 1 to 4.

- :func:`plot_path`: obstacles as filled discs, the optimal path with arrows for the robot's
  heading along it (orange and dashed where it reverses), start and goal marked with their
  headings, the initial feasible path's junctions (dashed) and the other local optima found.
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
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from .._atomic import write_atomic as _write_atomic
from ..errors import require_integer
from ..planning.results import PlanResult
from ..planning.scenario import Scenario, as_scenario
from ..planning.status import listed_alternatives
from .animation import animate_sweeps
from .options import DPI, DPI_MAX, DPI_MIN
from .style import (
    ALTERNATIVE_STYLES,
    COLLIDING_COLOR,
    FIGURE_FORMATS,
    GID_ALTERNATIVE,
    GID_COLLIDING,
    GID_END_HEADING,
    GID_HEADING,
    GID_PATH,
    GID_SWEEP,
    PATH_COLOR,
    REVERSE_COLOR,
    REVERSE_LABEL,
    answer_head,
    arrow_length,
    draw_arrows,
    draw_ends,
    draw_initial,
    draw_obstacles,
    draw_reversing,
    draw_waypoints,
    drop_titles,
    frame_axes,
    heading_colors,
    heading_proxy,
    initial_horizon,
    initial_junctions,
    legend_below,
    motion_label,
    new_figure,
    no_data,
    path_figsize,
    path_title,
    reversing_runs,
    status_text,
    sweep_colors,
    time_term,
)

__all__ = ["animate_sweeps", "plot_controls", "plot_convergence", "plot_path", "save_figure"]

# --------------------------------------------------------------------------- plot_path


def plot_path(
    result: PlanResult,
    scenario: Scenario | str,
    ax: Axes | None = None,
    *,
    arrows: int = 9,
    show_initial: bool = True,
    show_alternatives: bool = True,
    title: bool = True,
) -> Axes:
    """Draw the optimal path the way the paper does; returns the axes.

    Obstacles are filled discs (gid ``"obstacle"``), the optimal path a line (gid
    ``"optimal-path"``) with ``arrows`` heading arrows at evenly spaced interior times (one
    quiver, gid ``"heading"``; no arrows for ``arrows=0``). Where the robot drives backwards
    (``v < 0``) the path is drawn orange and dashed over that line (gid ``"reversing"``, labelled
    with the share of the time) and the arrows there are orange too. Start (circle) and goal
    (star) are marked hollow with their headings (quiver gid ``"end-heading"``), the waypoints
    as numbered diamonds (gid ``"waypoint"``). With ``show_initial`` the initial feasible path's
    junctions are drawn dashed. With ``show_alternatives`` the other initial paths' extremals
    are drawn in grey, each in its own line style (gid ``"alternative"``), those that pass
    through an obstacle red and dashed, "collides" in their legend entry (gid
    ``"alternative-collides"``), with their costs in the legend (those saved without a path:
    only the legend entry). ``title=False`` leaves the axes without a title (for a paper, whose
    caption says it).

    On a new figure (``ax`` None) the legend sits below the axes, across the figure, and the
    figure's height follows the data's aspect ratio; on a given axes it goes inside (``best``).

    A failed result (``trajectory is None``) draws obstacles, start, goal, the initial junctions
    and the junctions after the last sweep; the title says the status. ``scenario`` is a
    :class:`~leapfrog_planner.planning.scenario.Scenario` or a name/file for ``load_scenario``.
    """
    arrows = require_integer("arrows", arrows, 0, error=ValueError)
    sc = as_scenario(scenario)
    own = ax is None
    if own:
        ax = new_figure(figsize=path_figsize(sc, result, 1.0)).add_subplot()
    L = arrow_length(sc, result, arrows)

    draw_obstacles(ax, sc)
    if show_initial:
        draw_initial(ax, result)
    extra = _draw_answer(ax, result, arrows, L)
    tr = result.trajectory
    draw_ends(ax, sc, L)
    draw_waypoints(ax, sc)

    if tr is not None and sc.robot_radius:
        _draw_footprint(ax, sc, tr)
    if show_alternatives:
        extra += _draw_alternatives(ax, result)

    frame_axes(ax, sc, result)
    if title:
        ax.set_title(path_title(result, sc))
    handles = ax.get_legend_handles_labels()[0] + extra
    legend = None
    if own:  # below the axes, across the figure: inside it would hide part of the path
        legend_below(ax.figure, handles, lambda h: path_figsize(sc, result, h))
    else:
        legend = ax.legend(handles=handles, fontsize="small", loc="best", framealpha=0.85)
    if tr is not None:
        _zoom_reversing(ax, sc, result, legend)
    return ax


def _draw_answer(ax: Axes, result: PlanResult, arrows: int, L: float) -> list:
    """The answer's path with its reversing stretches and heading arrows, or, for a failed
    result, the junctions after its last sweep; returns extra legend handles."""
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
            ls="-" if result.optimal else "--",
            label=motion_label(result),
        )
        draw_reversing(ax, result)
        if arrows:
            t0, t1 = float(tr.t[0]), float(tr.t[-1])
            ts = np.linspace(t0, t1, arrows + 2)[1:-1]
            xy = np.column_stack([np.interp(ts, tr.t, tr.x[:, i]) for i in range(2)])
            th = np.interp(ts, tr.t, tr.x[:, 2])
            draw_arrows(ax, xy, th, L, gid=GID_HEADING, color=heading_colors(result, ts))
            extra.append(heading_proxy("heading"))
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
    return extra


#: Legend entries longer than this (characters, small font) would not fit a 6.4-inch figure.
_LABEL_WIDTH = 80


def _draw_alternatives(ax: Axes, result: PlanResult) -> list:
    """The other initial paths' extremals, grey in turns of line styles (red and dashed those
    that collide); legend entries for those without (the failed runs counted in one entry when
    there are many: :func:`listed_alternatives`)."""
    extra = []
    drawn = 0
    alts, failed = listed_alternatives(result.alternatives, result)
    if failed:
        text = f"{failed} other paths failed"
        extra.append(Line2D([], [], color="0.6", lw=1.0, ls=":", alpha=0.7, label=text))
    for alt in alts:
        if alt.trajectory is not None:
            collides = status_text(alt) == "collides"
            if collides:  # not a path the robot can take: marked, never drawn like the others
                what, note, gid = "extremal", ", collides", GID_COLLIDING
                color, ls = COLLIDING_COLOR, "--"
            else:
                what = "local optimum" if alt.status == "converged" else status_text(alt)
                note, gid = "", GID_ALTERNATIVE
                color, ls = "0.4", ALTERNATIVE_STYLES[drawn % len(ALTERNATIVE_STYLES)]
                drawn += 1
            label = f"{what} J = {alt.cost:.6g} ({alt.label}{note})"
            if len(label) > _LABEL_WIDTH:  # wider than the figure: the label on a line of its own
                label = f"{what} J = {alt.cost:.6g}\n  ({alt.label}{note})"
            ax.plot(
                alt.trajectory.x[:, 0], alt.trajectory.x[:, 1], color=color, lw=1.3, ls=ls,
                alpha=0.75 if collides else 1.0, zorder=2, gid=gid, label=label,
            )  # fmt: skip
        else:  # its path was not kept (a result saved before paths were)
            text = f"{alt.label}: {status_text(alt)}"
            if np.isfinite(alt.cost):
                text = f"local optimum J = {alt.cost:.6g}\n  ({alt.label}; not kept)"
            extra.append(Line2D([], [], color="0.6", lw=1.0, ls=":", alpha=0.7, label=text))
    return extra


#: A reversing stretch smaller than this share of the view gets a magnified inset, and so do
#: at most this many of them (paper case 3: one at the start, one at the goal).
_ZOOM_BELOW, _ZOOMS = 0.06, 2


def _zoom_reversing(ax: Axes, sc: Scenario, result: PlanResult, legend=None) -> list[Axes]:
    """Magnified insets (gid ``"reversing-zoom"``) of the reversing stretches too short to see
    at the figure's scale (a reverse leg of 1 % of the view at the start hides under the start
    marker), where least is drawn and off ``legend`` (a legend inside the axes), the region each
    shows framed on the axes."""
    tr = result.trajectory
    n = tr.t.size
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    view = max(x1 - x0, y1 - y0)
    w = 0.24
    h = min(w * (x1 - x0) / (y1 - y0), 0.4)  # square on the page (the axes have equal aspect)
    insets: list[Axes] = []
    taken: list = []
    avoid: list = []
    if legend is not None and reversing_runs(result):  # where "best" put it: known once drawn
        ax.figure.draw_without_rendering()
        (u0, v0), (u1, v1) = ax.transAxes.inverted().transform(legend.get_window_extent())
        avoid.append([u0, v0, u1 - u0, v1 - v0])
    for a, b in reversing_runs(result):
        pts = tr.x[max(a - 1, 0) : min(b + 1, n), :2]
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        size = float(max(hi - lo))
        if size >= _ZOOM_BELOW * view or len(insets) == _ZOOMS:
            continue
        half = max(0.8 * size, 1e-9 * view)
        cx, cy = 0.5 * (lo + hi)
        box = _emptiest_box(ax, sc, result, (cx, cy), (w, h), taken, avoid)
        if box is None:
            break
        taken.append(box)
        ins = ax.inset_axes(box)
        ins.set_gid("reversing-zoom")
        draw_obstacles(ins, sc, label=False)
        ins.plot(tr.x[:, 0], tr.x[:, 1], color=PATH_COLOR, lw=2.2, zorder=3)
        draw_reversing(ins, result)
        draw_ends(ins, sc, half, label=False)
        for arrow in [c for c in ins.collections if c.get_gid() == GID_END_HEADING]:
            arrow.remove()  # at this scale a hair that reads as a path
        ins.set_xlim(cx - half, cx + half)
        ins.set_ylim(cy - half, cy + half)
        ins.set_aspect("equal", adjustable="box")
        ins.set_xticks([])
        ins.set_yticks([])
        zoom = w * (x1 - x0) / (2 * half)
        where = ""
        for name, end in (("start", sc.start), ("goal", sc.goal)):
            if np.hypot(end[0] - cx, end[1] - cy) <= 2 * half:
                where = f" at the {name}"
        ins.text(0.04, 0.96, f"reversing{where}, {zoom:.0f}x", transform=ins.transAxes, ha="left",
                 va="top", fontsize="x-small", color="0.2")  # fmt: skip
        ax.indicate_inset([cx - half, cy - half, 2 * half, 2 * half], edgecolor="0.3")
        insets.append(ins)
    return insets


def _emptiest_box(ax: Axes, sc, result: PlanResult, target, size, taken, avoid=()):
    """``[x, y, w, h]`` (``size`` is ``w, h``) in axes fraction: of the places along the axes'
    edges (the corners, then the middles of the edges), the box that covers the fewest points
    of what is drawn (the paths, the obstacles' rims, the ends), neither ``target`` nor a box
    ``[x, y, w, h]`` of ``taken``, and off those of ``avoid`` (a legend) unless every place
    covers one; of two as empty, the nearer to ``target``. None when every place is ruled out."""
    w, h = size
    pts = [sc.start[None, :2], sc.goal[None, :2]]
    ring = np.exp(1j * np.linspace(0.0, 2 * np.pi, 16, endpoint=False))
    for cx, cy, r in sc.obstacles.tolist():
        pts.append(np.column_stack([cx + r * ring.real, cy + r * ring.imag]))
    for alt in [result, *result.alternatives]:
        if alt.trajectory is not None:
            pts.append(alt.trajectory.x[::4, :2])
    p = np.concatenate(pts)
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    u, v = (p[:, 0] - x0) / (x1 - x0), (p[:, 1] - y0) / (y1 - y0)
    tu, tv = (target[0] - x0) / (x1 - x0), (target[1] - y0) / (y1 - y0)
    m = 0.02
    (xa, xb, xc), (ya, yb, yc) = (m, 1 - m - w, 0.5 - 0.5 * w), (m, 1 - m - h, 0.5 - 0.5 * h)
    boxes = [(xa, ya), (xb, ya), (xa, yb), (xb, yb), (xc, ya), (xc, yb), (xa, yc), (xb, yc)]

    def cost(bx, by) -> float:
        def inside(uu, vv):
            return (uu > bx - m) & (uu < bx + w + m) & (vv > by - m) & (vv < by + h + m)

        def overlap(boxes) -> bool:
            return any(
                bx < ox + ow + m and ox < bx + w + m and by < oy + oh + m and oy < by + h + m
                for ox, oy, ow, oh in boxes
            )

        near = float(np.hypot(bx + 0.5 * w - tu, by + 0.5 * h - tv))
        ruled_out = overlap(taken) or bool(inside(tu, tv))
        return float(np.sum(inside(u, v))) + 20 * near + 1e6 * overlap(avoid) + 1e9 * ruled_out

    best = min(boxes, key=lambda b: cost(*b))
    return None if cost(*best) >= 1e9 else [*best, w, h]


def _draw_footprint(ax: Axes, sc: Scenario, tr) -> None:
    """The robot to scale at six poses along the path, and the obstacles grown by its radius
    (where its centre may not go)."""
    from matplotlib.patches import Circle

    for k, (cx, cy, r) in enumerate(sc.footprint_obstacles.tolist()):
        ax.add_patch(Circle((cx, cy), r, fill=False, ls="--", lw=0.8, ec="0.5", zorder=1,
                            label="obstacles grown by the robot" if k == 0 else None))  # fmt: skip
    idx = np.linspace(0, tr.t.size - 1, 6).round().astype(int)
    for k, i in enumerate(idx):
        label = "robot (to scale)" if k == 0 else None
        ax.add_patch(Circle(tr.x[i, :2], sc.robot_radius, fill=False, lw=1.0, ec=PATH_COLOR,
                            alpha=0.7, zorder=3, label=label))  # fmt: skip


# --------------------------------------------------------------------------- plot_convergence


def _draw_sweeps(fig: Figure, ax: Axes, sc: Scenario, result: PlanResult) -> None:
    """Obstacles, ends, the initial junctions, the junctions after each sweep (light to dark,
    with a colour bar) and the final path."""
    L = arrow_length(sc, result)
    hist = result.history
    draw_obstacles(ax, sc)
    draw_initial(ax, result)
    colors = sweep_colors(len(hist))
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
        cax = ax.inset_axes([1.02, 0.0, 0.03, 1.0])  # as high as the axes, however flat they are
        cb = fig.colorbar(sm, cax=cax)
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
            label=motion_label(result),
        )
        draw_reversing(ax, result, lw=1.8)
    draw_ends(ax, sc, L, label=False)
    frame_axes(ax, sc, result)
    ax.set_title("junctions after each sweep")
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize="small", loc="best", framealpha=0.85)


def _draw_progress(ax_cost: Axes, ax_jump: Axes, result: PlanResult) -> None:
    """The cost and the largest costate jump per sweep, the changes of q marked."""
    hist = result.history
    sweeps = np.array([h.sweep for h in hist], dtype=float)
    # With a free final time each cost with its price of time k T, as the final J has it.
    costs = np.array([h.cost + time_term(result, h.t[-1]) for h in hist], dtype=float)
    jumps = np.array([h.max_costate_jump for h in hist], dtype=float)
    what = "" if result.free_time is None else " incl. time k T"
    if hist:
        xs, ys = sweeps, costs
        if np.isfinite(result.initial_cost):
            c0 = result.initial_cost + time_term(result, initial_horizon(result))
            xs, ys = np.r_[0.0, sweeps], np.r_[c0, costs]
        ax_cost.plot(xs, ys, "o-", color=PATH_COLOR, ms=4, label=f"piecewise-optimal cost{what}")
        if np.isfinite(result.cost):
            final = f"final J = {result.cost:.6g}{what}"
            ax_cost.axhline(result.cost, color="black", ls="--", lw=1.0, label=final)
        ok = np.isfinite(jumps) & (jumps > 0)
        ax_jump.plot(sweeps[ok], jumps[ok], "s-", color="tab:purple", ms=4)
        if ok.any():
            ax_jump.set_yscale("log")
        qs = [h.q for h in hist]
        X0 = initial_junctions(result)
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
            no_data(a, "no sweeps")
    ax_cost.set_ylabel(f"cost J{what}")
    ax_jump.set_ylabel("max costate jump")
    ax_jump.set_xlabel("sweep")
    from matplotlib.ticker import MaxNLocator

    ax_jump.xaxis.set_major_locator(MaxNLocator(integer=True))
    ax_cost.tick_params(labelbottom=False)
    for a in (ax_cost, ax_jump):
        a.grid(True, which="major", alpha=0.3)


def plot_convergence(
    result: PlanResult, scenario: Scenario | str, fig=None, *, title: bool = True
) -> Figure:
    """Leapfrog's progress: junctions per sweep (left), cost and costate jump (right).

    Left: obstacles, start and goal, the initial junctions (dashed), the junction polyline
    after every sweep (one line each, gid ``"sweep"``, light to dark with the sweep number) and
    the final path. Right, stacked: the cost of the piecewise-optimal trajectory per sweep (the
    initial path at sweep 0, dotted lines where the number of partitions q changes, the final
    extremal's cost as a horizontal line) and the largest relative costate jump at the junctions
    per sweep (log scale). Returns the figure (a new one unless ``fig`` is given);
    ``title=False``: without any title (the figure's and the panels').
    """
    sc = as_scenario(scenario)
    if fig is None:
        fig = new_figure(figsize=(12.0, 5.5))
    gs = fig.add_gridspec(2, 2, width_ratios=(1.15, 1.0))
    ax = fig.add_subplot(gs[:, 0])
    ax_cost = fig.add_subplot(gs[0, 1])
    ax_jump = fig.add_subplot(gs[1, 1], sharex=ax_cost)
    hist = result.history

    _draw_sweeps(fig, ax, sc, result)

    _draw_progress(ax_cost, ax_jump, result)

    if title:
        sweeps = f"{len(hist)} sweeps, {answer_head(result)} ({result.method})"
        fig.suptitle(f"{sc.name} — Leapfrog convergence: {sweeps}")
    else:
        drop_titles(fig)
    return fig


# --------------------------------------------------------------------------- plot_controls


def plot_controls(result: PlanResult, fig=None, *, title: bool = True) -> Figure:
    """Controls (top), costates (middle) and ``H - H(0)`` (bottom, small) against time.

    Lines are labelled with the model's control and state names. Without a trajectory (a
    failed result) the axes say so. Returns the figure (a new one unless ``fig`` is given);
    ``title=False``: without any title (the figure's and the panels').
    """
    if fig is None:
        fig = new_figure(figsize=(8.0, 7.5))
    gs = fig.add_gridspec(3, 1, height_ratios=(3.0, 3.0, 1.6))
    ax_u = fig.add_subplot(gs[0])
    ax_l = fig.add_subplot(gs[1], sharex=ax_u)
    ax_h = fig.add_subplot(gs[2], sharex=ax_u)
    tr = result.trajectory
    if tr is not None:
        for i, name in enumerate(result.control_names):
            ax_u.plot(tr.t, tr.u[:, i], lw=1.6, label=name)
        for k, (i, j) in enumerate(reversing_runs(result)):  # shaded where v < 0
            t0, t1 = tr.t[max(i - 1, 0)], tr.t[min(j, tr.t.size - 1)]
            label = REVERSE_LABEL if k == 0 else None
            ax_u.axvspan(t0, t1, color=REVERSE_COLOR, alpha=0.15, lw=0, label=label)
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
        head = f"{result.scenario} — controls and costates, {answer_head(result)}"
    else:
        for a in (ax_u, ax_l, ax_h):
            no_data(a, f"no trajectory ({status_text(result)})")
        head = f"{result.scenario} — {status_text(result)}: no trajectory"
    ax_u.set_ylabel("controls")
    ax_l.set_ylabel("costates")
    ax_h.set_ylabel("H - H(0)")
    ax_h.set_xlabel("t")
    for a in (ax_u, ax_l):
        a.tick_params(labelbottom=False)
    for a in (ax_u, ax_l, ax_h):
        a.grid(True, alpha=0.3)
    if title:
        fig.suptitle(head)
    else:
        drop_titles(fig)
    return fig


# --------------------------------------------------------------------------- save_figure


#: Fonts embedded as TrueType (Type 42) in PDF and PostScript: Type 3 fonts, matplotlib's
#: default, are refused by publishers' checks (IEEE PDF eXpress).
_SAVE_RC = {"pdf.fonttype": 42, "ps.fonttype": 42}


def save_figure(fig: Figure | Axes, path, *, dpi: int = DPI) -> Path:
    """Save ``fig`` as PNG, PDF or SVG (chosen by the extension) atomically; returns the path.

    ``fig`` is a figure or an axes (such as :func:`plot_path` returns): an axes saves its figure.
    ``dpi``: pixels per inch of a PNG (and of the images inside a PDF or SVG), an integer from
    10 to 1200. A PDF embeds its fonts as TrueType, not Type 3.

    The file is written to a temporary file in the same folder and renamed, so ``path`` is
    either the old file or the complete new one, never half a file. The figure is closed once
    saved. An unknown extension raises ``ValueError`` before anything is written.
    """
    if isinstance(fig, Axes):
        fig = fig.get_figure(root=True)
    if not isinstance(fig, Figure):
        raise TypeError(f"expected a matplotlib Figure or Axes, got {type(fig).__name__}")
    path = Path(path)
    fmt = FIGURE_FORMATS.get(path.suffix.lower())
    if fmt is None:
        raise ValueError(
            f"{path.name}: unknown figure format {path.suffix or '(none)'!r};"
            f" use {', '.join(FIGURE_FORMATS)}"
        )
    dpi = require_integer("dpi", dpi, DPI_MIN, DPI_MAX, error=ValueError)

    def write(tmp) -> None:
        from matplotlib import rc_context

        with rc_context(_SAVE_RC):
            fig.savefig(tmp, format=fmt, dpi=dpi)

    _write_atomic(path, write)
    plt = sys.modules.get("matplotlib.pyplot")  # only pyplot's own figures need closing
    if plt is not None:
        plt.close(fig)
    return path
