"""Units of time: the horizon enters the problem only through ``W T^2``, and the planner
converges on one layout from T = 0.1 to T = 100.

For a control-affine model with a quadratic control cost, ``t = T s`` and ``u = u~ / T`` turn
``int_0^T (|u|^2 / 2 + P) dt`` into ``(1 / T) int_0^1 (|u~|^2 / 2 + T^2 P) ds``: the problem at
horizon ``T`` and weight ``W`` is the problem at horizon 1 and weight ``W T^2``, with the same
path and ``1 / T`` times the cost.
"""

import math
import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from leapfrog_planner import plan
from leapfrog_planner.planning.path_ranking import penalty_margin
from leapfrog_planner.planning.planner import Planner
from leapfrog_planner.planning.scenario import load_scenario

DATA = Path(__file__).parent / "data"


@pytest.mark.parametrize("T", [0.5, 3.0])
def test_horizon_is_weight_times_T_squared(T):
    """Time scaled by T is the weight scaled by T^2: the same cost (over T) and the same route.
    Paper case 1 has two routes of equal cost (one turns up first, one down) that several
    initial paths reach (the straight one, three-point turns): round-off picks either, so the
    unit-time route compared is the closest of those its initial paths lead to."""
    sc = load_scenario("paper-case-1")
    long = plan(replace(sc, horizon=T))
    unit = plan(replace(sc, horizon=1.0, weight=sc.weight * T * T))
    assert long.success and unit.success
    assert long.cost == pytest.approx(unit.cost / T, rel=1e-8)
    planner = Planner(replace(sc, horizon=1.0, weight=sc.weight * T * T))
    first, extra = planner.path_selection()
    s = np.linspace(0.0, 1.0, 41)
    want = np.column_stack([np.interp(s * T, long.trajectory.t, long.trajectory.x[:, k])
                            for k in range(3)])  # fmt: skip
    gaps = []
    for path in first + extra:
        run = planner.run_path(path)
        if run.clear and run.validation.cost == pytest.approx(long.cost * T, rel=1e-8):
            tr = run.validation.trajectory
            got = np.column_stack([np.interp(s, tr.t, tr.x[:, k]) for k in range(3)])
            gaps.append(np.abs(got - want).max())
    assert gaps and min(gaps) < 1e-3  # linear interpolation of 1001 samples


@pytest.mark.parametrize("name", ["units-a", "units-b"])
@pytest.mark.parametrize("T", [0.1, 1.0, 10.0, 100.0])
def test_same_layout_converges_from_tenth_to_hundred(name, T):
    """units-a needs the obstacle weight raised 64-fold at T = 0.1 (the penalty is 100 times
    weaker against the control energy); units-b needs the penalty-aware margin at T = 100."""
    sc = replace(load_scenario(DATA / f"{name}.toml"), horizon=T)
    r = plan(sc)
    assert r.success, r.message
    assert r.min_clearance >= 0.0


def test_penalty_margin_grows_with_the_horizon():
    sc = load_scenario(DATA / "units-b.toml")
    margins = [penalty_margin(replace(sc, horizon=T)) for T in (0.01, 1.0, 10.0, 100.0)]
    assert margins[0] == 0.0  # the penalty never exceeds the energy of so fast a drive
    assert margins[1] < margins[2] < margins[3]
    r = float(np.mean(sc.obstacles[:, 2]))
    assert margins[3] < r  # ln(W / e)^(1/4) < 2 for any sane weight and horizon
    assert penalty_margin(replace(sc, obstacles=np.zeros((0, 3)))) == 0.0
    assert penalty_margin(replace(sc, weight=0.0)) == 0.0


def _layout(name: str, horizon: float):
    from leapfrog_planner.batch.generate import GeneratorSpec, generate

    (sc,) = [s for s in generate(GeneratorSpec(n=40, seed=1)) if s.name == name]
    return replace(sc, horizon=horizon)


def test_penalty_timing_hurries_where_the_penalty_is_high():
    """Beltrami's identity on the path's own geometry: v^2 / 2 - P is constant along it, the
    whole path takes the horizon, start and goal stay where they are."""
    from leapfrog_planner.planning.path_ranking import penalty_timed
    from leapfrog_planner.planning.planner import Planner

    sc = _layout("random-s1-00030", 100.0)  # its start lies 1.43 radii from an obstacle's centre
    pl = Planner(sc)
    path = pl.initial_paths()[0]
    timed = penalty_timed(pl.problem, path, sc.horizon)
    assert timed.label.endswith("penalty-timed") and timed.signature == path.signature
    s = np.linspace(0.0, 1.0, 4001)
    xy, th = timed.curve(s)
    np.testing.assert_allclose(xy[[0, -1]], path.curve([0.0, 1.0])[0], atol=1e-12)
    plane = np.hypot(*np.diff(xy, axis=0).T)
    step = np.where(plane > 1e-9 * plane.sum(), plane, np.abs(np.diff(th)))  # drive or turn
    v = step / (np.diff(s) * sc.horizon)  # the speed in the unicycle's metric
    c = 0.5 * v**2 - pl.problem.penalty(0.5 * (xy[1:] + xy[:-1]))
    # constant but where the speed changes within a sample (measured: 99% within 1e-4)
    assert np.quantile(np.abs(c - np.median(c)), 0.95) <= 1e-3 * np.median(0.5 * v**2)
    # Out of the penalty's grip fast: at the start several times its typical speed (9.2 times
    # on this first path, whose whole turn the goal heading asks for is made in its turn in
    # place; 12 times when it was spread along the drive, a slower path).
    assert v[:4].mean() > 5.0 * np.median(v)


@pytest.mark.parametrize("name", ["random-s1-00018", "random-s1-00030"])
def test_a_start_in_the_penalty_grip_converges_at_a_long_horizon(name):
    """T = 100 (the penalty 1e4 times stronger against the control energy than at T = 1) and a
    start within 1.6 radii of an obstacle's centre: no initial path at constant speed gave an
    extremal; timed by the penalty, one does."""
    r = plan(_layout(name, 100.0))
    assert r.success, r.message
    assert r.min_clearance >= 0.0


def test_a_failure_at_a_long_horizon_hands_back_the_cheapest_path():
    """A layout that still fails at T = 100: what comes back is the cheapest initial path as
    timed, here one timed by the penalty (cost 3.27), not the first path at constant speed,
    which sat in the penalty's grip (90.26)."""
    r = plan(_layout("random-s1-00032", 100.0))
    assert not r.success and r.trajectory_source == "initial path, not optimal"
    assert r.cost < 4.0  # (a path timed by the penalty: at constant speed, 90.26)
    assert r.min_clearance >= 0.0


def test_a_cheaper_collision_free_iterate_is_reported_with_a_converged_extremal():
    """Default layout 15 of seed 1 at T = 100. With multiple shooting's arcs refined only once
    (4 and 8 arcs) the run that converges ends on an extremal of 0.2110, not the optimum:
    another path's last Leapfrog iterate, collision-free but not an extremal, costs 0.0934. The
    result stays converged (it is a validated extremal), and its message says that a cheaper
    optimum exists and what it costs. With the default refinements (16 arcs too) that path's
    run converges to the optimum itself, which IPOPT, independently, finds too."""
    from rich.console import Console

    from leapfrog_planner.batch.generate import GeneratorSpec, generate_one
    from leapfrog_planner.cli.solve import _summary
    from leapfrog_planner.planning.direct import solve_direct

    sc = generate_one(GeneratorSpec(n=40, seed=1, horizon=100.0), 15)
    r = plan(sc, final_refinements=1, finer_doublings=0)  # (q = 16 would find the optimum)
    assert r.success and r.optimal
    match = re.search(
        r"a collision-free motion that is not an extremal .* costing (\S+), less", r.message
    )
    assert match, r.message
    assert "a cheaper optimum exists that no run converged to" in r.message
    iterate = float(match.group(1))
    assert iterate < 0.5 * r.cost
    ipopt = solve_direct(sc.start, sc.goal, sc.horizon, sc.obstacles, weight=sc.weight)
    assert ipopt.success and ipopt.cost < 0.5 * r.cost
    assert iterate == pytest.approx(ipopt.cost, rel=1e-2)
    assert r.cheaper_motion == pytest.approx(iterate, rel=1e-5)  # the same figure, a number
    console = Console(width=200, record=True)
    console.print(_summary(r))  # what `leapfrog solve` shows: a warning row
    text = " ".join(console.export_text().replace("│", " ").split())  # (rows wrap)
    assert "warning" in text and "a cheaper optimum exists" in text

    best = plan(sc)
    assert best.success and best.optimal and math.isnan(best.cheaper_motion)
    assert best.cost == pytest.approx(ipopt.cost, rel=1e-2)
    assert best.cost < iterate  # the extremal, where the iterate was not one


def test_where_the_penalty_dominates_the_optimum_is_found():
    """Default layout 14 of seed 1 at T = 10: followed at their own pace, the paths at the
    robot's margin are estimated at 8.2 or more, 8.7 times the extremal found from them
    (0.9448): near the obstacles the penalty dominates. The paths at the penalty's own distance
    that start cheaper run too (the search's ``wider margin`` stage), and the plan converges to
    0.5363, the optimum that IPOPT, independently, finds."""
    from leapfrog_planner.batch.generate import GeneratorSpec, generate_one
    from leapfrog_planner.planning.direct import solve_direct

    sc = generate_one(GeneratorSpec(n=40, seed=1, horizon=10.0), 14)
    r = plan(sc)
    assert r.success and r.optimal and r.min_clearance >= 0.0
    ipopt = solve_direct(sc.start, sc.goal, sc.horizon, sc.obstacles, weight=sc.weight)
    assert ipopt.success and r.cost == pytest.approx(ipopt.cost, rel=1e-3)


def test_a_three_point_turn_backs_away_from_the_obstacle_next_to_the_start():
    """Default layout 30 of seed 1 at T = 10: the start lies 0.08 from a disc of radius 0.2 with
    the robot's heading towards it. No heading points away from any path, yet the optimum backs
    away first, turns at a cusp and drives on (IPOPT, independently: 0.3254 on 100 intervals).
    The three-point turn runs besides the ranked paths and converges to it; the ranked paths
    alone ended on 0.6285, on the wrong side of a small disc. One round: the finer one that
    follows (the answer comes from a three-point turn alone) finds the same optimum, and doubles
    the test's time (tests/test_search.py checks the finer rounds)."""
    from leapfrog_planner.batch.generate import GeneratorSpec, generate_one
    from leapfrog_planner.planning.direct import solve_direct

    sc = generate_one(GeneratorSpec(n=40, seed=1, horizon=10.0), 30)
    r = plan(sc, finer_doublings=0)
    assert r.success and r.optimal and r.min_clearance >= 0.0
    ipopt = solve_direct(sc.start, sc.goal, sc.horizon, sc.obstacles, weight=sc.weight)
    assert ipopt.success and r.cost <= ipopt.cost
    assert r.cost < 0.6 * 0.6285


def test_the_penalty_of_a_quick_dash_is_integrated_over_the_integrators_steps():
    """Default layout 4 of seed 2 at T = 100 ends its motion with a dash of about 0.1 s near an
    obstacle. Simpson's rule on the 1,001 uniform samples (0.1 s apart) put the penalty at 0.1765,
    more than the whole cost (0.1628), and the energy below zero; the integrator's own steps
    resolve the dash. One round each (the finer round finds the same optimum, in twice the
    time)."""
    from leapfrog_planner.batch.generate import GeneratorSpec, generate_one

    sc = generate_one(GeneratorSpec(n=40, seed=2, horizon=100.0), 4)
    r = plan(sc, finer_doublings=0)
    assert r.success and r.energy > 0.0 and r.penalty > 0.0
    assert r.energy + r.penalty == pytest.approx(r.cost, rel=1e-12)
    fine = plan(sc, samples=20001, finer_doublings=0)
    assert fine.cost == pytest.approx(r.cost, rel=1e-9)
    assert r.penalty == pytest.approx(fine.penalty, rel=1e-2)


def test_a_long_horizon_in_the_penalty_s_grip_converges_no_dearer_than_before():
    """Default layout 10 of seed 1 at T = 100: with q = 8 the paths of the homotopy classes at
    the robot's margin lead to no extremal (an end in the penalty's grip). The search goes on
    (wider margins, paths timed by the penalty, twice the partitions) to a collision-free
    extremal no dearer than the 1.3367 it gave before (IPOPT, on 200 intervals: 1.14; the
    cheapest motion any run has seen here costs 0.4710). Which stage finds it depends on the
    round-off of the machine (tests/test_search.py checks the stages themselves)."""
    sc = _layout("random-s1-00010", 100.0)
    r = plan(sc)
    assert r.success and r.optimal and r.min_clearance >= 0.0, r.message
    assert r.cost <= 1.3367
    assert math.isnan(r.cheaper_motion) or r.cheaper_motion < r.cost
    assert len(r.search) > 3  # more than the first three paths ran


def test_no_cheaper_iterate_is_claimed_where_the_extremal_is_the_optimum():
    r = plan("paper-case-3")
    assert "cheaper optimum" not in r.message and math.isnan(r.cheaper_motion)
