"""Figures: what is drawn (artists and their data), files that load back, failed results."""

from __future__ import annotations

import dataclasses
import logging
import os
import warnings

import matplotlib
import matplotlib.image as mpimg
import numpy as np
import pytest
from matplotlib.figure import Figure
from matplotlib.patches import Circle
from matplotlib.quiver import Quiver
from PIL import Image

from leapfrog_planner.planning.planner import plan
from leapfrog_planner.planning.results import PathOutcome, PlanStatus
from leapfrog_planner.planning.scenario import load_scenario
from leapfrog_planner.viz.plots import (
    animate_sweeps,
    plot_controls,
    plot_convergence,
    plot_path,
    save_figure,
)

matplotlib.use("Agg")

CASES = ("paper-case-1", "paper-case-2")


@pytest.fixture(scope="module")
def planned():
    """``{name: (result, scenario)}`` for the paper cases 1 (no obstacles) and 2 (two discs)."""
    out = {}
    for name in CASES:
        result = plan(name, initial_paths=1)
        assert result.success, result.message
        out[name] = (result, load_scenario(name))
    return out


@pytest.fixture(params=CASES)
def case(request, planned):
    return planned[request.param]


@pytest.fixture(scope="module")
def failed(planned):
    result, sc = planned["paper-case-2"]
    bad = dataclasses.replace(
        result, status=PlanStatus.FAILED, trajectory=None, cost=float("nan"), alternatives=()
    )
    return bad, sc


@pytest.fixture(autouse=True)
def quiet(caplog):
    """Nothing here warns or logs (matplotlib logs layout problems as warnings)."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with caplog.at_level(logging.WARNING):
            yield
    assert not [r for r in caplog.records if r.levelno >= logging.WARNING]


def gid(container, name):
    return [a for a in container if a.get_gid() == name]


def headings(ax) -> list[Quiver]:
    return [c for c in gid(ax.collections, "heading") if isinstance(c, Quiver)]


def check_png(path, fig_size_px=None):
    img = mpimg.imread(path)
    assert img.ndim == 3 and img.shape[2] in (3, 4)
    if fig_size_px is not None:
        h, w = fig_size_px
        assert abs(img.shape[0] - h) <= 1 and abs(img.shape[1] - w) <= 1
    assert img.shape[0] > 100 and img.shape[1] > 100
    assert float(img[..., :3].var()) > 0.0
    return img


def px(fig: Figure, dpi=150):
    w, h = fig.get_size_inches()
    return round(h * dpi), round(w * dpi)


def files(folder):
    return sorted(p.name for p in folder.iterdir())


# --------------------------------------------------------------------------- plot_path


@pytest.mark.parametrize("arrows", [9, 4, 1])
def test_plot_path_artists(case, arrows):
    result, sc = case
    ax = plot_path(result, sc, arrows=arrows)
    circles = [p for p in ax.patches if isinstance(p, Circle)]
    assert len(circles) == sc.obstacles.shape[0]
    for c, (cx, cy, r) in zip(circles, sc.obstacles, strict=True):
        assert c.center == pytest.approx((cx, cy)) and c.radius == pytest.approx(r)

    (line,) = gid(ax.lines, "optimal-path")
    np.testing.assert_array_equal(line.get_xdata(), result.trajectory.x[:, 0])
    np.testing.assert_array_equal(line.get_ydata(), result.trajectory.x[:, 1])

    (q,) = headings(ax)
    assert q.N == arrows
    # Arrows sit on the path and point along the heading at evenly spaced interior times.
    tr = result.trajectory
    ts = np.linspace(tr.t[0], tr.t[-1], arrows + 2)[1:-1]
    np.testing.assert_allclose(q.X, np.interp(ts, tr.t, tr.x[:, 0]))
    np.testing.assert_allclose(q.Y, np.interp(ts, tr.t, tr.x[:, 1]))
    np.testing.assert_allclose(np.arctan2(q.V, q.U), np.angle(np.exp(1j * q_theta(tr, ts))))

    ends = gid(ax.collections, "end-heading")
    assert len(ends) == 2
    for quiv, state in zip(ends, (sc.start, sc.goal), strict=True):
        assert (quiv.X[0], quiv.Y[0]) == pytest.approx(tuple(state[:2]))
        assert np.arctan2(quiv.V[0], quiv.U[0]) == pytest.approx(np.angle(np.exp(1j * state[2])))
    (start,) = gid(ax.lines, "start")
    (goal,) = gid(ax.lines, "goal")
    assert start.get_marker() != goal.get_marker()
    assert (start.get_xdata()[0], start.get_ydata()[0]) == pytest.approx(tuple(sc.start[:2]))
    assert (goal.get_xdata()[0], goal.get_ydata()[0]) == pytest.approx(tuple(sc.goal[:2]))

    (initial,) = gid(ax.lines, "initial-junctions")
    np.testing.assert_array_equal(initial.get_xdata(), result.initial_junctions[1][:, 0])
    assert initial.get_linestyle() == "--"

    assert ax.get_aspect() == 1.0
    title = ax.get_title()
    assert title.startswith(sc.name) and f"{result.cost:.6g}" in title and result.method in title


def q_theta(tr, ts):
    return np.interp(ts, tr.t, tr.x[:, 2])


def test_plot_path_options(planned):
    result, sc = planned["paper-case-2"]
    ax = plot_path(result, sc, arrows=0, show_initial=False)
    assert headings(ax) == []
    assert gid(ax.lines, "initial-junctions") == []
    for bad in (-1, 2.5, True):
        with pytest.raises(ValueError, match="arrows"):
            plot_path(result, sc, arrows=bad)
    # A given axes is drawn on and returned; the scenario may be given by name.
    fig = Figure()
    ax0 = fig.add_subplot()
    assert plot_path(result, "paper-case-2", ax0) is ax0
    assert len([p for p in ax0.patches if isinstance(p, Circle)]) == 2


def test_plot_path_lists_alternatives_by_cost(planned):
    result, sc = planned["paper-case-2"]
    alts = (
        PathOutcome("visibility #2", PlanStatus.CONVERGED, 23.215020, 35.7, 14, "converged", 100.0),
        PathOutcome("visibility #3", PlanStatus.FAILED, float("nan"), 40.1, 3, "diverged", 100.0),
    )
    ax = plot_path(dataclasses.replace(result, alternatives=alts), sc)
    texts = [t.get_text() for t in ax.figure.legends[0].get_texts()]
    assert any("23.215" in t and "visibility #2" in t for t in texts)
    assert any("visibility #3" in t and "failed" in t for t in texts)
    # These two carry no path: nothing is drawn for them. The planner's own alternatives carry
    # their extremals, drawn dotted, one line each.
    n_lines = len(ax.lines)
    ax2 = plot_path(dataclasses.replace(result, alternatives=()), sc)
    assert len(ax2.lines) == n_lines
    kept = dataclasses.replace(alts[0], trajectory=result.trajectory)
    ax3 = plot_path(dataclasses.replace(result, alternatives=(kept, alts[1])), sc)
    assert len(ax3.lines) == n_lines + 1
    assert [line.get_linestyle() for line in ax3.lines].count(":") == 1
    ax3 = plot_path(dataclasses.replace(result, alternatives=alts), sc, show_alternatives=False)
    assert not any("23.215" in t.get_text() for t in ax3.figure.legends[0].get_texts())


def test_many_failed_paths_share_one_legend_entry(planned):
    # A long horizon can fail on 16 runs: one entry counts them, the converged one stays.
    result, sc = planned["paper-case-2"]
    ok = PathOutcome("visibility #2", PlanStatus.CONVERGED, 23.215020, 35.7, 14, "converged", 100.0)
    failed = tuple(
        PathOutcome(f"visibility #{k}", PlanStatus.FAILED, float("nan"), 40.1, 3, "diverged", 100.0)
        for k in range(3, 8)
    )
    ax = plot_path(dataclasses.replace(result, alternatives=(ok, *failed)), sc)
    texts = [t.get_text() for t in ax.figure.legends[0].get_texts()]
    assert "5 other paths failed" in texts and any("23.215" in t for t in texts)
    assert not any("visibility #3" in t for t in texts)
    ax = plot_path(dataclasses.replace(result, alternatives=(ok, *failed[:3])), sc)
    texts = [t.get_text() for t in ax.figure.legends[0].get_texts()]
    assert sum("failed" in t for t in texts) == 3  # a few are each named


# --------------------------------------------------------------------------- plot_convergence


def test_plot_convergence(case):
    result, sc = case
    fig = plot_convergence(result, sc)
    ax, ax_cost, ax_jump = fig.axes[:3]
    sweeps = gid(ax.lines, "sweep")
    assert len(sweeps) == len(result.history) > 0
    for line, h in zip(sweeps, result.history, strict=True):
        np.testing.assert_array_equal(line.get_xdata(), h.X[:, 0])
        np.testing.assert_array_equal(line.get_ydata(), h.X[:, 1])
    # Colours go from light to dark with the sweep number.
    lum = [np.mean(matplotlib.colors.to_rgb(line.get_color())) for line in sweeps]
    assert lum[0] > lum[-1] and np.all(np.diff(lum) <= 1e-12)
    assert len([p for p in ax.patches if isinstance(p, Circle)]) == sc.obstacles.shape[0]
    (final,) = gid(ax.lines, "optimal-path")
    np.testing.assert_array_equal(final.get_xdata(), result.trajectory.x[:, 0])

    cost_line = ax_cost.lines[0]
    np.testing.assert_allclose(cost_line.get_ydata()[1:], [h.cost for h in result.history])
    assert cost_line.get_ydata()[0] == pytest.approx(result.initial_cost)
    assert ax_jump.get_yscale() == "log"
    np.testing.assert_allclose(
        ax_jump.lines[0].get_ydata(), [h.max_costate_jump for h in result.history]
    )
    # q changes (8 -> 4 in these runs) are marked in both axes.
    qs = [h.q for h in result.history]
    changes = sum(1 for a, b in zip(qs, qs[1:], strict=False) if a != b)
    assert changes >= 1
    assert sum(t.get_text().startswith("q = ") for t in ax_jump.texts) == changes


# --------------------------------------------------------------------------- plot_controls


def test_plot_controls(case):
    result, _ = case
    fig = plot_controls(result)
    ax_u, ax_l, ax_h = fig.axes[:3]
    tr = result.trajectory
    labels = [line.get_label() for line in ax_u.get_lines() if not line.get_label().startswith("_")]
    assert labels == list(result.control_names)
    for i, line in enumerate(ax_u.get_lines()[: len(labels)]):
        np.testing.assert_array_equal(line.get_ydata(), tr.u[:, i])
    costates = [ln for ln in ax_l.get_lines() if not ln.get_label().startswith("_")]
    assert len(costates) == tr.lam.shape[1]
    np.testing.assert_array_equal(costates[2].get_ydata(), tr.lam[:, 2])
    dH = ax_h.lines[0].get_ydata()
    assert dH[0] == 0.0 and np.max(np.abs(dH)) < 1e-6 * max(1.0, abs(tr.hamiltonian[0]))


# --------------------------------------------------------------------------- files


def test_every_function_writes_a_file(case, tmp_path, capsys):
    result, sc = case
    for name, fig in [
        ("path", plot_path(result, sc).figure),
        ("convergence", plot_convergence(result, sc)),
        ("controls", plot_controls(result)),
    ]:
        size = px(fig)
        out = save_figure(fig, tmp_path / f"{name}.png")
        assert out == tmp_path / f"{name}.png"
        check_png(out, size)
    gif = animate_sweeps(result, sc, tmp_path / "sweeps.gif", fps=5)
    with Image.open(gif) as im:
        assert im.format == "GIF"
        assert im.n_frames >= len(result.history) + 2  # initial, each sweep, final
        assert im.size[0] > 100 and im.size[1] > 100
        im.seek(im.n_frames // 2)
        assert np.asarray(im.convert("L"), dtype=float).var() > 0.0
    assert files(tmp_path) == ["controls.png", "convergence.png", "path.png", "sweeps.gif"]
    out = capsys.readouterr()  # the library never prints
    assert out.out == "" and out.err == ""


def test_save_figure_formats_and_permissions(planned, tmp_path):
    result, sc = planned["paper-case-2"]
    heads = {"pdf": b"%PDF", "svg": b"<?xml", "PNG": b"\x89PNG"}
    for ext, head in heads.items():
        path = save_figure(plot_path(result, sc).figure, tmp_path / f"fig.{ext}")
        assert path.read_bytes().startswith(head)
    mask = os.umask(0o022)
    os.umask(mask)
    for p in tmp_path.iterdir():
        assert p.stat().st_mode & 0o777 == 0o666 & ~mask
    # Overwriting replaces the file and leaves no temporary file behind.
    before = (tmp_path / "fig.svg").read_bytes()
    save_figure(plot_controls(result), tmp_path / "fig.svg")
    assert (tmp_path / "fig.svg").read_bytes() != before
    assert files(tmp_path) == ["fig.PNG", "fig.pdf", "fig.svg"]


@pytest.mark.parametrize("name", ["fig.jpg", "fig", "fig.png.bak"])
def test_save_figure_bad_extension(planned, tmp_path, name):
    result, sc = planned["paper-case-1"]
    fig = plot_path(result, sc).figure
    with pytest.raises(ValueError) as exc:
        save_figure(fig, tmp_path / name)
    assert "\n" not in str(exc.value) and ".png" in str(exc.value)
    assert files(tmp_path) == []
    with pytest.raises(ValueError, match="gif"):
        animate_sweeps(result, sc, tmp_path / "anim.png")
    assert files(tmp_path) == []


def test_failed_write_leaves_nothing(planned, tmp_path, monkeypatch):
    result, sc = planned["paper-case-1"]
    (tmp_path / "keep.png").write_bytes(b"old")
    fig = plot_path(result, sc).figure

    def broken(fname, **kw):
        with open(fname, "wb") as fh:
            fh.write(b"\x89PNG half")
        raise OSError("disk full")

    monkeypatch.setattr(fig, "savefig", broken)
    for name in ("keep.png", "new.png"):
        with pytest.raises(OSError, match="disk full"):
            save_figure(fig, tmp_path / name)
    assert files(tmp_path) == ["keep.png"]
    assert (tmp_path / "keep.png").read_bytes() == b"old"


# --------------------------------------------------------------------------- failed results


def test_failed_result_still_plots(failed, tmp_path):
    result, sc = failed
    ax = plot_path(result, sc)
    assert "failed" in ax.get_title()
    assert gid(ax.lines, "optimal-path") == [] and headings(ax) == []
    assert len([p for p in ax.patches if isinstance(p, Circle)]) == 2
    assert len(gid(ax.lines, "initial-junctions")) == 1
    assert len(gid(ax.lines, "start")) == len(gid(ax.lines, "goal")) == 1
    check_png(save_figure(ax.figure, tmp_path / "path.png"))

    fig = plot_convergence(result, sc)
    assert "failed" in fig.get_suptitle()
    assert len(gid(fig.axes[0].lines, "sweep")) == len(result.history)
    check_png(save_figure(fig, tmp_path / "conv.png"))

    fig = plot_controls(result)
    assert "failed" in fig.get_suptitle()
    assert all(any("no trajectory" in t.get_text() for t in a.texts) for a in fig.axes)
    check_png(save_figure(fig, tmp_path / "controls.png"))

    with Image.open(animate_sweeps(result, sc, tmp_path / "a.gif")) as im:
        # initial, each sweep, the last sweep again with the status; no final path
        assert im.n_frames == len(result.history) + 2


def test_failed_without_sweeps_or_obstacles(failed, planned, tmp_path):
    bare, _ = failed
    _, sc1 = planned["paper-case-1"]  # no obstacles
    for sc in (failed[1], sc1):
        result = dataclasses.replace(bare, history=(), initial_cost=float("nan"))
        ax = plot_path(result, sc)
        assert len([p for p in ax.patches if isinstance(p, Circle)]) == sc.obstacles.shape[0]
        fig = plot_convergence(result, sc)
        assert gid(fig.axes[0].lines, "sweep") == []
        assert any("no sweeps" in t.get_text() for t in fig.axes[1].texts)
        no_path = dataclasses.replace(result, initial_junctions=(None, None))
        plot_path(no_path, sc)
        gif = animate_sweeps(no_path, sc, tmp_path / f"{sc.name}.gif")
        with Image.open(gif) as im:
            assert im.n_frames == 1
    assert sorted(files(tmp_path)) == ["paper-case-1.gif", "paper-case-2.gif"]


def test_save_figure_closes_pyplot_figures(planned, tmp_path):
    import matplotlib.pyplot as plt

    result, sc = planned["paper-case-1"]
    fig = plt.figure()
    ax = plot_path(result, sc, fig.add_subplot())
    assert ax.figure is fig and plt.fignum_exists(fig.number)
    save_figure(fig, tmp_path / "p.png")
    assert not plt.fignum_exists(fig.number)
    check_png(tmp_path / "p.png")


def test_the_hamiltonian_panel_of_a_saved_result_reads_the_integrator_steps(tmp_path):
    """The figure of a result read back from its file titles the Hamiltonian's variation at the
    integrator's own steps, as the result itself reports it (it used every interpolated row:
    3.8e-5 in the title where the file said 6.9e-12)."""
    import matplotlib.pyplot as plt

    from leapfrog_planner.planning.planner import plan
    from leapfrog_planner.planning.results import PlanResult
    from leapfrog_planner.viz.plots import plot_controls

    r = plan("paper-case-4")
    path = tmp_path / "r.json"
    r.save_json(path)
    back = PlanResult.load(path)
    np.testing.assert_array_equal(back.trajectory.at_step, r.trajectory.at_step)
    fig = plot_controls(back)
    title = next(a.get_title() for a in fig.axes if "Hamiltonian" in a.get_title())
    shown = float(title.rsplit("=", 1)[1])
    H = r.trajectory.hamiltonian[r.trajectory.at_step]
    assert shown == pytest.approx(float(np.abs(H - H[0]).max()), rel=0.01)
    assert shown <= 1e-9
    plt.close(fig)


# --------------------------------------------------------------------------- figures for print


def _plot_cli(args) -> int:
    """``leapfrog plot ARGS`` in this process; its exit code."""
    from leapfrog_planner.cli.main import main

    with pytest.raises(SystemExit) as e:
        main(["plot", *map(str, args)])
    return e.value.code


@pytest.fixture(scope="module")
def saved(planned, tmp_path_factory):
    """paper case 2's result as a JSON file."""
    path = tmp_path_factory.mktemp("saved") / "case2.json"
    planned["paper-case-2"][0].save_json(path)
    return path


def test_dpi_sets_the_pixels_of_a_png(planned, saved, tmp_path, capsys):
    result, sc = planned["paper-case-2"]
    fig = plot_path(result, sc).figure
    save_figure(fig, tmp_path / "300.png", dpi=300)
    check_png(tmp_path / "300.png", px(fig, 300))
    for bad in (0, 5, 2.5, 5000):
        with pytest.raises(ValueError, match="dpi"):
            save_figure(plot_path(result, sc), tmp_path / "bad.png", dpi=bad)
    assert files(tmp_path) == ["300.png"]
    # The command: the default stays 150; --dpi 300 doubles each side.
    sizes = {}
    for dpi in (None, 300):
        out = tmp_path / f"cli-{dpi}.png"
        assert _plot_cli([saved, "--out", out] + ([] if dpi is None else ["--dpi", dpi])) == 0
        with Image.open(out) as im:
            sizes[dpi] = im.size
    assert sizes[300] == pytest.approx((2 * sizes[None][0], 2 * sizes[None][1]), abs=1)
    capsys.readouterr()
    assert _plot_cli([saved, "--out", tmp_path / "x.png", "--dpi", "5"]) == 2
    err = capsys.readouterr().err
    assert "--dpi" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "x.png").exists()


def titles(fig):
    fig = fig if isinstance(fig, Figure) else fig.figure
    texts = [ax.get_title(loc=loc) for ax in fig.axes for loc in ("left", "center", "right")]
    return [t for t in [*texts, fig._suptitle and fig._suptitle.get_text()] if t]


def test_no_title(planned, failed, saved, tmp_path, monkeypatch):
    result, sc = planned["paper-case-2"]
    for res in (result, failed[0]):
        assert titles(plot_path(res, sc).figure) and titles(plot_controls(res))
        assert titles(plot_path(res, sc, title=False).figure) == []
        assert titles(plot_controls(res, title=False)) == []
        assert titles(plot_convergence(res, sc, title=False)) == []
    # The command passes --no-title to every figure it draws.
    import leapfrog_planner.viz.plots as plots

    seen = []
    real = plots.save_figure
    monkeypatch.setattr(plots, "save_figure", lambda f, p, **kw: seen.append(f) or real(f, p, **kw))
    args = ["--out", tmp_path / "p.png", "--controls", tmp_path / "c.png"]
    assert _plot_cli([saved, *args, "--convergence", tmp_path / "v.pdf", "--no-title"]) == 0
    assert len(seen) == 3 and all(titles(f) == [] for f in seen)
    seen.clear()
    assert _plot_cli([saved, "--out", tmp_path / "p.png"]) == 0
    assert len(seen) == 1 and titles(seen[0])


def test_pdf_fonts_are_truetype_not_type3(planned, tmp_path):
    result, sc = planned["paper-case-2"]
    save_figure(plot_path(result, sc), tmp_path / "p.pdf")
    save_figure(plot_controls(result), tmp_path / "c.pdf")
    for name in ("p.pdf", "c.pdf"):
        data = (tmp_path / name).read_bytes()
        assert data.startswith(b"%PDF")
        assert b"/Type3" not in data  # matplotlib's default: refused by publishers' checks
        assert b"/FontFile2" in data  # an embedded TrueType font program
    assert matplotlib.rcParams["pdf.fonttype"] == 3  # the setting is the save's alone


def test_waypoints_are_drawn_numbered(tmp_path):
    from leapfrog_planner.planning.scenario import Scenario

    W = [[0.5, 0.25], [1.5, -0.25]]
    sc = Scenario(
        name="wp", horizon=2.0, start=[0, 0, 0], goal=[2, 0, 0], obstacles=[[1.0, 0.0, 0.2]],
        waypoints=W,
    )  # fmt: skip
    result = plan(sc)
    assert result.success, result.message
    ax = plot_path(result, sc)
    (marks,) = gid(ax.lines, "waypoint")
    np.testing.assert_array_equal(np.column_stack(marks.get_data()), W)
    numbers = gid(ax.texts, "waypoint")
    assert [t.get_text() for t in numbers] == ["1", "2"]
    assert [t.xy for t in numbers] == [tuple(w) for w in W]
    assert any("waypoints" in t.get_text() for t in ax.figure.legends[0].get_texts())
    save_figure(ax, tmp_path / "wp.png")
    check_png(tmp_path / "wp.png")
    # Without waypoints, none.
    p2, sc2 = plan("paper-case-1", initial_paths=1), load_scenario("paper-case-1")
    assert gid(plot_path(p2, sc2).lines, "waypoint") == []


def test_colliding_alternatives_are_marked(planned):
    result, sc = planned["paper-case-2"]
    tr = result.trajectory
    ok = PathOutcome("visibility #2", PlanStatus.CONVERGED, 23.2, 35.7, 14, "converged", 100.0)
    bad = PathOutcome("visibility #3", PlanStatus.COLLIDES, 21.5, 40.1, 9, "collides", 100.0)
    alts = (dataclasses.replace(ok, trajectory=tr), dataclasses.replace(bad, trajectory=tr))
    ax = plot_path(dataclasses.replace(result, alternatives=alts), sc)
    (good,) = gid(ax.lines, "alternative")
    (hit,) = gid(ax.lines, "alternative-collides")
    assert hit.get_linestyle() == "--" and good.get_linestyle() != "--"
    assert matplotlib.colors.to_rgb(hit.get_color()) == matplotlib.colors.to_rgb("tab:red")
    assert matplotlib.colors.to_rgb(good.get_color()) != matplotlib.colors.to_rgb("tab:red")
    assert "collides" in hit.get_label() and "visibility #3" in hit.get_label()
    assert "collides" not in good.get_label() and "local optimum" in good.get_label()
    texts = [t.get_text() for t in ax.figure.legends[0].get_texts()]
    assert any("collides" in t and "21.5" in t for t in texts)


def _reversing_first(result, k):
    """``result`` whose robot drives backwards over its first ``k`` samples (v < 0 there)."""
    tr = result.trajectory
    u = np.array(tr.u)
    iv = list(result.control_names).index("v")
    u[:k, iv] = -np.abs(u[:k, iv]) - 0.1
    u[k:, iv] = np.abs(u[k:, iv]) + 0.1
    return dataclasses.replace(result, trajectory=dataclasses.replace(tr, u=u))


def test_a_short_reverse_leg_at_the_start_stays_visible(planned, tmp_path):
    """Paper case 4 reverses over 1 % of the view at the start, under the start marker: the
    markers are hollow, the heading arrows of the ends lie under the path, a dot marks the
    change of direction, and an inset magnifies the stretch."""
    result, sc = planned["paper-case-2"]
    short = _reversing_first(result, 5)
    tr = short.trajectory
    ax = plot_path(short, sc)
    (start,) = gid(ax.lines, "start")
    assert start.get_markerfacecolor() == "none"
    (path,) = gid(ax.lines, "optimal-path")
    assert all(q.get_zorder() < path.get_zorder() for q in gid(ax.collections, "end-heading"))
    (cusp,) = gid(ax.lines, "direction-change")
    np.testing.assert_array_equal(np.column_stack(cusp.get_data()), tr.x[[5], :2])
    (zoom,) = [a for a in ax.child_axes if a.get_gid() == "reversing-zoom"]
    (x0, x1), (y0, y1) = zoom.get_xlim(), zoom.get_ylim()
    stretch = tr.x[:6, :2]
    assert np.all((stretch[:, 0] >= x0) & (stretch[:, 0] <= x1))
    assert np.all((stretch[:, 1] >= y0) & (stretch[:, 1] <= y1))
    assert (x1 - x0) < 0.2 * np.diff(ax.get_xlim())[0]  # magnified
    assert gid(zoom.lines, "reversing") and gid(zoom.lines, "direction-change")
    assert "at the start" in " ".join(t.get_text() for t in zoom.texts)
    save_figure(ax, tmp_path / "short.png")
    check_png(tmp_path / "short.png")
    # On a given axes, the legend inside: the inset keeps off it where there is room.
    fig = Figure(figsize=(9, 7))
    ax = plot_path(short, sc, fig.add_subplot())
    (zoom,) = ax.child_axes
    fig.draw_without_rendering()
    assert not ax.get_legend().get_window_extent().overlaps(zoom.get_window_extent())
    assert len(plot_path(short, sc, Figure(figsize=(4, 3)).add_subplot()).child_axes) == 1
    # A long reverse leg is seen at the figure's scale: no inset; nor without one.
    long = _reversing_first(result, tr.t.size // 2)
    assert gid(plot_path(long, sc).lines, "reversing")
    assert plot_path(long, sc).child_axes == []
    assert plot_path(result, sc).child_axes == []


def test_solve_plot_takes_the_same_figure_options(tmp_path, monkeypatch):
    import leapfrog_planner.viz.plots as plots
    from leapfrog_planner.cli.main import main

    seen = []
    real = plots.save_figure
    monkeypatch.setattr(plots, "save_figure", lambda f, p, **kw: seen.append(f) or real(f, p, **kw))
    out = tmp_path / "p.png"
    with pytest.raises(SystemExit) as e:
        main(["solve", "paper-case-1", "--plot", str(out), "--dpi", "50", "--no-title", "--quiet"])
    assert e.value.code == 0
    with Image.open(out) as im:
        assert im.size[0] == round(6.4 * 50)  # a path figure is 6.4 inches wide
    assert len(seen) == 1 and titles(seen[0]) == []


def test_a_result_that_collides_says_so(planned):
    """When every extremal found passes through an obstacle, the path drawn is no optimal path:
    its legend entry and the title say that it collides."""
    result, sc = planned["paper-case-2"]
    ax = plot_path(dataclasses.replace(result, status=PlanStatus.COLLIDES), sc)
    (path,) = gid(ax.lines, "optimal-path")
    assert "collides" in path.get_label() and "optimal" not in path.get_label()
    assert "collides" in ax.get_title()
    assert "collides" not in plot_path(result, sc).get_title()


def test_a_failed_result_is_not_drawn_as_an_optimal_path(planned, tmp_path):
    """A failed result that returns a motion (a Leapfrog iterate, an initial path) says it is
    failed and draws that motion as what it is, not optimal: never "optimal path"."""
    result, sc = planned["paper-case-2"]
    source = "Leapfrog iterate (q = 2), not optimal"
    bad = dataclasses.replace(
        result, status=PlanStatus.FAILED, optimal=False, trajectory_source=source
    )
    ax = plot_path(bad, sc)
    (path,) = gid(ax.lines, "optimal-path")
    assert "optimal path" not in path.get_label() and source in path.get_label()
    assert "failed" in ax.get_title() and "not optimal" in ax.get_title()
    fig = plot_convergence(bad, sc)
    assert "failed" in fig.get_suptitle() and "not optimal" in fig.get_suptitle()
    (final,) = gid(fig.axes[0].lines, "optimal-path")
    assert "optimal path" not in final.get_label() and source in final.get_label()
    assert "failed" in plot_controls(bad).get_suptitle()
    # an extremal of a fixed horizon (free final time, the condition not met): not optimal
    extremal = dataclasses.replace(bad, trajectory_source="extremal")
    (path,) = gid(plot_path(extremal, sc).lines, "optimal-path")
    assert path.get_label().startswith("returned extremal, not optimal")
    # every extremal collides: the collision-free motion returned is what its source says
    collides = dataclasses.replace(bad, status=PlanStatus.COLLIDES)
    ax = plot_path(collides, sc)
    (path,) = gid(ax.lines, "optimal-path")
    assert source in path.get_label() and "not optimal" in ax.get_title()
    assert "optimal path" not in plot_path(result, sc).get_title()  # converged: as before
    assert gid(plot_path(result, sc).lines, "optimal-path")[0].get_label().startswith("optimal")


def test_free_final_time_costs_are_drawn_with_the_time_term(planned):
    """With a free final time the result's cost includes the price of time k T; the initial
    path's and the sweeps' costs drawn beside it include it too (each at its own horizon), and
    the labels say so."""
    from leapfrog_planner.planning.status import FreeTimeReport

    result, sc = planned["paper-case-2"]
    k, T = 0.5, float(result.history[-1].t[-1])
    free = dataclasses.replace(
        result, cost=result.cost + k * T, free_time=FreeTimeReport(k, None, T, 0.0, "", ())
    )
    fig = plot_convergence(free, sc)
    ax_cost = fig.axes[1]
    costs = ax_cost.lines[0].get_ydata()
    np.testing.assert_allclose(costs[1:], [h.cost + k * h.t[-1] for h in result.history])
    assert costs[0] == pytest.approx(result.initial_cost + k * T)
    assert costs[-1] == pytest.approx(free.cost, rel=1e-3)  # the last sweep meets the final J
    assert "incl. time k T" in ax_cost.get_ylabel()
    labels = [line.get_label() for line in plot_path(free, sc).lines]
    (initial,) = [s for s in labels if s.startswith("initial path")]
    assert f"J = {result.initial_cost + k * T:.6g} incl. time k T = {k * T:.3g}" in initial
    (path,) = [s for s in labels if s.startswith("optimal path")]
    assert f"J = {free.cost:.6g} incl. time k T = {k * T:.3g}" in path


def test_start_and_goal_not_connected_draw_the_scene_and_no_path(tmp_path):
    """Walls keep start and goal apart: no motion, no initial path. The figure draws the walls
    and the ends, no line from start to goal through the wall, and says why in the title."""
    from tests.test_cli import ENCLOSED

    from leapfrog_planner.planning.scenario import load_scenario_text

    sc = load_scenario_text(ENCLOSED)
    result = plan(sc)
    assert result.status is PlanStatus.FAILED and result.trajectory is None
    ax = plot_path(result, sc)
    assert "no path joins start and goal" in ax.get_title()
    assert gid(ax.lines, "initial-junctions") == [] and gid(ax.lines, "optimal-path") == []
    assert "walls" in [p.get_label() for p in ax.patches]
    assert "no path joins start and goal" in plot_convergence(result, sc).get_suptitle()
    check_png(save_figure(ax.figure, tmp_path / "enclosed.png"))


def test_the_other_paths_list_each_extremal_once_and_never_the_answer(planned):
    """Several initial paths can converge to one extremal: the answer's found again from another
    path is not another path, and one found from two paths is listed once (figure and table).
    A mirror image of the answer, as cheap but metres away, is another path."""
    from rich.console import Console

    from leapfrog_planner.cli.solve import _summary

    result, sc = planned["paper-case-2"]
    tr = result.trajectory

    def outcome(label, trajectory, cost=result.cost):
        return PathOutcome(
            label, PlanStatus.CONVERGED, cost, 30.0, 9, "converged", 100.0, trajectory
        )

    mirror = dataclasses.replace(tr, x=tr.x * np.array([1.0, -1.0, -1.0]))
    other = dataclasses.replace(tr, x=tr.x + np.array([0.0, 0.3, 0.0]))
    alts = (
        outcome("visibility #1, turn in place at goal", tr, result.cost * (1 + 1e-12)),
        outcome("visibility #3", other, 30.5),
        outcome("visibility #3, margin 0.1", other, 30.5),
        outcome("mirror", mirror),
    )
    shown = dataclasses.replace(result, alternatives=alts)
    ax = plot_path(shown, sc)
    texts = [t.get_text() for t in ax.figure.legends[0].get_texts()]
    assert not any("turn in place at goal" in t or "margin 0.1" in t for t in texts), texts
    assert sum("visibility #3" in t for t in texts) == 1 and any("mirror" in t for t in texts)
    assert len(gid(ax.lines, "alternative")) == 2
    console = Console(width=200, record=True)
    console.print(_summary(shown))
    table = console.export_text()
    assert "turn in place at goal" not in table and "margin 0.1" not in table
    assert table.count("other path visibility #3") == 1 and "other path mirror" in table
