"""Start and goal poses a robot meets every day, beyond the easy distribution of headings
close to the goal direction: each converges to the cost of the independent direct method.

The direct method (CasADi/IPOPT, RK4 multiple shooting) is started from the straight line, bent
lines and the planner's own initial paths; its cost on 100 intervals lies above the true
optimum by its mesh error (about 1e-4 to 1e-3 relative), so Leapfrog's must lie just below it.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from leapfrog_planner.batch.generate import GeneratorSpec, generate, generate_one
from leapfrog_planner.planning.leapfrog import LeapfrogSettings, continuation
from leapfrog_planner.planning.planner import Planner, plan
from leapfrog_planner.planning.results import PlanStatus
from leapfrog_planner.planning.scenario import Scenario

PI = math.pi

KINDS = {
    # parked facing away from the goal, an obstacle beside the way
    "facing-away": dict(horizon=1.5, start=[0, 0, PI], goal=[2, 0, 0], obstacles=[[1, 0.4, 0.2]]),
    # the goal straight behind the robot, facing the same way
    "goal-behind": dict(
        horizon=1.0, start=[0, 0, 0], goal=[-1.5, 0, 0], obstacles=[[-0.75, 0.3, 0.15]]
    ),
    # come back the other way, round an obstacle
    "turn-around": dict(
        horizon=2.0, start=[0, 0, 0], goal=[0, 0.8, PI], obstacles=[[0.6, 0.4, 0.2]]
    ),
    # nose against an obstacle, hemmed in by two more
    "tight-start": dict(
        horizon=1.5,
        start=[0, 0, PI / 2],
        goal=[1.5, 0.5, 0],
        obstacles=[[0, 0.35, 0.25], [-0.3, -0.1, 0.2], [0.35, -0.2, 0.15]],
    ),
}


@pytest.mark.parametrize("kind", list(KINDS))
def test_hard_pose_converges_to_the_direct_methods_cost(kind):
    pytest.importorskip("casadi")
    from leapfrog_planner.planning.direct import solve_direct

    sc = Scenario(name=kind, **KINDS[kind])
    planner = Planner(sc)
    r = planner.plan()
    assert r.status is PlanStatus.CONVERGED, r.message
    assert r.min_clearance > 0.0 and r.end_state_error < 1e-8 and r.max_dH_du < 1e-6
    s = np.linspace(0.0, 1.0, 101)
    guesses = [np.column_stack(p.curve(s)) for p in planner.initial_paths()]
    d = solve_direct(sc.start, sc.goal, sc.horizon, sc.obstacles, intervals=100, guesses=guesses)
    assert d.success and d.min_clearance > 0.0
    # (Backing straight along the chord, the mesh has no error: equal to rounding.)
    assert r.cost * (1 - 1e-9) <= d.cost <= r.cost * (1 + 1e-3), (r.cost, d.cost)


def test_goal_behind_is_reached_in_reverse():
    """Backing straight into a goal behind: v < 0 all the way, the heading kept."""
    r = plan(Scenario(name="back", horizon=1.0, start=[0, 0, 0], goal=[-1.5, 0, 0]))
    assert r.success and r.cost == pytest.approx(0.5 * 1.5**2, rel=1e-9)  # v = -1.5, omega = 0
    assert np.all(r.trajectory.u[:, 0] < 0) and np.abs(r.trajectory.x[:, 2]).max() < 1e-9


def test_failed_segments_name_what_was_tried_and_the_strategies_are_counted():
    r = Planner(Scenario(name="k", **KINDS["facing-away"]), initial_paths=1)
    run = r.run_path(r.initial_paths()[0]).run
    solved = {k: v for k, v in run.fit_strategies.items() if k not in ("failed", "split")}
    # every segment of the initial path (8, plus two for each split) was solved by one of them
    assert sum(solved.values()) == LeapfrogSettings().partitions + run.fit_strategies.get(
        "split", 0
    )
    assert set(solved) <= {
        "warm",
        "path costate",
        "weight continuation",
        "end-state continuation",
        "affine guess",
    }


def test_continuation_steps_adapt_and_predict():
    """A problem family whose solve only converges from a guess within 0.3 of the root
    s(p) = 10 p^2: steps halve where the guess is too far, double after successes, and the
    secant predictor carries the guess along."""
    calls = []

    from leapfrog_planner.bvp.shooting import LocalSolution
    from leapfrog_planner.roots import RootStatus

    def solve_at(p, guess):
        calls.append(p)
        root = 10.0 * p**2
        if abs(guess - root) < 0.3:
            return LocalSolution(RootStatus.CONVERGED, np.array([root]), np.array([0.0]), 0, 1, 1)
        return LocalSolution.failure(RootStatus.DIVERGED, np.array([guess]))

    settings = LeapfrogSettings(continuation_steps=60)
    r = continuation(solve_at, 0.0, 1.0, settings)
    assert r.success and r.costate0 == 10.0
    steps = np.diff([0.0] + sorted(set(calls)))
    assert steps.min() < settings.continuation_first_step  # halved somewhere
    # Within a tight step budget, or with a too small minimum step, it gives up.
    failed = continuation(solve_at, 0.0, 1.0, LeapfrogSettings(continuation_steps=3))
    assert not failed.success and failed.status is RootStatus.MAX_ITERATIONS


def test_general_preset_sample_converges_without_collisions():
    """Eight scenarios of the general preset (headings in every direction, T in 0.5..3), both
    methods: converged, collision-free, and the two methods agree on most optima."""
    costs = {}
    for sc in generate(GeneratorSpec.preset("general", n=8, seed=1)):
        for method in ("modified-newton", "newton"):
            r = plan(sc, method=method)
            assert r.status is PlanStatus.CONVERGED, (sc.name, method, r.message)
            assert r.min_clearance > 0.0 and r.end_state_error < 1e-8
            costs[sc.name, method] = r.cost
    same = [abs(costs[n, "newton"] / costs[n, "modified-newton"] - 1) < 1e-6 for n, _ in costs]
    assert sum(same) >= 12  # of 16 entries (8 scenarios, counted twice)


# --------------------------------------------------------------------------- collisions


@settings(max_examples=150)
@given(
    preset=st.sampled_from(["default", "general"]),
    index=st.integers(0, 10_000),
    log_weight=st.floats(0.0, math.log(1000.0)),
    waypoint=st.none() | st.tuples(st.floats(0.0, 1.0), st.floats(-0.5, 0.5)),
    paths=st.sampled_from([1, 3]),
)
def test_no_converged_result_passes_through_an_obstacle(preset, index, log_weight, waypoint, paths):
    """Random scenarios of both presets, obstacle weights from 1 to 1000, with and without a
    waypoint (placed along the chord, offset sideways, moved off any obstacle it falls in):
    a converged result is collision-free; anything else hands back a feasible motion."""
    sc = generate_one(GeneratorSpec.preset(preset, n=index + 1, seed=3), index)
    sc = replace(sc, weight=math.exp(log_weight))
    if waypoint is not None:
        along, side = waypoint
        chord = sc.goal[:2] - sc.start[:2]
        w = sc.start[:2] + along * chord + side * np.array([-chord[1], chord[0]])
        for cx, cy, r in sc.obstacles:
            d = math.hypot(w[0] - cx, w[1] - cy)
            if d < r + 0.05:  # outside, with room: pushed radially out of the disc
                w = np.array([cx, cy]) + (w - [cx, cy]) * (r + 0.05) / max(d, 1e-9)
        if all(math.hypot(w[0] - cx, w[1] - cy) > r for cx, cy, r in sc.obstacles):
            sc = replace(sc, waypoints=[w.tolist()])
    r = plan(sc, initial_paths=paths)
    if r.status is PlanStatus.CONVERGED:
        assert r.min_clearance is None or r.min_clearance >= 0.0, (sc.name, r.message)
        assert r.end_state_error <= 1e-8
    else:
        assert not r.optimal and r.trajectory is not None
        np.testing.assert_allclose(r.trajectory.x[0], sc.start, atol=1e-12)
