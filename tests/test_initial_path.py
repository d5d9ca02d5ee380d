"""Tests of the initial feasible paths: tangent graph, homotopy classes, smoothing, junctions."""

from __future__ import annotations

import math

import numpy as np
import pytest

from conftest import CASES
from leapfrog_planner.errors import ScenarioError, SettingsError
from leapfrog_planner.planning.initial_path import (
    FORWARD,
    EndModes,
    InitialPath,
    end_modes,
    initial_paths,
    plot_initial_paths,
    search,
)

PI = math.pi

# Spec section 5, typed in independently of the TOML files: (start, goal, obstacles).
# The paper's cases, transcribed once from the spec in conftest.
PAPER_CASES = {c.name: (c.start, c.goal, c.obstacles) for c in CASES.values()}

# One big disc centred on the chord: the two sides are mirror images.
SYMMETRIC = ([0.0, 0.0, 0.0], [4.0, 0.0, 0.0], [[2.0, 0.0, 1.0]])


def polyline_clearance(poly: np.ndarray, obstacles) -> float:
    """Exact minimum distance of a polyline's segments to the obstacle edges."""
    obs = np.asarray(obstacles, dtype=float).reshape(-1, 3)
    a, b = poly[:-1], poly[1:]
    ab = b - a
    best = math.inf
    for cx, cy, r in obs:
        ac = np.array([cx, cy]) - a
        t = np.clip(np.einsum("ij,ij->i", ac, ab) / np.einsum("ij,ij->i", ab, ab), 0, 1)
        d = np.hypot(*(ac - t[:, None] * ab).T) - r
        best = min(best, float(d.min()))
    return best


def dense_length(path: InitialPath, n: int = 20001) -> tuple[np.ndarray, np.ndarray]:
    """Cumulative chord length of the curve sampled uniformly in its arclength parameter."""
    s = np.linspace(0.0, 1.0, n)
    xy, _ = path.curve(s)
    return s, np.concatenate(([0.0], np.cumsum(np.hypot(*np.diff(xy, axis=0).T))))


# --------------------------------------------------------------------------- straight path


def test_straight_path_when_the_chord_is_free():
    start, goal = [0.0, 0.0, 0.3], [2.0, 1.0, -0.2]
    obstacles = [[1.0, 2.0, 0.5], [3.0, -1.0, 0.4]]
    paths = initial_paths(start, goal, obstacles)
    first = paths[0]
    assert first.label == "straight"
    np.testing.assert_array_equal(first.polyline, [[0.0, 0.0], [2.0, 1.0]])
    assert first.signature == (0, 0)
    assert first.min_clearance > 0.05
    assert first.length >= math.hypot(2.0, 1.0)
    for p in paths[1:]:
        assert p.signature != first.signature


def test_junctions_exact_ends_uniform_times_and_continuous_headings():
    start, goal = [0.0, 0.0, 0.3], [2.0, 1.0, -0.2]
    path = initial_paths(start, goal, [[1.0, 2.0, 0.5]], k=1)[0]
    q, T, t0 = 16, 2.5, 0.5
    t, X = path.junctions(q, T, t0)
    assert t.shape == (q + 1,) and X.shape == (q + 1, 3)
    np.testing.assert_array_equal(X[0], start)
    np.testing.assert_array_equal(X[-1], goal)
    assert t[0] == t0 and t[-1] == t0 + T
    np.testing.assert_allclose(np.diff(t), T / q, rtol=1e-12)
    assert np.max(np.abs(np.diff(X[:, 2]))) < PI / 4
    # Junction points lie on the curve, uniformly in arclength.
    s, cum = dense_length(path)
    at = np.interp(np.arange(q + 1) / q, s, cum)
    np.testing.assert_allclose(np.diff(at), path.length / q, rtol=1e-4)
    xy, heading = path.curve(np.arange(q + 1) / q)
    np.testing.assert_allclose(X[1:-1, :2], xy[1:-1], atol=1e-12)
    np.testing.assert_allclose(X[1:-1, 2], heading[1:-1], atol=1e-12)


def test_curve_is_parametrised_by_arclength_and_leaves_and_arrives_along_the_headings():
    start, goal, obstacles = PAPER_CASES["paper-case-4"]
    for path in initial_paths(start, goal, obstacles):
        s, cum = dense_length(path)
        assert cum[-1] == pytest.approx(path.length, rel=1e-6)
        np.testing.assert_allclose(cum, s * path.length, atol=2e-5 * path.length)
        xy, heading = path.curve([0.0, 1.0])
        np.testing.assert_allclose(xy, [start[:2], goal[:2]], atol=1e-12)
        np.testing.assert_allclose(heading, [start[2], goal[2]], atol=1e-9)
        # Headings are the tangent directions of the curve.
        s = np.linspace(0.1, 0.9, 9)
        h = 1e-6
        p1, _ = path.curve(s + h)
        p0, _ = path.curve(s - h)
        _, th = path.curve(s)
        d = (p1 - p0) / (2 * h)
        np.testing.assert_allclose(np.hypot(*d.T), path.length, rtol=1e-3)
        np.testing.assert_allclose(np.arctan2(d[:, 1], d[:, 0]), th, atol=1e-5)


def test_paper_case_1_is_a_smooth_s_curve_up_and_up():
    start, goal, obstacles = PAPER_CASES["paper-case-1"]
    paths = initial_paths(start, goal, obstacles)
    assert len(paths) == 1 and paths[0].label == "straight"
    assert paths[0].signature == () and paths[0].min_clearance == math.inf
    xy, heading = paths[0].curve([0.0, 0.02, 0.5, 0.98, 1.0])
    assert xy[1, 1] > 2.0 and xy[3, 1] < 2.0  # leaves upward, arrives upward from below
    np.testing.assert_allclose(xy[2], [0.0, 2.0], atol=1e-9)  # point symmetric
    np.testing.assert_allclose(heading[[0, -1]], PI / 2, atol=1e-9)
    t, X = paths[0].junctions(16, 1.0)
    assert np.max(np.abs(np.diff(X[:, 2]))) < PI / 4


# --------------------------------------------------------------------------- homotopy classes


@pytest.mark.parametrize("name", sorted(PAPER_CASES))
def test_paper_cases(name):
    start, goal, obstacles = PAPER_CASES[name]
    paths = initial_paths(start, goal, obstacles, k=3)
    assert 1 <= len(paths) <= 3
    signatures = [p.signature for p in paths]
    assert len(set(signatures)) == len(paths)
    lengths = [p.length for p in paths]
    assert lengths == sorted(lengths)
    for p in paths:
        assert p.min_clearance >= 0.0
        assert len(p.signature) == len(obstacles)
        np.testing.assert_array_equal(p.polyline[0], start[:2])
        np.testing.assert_array_equal(p.polyline[-1], goal[:2])
        if len(obstacles):
            # The polyline keeps the margin up to the sampling of arcs (10 degree chords).
            assert polyline_clearance(p.polyline, obstacles) > 0.05 - 0.005
        t, X = p.junctions(16, 1.0)
        np.testing.assert_array_equal(X[0], start)
        np.testing.assert_array_equal(X[-1], goal)
        assert np.max(np.abs(np.diff(X[:, 2]))) < PI / 2
    if name in ("paper-case-2", "paper-case-3", "paper-case-4"):
        assert len(paths) >= 2
    if name == "paper-case-2":
        assert len(paths) == 3


def test_paper_case_3_gaps_open_with_a_smaller_margin():
    # The reference optimum of case 3 passes a 0.066 wide gap; a margin of 0.05 closes it.
    start, goal, obstacles = PAPER_CASES["paper-case-3"]
    closed = {p.signature for p in initial_paths(start, goal, obstacles, margin=0.05)}
    gaps = initial_paths(start, goal, obstacles, margin=0.02)
    assert {(1, 0, 0), (-1, 0, 0)} <= {p.signature for p in gaps}
    assert not closed & {(1, 0, 0), (-1, 0, 0)}
    assert all(p.min_clearance >= 0.0 for p in gaps)


def test_symmetric_obstacle_gives_one_path_per_side_of_equal_length():
    start, goal, obstacles = SYMMETRIC
    paths = initial_paths(start, goal, obstacles, k=3)
    assert len(paths) == 2
    assert {p.signature for p in paths} == {(1,), (-1,)}
    assert paths[0].length == pytest.approx(paths[1].length, abs=1e-6)
    mirrored = paths[1].polyline * [1.0, -1.0]
    np.testing.assert_allclose(paths[0].polyline, mirrored, atol=1e-9)
    # Above (clockwise round the centre) is -1, below is +1.
    for p in paths:
        y_mid = p.curve(0.5)[0][0, 1]
        assert np.sign(y_mid) == -p.signature[0]
        assert y_mid == pytest.approx(-p.signature[0] * 1.05, abs=2e-3)
    # The exact shortest path round a disc: two tangents and an arc.
    R = 1.05
    exact = 2 * math.sqrt(2.0**2 - R**2) + R * (PI - 2 * math.acos(R / 2.0))
    assert polyline_length(paths[0].polyline) == pytest.approx(exact, rel=1e-3)


def polyline_length(poly: np.ndarray) -> float:
    return float(np.hypot(*np.diff(poly, axis=0).T).sum())


def test_k_limits_the_number_of_paths_and_k1_gives_the_shortest():
    start, goal, obstacles = PAPER_CASES["paper-case-4"]
    three = initial_paths(start, goal, obstacles, k=3)
    one = initial_paths(start, goal, obstacles, k=1)
    assert len(one) == 1
    assert one[0].signature == three[0].signature
    np.testing.assert_array_equal(one[0].polyline, three[0].polyline)
    five = initial_paths(start, goal, obstacles, k=5)
    assert [p.signature for p in five[:3]] == [p.signature for p in three]
    assert len({p.signature for p in five}) == len(five)


def test_no_obstacles_gives_one_straight_path():
    paths = initial_paths([0, 0, 0], [1, 1, PI / 2], [], k=3)
    assert len(paths) == 1 and paths[0].label == "straight"
    assert paths[0].signature == () and paths[0].min_clearance == math.inf


def test_overlapping_obstacles_are_passed_as_one():
    obstacles = [[2.0, 0.0, 0.5], [2.0, 0.6, 0.4], [2.0, -0.6, 0.4]]
    paths = initial_paths([0, 0, 0], [4, 0, 0], obstacles, k=3)
    assert len(paths) == 2
    for p in paths:
        assert p.min_clearance >= 0.0
        assert polyline_clearance(p.polyline, obstacles) > 0.04


def test_start_closer_to_an_obstacle_than_the_margin():
    # The start is 0.02 from the first obstacle, and touches it in the second case.
    for gap in (0.02, 0.0):
        obstacles = [[0.0, 0.1 + gap, 0.1], [1.5, 0.0, 0.3]]
        paths = initial_paths([0.0, 0.0, 0.0], [3.0, 0.0, 0.0], obstacles)
        assert len(paths) == 2
        for p in paths:
            # Only that obstacle's inflation shrinks (to the start's distance from it).
            assert p.min_clearance >= gap - 1e-5
            np.testing.assert_array_equal(p.junctions(8, 1.0)[1][0], [0.0, 0.0, 0.0])


# --------------------------------------------------------------------------- smoothing


def test_heading_pointing_back_turns_round_without_a_cusp():
    for heading in (PI, PI - 0.1, -PI + 0.05, 2.4, -2.0):
        path = initial_paths([0.0, 0.0, heading], [2.0, 0.0, 0.0], [], k=1)[0]
        t, X = path.junctions(32, 1.0)
        assert np.max(np.abs(np.diff(X[:, 2]))) < PI / 4
        s = np.linspace(0.0, 1.0, 2001)
        _, th = path.curve(s)
        curvature = np.abs(np.diff(th)) / (path.length / 2000)
        assert np.max(curvature) < 10.0  # a turning arc of radius 2 / 4, not a cusp
        # It turns towards the goal's side when that is ambiguous, else the short way.
        if abs(math.sin(heading)) > 0.5:
            assert np.sign(path.curve(0.05)[0][0, 1]) == np.sign(math.sin(heading))


def test_extra_turns_of_the_goal_heading_are_spread_over_the_path():
    path = initial_paths([0.0, 0.0, 0.0], [2.0, 0.0, 2 * PI], [], k=1)[0]
    t, X = path.junctions(16, 1.0)
    assert X[-1, 2] == 2 * PI
    np.testing.assert_allclose(np.diff(X[:, 2]), 2 * PI / 16, atol=1e-9)


def test_start_equal_to_goal_turns_on_the_spot():
    path = initial_paths([1.0, 1.0, 0.0], [1.0, 1.0, PI / 2], [[3.0, 3.0, 1.0]])[0]
    assert path.length == 0.0
    t, X = path.junctions(4, 1.0)
    np.testing.assert_allclose(X[:, :2], 1.0)
    np.testing.assert_allclose(X[:, 2], np.linspace(0.0, PI / 2, 5), atol=1e-15)


# --------------------------------------------------------------------------- end modes


def test_end_modes_only_where_a_heading_points_away():
    line = np.array([[0.0, 0.0], [2.0, 0.0]])
    assert end_modes(line, [0, 0, 0.3], [2, 0, -1.2]) == [FORWARD]
    assert end_modes(line, [0, 0, PI / 2], [2, 0, 0]) == [FORWARD]  # 90 degrees: still forward
    # The start points back: forward with a turning arc or a turn in place; reverse, whose
    # start fits and whose goal then points back.
    assert end_modes(line, [0, 0, 3.0], [2, 0, 0.0]) == [
        FORWARD,
        EndModes(turn_start=True),
        EndModes(reverse=True),
        EndModes(reverse=True, turn_goal=True),
    ]
    # Both point back: reversing fits both ends.
    assert EndModes(reverse=True) in end_modes(line, [0, 0, PI], [2, 0, -PI])
    assert EndModes(reverse=True, turn_start=True).describe() == "reverse, turn in place at start"


def test_goal_behind_the_start_is_reached_in_reverse():
    """Parked facing away from the goal: the reverse path keeps the heading and backs along the
    chord; the forward one loops round."""
    paths = initial_paths([0.0, 0.0, 0.0], [-1.5, 0.0, 0.0], [], k=1)
    by_modes = {p.modes: p for p in paths}
    back = by_modes[EndModes(reverse=True)]
    assert back.label == "straight, reverse"
    s = np.linspace(0.0, 1.0, 201)
    xy, th = back.curve(s)
    np.testing.assert_allclose(th, 0.0, atol=1e-12)
    np.testing.assert_allclose(xy[:, 1], 0.0, atol=1e-12)
    np.testing.assert_allclose(xy[:, 0], -1.5 * s, atol=1e-9)  # constant speed
    assert by_modes[FORWARD].length > 2.0 * back.length  # the forward loop


def test_turn_in_place_then_drive_and_turn_again():
    start, goal = [0.0, 0.0, PI], [2.0, 0.0, 0.75 * PI]
    path = {p.modes: p for p in initial_paths(start, goal, [], k=1)}[
        EndModes(turn_start=True, turn_goal=True)
    ]
    assert path.length == pytest.approx(2.0)
    # Time is shared by the unicycle's metric: turns of pi and 3 pi / 4, 2 units of path.
    total = 2.0 + PI + 0.75 * PI
    a, b = PI / total, 1.0 - 0.75 * PI / total
    xy, th = path.curve(np.array([0.0, a / 2, a, (a + b) / 2, b, (b + 1) / 2, 1.0]))
    np.testing.assert_allclose(xy[:3], 0.0, atol=1e-12)  # turning on the spot
    np.testing.assert_allclose(th[:3], [PI, PI / 2, 0.0], atol=1e-12)
    np.testing.assert_allclose(xy[3], [1.0, 0.0], atol=1e-9)
    np.testing.assert_allclose(th[3:5], 0.0, atol=1e-12)
    np.testing.assert_allclose(xy[4:], [[2.0, 0.0]] * 3, atol=1e-12)
    np.testing.assert_allclose(th[4:], [0.0, 0.375 * PI, 0.75 * PI], atol=1e-12)
    t, X = path.junctions(8, 1.0)
    assert np.array_equal(X[0], start) and np.array_equal(X[-1], goal)


@pytest.mark.parametrize(
    "start, goal",
    [
        ([0.0, 0.0, 0.0], [2.0, 0.5, PI - 1e-5]),  # the start turns about; it backs to the goal
        ([0.0, 0.0, -PI + 1e-5], [2.0, 0.5, 2.2]),  # it backs away; the goal turns about
        ([0.0, 0.0, 3.0], [2.0, -0.5, -3.0]),
    ],
)
def test_whole_turns_the_goal_heading_asks_for_go_into_a_turn_in_place(start, goal):
    """A path with a turn in place turns there by what the goal's heading asks for beyond the
    drive's own turning: along the drive the heading stays the curve's direction (plus pi in
    reverse), not turned sideways by whole turns spread over it (a TurtleBot3's reverse path
    turned a whole turn across its route, and Leapfrog could not fit it)."""
    paths = [p for p in initial_paths(start, goal, [], k=1) if not p.modes.cusp]
    turning = [p for p in paths if p.modes.turn_start or p.modes.turn_goal]
    assert turning
    for path in turning:
        s = np.linspace(0.0, 1.0, 4001)
        xy, th = path.curve(s)
        step = np.diff(xy, axis=0)
        moving = np.linalg.norm(step, axis=1) > 1e-6 * path.length
        direction = np.arctan2(step[moving, 1], step[moving, 0])
        heading = th[:-1][moving] + (PI if path.modes.reverse else 0.0)
        off = np.abs((heading - direction + PI) % (2 * PI) - PI)
        assert off.max() < 0.05, path.label
        t, X = path.junctions(16, 1.0)
        assert np.array_equal(X[0], start) and np.array_equal(X[-1], goal)


def test_modes_keep_the_homotopy_class_and_the_paper_cases_stay_forward():
    start, goal, obstacles = [0.0, 0.0, PI], [2.0, 0.0, PI], [[1.0, 0.0, 0.2]]
    paths = [p for p in initial_paths(start, goal, obstacles, k=2) if not p.modes.cusp]
    classes = {}
    for p in paths:
        classes.setdefault(p.label.split(",")[0], set()).add(p.signature)
        assert p.min_clearance >= 0.0
    assert len(classes) == 2 and all(len(sig) == 1 for sig in classes.values())
    assert any(p.modes == EndModes(reverse=True) for p in paths)
    for name, (s, g, obs) in PAPER_CASES.items():
        assert all(p.modes == FORWARD for p in initial_paths(s, g, obs, k=8)), name


# --------------------------------------------------------------------------- waypoints


def test_waypoints_give_the_only_path_through_the_points():
    waypoints = [[0.8, 0.6], [1.6, 0.5]]
    obstacles = [[1.0, 0.0, 0.3]]
    paths = initial_paths([0, 0, 0], [2, 0, 0], obstacles, k=3, waypoints=waypoints)
    assert len(paths) == 1
    p = paths[0]
    assert p.label == "waypoints"
    np.testing.assert_array_equal(p.polyline, [[0, 0], *waypoints, [2, 0]])
    xy, _ = p.curve(np.linspace(0.0, 1.0, 20001))
    for w in waypoints:
        assert np.min(np.hypot(*(xy - w).T)) < 1e-3
    assert p.signature == (-1,)  # passes above the obstacle that sits on the chord
    assert p.min_clearance > 0.0


def test_waypoint_legs_go_round_the_obstacles():
    """Legs between waypoints that would cross a disc are routed round it (shortest way); the
    path still passes through every waypoint, in order."""
    waypoints = [[1, 0.5], [1, -0.5]]
    p = initial_paths([0, 0, 0], [2, 0, 0], [[1, 0, 0.2]], waypoints=waypoints)[0]
    assert p.min_clearance > 0.0
    assert len(p.polyline) > 4  # the leg from [1, 0.5] to [1, -0.5] bends round the disc
    xy, _ = p.curve(np.linspace(0.0, 1.0, 20001))
    hits = [int(np.argmin(np.hypot(*(xy - w).T))) for w in waypoints]
    assert hits[0] < hits[1] and all(np.min(np.hypot(*(xy - w).T)) < 1e-3 for w in waypoints)
    assert initial_paths([0, 0, 0], [2, 0, 0], [], waypoints=[])[0].label == "straight"


def test_from_polyline():
    p = InitialPath.from_polyline([[0, 0], [1, 1], [2, 0]], [0, 0, 0], [2, 0, 0], [[1, 0, 0.2]])
    assert p.label == "custom" and p.signature == (-1,)
    assert 0.3 < p.min_clearance < polyline_clearance(p.polyline, [[1, 0, 0.2]])
    with pytest.raises(ScenarioError, match="not the goal position"):
        InitialPath.from_polyline([[0, 0], [1, 1]], [0, 0, 0], [2, 0, 0])


# --------------------------------------------------------------------------- determinism


def test_deterministic():
    start, goal, obstacles = PAPER_CASES["paper-case-4"]
    a = initial_paths(start, goal, obstacles, k=4)
    b = initial_paths(start, goal, obstacles, k=4)
    assert [p.label for p in a] == [p.label for p in b]
    assert [p.signature for p in a] == [p.signature for p in b]
    for p, q in zip(a, b, strict=True):
        np.testing.assert_array_equal(p.polyline, q.polyline)
        assert p.length == q.length and p.min_clearance == q.min_clearance
        for x, y in zip(p.junctions(12, 1.0), q.junctions(12, 1.0), strict=True):
            np.testing.assert_array_equal(x, y)


def test_paths_are_immutable():
    p = initial_paths([0, 0, 0], [1, 0, 0], [])[0]
    with pytest.raises(ValueError):
        p.polyline[0, 0] = 1.0
    with pytest.raises(AttributeError):
        p.length = 3.0


# --------------------------------------------------------------------------- errors


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"start": [0.05, 0.0, 0.0]}, r"start: \(0.05, 0.0\) is inside obstacles\[0\]"),
        ({"goal": [1.0, 1.0, 0.0]}, r"goal: \(1.0, 1.0\) is inside obstacles\[1\]"),
        ({"start": [0.0, float("nan"), 0.0]}, r"start\[1\]: must be finite"),
        ({"goal": [1.0, 0.0]}, "goal: expected 3 numbers"),
        ({"obstacles": [[0.0, 0.0, float("inf")]]}, r"obstacles\[0\]\[2\]: must be finite"),
        ({"obstacles": [[0.0, 0.0, -1.0]]}, r"obstacles\[0\]\.radius: must be > 0"),
        ({"obstacles": [[0.0, 0.0]]}, r"obstacles\[0\]: expected 3 numbers, got 2"),
        ({"k": 0}, "k: must be an integer >= 1, got 0"),
        ({"k": 2.0}, "k: expected an integer >= 1"),
        ({"k": True}, "k: expected an integer >= 1"),
        ({"margin": -0.1}, "margin: must be >= 0"),
        ({"margin": float("nan")}, "margin: must be finite"),
        ({"waypoints": [[0.5, float("inf")]]}, r"waypoints\[0\]\[1\]: must be finite"),
        ({"waypoints": [[1.0, 1.0]]}, r"waypoints\[0\]: \(1.0, 1.0\) is inside obstacles\[1\]"),
    ],
)
def test_errors(kwargs, message):
    args = {
        "start": [-1.0, 0.0, 0.0],
        "goal": [3.0, 0.0, 0.0],
        "obstacles": [[0.0, 0.0, 0.1], [1.0, 1.0, 0.2]],
    }
    args.update(kwargs)
    options = {key: args.pop(key) for key in ("k", "margin", "waypoints") if key in args}
    with pytest.raises(ScenarioError, match=message) as info:
        initial_paths(args["start"], args["goal"], args["obstacles"], **options)
    assert "\n" not in str(info.value)


def test_enclosed_start_has_no_path():
    ring = [[math.cos(a), math.sin(a), 0.3] for a in np.linspace(0, 2 * PI, 13)[:-1]]
    with pytest.raises(ScenarioError, match="no collision-free initial path") as info:
        initial_paths([0.0, 0.0, 0.0], [3.0, 0.0, 0.0], ring)
    assert "\n" not in str(info.value)


def test_narrow_gaps_fall_back_to_a_smaller_margin():
    # A ring with 0.02 wide gaps: margin 0.05 closes them, so a smaller margin is used.
    r = math.sin(PI / 12) - 0.01
    ring = [[math.cos(a), math.sin(a), r] for a in np.linspace(0, 2 * PI, 13)[:-1]]
    paths = initial_paths([0.0, 0.0, 0.0], [3.0, 0.0, 0.0], ring, k=1)
    assert "(margin 0.00625)" in paths[0].label
    assert polyline_clearance(paths[0].polyline, ring) > 0.005


def _class_retries():
    """(S, G, obstacles, class, margin) of every class whose smoothed path cuts an obstacle, in
    layouts where that happens: two of the random presets and one of 1,000 obstacles."""
    from leapfrog_planner.batch.generate import GeneratorSpec, generate

    picks = {"random-s1-00039", "random-s1-00080", "general-s1-00041", "general-s1-00047"}
    scenarios = [s for s in generate(GeneratorSpec(n=100, seed=1)) if s.name in picks]
    scenarios += [
        s for s in generate(GeneratorSpec.preset("general", n=50, seed=1)) if s.name in picks
    ]
    side = 4.0 * math.sqrt(10.0)  # as in the obstacle-count benchmark
    scenarios += generate(
        GeneratorSpec(
            n=1,
            seed=4,
            obstacles=(1000, 1000),
            workspace=(0.0, 0.0, side, side),
            radius=(0.03, 0.08),
            obstacle_gap=0.03,
            min_distance=0.7 * side,
            clearance=0.1,
        )
    )
    out = []
    for sc in scenarios:
        S, G, obs = sc.start, sc.goal, sc.footprint_obstacles
        tol = search.tolerance(S, G, obs)
        for cand in search._plan(S, G, obs, 0.02, 8, tol)[:8]:
            if any(
                search._smooth_best(cand.polyline, S, G, obs, tol, cand.signature, m).min_clearance
                < 0.0
                for m in end_modes(cand.polyline, S, G)
            ):
                out.append((S, G, obs, cand, tol))
    return out


def test_a_class_replanned_among_nearby_obstacles_is_the_class_planned_among_all():
    # A smoothed path that cuts an obstacle sends its class to be planned again with twice and
    # four times the margin; that tangent graph holds only the obstacles near the class's path,
    # and gives the same path as a graph of every obstacle (at 1,000 obstacles in a fraction of
    # the time).
    retries = _class_retries()
    assert len(retries) >= 6 and max(r[2].shape[0] for r in retries) == 1000
    found = 0
    for S, G, obs, cand, tol in retries:
        for f in search._RETRY_MARGIN_FACTORS:
            whole = search._plan_among(S, G, obs, 0.02 * f, 8, tol) or []
            same = [c.polyline for c in whole if c.signature == cand.signature]
            near = search._replan_class(cand, S, G, obs, 0.02 * f, 8, tol)
            if not same:
                assert near is None
            else:
                assert near is not None and near.shape == same[0].shape
                np.testing.assert_allclose(near, same[0], rtol=0, atol=1e-12)
                found += 1
    assert found >= 8  # (at 1,000 obstacles the class is lost at the larger margins)


def _same_route(a: np.ndarray, b: np.ndarray) -> bool:
    """Whether two polylines trace the same route: each vertex of one lies within 1e-4 of the
    other (the whole graph may hold a tangent point more at the end of a tiny arc)."""

    def on(points, poly):
        d = search.segment_distance(poly[:-1], poly[1:], points).min(axis=0)
        return bool(np.all(d < 1e-4))

    return on(a, b) and on(b, a)


def test_a_leg_planned_among_the_obstacles_its_ellipse_holds_is_the_shortest_among_all(
    monkeypatch,
):
    # Three-point turns and waypoints route their legs one by one; each leg's tangent graph
    # holds only the obstacles that a path of its length could touch (an ellipse round its
    # ends, grown until it holds the path). The same route as the graph of every obstacle.
    from leapfrog_planner.batch.generate import GeneratorSpec, generate

    side = 4.0 * math.sqrt(3.0)
    (sc,) = generate(
        GeneratorSpec(
            n=1, seed=2, obstacles=(300, 300), workspace=(0.0, 0.0, side, side),
            radius=(0.03, 0.08), obstacle_gap=0.03, min_distance=0.7 * side, clearance=0.1,
        )
    )  # fmt: skip
    rng = np.random.default_rng(7)
    ends = [rng.uniform(0.0, side, (2, 2)) for _ in range(30)]
    # Legs across a wide disc, whose detour is longer than the first ellipse's string.
    ring = np.array([[5.0, 5.0, 0.6]])
    ends += [
        np.array(e)
        for e in ([[4, 5.2], [6, 5.1]], [[4.1, 4.8], [5.9, 5.05]], [[3.9, 5.3], [6.1, 5.25]])
    ]
    obs = sc.footprint_obstacles
    obs = np.vstack([ring, obs[np.hypot(*(obs[:, :2] - 5.0).T) > 0.8]])
    tol = search.tolerance(sc.start, sc.goal, obs)
    plans = []
    plan = search._plan_among
    monkeypatch.setattr(search, "_plan_among", lambda *a: plans.append(a[2].shape[0]) or plan(*a))
    legs = grown = 0
    for a, b in ends:
        if np.any(np.hypot(*(np.vstack([a, b])[:, None] - obs[:, :2]).T) <= obs[:, 2, None]):
            continue
        whole = plan(np.append(a, 0), np.append(b, 0), obs, 0.02, 1, tol)
        plans.clear()
        leg = search._shortest_leg(a, b, obs, 0.02, tol)
        assert (whole is None) == (leg is None)
        if whole is None:
            continue
        legs += 1
        grown += len(plans) > 1
        assert max(plans, default=0) < obs.shape[0]  # never the whole graph here
        length = np.hypot(*np.diff(leg, axis=0).T).sum()
        assert length == pytest.approx(np.hypot(*np.diff(whole[0].polyline, axis=0).T).sum())
        assert _same_route(leg, whole[0].polyline)
    assert legs >= 25 and grown >= 3  # (the ellipse had to grow on the legs across the disc)


def test_class_paths_planned_among_the_obstacles_their_ellipse_holds_are_those_of_all(
    monkeypatch,
):
    # The classes' shortest paths are planned among the obstacles that the k-th of them could
    # touch (an ellipse round the ends, grown until it holds them and every barrier obstacle):
    # the same first k classes, lengths and routes as the tangent graph of every obstacle.
    from leapfrog_planner.batch.generate import GeneratorSpec, generate
    from leapfrog_planner.planning.scenario import Scenario

    fields = []
    for n, seed in ((300, 1), (300, 2), (1000, 1)):
        side = 4.0 * math.sqrt(n / 100.0)
        fields += generate(
            GeneratorSpec(
                n=1, seed=seed, obstacles=(n, n), workspace=(0.0, 0.0, side, side),
                radius=(0.03, 0.08), obstacle_gap=0.03, min_distance=0.7 * side, clearance=0.1,
            )
        )  # fmt: skip
    fields += generate(GeneratorSpec(n=12, seed=1))
    # Layouts where an obstacle outside the ellipse that holds the first 8 classes is among
    # the barriers of the whole graph: the ellipse grows to hold it.
    fields += [s for s in generate(GeneratorSpec(n=50, seed=3)) if s.name[-2:] in ("01", "45")]
    # Two classes round a disc on the chord, a third below a disc far outside the first
    # ellipse: fewer classes than asked for, so the ellipse grows to the longest detour kept.
    far = np.array([[2.0, 0.0, 0.5], [2.0, -2.2, 0.3]])
    fields.append(Scenario("far", 1.0, np.zeros(3), np.array([4.0, 0.0, 0.0]), far))
    plans = []
    plan = search._plan_among
    monkeypatch.setattr(search, "_plan_among", lambda *a: plans.append(a[2]) or plan(*a))
    smaller = 0
    for sc in fields:
        S, G, obs = sc.start, sc.goal, sc.footprint_obstacles
        tol = search.tolerance(S, G, obs)
        whole = plan(S, G, obs, 0.02, 8, tol)[:8]
        plans.clear()
        cands = search._plan(S, G, obs, 0.02, 8, tol)
        smaller += plans[-1].shape[0] < obs.shape[0]
        assert [c.signature for c in cands] == [c.signature for c in whole]
        for c, w in zip(cands, whole, strict=True):
            assert c.graph_length == pytest.approx(w.graph_length, rel=1e-9)
            assert _same_route(c.polyline, w.polyline)
        act, R = whole[0].graph.active, search._inflated(obs, S[:2], G[:2], 0.02)[0]
        barriers = search._barriers(
            S[:2], G[:2], obs[act, :2], R[act], whole[0].polyline, whole[0].graph_length, act, tol
        )
        held = {tuple(row) for row in plans[-1].tolist()}
        assert all(tuple(row) in held for row in obs[barriers].tolist())
    assert smaller >= 3  # (the fields)


def test_three_point_turns_are_offered_whatever_the_headings():
    # Both headings along the chord, nothing points away: the turns are still among the paths
    # (backing off first can be cheaper next to an obstacle or over a long horizon).
    start, goal, obstacles = PAPER_CASES["paper-case-2"]
    paths = initial_paths(start, goal, obstacles, k=3, turns=True)
    assert end_modes(np.array([start[:2], goal[:2]]), start, goal) == [FORWARD]
    assert not any(p.modes.cusp for p in initial_paths(start, goal, obstacles, k=3))
    turns = [p for p in paths if p.modes.cusp]
    assert turns and all(p.label.startswith("three-point turn at (") for p in turns)
    assert paths.index(turns[0]) > max(i for i, p in enumerate(paths) if not p.modes.cusp)
    for p in turns:
        assert p.min_clearance >= 0.0


def test_no_three_point_turn_is_begun_past_a_plan_s_time():
    """A plan gives building its paths half its time limit: three-point turns (two shortest
    paths each: 2.4 s among 10,000 discs) are begun only until then, the class paths always."""
    import time

    start, goal, obstacles = PAPER_CASES["paper-case-2"]
    every = initial_paths(start, goal, obstacles, k=3, turns=True)
    some = initial_paths(start, goal, obstacles, k=3, turns=True, turns_until=time.perf_counter())
    assert any(p.modes.cusp for p in every) and not any(p.modes.cusp for p in some)
    assert [p.label for p in some] == [p.label for p in every if not p.modes.cusp]
    later = initial_paths(start, goal, obstacles, k=3, turns=True, turns_until=math.inf)
    assert [p.label for p in later] == [p.label for p in every]
    # A planner's paths asked for after a plan with a time limit are whole again.
    from leapfrog_planner.planning.planner import Planner

    def labels(planner):
        return [[p.label for p in paths] for paths in planner.path_selection()]

    planner = Planner("paper-case-2", time_limit=1e-6, initial_paths=12)
    before = labels(planner)
    assert "time limit" in planner.plan().message
    assert labels(planner) == before and planner.paths_deadline == math.inf


def test_a_three_point_turn_whose_first_leg_ends_past_a_plan_s_time_is_dropped(monkeypatch):
    """A turn begun before the paths' share of a time limit has passed, whose first leg ends
    after it, does not begin its second leg (among 10,000 discs a leg took up to 3 s)."""
    from types import SimpleNamespace

    import leapfrog_planner.planning.initial_path.search as search

    start, goal, obstacles = PAPER_CASES["paper-case-2"]
    every = initial_paths(start, goal, obstacles, k=3, turns=True)
    clock = SimpleNamespace(now=0.0)
    monkeypatch.setattr(search, "time", SimpleNamespace(perf_counter=lambda: clock.now))
    legs, real = [], search._route

    def slow_first_leg(a, *args):
        legs.append(a)
        clock.now = 2.0  # the first turn's first leg ends past the paths' time
        return real(a, *args)

    monkeypatch.setattr(search, "_route", slow_first_leg)
    some = initial_paths(start, goal, obstacles, k=3, turns=True, turns_until=1.0)
    assert len(legs) == 1 and any(p.modes.cusp for p in every)
    assert [p.label for p in some] == [p.label for p in every if not p.modes.cusp]


def test_junction_errors():
    p = initial_paths([0, 0, 0], [1, 0, 0], [])[0]
    for q in (0, 1.5, True):
        with pytest.raises(SettingsError, match="q:"):
            p.junctions(q, 1.0)
    with pytest.raises(SettingsError, match="horizon:"):
        p.junctions(4, 0.0)
    with pytest.raises(SettingsError, match="t0:"):
        p.junctions(4, 1.0, float("inf"))
    with pytest.raises(ValueError, match="s:"):
        p.curve(1.5)


def test_plot_initial_paths():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    start, goal, obstacles = PAPER_CASES["paper-case-2"]
    fig, ax = plt.subplots()
    try:
        plot_initial_paths(ax, initial_paths(start, goal, obstacles), obstacles)
        assert len(ax.patches) == 2 and len(ax.lines) == 6
    finally:
        plt.close(fig)


def test_a_cusp_on_the_axis_is_labelled_without_rounding_noise():
    """A three-point turn's cusp on the x axis is labelled "(3, 0)", not "(3, -1.22e-16)"."""
    S, G = np.array([0.0, 0.0, 0.0]), np.array([2.0, 0.0, 0.0])
    paths = initial_paths(S, G, np.array([[1.0, 0.05, 0.2]]), k=8, margin=0.05, turns=True)
    turns = [p.label for p in paths if p.label.startswith("three-point turn")]
    assert "three-point turn at (3, 0), forward, then reverse" in turns
    assert not any("e-1" in label for label in turns), turns
