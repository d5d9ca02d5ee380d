"""The robot's footprint (``[robot] radius``) and the clearance a converged path keeps beyond
it (``margin``): read from files, planned as a point among grown obstacles, and checked on the
returned path from its own arrays."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from leapfrog_planner.batch.generate import GeneratorSpec, generate_one
from leapfrog_planner.errors import ScenarioError
from leapfrog_planner.planning.planner import plan
from leapfrog_planner.planning.scenario import Scenario, load_scenario_text

ROOM = """horizon = 1.0
start = [0.0, 0.0, 0.0]
goal = [2.0, 0.0, 0.0]
[robot]
radius = 0.1
margin = 0.02
[[obstacles]]
center = [1.0, 0.1]
radius = 0.2
"""


def edge_distance(obstacles: np.ndarray, xy: np.ndarray) -> float:
    """Smallest distance from the path's centre line to an obstacle's edge, from the arrays."""
    d = np.hypot(xy[:, None, 0] - obstacles[None, :, 0], xy[:, None, 1] - obstacles[None, :, 1])
    return float((d - obstacles[None, :, 2]).min())


def test_radius_and_margin_are_read_written_and_checked():
    sc = load_scenario_text(ROOM, "room.toml")
    assert (sc.robot_radius, sc.margin) == (0.1, 0.02)
    np.testing.assert_allclose(sc.footprint_obstacles, [[1.0, 0.1, 0.3]], rtol=1e-15)
    assert load_scenario_text(sc.to_toml()) == sc
    assert "radius" not in load_scenario_text(ROOM.replace("radius = 0.1\n", "")).to_dict()["robot"]
    with pytest.raises(ScenarioError, match=r"room\.toml: robot\.radius: must be >= 0"):
        load_scenario_text(ROOM.replace("radius = 0.1", "radius = -0.1"), "room.toml")
    with pytest.raises(ScenarioError, match=r"robot\.margin: expected a number"):
        load_scenario_text(ROOM.replace("margin = 0.02", "margin = 'x'"))
    # The footprint at the start may not overlap an obstacle (a point there would be fine).
    close = ROOM.replace("start = [0.0, 0.0, 0.0]", "start = [0.75, 0.0, 0.0]")
    with pytest.raises(ScenarioError) as info:
        load_scenario_text(close)
    assert str(info.value) == (  # the radii as written, the robot's and the obstacle's
        "<string>: start: the robot (radius 0.1) at (0.75, 0.0) overlaps obstacles[0]"
        " (center (1.0, 0.1), radius 0.2)"
    )
    load_scenario_text(close.replace("radius = 0.1\n", ""))
    wide = ROOM.replace("radius = 0.1", "radius = 0.3").replace("[0.0, 0.0, 0.0]", "[0.6, 0.0, 0]")
    with pytest.raises(ScenarioError, match=r"robot \(radius 0\.3\) .*, radius 0\.2\)$"):
        load_scenario_text(wide)


def test_a_round_robot_is_a_point_among_grown_obstacles():
    sc = load_scenario_text(ROOM)
    point = dataclasses.replace(sc, robot_radius=0.0, obstacles=sc.footprint_obstacles)
    a, b = plan(sc, threads=1), plan(point, threads=1)
    assert a.success and a.cost == b.cost
    np.testing.assert_array_equal(a.trajectory.x, b.trajectory.x)
    np.testing.assert_array_equal(a.clearance, b.clearance)  # the footprint's clearance


def test_a_path_closer_than_the_margin_is_not_converged_as_it_is():
    """Without a margin the optimum passes 0.086 from the obstacle; with a margin of 0.1 the
    planner raises the obstacle weight until the path keeps it, and says so."""
    loose = dataclasses.replace(load_scenario_text(ROOM), robot_radius=0.0, margin=0.0)
    r0 = plan(loose, threads=1)
    assert r0.success and 0.0 < r0.min_clearance < 0.1
    r = plan(dataclasses.replace(loose, margin=0.1), threads=1)
    if r.success:
        assert r.min_clearance >= 0.1 and r.weight > loose.weight
        assert "closer than the margin 0.1" in r.message
    else:
        assert str(r.status) == "collides" and "closer than the margin" in r.message


@pytest.mark.parametrize("i", range(12))
def test_no_converged_path_comes_closer_than_radius_plus_margin(i):
    """Random layouts (the default preset), a robot of radius 0.03 and a margin of 0.01: every
    converged path keeps 0.04 from every obstacle's edge, measured on the returned arrays."""
    base = generate_one(GeneratorSpec(n=12, seed=7, clearance=0.1), i)
    sc = dataclasses.replace(base, robot_radius=0.03, margin=0.01)
    r = plan(sc, threads=1)
    assert r.success, r.message  # all 12 converge (measured)
    assert edge_distance(sc.obstacles, r.trajectory.x[:, :2]) >= 0.04 - 1e-12
    assert r.min_clearance >= 0.01


def test_a_scenario_built_in_python_checks_the_footprint_too():
    with pytest.raises(ScenarioError, match="robot.radius"):
        Scenario(name="x", horizon=1.0, start=[0, 0, 0], goal=[1, 0, 0], robot_radius=float("nan"))
