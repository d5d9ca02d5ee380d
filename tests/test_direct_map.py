"""The direct method on a map (planning/direct_map.py): the map's penalty in CasADi is the field
of world/field.py (value and gradient to 1e-10 at random points, near obstacles, on and beyond
the padding, on a yawed map), the NLP is built once per map and reused, a crop changes nothing
unless it binds (and then says so), and on a depot query IPOPT's cost converges at order 2 to
the indirect (shooting) solution's."""

from __future__ import annotations

import gc
import math
import weakref
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("casadi")

from leapfrog_planner.compiled.kernels import model_info  # noqa: E402
from leapfrog_planner.integrate.problem import ObstaclePenalty, OptimalControlProblem  # noqa: E402
from leapfrog_planner.planning.direct import richardson  # noqa: E402
from leapfrog_planner.planning.direct_map import (  # noqa: E402
    cached_map_transcription,
    clear_map_transcriptions,
    crop_window,
    flat_edges,
    map_penalty_function,
    query_box,
    solve_direct_map,
)
from leapfrog_planner.planning.scenario import load_scenario_text  # noqa: E402
from leapfrog_planner.world import load_ros_map  # noqa: E402
from leapfrog_planner.world.field import field_penalty_rows  # noqa: E402
from leapfrog_planner.world.obstacle_map import ObstacleMap  # noqa: E402

MAPS = Path(__file__).parent / "data" / "maps"
START, GOAL, HORIZON = (14.3, 4.3, 0.0), (16.8, 4.3, 0.0), 3.0  # through the depot's racks


@pytest.fixture(scope="module")
def depot():
    return ObstacleMap(load_ros_map(MAPS / "depot.yaml"), radius=0.2)


@pytest.fixture(scope="module")
def problem(depot):
    return OptimalControlProblem(
        model_info("unicycle"), ObstaclePenalty(np.zeros((0, 3)), 1.0, 2, depot)
    )


def reference(world: ObstacleMap, xy: np.ndarray, weight: float, exponent: int) -> np.ndarray:
    out = np.empty((len(xy), 6))
    field_penalty_rows(np.ascontiguousarray(xy), world.field, weight, exponent, False, out)
    return out[:, :3]


def casadi_terms(world: ObstacleMap, xy, weight, exponent, window=None) -> np.ndarray:
    f = map_penalty_function(world, window).map(len(xy))
    p, g = f(xy.T, weight, exponent)
    return np.column_stack((np.asarray(p).ravel(), np.asarray(g).T))


def sample_points(world: ObstacleMap, weight: float, exponent: int, seed: int = 0) -> np.ndarray:
    """2000 points anywhere on the field's grid and 3 nodes beyond it (the clamp), and 2000
    where the penalty is between 1e-6 W and W (near and on the obstacles' edges)."""
    f, rng = world.field, np.random.default_rng(seed)
    ny, nx = f.coef.shape
    g = rng.uniform((-3, -3), (nx + 3, ny + 3), (200000, 2)) * f.h
    xy = np.column_stack(
        (f.x0 + f.cos_yaw * g[:, 0] - f.sin_yaw * g[:, 1],
         f.y0 + f.sin_yaw * g[:, 0] + f.cos_yaw * g[:, 1])
    )  # fmt: skip
    p = reference(world, xy, weight, exponent)[:, 0]
    near = xy[(p > 1e-6 * weight) & (p < weight)]
    assert len(near) >= 2000
    return np.vstack((xy[:2000], near[:2000]))


def assert_same_field(ours: np.ndarray, ref: np.ndarray, weight: float, h: float) -> None:
    """Value and gradient (as a vector) within 1e-10 relative; the absolute floor, 1e-20 W (per
    cell for the gradient), only admits the tail below e^-60 W that the reference cuts to 0."""
    assert np.all(np.abs(ours[:, 0] - ref[:, 0]) <= 1e-10 * np.abs(ref[:, 0]) + 1e-20 * weight)
    dg = np.linalg.norm(ours[:, 1:] - ref[:, 1:], axis=1)
    assert np.all(dg <= 1e-10 * np.linalg.norm(ref[:, 1:], axis=1) + 1e-20 * weight / h)


@pytest.mark.parametrize(
    ("name", "yaw", "unknown_is_occupied", "weight", "exponent"),
    [
        ("depot", None, True, 1.0, 2),
        ("tiny_yaw", None, True, 100.0, 3),  # the file's yaw, 0.5 rad
        ("depot", -0.7, False, 100.0, 2),  # turned by hand; the world beyond it free
    ],
)
def test_the_casadi_penalty_is_the_fields(name, yaw, unknown_is_occupied, weight, exponent):
    occ = load_ros_map(MAPS / f"{name}.yaml")
    if yaw is not None:
        occ = type(occ)(occ.data, occ.resolution, (occ.origin[0], occ.origin[1], yaw))
    world = ObstacleMap(occ, radius=0.2, unknown_is_occupied=unknown_is_occupied)
    assert flat_edges(world.field)  # what makes the clamp exact
    xy = sample_points(world, weight, exponent)
    ref = reference(world, xy, weight, exponent)
    assert_same_field(casadi_terms(world, xy, weight, exponent), ref, weight, world.field.h)


def test_a_cropped_field_is_the_whole_one_in_its_box(depot):
    box = query_box(np.array([START[:2], GOAL[:2]]), 1.0)
    window = crop_window(depot.field, box)
    assert window.rows[1] - window.rows[0] < 150 and window.cols[1] - window.cols[0] < 150
    rng = np.random.default_rng(4)
    xy = rng.uniform((box[0] - 0.9, box[2] - 0.9), (box[1] + 0.9, box[3] + 0.9), (3000, 2))
    ours = casadi_terms(depot, xy, 1.0, 2, window)
    assert_same_field(ours, reference(depot, xy, 1.0, 2), 1.0, depot.field.h)


def test_the_nlp_is_built_once_per_map_and_reused(depot, problem):
    first = cached_map_transcription(depot, 0, 100, model="unicycle")
    result = solve_direct_map(problem.with_weight(5.0), (14.3, 4.2, 0.1), GOAL, 2.5)
    assert result.success and cached_map_transcription(depot, 0, 100, model="unicycle") is first
    other = ObstacleMap(depot.occupancy, radius=0.2)  # the same map, another object
    assert cached_map_transcription(other, 0, 100, model="unicycle") is not first


def test_a_dropped_map_frees_its_nlps():
    world = ObstacleMap(load_ros_map(MAPS / "tiny_yaw.yaml"))
    transcription = cached_map_transcription(world, 0, 4, model="unicycle")
    assert transcription.obstacle_map is world
    probe = weakref.ref(world)
    del world
    gc.collect()
    assert probe() is None and transcription.obstacle_map is None


def test_the_cost_converges_to_the_indirect_solutions(problem):
    """IPOPT from the straight line against Newton shooting from the affine costate guess: the
    transcription's error falls by 4 per mesh doubling (order 2), and Richardson's
    extrapolation meets the indirect cost to the shooting's own accuracy (~1e-8)."""
    from leapfrog_planner.bvp.shooting import ShootingSettings, solve_shooting
    from leapfrog_planner.roots.loop import RootSettings

    settings = ShootingSettings(root=RootSettings(tol=1e-8), inexact=False, compiled=False)
    x0, x1 = np.array(START), np.array(GOAL)
    indirect = solve_shooting(problem, 0.0, x0, HORIZON, x1, method="newton", settings=settings)
    assert indirect.success
    results = {n: solve_direct_map(problem, START, GOAL, HORIZON, intervals=n) for n in (100, 200)}
    assert all(r.success and r.end_state_error < 1e-9 for r in results.values())
    assert results[100].min_clearance > 0.19  # the racks' gap, 0.2 m wider than the robot
    err = {n: (r.cost - indirect.cost) / indirect.cost for n, r in results.items()}
    assert 0 < err[200] < err[100] < 1e-6 and 3.5 < err[100] / err[200] < 4.5
    extrapolated = richardson(results[100].cost, results[200].cost)
    assert abs(extrapolated - indirect.cost) / indirect.cost < 1e-8


def test_a_crop_changes_nothing_unless_it_binds(problem):
    """The goal's heading makes the path dip 0.1 m below the line y = 4.3: a crop of 3 m gives
    the whole map's optimum; one of 0.1 m binds, and the result says so."""
    goal = (16.8, 4.3, 0.5)
    clear_map_transcriptions()  # a crop reuses any cached one that holds its box: none here
    tight = solve_direct_map(problem, START, goal, HORIZON, crop=0.1)
    assert not tight.success and tight.status == "crop_too_small"
    whole = solve_direct_map(problem, START, goal, HORIZON)
    wide = solve_direct_map(problem, START, goal, HORIZON, crop=3.0)
    assert whole.success and wide.success
    assert abs(wide.cost - whole.cost) < 1e-9 * whole.cost
    assert np.abs(wide.states - whole.states).max() < 1e-6


def test_a_diff_drive_scenario_costs_twice_the_unicycle_at_twice_the_weight(problem):
    """With wheel radius 1 and axle 2 the diff-drive's effort is v^2 + omega^2, twice the
    unicycle's: at twice the weight, the same optimum at twice the cost (discs add theirs)."""
    text = f"""
name = "depot gap"
horizon = {HORIZON}
start = {list(START)}
goal = {list(GOAL)}
[robot]
model = "diff-drive"
radius = 0.2
[penalty]
weight = 2.0
[map]
file = "{MAPS / "depot.yaml"}"
[[obstacles]]
center = [15.5, 3.0]
radius = 0.3
"""
    scenario = load_scenario_text(text, "gap.toml")
    twice = solve_direct_map(scenario)
    disc = ObstaclePenalty(np.array([[15.5, 3.0, 0.5]]), 1.0, 2, problem.penalty.map)
    once = solve_direct_map(OptimalControlProblem(problem.model, disc), START, GOAL, HORIZON)
    assert twice.success and once.success
    assert abs(twice.cost - 2.0 * once.cost) < 1e-8 * once.cost
    assert math.isclose(twice.min_clearance, once.min_clearance, abs_tol=1e-6)
