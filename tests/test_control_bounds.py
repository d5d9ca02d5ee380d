"""Bounds on the controls (``[robot] v = [min, max]``): the smooth saturation, the scenario
keys, and plans that match the direct method with the same box constraints."""

from __future__ import annotations

import dataclasses
import re

import numpy as np
import pytest

from leapfrog_planner.batch.generate import GeneratorSpec, generate
from leapfrog_planner.errors import ScenarioError
from leapfrog_planner.model.bounds import saturate
from leapfrog_planner.planning.bounded import exceeded
from leapfrog_planner.planning.planner import plan
from leapfrog_planner.planning.scenario import load_scenario, load_scenario_text

pytest.importorskip("casadi")
from leapfrog_planner.planning.direct import richardson, solve_direct  # noqa: E402


def test_the_smooth_clip_is_the_identity_inside_and_the_bound_outside():
    lo, hi = -1.0, 2.0
    s = np.linspace(-10, 10, 20001)
    for eps in (0.3, 0.01, 1e-4):
        u, slope = np.array([saturate(x, lo, hi, 1.0, eps) for x in s]).T
        assert np.all(np.diff(u) > 0)  # strictly increasing: a unique minimiser
        h = 1e-3 * eps  # the slope is the derivative (central differences)
        up = np.array([saturate(x + h, lo, hi, 1.0, eps)[0] for x in s[::97]])
        down = np.array([saturate(x - h, lo, hi, 1.0, eps)[0] for x in s[::97]])
        fd = (up - down) / (2 * h)
        np.testing.assert_allclose(slope[::97], fd, rtol=1e-5, atol=1e-7)
        assert u.max() <= hi + eps**2 / (4 * (hi - lo)) + 1e-15
        assert u.min() >= lo - eps**2 / (4 * (hi - lo)) - 1e-15
        inside = (s > lo + 10 * eps) & (s < hi - 10 * eps)
        np.testing.assert_allclose(u[inside], s[inside], atol=eps)
        np.testing.assert_allclose(u[s > hi + 100 * eps], hi, atol=eps / 100)
    # Switched off, the control is the unconstrained one exactly, with slope 1.
    assert all(saturate(x, lo, hi, 0.0, 0.3) == (x, 1.0) for x in s[::500])


ROOM = """horizon = 1.0
start = [0.0, 0.0, 0.0]
goal = [2.0, 0.0, 0.0]
[robot]
v = [0.0, 3.0]
omega = [-4, 4]
[[obstacles]]
center = [1.0, 0.1]
radius = 0.2
"""


def test_bounds_are_read_written_and_checked():
    sc = load_scenario_text(ROOM, "room.toml")
    assert sc.control_bounds == {"v": (0.0, 3.0), "omega": (-4.0, 4.0)}
    assert load_scenario_text(sc.to_toml()) == sc
    bad = {
        "v = [1, 1]": r"room\.toml: robot\.v: expected \[min, max\] with min < max",
        "v = [3.0, 0.0]": r"robot\.v: expected \[min, max\] with min < max",
        "v = [0.0]": r"robot\.v: expected 2 numbers",
        "v = [0.0, inf]": r"robot\.v\[1\]: must be finite",
    }
    for line, message in bad.items():
        with pytest.raises(ScenarioError, match=message):
            load_scenario_text(ROOM.replace("v = [0.0, 3.0]", line), "room.toml")
    with pytest.raises(ScenarioError, match="unknown key"):
        load_scenario_text(ROOM.replace("omega = [-4, 4]", "sigma = [-4, 4]"))


def _direct(sc, bounds):
    """The bounded direct method on meshes of 100 and 200 intervals, extrapolated."""
    from leapfrog_planner.planning.planner import Planner

    s = np.linspace(0.0, 1.0, 201)
    guesses = [np.column_stack(p.curve(s)) for p in Planner(sc).initial_paths()]
    box = (bounds.get("v"), bounds.get("omega"))
    args = (sc.start, sc.goal, sc.horizon, sc.obstacles)
    coarse = solve_direct(
        *args, intervals=100, guesses=[g[::2] for g in guesses], control_bounds=box
    )
    fine = solve_direct(*args, intervals=200, guesses=guesses, control_bounds=box)
    assert coarse.success and fine.success
    return richardson(coarse.cost, fine.cost)


@pytest.mark.parametrize("case", [1, 2, 3, 4])
def test_a_robot_that_never_reverses_matches_the_bounded_direct_method(case):
    """v in [0, 6]: paper case 1's optimum reversed on 30% of its samples; bounded, it drives
    forwards only. The cost matches IPOPT with the same bounds (Richardson-extrapolated) to
    1e-5, and no control leaves its bounds by more than 1e-6."""
    bounds = {"v": (0.0, 6.0)}
    sc = dataclasses.replace(load_scenario(f"paper-case-{case}"), control_bounds=bounds)
    r = plan(sc, threads=1)
    assert r.success, r.message
    assert "saturated sharply" in r.message
    v = r.trajectory.u[:, 0]
    assert v.min() >= -1e-6 and v.max() <= 6.0 + 1e-6
    assert abs(r.cost - _direct(sc, bounds)) <= 1e-5 * r.cost


@pytest.mark.parametrize("case, w", [(1, 4.0), (2, 3.0), (3, 2.5), (4, 2.5)])
def test_speed_and_turn_rate_bounds_match_the_bounded_direct_method(case, w):
    """v in [0, 6] and |omega| <= w, each chosen so that the turn-rate bound is active (the free
    optima turn at up to 4.54, 4.16, 2.51 and 2.94): the cost matches IPOPT with the same box
    to 1e-5, the turn rate rides its bound, and no control leaves its bounds by 1e-6."""
    bounds = {"v": (0.0, 6.0), "omega": (-w, w)}
    sc = dataclasses.replace(load_scenario(f"paper-case-{case}"), control_bounds=bounds)
    r = plan(sc, threads=1)
    assert r.success, r.message
    v, omega = r.trajectory.u[:, 0], r.trajectory.u[:, 1]
    assert v.min() >= -1e-6 and v.max() <= 6.0 + 1e-6
    assert np.abs(omega).max() <= w + 1e-6
    assert np.abs(omega).max() >= w - 1e-3  # active
    assert abs(r.cost - _direct(sc, bounds)) <= 1e-5 * r.cost


def test_the_continuation_to_the_bounds_halves_its_step_after_a_short_line_search(monkeypatch):
    """The continuation to bounded controls solves each smoothing width with the final solves'
    tolerances and MNM's line search stopped at 2^-3 (a failed step is halved sooner: 120
    bounded layouts gave the same answers in 33 to 37% less time); the car's assist keeps the
    final solves' own 2^-20."""
    from leapfrog_planner.planning import runner
    from leapfrog_planner.planning.leapfrog import LeapfrogSettings
    from leapfrog_planner.roots import ModifiedNewtonStep

    lf = LeapfrogSettings()
    bounded = lf.bounds_solves()
    assert (bounded.root, bounded.integrator) == (
        lf.final_shooting.root,
        lf.final_shooting.integrator,
    )
    assert bounded.method == ModifiedNewtonStep(max_halvings=3)
    seen = []
    original = runner.continue_to_bounds

    def recorded(at, run, t, ends, steps, settings, deadline):
        seen.append(settings.method)
        return original(at, run, t, ends, steps, settings, deadline)

    monkeypatch.setattr(runner, "continue_to_bounds", recorded)
    sc = load_scenario("paper-case-1")
    r = plan(dataclasses.replace(sc, control_bounds={"v": (0.0, 3.0)}), initial_paths=1)
    assert r.status.value == "converged"
    assert seen and all(m == ModifiedNewtonStep(max_halvings=3) for m in seen)


def test_a_turn_rate_too_low_for_the_task_fails_honestly():
    """Paper case 1 with v in [0, 6] and |omega| <= 3 is barely feasible: the robot must turn in
    place at the bound, cross at top speed and turn again; IPOPT with the same box stops short
    of its tolerance too (cost 10.526). The planner says it failed and hands back the motion it
    computed from start to goal, which turns faster than the bounds allow, and says so. (It had
    integrated that iterate, planned with the turn rate relaxed, under the bounds: a "motion"
    within them that jumped by 0.45 between samples and ended 0.45 from the goal.)"""
    bounds = {"v": (0.0, 6.0), "omega": (-3.0, 3.0)}
    sc = dataclasses.replace(load_scenario("paper-case-1"), control_bounds=bounds)
    r = plan(sc, threads=1)
    assert not r.success and str(r.status) == "failed"
    assert "continuation to the problem itself stopped" in r.message
    assert not r.optimal
    x, v, omega = r.trajectory.x, r.trajectory.u[:, 0], r.trajectory.u[:, 1]
    assert np.linalg.norm(x[-1] - sc.goal) < 1e-5 and np.abs(np.diff(x, axis=0)).max() < 0.05
    assert v.min() >= -1e-6 and v.max() <= 6.0 + 1e-6 and 3.0 < np.abs(omega).max() < 5.0
    assert "omega from -4.8 to 4.82 (the robot's -3 to 3)" in r.trajectory_source
    assert r.trajectory_source.endswith("not a motion the robot can make")


def test_only_the_bounds_the_initial_path_leaves_are_relaxed():
    u = np.array([[1.0, -5.0], [2.0, 13.0]])  # v within [0, 3], omega beyond +-4
    bounds = {"v": (0.0, 3.0), "omega": (-4.0, 4.0)}
    assert exceeded(bounds, ("v", "omega"), u) == ("omega",)
    assert exceeded(bounds, ("v", "omega"), np.clip(u, -3.0, 3.0)) == ("v", "omega")  # none: all


def test_a_relaxed_turn_rate_keeps_the_forward_only_class():
    """A random layout whose initial paths turn at up to 13-27 rad/s, within v in [0, 3]: with
    both bounds relaxed, the cheapest class's continuation folded at 86% and the plan returned
    a dearer optimum (6.32424); with the turn rate alone relaxed it finds IPOPT's 4.82898."""
    (base,) = [s for s in generate(GeneratorSpec(n=10, seed=11)) if s.name.endswith("00009")]
    bounds = {"v": (0.0, 3.0), "omega": (-4.0, 4.0)}
    sc = dataclasses.replace(base, control_bounds=bounds)
    r = plan(sc, threads=1)
    assert r.success, r.message
    assert abs(r.cost - _direct(sc, bounds)) <= 1e-4 * r.cost


def test_bounds_far_outside_the_optimum_change_nothing():
    free = plan("paper-case-4", threads=1)
    wide = dataclasses.replace(load_scenario("paper-case-4"), control_bounds={"v": (-50, 50)})
    r = plan(wide, threads=1)
    assert r.success and abs(r.cost - free.cost) <= 1e-8 * free.cost


def test_a_failed_plan_hands_back_a_motion_to_the_goal_and_says_what_it_breaks():
    """A forward-only robot (v in [0, 6]) with its goal close behind (headings in every
    direction, seed 4, layout 34): no extremal. Runs whose initial segments failed ran again
    with v's bounds relaxed, and such a run's iterate (reversing at up to 2.7) was integrated
    with the flow of the robot's own bounds: the motion handed back jumped by up to 0.57
    between samples and ended 0.62 from the goal. Each iterate is now integrated with its own
    problem; none is a motion the robot can make, nor is the cheapest initial path followed as
    timed (it drives at up to 7.6), so the iterate is handed back, and its source says why.
    One round (a failed plan's finer round fails too, in twice the time)."""
    spec = GeneratorSpec(n=35, seed=4, heading_spread=3.14159, min_distance=0.3)
    (base,) = [s for s in generate(spec) if s.name.endswith("00034")]
    sc = dataclasses.replace(base, control_bounds={"v": (0.0, 6.0)})
    r = plan(sc, finer_doublings=0)
    assert str(r.status) == "failed" and not r.optimal
    x = r.trajectory.x
    assert np.linalg.norm(x[-1] - sc.goal) < 1e-5 and np.abs(np.diff(x, axis=0)).max() < 0.05
    assert r.trajectory_source.endswith("not a motion the robot can make")
    found = re.search(r"v from (\S+) to (\S+) \(the robot's 0 to 6\)", r.trajectory_source)
    assert found and float(found[1]) < float(found[2]) < 0.0  # it reverses all the way
    assert r.message.endswith(f"returned: the {r.trajectory_source}")


def test_a_speed_too_low_for_every_path_fails_honestly():
    """Paper case 2's goal is 4.95 away, and every path around its obstacles is longer than 5
    (5.23 the shortest): with T = 1 and v <= 5 the planner runs and fails, saying so; with
    v <= 4 not even the straight line can be driven, and the task is refused before planning.
    One round (a failed plan's finer round fails too, in twice the time)."""
    base = load_scenario("paper-case-2")
    r = plan(
        dataclasses.replace(base, control_bounds={"v": (0.0, 5.0)}), threads=1, finer_doublings=0
    )
    assert not r.success and str(r.status) == "failed"
    with pytest.raises(ScenarioError, match="it takes at least 1.23744 s, longer than T = 1"):
        plan(dataclasses.replace(base, control_bounds={"v": (0.0, 4.0)}))


def _general(name: str):
    (base,) = [
        s for s in generate(GeneratorSpec.preset("general", n=50, seed=11)) if s.name == name
    ]
    return base


def test_a_robot_that_cannot_reverse_is_given_only_paths_it_can_drive():
    """The goal lies behind the robot: a free robot is offered reverse legs and three-point
    turns, one with ``v = [0, vmax]`` only paths driven forwards (with turns in place)."""
    from leapfrog_planner.planning.path_ranking import drivable
    from leapfrog_planner.planning.planner import Planner

    base = _general("general-s11-00013")
    free = Planner(base, initial_paths=12).initial_paths()  # every variant
    assert any(p.modes.reverse or p.modes.cusp for p in free)
    bounded = Planner(dataclasses.replace(base, control_bounds={"v": (0.0, 8.0)})).initial_paths()
    assert bounded and not any(p.modes.reverse or p.modes.cusp for p in bounded)
    planner = Planner(base)
    ends = (base.start, base.goal)
    backwards = [p for p in free if p.modes.reverse and not p.modes.cusp]
    forwards = [p for p in free if not (p.modes.reverse or p.modes.cusp)]
    assert backwards and forwards
    args = (planner.problem, backwards + forwards, base.horizon)
    keep = drivable(*args, {"v": (0.0, 8.0)}, ends)
    assert keep == [False] * len(backwards) + [True] * len(forwards)
    assert drivable(*args, {"v": (-8.0, 0.0)}, ends) == [True] * len(backwards) + [False] * len(
        forwards
    )
    assert all(drivable(*args, {"v": (-8.0, 8.0)}, ends))


def test_headings_in_every_direction_find_the_bounded_optimum():
    """A layout with the goal behind the robot, ``v = [0, 8]``, ``|omega| <= 6``: from a
    three-point turn relaxed to reverse, the continuation to the bounds ended on an extremal of
    cost 31.01; from the forward paths the plan finds IPOPT's 6.60."""
    bounds = {"v": (0.0, 8.0), "omega": (-6.0, 6.0)}
    sc = dataclasses.replace(_general("general-s11-00013"), control_bounds=bounds)
    r = plan(sc, threads=1)
    assert r.success, r.message
    assert abs(r.cost - _direct(sc, bounds)) <= 1e-4 * r.cost


def test_a_time_limit_also_stops_the_continuation_to_the_bounds():
    """The continuation from smoothly saturating controls to the sharp bounds makes several
    solves per run after Leapfrog (on a real map, most of a plan: 59 s of a plan limited to
    10 s took place there); past the time limit it starts none: each run says it stopped at the
    time limit, and the plan says the limit cut it short, with a motion handed back."""
    import leapfrog_planner.planning.runner as runner_module

    bounds = {"v": (0.0, 6.0), "omega": (-2.5, 2.5)}
    sc = dataclasses.replace(load_scenario("paper-case-4"), control_bounds=bounds)
    unlimited = runner_module.leapfrog  # Leapfrog itself unlimited: the limit passes after it

    def leapfrog(*args, deadline, **kwargs):
        return unlimited(*args, **kwargs)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(runner_module, "leapfrog", leapfrog)
        r = plan(sc, threads=1, time_limit=1e-6)
    assert "the time limit of 1e-06 s cut the search short" in r.message
    assert not r.success and r.trajectory is not None
    stopped = [x for x in r.search if "stopped at 0% (" in x.message]
    assert stopped and all(x.message.endswith(", at the time limit") for x in stopped)
    assert plan(sc, threads=1).success  # unlimited, the same plan converges
