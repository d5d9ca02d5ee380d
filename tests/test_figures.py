"""Figures as a reader sees them: where the legend is, equal aspect, one title, reversing shown,
the GIF's size and frames, and report curves that stay apart where they overlap."""

from __future__ import annotations

import dataclasses
import math
import re

import matplotlib
import numpy as np
import pytest
from matplotlib.axes import Axes
from matplotlib.colors import to_rgba
from matplotlib.figure import Figure
from matplotlib.transforms import Bbox
from PIL import Image

from leapfrog_planner.batch.report import build_report, report_figures
from leapfrog_planner.experiments import paper
from leapfrog_planner.planning.planner import plan
from leapfrog_planner.planning.scenario import load_scenario
from leapfrog_planner.viz import animation
from leapfrog_planner.viz import plots as viz_plots
from leapfrog_planner.viz.plots import animate_sweeps, plot_convergence, plot_path, save_figure
from leapfrog_planner.viz.style import ARROW_COLOR, PATH_COLOR, REVERSE_COLOR

matplotlib.use("Agg")


@pytest.fixture(scope="module")
def case1():
    """Paper case 1: its optimum reverses at both ends (v < 0 on 30% of the time)."""
    result = plan("paper-case-1")
    assert result.success, result.message
    return result, load_scenario("paper-case-1")


@pytest.fixture(scope="module")
def case2():
    """Paper case 2: two discs, two other local optima with their paths, never reverses."""
    result = plan("paper-case-2")
    assert result.success, result.message
    return result, load_scenario("paper-case-2")


def titles(fig: Figure) -> list[str]:
    """Every non-empty title of the figure: the axes' (left, centre, right) and the suptitle."""
    out = [ax.get_title(loc) for ax in fig.axes for loc in ("left", "center", "right")]
    if fig._suptitle is not None:  # no public getter tells 'none'
        out.append(fig._suptitle.get_text())
    return [t for t in out if t.strip()]


def dashes(line) -> tuple:
    """The line style as drawn, before scaling by the width ('--' for every custom pattern)."""
    return line._unscaled_dash_pattern


def by_gid(ax: Axes, gid: str) -> list:
    return [a for a in [*ax.lines, *ax.collections] if a.get_gid() == gid]


# --------------------------------------------------------------------------- path figure


@pytest.mark.parametrize("name", ["case1", "case2"])
def test_path_legend_is_below_the_axes_and_inside_the_figure(name, request):
    result, sc = request.getfixturevalue(name)
    ax = plot_path(result, sc)
    fig = ax.figure
    fig.canvas.draw()
    (legend,) = fig.legends
    lb, ab, fb = legend.get_window_extent(), ax.get_window_extent(), fig.bbox
    assert lb.y1 <= ab.y0  # below the axes, not beside them
    assert lb.x0 >= fb.x0 - 1 and lb.x1 <= fb.x1 + 1 and lb.y0 >= fb.y0 - 1
    assert ab.width >= 0.75 * fb.width  # no side strip: the axes take the figure's width
    assert ax.get_legend() is None


def test_a_long_alternative_label_keeps_the_legend_inside_the_figure(case2):
    # Labels of a long horizon's runs run to 90 characters: the label goes to a second line.
    import dataclasses

    result, sc = case2
    label = "three-point turn at (1.75, 1.52), reverse, then forward, margin 0.0841, q = 16"
    alts = tuple(dataclasses.replace(a, label=label) for a in result.alternatives[:1])
    assert alts and alts[0].trajectory is not None
    ax = plot_path(dataclasses.replace(result, alternatives=alts), sc)
    fig = ax.figure
    fig.canvas.draw()
    (legend,) = fig.legends
    lb, fb = legend.get_window_extent(), fig.bbox
    assert lb.x0 >= fb.x0 - 1 and lb.x1 <= fb.x1 + 1
    assert any(t.get_text().endswith(f"\n  ({label})") for t in legend.get_texts())


def test_path_legend_on_given_axes_is_inside_them(case2):
    result, sc = case2
    fig = Figure(figsize=(6, 6))
    ax = plot_path(result, sc, fig.add_subplot())
    fig.canvas.draw()
    lb, ab = ax.get_legend().get_window_extent(), ax.get_window_extent()
    assert ab.x0 <= lb.x0 and lb.x1 <= ab.x1 and ab.y0 <= lb.y0 and lb.y1 <= ab.y1


@pytest.mark.parametrize("name", ["case1", "case2"])
def test_path_has_equal_aspect_and_one_title(name, request):
    result, sc = request.getfixturevalue(name)
    ax = plot_path(result, sc)
    ax.figure.canvas.draw()
    assert ax.get_aspect() == 1.0
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    box = ax.get_window_extent()
    assert (x1 - x0) / (y1 - y0) == pytest.approx(box.width / box.height, rel=0.02)
    (title,) = titles(ax.figure)
    assert "\n" not in title and sc.name in title


def test_reversing_is_drawn_in_its_own_style(case1):
    result, sc = case1
    ax = plot_path(result, sc)
    tr = result.trajectory
    v = tr.u[:, list(result.control_names).index("v")]
    assert 0.25 < (v < 0).mean() < 0.35  # the 30%

    (rev,) = by_gid(ax, "reversing")
    (path,) = by_gid(ax, "optimal-path")
    assert rev.get_label().startswith("reversing (v < 0)")
    assert to_rgba(rev.get_color()) == to_rgba(REVERSE_COLOR) != to_rgba(path.get_color())
    assert dashes(rev) != dashes(path) and rev.get_zorder() > path.get_zorder()
    # Its points are the reversing samples (two stretches, one forward sample either side).
    xy = np.column_stack([rev.get_xdata(), rev.get_ydata()])
    xy = xy[np.isfinite(xy).all(axis=1)]
    assert abs(len(xy) - int((v < 0).sum())) <= 4
    i = np.argmin(np.hypot(*(tr.x[:, None, :2] - xy[None]).transpose(2, 0, 1)), axis=0)
    assert (v[i] < 0).mean() > 0.95

    # The heading arrows take the reversing colour exactly where v < 0.
    (q,) = [c for c in by_gid(ax, "heading") if hasattr(c, "U")]
    ts = np.linspace(tr.t[0], tr.t[-1], q.N + 2)[1:-1]
    backwards = np.interp(ts, tr.t, v) < 0
    assert backwards.any() and not backwards.all()
    colors = [tuple(c) for c in q.get_facecolors()]
    expected = [to_rgba(REVERSE_COLOR) if b else to_rgba(ARROW_COLOR) for b in backwards]
    assert colors == expected

    texts = [t.get_text() for t in ax.figure.legends[0].get_texts()]
    assert any(t.startswith("reversing (v < 0)") and "30%" in t for t in texts)

    # The convergence figure marks it on the final path too.
    assert len(by_gid(plot_convergence(result, sc).axes[0], "reversing")) == 1


def test_no_reversing_style_when_the_robot_only_drives_forwards(case1, case2):
    result, sc = case2
    ax = plot_path(result, sc)
    assert by_gid(ax, "reversing") == []
    assert not any("reversing" in t.get_text() for t in ax.figure.legends[0].get_texts())
    # Case 1 with |v| in place of v: the control decides, nothing is drawn as reversing.
    r1, sc1 = case1
    tr = r1.trajectory
    u = tr.u.copy()
    u[:, 0] = np.abs(u[:, 0])
    fwd = dataclasses.replace(r1, trajectory=dataclasses.replace(tr, u=u))
    assert by_gid(plot_path(fwd, sc1), "reversing") == []


def test_alternatives_are_drawn_each_in_its_own_style(case2):
    result, sc = case2
    kept = [a for a in result.alternatives if a.trajectory is not None]
    assert len(kept) >= 2
    ax = plot_path(result, sc)
    alts = [line for line in ax.lines if "local optimum" in line.get_label()]
    assert len(alts) == len(kept)
    assert len({dashes(line) for line in alts}) == len(alts)
    for line, alt in zip(alts, kept, strict=True):
        np.testing.assert_array_equal(line.get_xdata(), alt.trajectory.x[:, 0])
        assert to_rgba(line.get_color()) != to_rgba(PATH_COLOR)


# --------------------------------------------------------------------------- paper figures


def test_paper_figures_carry_one_title(case1, monkeypatch, tmp_path):
    result, _ = case1
    run = paper.MethodRun("modified-newton", result, (1.0,))
    nm = paper.MethodRun("newton", result, (1.0,))
    res = paper.PaperResult(
        paper.PaperSettings(cases=(1,), repeat=1),
        (paper.CaseRun(1, "paper-case-1", 0, nm, run),),
        paper.machine_info(),
        1.0,
    )
    saved = []
    monkeypatch.setattr(viz_plots, "save_figure", lambda fig, path: saved.append(fig) or path)
    paper.write_paper(res, tmp_path)
    (fig,) = saved
    fig = fig.figure if isinstance(fig, Axes) else fig
    (title,) = titles(fig)
    assert title == f"Figure 1: paper-case-1, Leapfrog with MNM, J = {result.cost:.6g}"


# --------------------------------------------------------------------------- save_figure


def test_save_figure_takes_an_axes(case1, tmp_path):
    result, sc = case1
    ax = plot_path(result, sc)
    w, h = ax.figure.get_size_inches()
    out = save_figure(ax, tmp_path / "p.png")
    with Image.open(out) as im:
        assert abs(im.size[0] - w * 150) <= 1 and abs(im.size[1] - h * 150) <= 1
    with pytest.raises(TypeError, match="Figure or Axes"):
        save_figure("not a figure", tmp_path / "q.png")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p.png"]


# --------------------------------------------------------------------------- GIF


def test_gif_is_large_and_its_frames_differ(case1, tmp_path):
    result, sc = case1
    gif = animate_sweeps(result, sc, tmp_path / "a.gif")
    with Image.open(gif) as im:
        assert im.size[0] >= 780 and 300 <= im.size[1] <= 900
        n = im.n_frames
        frames = []
        for k in range(n):
            im.seek(k)
            frames.append(np.asarray(im.convert("RGB"), dtype=int))
    # initial, each sweep, the final path (held three frames long: GIF merges equal frames)
    assert n == len(result.history) + 2
    for a, b in zip(frames[:-1], frames[1:], strict=True):
        assert np.abs(a - b).sum() > 0  # each frame changes the picture
    # The final frames draw the reversing stretches in orange: more orange than in frame 0
    # (where only the legend has it).
    orange = np.array([255, 127, 14])

    def n_orange(f):
        return int((np.abs(f - orange).sum(axis=2) < 60).sum())

    assert n_orange(frames[-1]) > n_orange(frames[0]) + 100
    assert n_orange(frames[0]) > 20  # the legend's entry keeps its colour in every frame
    assert all(tuple(f[2, 2]) == (255, 255, 255) for f in frames)  # white stays white


def test_gif_counts_the_sweeps(case1):
    result, sc = case1
    texts = [text for _, _, text in animation._frames(sc, result)]
    K = len(result.history)
    assert texts[0].startswith(f"initial path (sweep 0 of {K}), cost J = ")
    for k in range(1, K + 1):
        assert re.match(rf"sweep {k} of {K}, cost J = \d", texts[k])
    assert texts[-1] == f"final extremal after {K} sweeps, cost J = {result.cost:.6g}"
    names = [h.get_label() for h in animation._legend_handles(sc, result)]
    assert "final extremal" in names and "heading" in names
    assert any(n.startswith("reversing (v < 0)") for n in names)


# --------------------------------------------------------------------------- report figures


def _rec(scenario, method, cost, t):
    return {
        "scenario": scenario,
        "method": method,
        "status": "failed" if cost is None else "converged",
        "failure": None if cost is not None else "solver",
        "cost": cost,
        "wall_time_s": t,
        "newton_iterations": 10,
    }


def test_report_curves_stay_apart_and_every_figure_has_a_title():
    methods = ["newton", "modified-newton", "nleq-err", "shooting", "direct"]
    recs = []
    for i in range(12):  # the first three methods find the same costs: identical curves
        for k, m in enumerate(methods):
            cost = None if (m == "shooting" and i % 2) else 1.0 + (0.01 * i if k == 4 else 0.0)
            recs.append(_rec(f"s{i}", m, cost, 0.01 * (i + 1) * (1 + k)))
    figs = report_figures(build_report(recs))
    assert sorted(figs) == ["cost_ratio_ecdf.png", "success.png", "time_ecdf.png"]
    for name, fig in figs.items():
        (title,) = titles(fig)
        assert title and "\n" not in title, name
    for name in ("cost_ratio_ecdf.png", "time_ecdf.png"):
        (ax,) = figs[name].axes
        lines = [line for line in ax.get_lines() if not line.get_label().startswith("_")]
        assert len(lines) == len(methods)
        styles = {(to_rgba(line.get_color()), dashes(line)) for line in lines}
        assert len(styles) == len(methods), name  # pairwise distinct colour and line style
        assert len({line.get_marker() for line in lines}) == len(methods)
        widths = [line.get_linewidth() for line in lines]
        assert widths == sorted(widths, reverse=True) and widths[0] > widths[-1]
        labels = [t.get_text() for t in ax.get_legend().get_texts()]
        shooting = 6 if name == "cost_ratio_ecdf.png" else 12  # converged runs; all runs
        assert labels[0] == "newton (n = 12)" and labels[3] == f"shooting (n = {shooting})"


# --------------------------------------------------------------------------- benchmark figures


def _bench_result(solvers, failed=()):
    """A synthetic peer benchmark on two scenarios: every solver succeeds except ``failed``
    (solver, scenario) pairs."""
    from leapfrog_planner.experiments.bench import BenchResult, BenchSettings
    from leapfrog_planner.experiments.peers import PeerOutcome

    names = ("paper-case-1", "random-0")
    outcomes = []
    for k, s in enumerate(solvers):
        for i, name in enumerate(names):
            ok = (s, name) not in failed
            cost = 10.0 * (1 + 1e-4 * k) if ok else float("nan")
            t = 1e-3 * (k + 1) * (i + 1)
            outcomes.append(PeerOutcome(s, name, ok, cost, 1e-9, t, (t,), "" if ok else "no"))
    return BenchResult(BenchSettings(cases=(1,), random=1), names, tuple(outcomes), (), None,
                       (), {}, 0.0)  # fmt: skip


def _bench_checks(fig, solvers):
    """The legend below both axes and inside the figure, one title, and per solver one colour
    that no other solver has, the same on its bars and its legend swatch."""
    from matplotlib.patches import Patch

    (legend,) = fig.legends
    fig.canvas.draw()
    lb, fb = legend.get_window_extent(), fig.bbox
    for ax in fig.axes:
        ab = ax.get_window_extent()
        assert ax.get_legend() is None
        assert lb.y1 <= ab.y0 + 1  # below the axes, not at their side
        assert lb.x0 < ab.x1 - 0.5 * ab.width  # not a strip to the right
    assert fb.x0 - 1 <= lb.x0 and lb.x1 <= fb.x1 + 1 and lb.y0 >= fb.y0 - 1
    (title,) = titles(fig)
    assert "\n" not in title
    swatches = [h for h in legend.legend_handles if isinstance(h, Patch)]
    labels = [t.get_text() for t in legend.get_texts()]
    assert labels[: len(solvers)] == list(solvers)
    colours = [to_rgba(h.get_facecolor()) for h in swatches[: len(solvers)]]
    assert len(set(colours)) == len(solvers)  # pairwise distinct
    assert not any(h.get_hatch() for h in swatches[: len(solvers)])  # a method is never hatched
    ax_t = fig.axes[0]
    for s, c in zip(solvers, colours, strict=True):
        bars = [p for p in ax_t.patches if p.get_gid() == f"time:{s}"]
        assert bars and all(
            (p.get_hatch() and to_rgba(p.get_edgecolor()) == c) or to_rgba(p.get_facecolor()) == c
            for p in bars
        )
    return legend, swatches, labels


def test_bench_figure_legend_below_with_distinct_colours_and_no_hatch_when_none_failed():
    from leapfrog_planner.batch.report import method_style
    from leapfrog_planner.experiments.bench import bench_figure

    solvers = ["leapfrog-mnm", "leapfrog-mnm-1path", "shooting", "bvp-line"]
    fig = bench_figure(_bench_result(solvers))
    legend, swatches, labels = _bench_checks(fig, solvers)
    assert len(labels) == len(solvers)  # no 'failed' entry: nothing failed
    assert not any(p.get_hatch() for ax in fig.axes for p in ax.patches)
    # The report figures' palette, in the same order.
    assert [to_rgba(h.get_facecolor()) for h in swatches] == [
        to_rgba(method_style(k)["color"]) for k in range(len(solvers))
    ]


def test_bench_figure_thirteen_solvers_and_a_failure_has_one_hatched_entry():
    from leapfrog_planner.experiments.bench import bench_figure

    solvers = ["leapfrog-mnm", "leapfrog-mnm-1path", "leapfrog-nm", "leapfrog-nleq-err",
               "shooting", "bvp-line", "bvp-path"]  # fmt: skip
    solvers += [f"direct-N{n}-{g}" for n in (100, 200) for g in ("line", "path", "paths")]
    # The first solver fails on the first scenario: its swatch used to come out hatched.
    failed = {("leapfrog-mnm", "paper-case-1"), ("direct-N200-line", "random-0")}
    fig = bench_figure(_bench_result(solvers, failed))
    legend, swatches, labels = _bench_checks(fig, solvers)
    assert len(labels) == len(solvers) + 1 and "failed" in labels[-1]
    assert [bool(h.get_hatch()) for h in swatches] == [False] * len(solvers) + [True]
    hatched = [p for p in fig.axes[0].patches if p.get_hatch()]
    assert len(hatched) == len(failed)
    crosses = [line for line in fig.axes[1].lines if line.get_marker() == "x"]
    assert sum(len(line.get_xdata()) for line in crosses) == len(failed)


def _wp_result(n_scenarios=5, marks=True):
    """A synthetic work-precision run: per scenario a curve per method, with (``marks``) one
    solve_bvp failure and one IPOPT point on another extremal in the first scenario."""
    from leapfrog_planner.experiments.work_precision import (
        METHODS,
        Point,
        Reference,
        WorkPrecisionResult,
        WorkPrecisionSettings,
    )

    points, refs = [], []
    for i in range(n_scenarios):
        name = f"paper-case-{i + 1}" if i < 4 else f"general-s1-{i - 4:05d}"
        refs.append(Reference(name, 10.0, 10.0))
        for k, m in enumerate(METHODS):
            for j, knob in enumerate((1e-4, 1e-6, 1e-8)):
                err, t = 10.0 ** (-3 - 2 * j - k), 1e-3 * (k + 1) * (j + 1)
                points.append(Point(name, m, knob, t, 10.0 * (1 + err), err, "ok"))
        if marks and i == 0:
            points.append(Point(name, "solve_bvp", 1e-9, 0.5, math.nan, math.nan, "failed"))
            points.append(Point(name, "ipopt", 50, 0.2, 12.0, 0.2, "other extremal"))
    settings = WorkPrecisionSettings(cases=(1,), general=0, repeat=1)
    return WorkPrecisionResult(settings, tuple(points), tuple(refs), {}, ())


@pytest.mark.parametrize("n, marks", [(5, True), (1, False)])
def test_work_precision_figure_legend_below_and_a_style_per_method(n, marks):
    from leapfrog_planner.experiments.work_precision import LABELS, METHODS, work_precision_figure

    fig = work_precision_figure(_wp_result(n, marks))
    fig.canvas.draw()
    (legend,) = fig.legends
    lb, fb = legend.get_window_extent(), fig.bbox
    axes = [ax for ax in fig.axes if ax.get_visible()]
    assert len(axes) == n
    for ax in axes:
        assert lb.y1 <= ax.get_window_extent().y0 + 1  # below every panel
        assert ax.get_legend() is None
        assert "(s)" in ax.get_ylabel() and "relative cost error" in ax.get_xlabel()
    panels = Bbox.union([ax.get_window_extent() for ax in axes])
    assert lb.x0 < panels.x0 + 0.5 * panels.width < lb.x1  # centred under them, not at the side
    assert fb.x0 - 1 <= lb.x0 and lb.x1 <= fb.x1 + 1 and lb.y0 >= fb.y0 - 1
    # One figure title (the panels' titles name their scenarios), inside the figure.
    assert fig._suptitle.get_text() and "\n" not in fig._suptitle.get_text()
    assert fig._suptitle.get_window_extent().x0 >= fb.x0 - 1
    assert fig._suptitle.get_window_extent().x1 <= fb.x1 + 1
    assert [ax.get_title() for ax in axes] == [f"paper-case-{i + 1}" for i in range(min(n, 4))] + [
        f"general-s1-{i:05d}" for i in range(n - 4)
    ]
    # Every method in the legend, in a colour and a marker no other method has, as drawn.
    texts = [t.get_text() for t in legend.get_texts()]
    assert texts[: len(METHODS)] == [LABELS[m] for m in METHODS]
    handles = legend.legend_handles[: len(METHODS)]
    assert len({to_rgba(h.get_color()) for h in handles}) == len(METHODS)
    assert len({h.get_marker() for h in handles}) == len(METHODS)
    for m, h in zip(METHODS, handles, strict=True):
        (line,) = [line for line in axes[0].lines if line.get_gid() == m]
        assert to_rgba(line.get_color()) == to_rgba(h.get_color())
        assert line.get_marker() == h.get_marker() and dashes(line) == dashes(h)
    # The target line explained; the open marker and the cross only when drawn.
    assert any("1e-6" in t for t in texts)
    assert any("another extremal" in t for t in texts) == marks
    assert any("failed" in t for t in texts) == marks
