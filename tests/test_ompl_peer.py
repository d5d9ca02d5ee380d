"""The OMPL peer (experiments/ompl_peer.py): settings, and plans on small maps checked against the
exact map clearance, the turning radius and the timing. The planning tests need the optional
``ompl`` package and are skipped without it; the settings tests run everywhere."""

import math
from pathlib import Path

import numpy as np
import pytest

from leapfrog_planner.errors import ScenarioError, SettingsError
from leapfrog_planner.experiments.ompl_peer import (
    OmplSettings,
    ompl_available,
    ompl_plan,
    random_queries,
    timed,
)
from leapfrog_planner.world import OCCUPIED, MapClearance, OccupancyMap, load_ros_map

MAPS = Path(__file__).parent / "data" / "maps"
RADIUS = 0.1  # the robot's disc (m)
TURN = 0.3  # the turning radius (m)
START, GOAL = (0.5, 0.5, 0.0), (2.5, 0.5, math.pi / 2)


def room(enclosed: bool = False) -> MapClearance:
    """A 3 x 2 m room at 5 cm, walled, split by a wall from the floor to y = 1.3 at x = 1.5: a
    path from START to GOAL goes over it. ``enclosed``: GOAL walled in all round as well."""
    data = np.zeros((40, 60), np.int8)
    data[[0, -1], :] = data[:, [0, -1]] = OCCUPIED
    data[:26, 29:31] = OCCUPIED
    if enclosed:  # a ring of 1 cell round (2.5, 0.5), 0.7 m across: no way in
        data[3:18, 43:58] = OCCUPIED
        data[4:17, 44:57] = 0
    return MapClearance(OccupancyMap(data, 0.05, name="room"))


@pytest.fixture(scope="module")
def ompl():
    return pytest.importorskip("ompl", reason="OMPL is not installed (pip install ompl)")


@pytest.fixture(scope="module")
def clear():
    return room()


@pytest.fixture(scope="module", params=["RRTstar", "BITstar"])
def plan(request, ompl, clear):
    settings = OmplSettings(planner=request.param, turning_radius=TURN, time_limit=0.5, seed=3)
    return ompl_plan(clear, START, GOAL, RADIUS, settings)


def headings_close(a, b, tol=1e-6) -> bool:
    return abs((a - b + math.pi) % (2 * math.pi) - math.pi) <= tol


# --------------------------------------------------------------------------- settings


@pytest.mark.parametrize(
    ("options", "key"),
    [
        ({"planner": "PRMstar"}, "planner"),
        ({"planner": "rrtstar"}, "planner"),
        ({"space": "se2"}, "space"),
        ({"turning_radius": 0.0}, "turning_radius"),
        ({"turning_radius": math.inf}, "turning_radius"),
        ({"time_limit": -1.0}, "time_limit"),
        ({"time_limit": "1"}, "time_limit"),
        ({"seed": -1}, "seed"),
        ({"seed": 1.5}, "seed"),
        ({"resolution": 0.0}, "resolution"),
        ({"margin": -0.01}, "margin"),
        ({"step": 2.0}, "step"),
        ({"simplify": "yes"}, "simplify"),
        ({"plannr": "RRTstar"}, "plannr"),
        ({"planner": "AORRTC", "space": "dubins"}, "AORRTC"),
    ],
)
def test_bad_settings_one_line(options, key):
    with pytest.raises(SettingsError) as info:
        OmplSettings.from_mapping(options)
    message = str(info.value)
    assert "\n" not in message and key in message


def test_settings_defaults_and_margin():
    s = OmplSettings.from_mapping({"planner": "BITstar", "time_limit": 2})
    assert (s.planner, s.space, s.time_limit) == ("BITstar", "reeds_shepp", 2.0)
    assert s.clearance_margin == s.resolution / 2
    assert OmplSettings(margin=0).clearance_margin == 0.0
    with pytest.raises(TypeError):
        OmplSettings(plannr="RRTstar")


def test_random_queries_keep_clearance_and_distance(clear):
    queries = random_queries(clear, 5, seed=1, radius=RADIUS, clearance=0.2, min_distance=1.0)
    assert len(queries) == 5
    for start, goal in queries:
        assert np.hypot(*(goal[:2] - start[:2])) >= 1.0
        both = np.array([start, goal])
        assert (clear.clearance(both[:, 0], both[:, 1], RADIUS) >= 0.2).all()
    again = random_queries(clear, 5, seed=1, radius=RADIUS, clearance=0.2, min_distance=1.0)
    assert np.array_equal(np.array(queries), np.array(again))


class Pose:
    """A stand-in for OMPL's SE2 state (what the state check reads of it)."""

    def __init__(self, x, y):
        self.x, self.y = x, y

    def getX(self):  # noqa: N802 (OMPL's name)
        return self.x

    def getY(self):  # noqa: N802
        return self.y


@pytest.mark.parametrize("margin", [0.0, 0.005, 0.3])
@pytest.mark.parametrize("which", ["room", "tiny_yaw"])
def test_state_check_agrees_with_the_exact_clearance(which, margin):
    from leapfrog_planner.experiments.ompl_peer import _StateCheck

    clear = room() if which == "room" else MapClearance(load_ros_map(MAPS / "tiny_yaw.yaml"))
    check = _StateCheck(clear, RADIUS, margin)
    xmin, xmax, ymin, ymax = clear.occupancy.extent
    rng = np.random.default_rng(5)
    x = rng.uniform(xmin - 0.2, xmax + 0.2, 3000)
    y = rng.uniform(ymin - 0.2, ymax + 0.2, 3000)
    exact = clear.clearance(x, y, RADIUS) >= margin
    assert [check(Pose(*p)) for p in zip(x, y, strict=True)] == exact.tolist()
    assert 0 < exact.sum() < exact.size
    if which == "room":  # 5 cm cells: the cell-centre bound settles most points on the map
        off = np.count_nonzero(~clear.occupancy.contains(x, y))
        assert check.exact_calls - off < exact.size / 4


# --------------------------------------------------------------------------- planning


def test_available(ompl):
    assert ompl_available()


def test_path_starts_and_ends_at_the_poses(plan):
    assert plan.solved and plan.status == "Exact solution", plan.message
    assert np.allclose(plan.poses[0, :2], START[:2]) and headings_close(plan.poses[0, 2], START[2])
    assert np.allclose(plan.poses[-1, :2], GOAL[:2], atol=1e-6)
    assert headings_close(plan.poses[-1, 2], GOAL[2])
    assert plan.poses.shape == (plan.arclength.size, 3) == (plan.direction.size + 1, 3)
    assert plan.arclength[-1] == plan.length and plan.length > 2.0  # over the wall, not through
    assert 0 <= plan.first_time <= plan.plan_time


def test_path_is_collision_free(plan, clear):
    x, y = plan.poses[:, 0], plan.poses[:, 1]
    assert (clear.clearance(x, y, RADIUS) >= 0).all()
    assert plan.min_clearance == pytest.approx(clear.clearance(x, y, RADIUS).min())
    mid = (plan.poses[1:, :2] + plan.poses[:-1, :2]) / 2  # between the poses, on the chords
    assert (clear.clearance(mid[:, 0], mid[:, 1], RADIUS) >= -1e-3).all()
    assert (clear.clearance(x, y, 0.0) < 0.2).any()  # it does pass close to a wall


def test_path_is_dense_and_reeds_shepp_feasible(plan):
    chords = np.hypot(*np.diff(plan.poses[:, :2], axis=0).T)
    ds = np.diff(plan.arclength)
    assert (chords <= ds + 1e-9).all() and (ds <= plan.settings.step + 1e-12).all()
    assert chords.sum() == pytest.approx(plan.length, rel=1e-2)
    turn = np.abs((np.diff(plan.poses[:, 2]) + np.pi) % (2 * np.pi) - np.pi)
    # A piece of arcs and segments (curvature <= 1/TURN) has a chord > 0.9998 of its arclength;
    # only a piece that holds a cusp is shorter.
    moving = chords > 0.99 * ds
    assert np.count_nonzero(~moving) <= plan.cusps
    assert (turn[moving] / chords[moving] <= (1 / TURN) * 1.001).all()
    assert plan.max_curvature <= 1 / TURN + 1e-9


def test_directions_follow_the_motion(plan):
    d = np.diff(plan.poses[:, :2], axis=0)
    along = d[:, 0] * np.cos(plan.poses[:-1, 2]) + d[:, 1] * np.sin(plan.poses[:-1, 2])
    clear_cut = np.abs(along) > 0.9 * np.diff(plan.arclength)
    assert (np.sign(along[clear_cut]) == plan.direction[clear_cut]).all()
    assert plan.cusps == np.count_nonzero(np.diff(plan.direction))


def test_timed_path_spans_the_horizon(plan):
    horizon = 7.0
    t, poses, v, omega = timed(plan, horizon)
    assert t[0] == 0.0 and t[-1] == horizon and (np.diff(t) > 0).all()
    assert np.array_equal(poses, plan.poses)
    assert np.allclose(np.abs(v), plan.length / horizon)
    assert np.array_equal(np.sign(v[:-1]), plan.direction)
    assert np.abs(omega).max() <= np.abs(v).max() / TURN * (1 + 1e-6)
    # The unicycle's exact arc over each piece (v, omega constant) lands on the next pose, but
    # across a cusp (and within 1 mm where an arc meets a straight inside a piece).
    dt, th = np.diff(t), poses[:-1, 2]
    half = omega[:-1] * dt / 2
    chord = v[:-1] * dt * np.sinc(half / np.pi)  # 2 (v / omega) sin(omega dt / 2)
    step = chord[:, None] * np.column_stack([np.cos(th + half), np.sin(th + half)])
    miss = np.hypot(*(poses[:-1, :2] + step - poses[1:, :2]).T)
    no_cusp = np.hypot(*np.diff(poses[:, :2], axis=0).T) > 0.99 * np.diff(plan.arclength)
    assert np.median(miss) < 1e-9 and miss[no_cusp].max() < 1e-3


def test_dubins_goes_forward_only(ompl, clear):
    # (a sampling planner within a time limit: 0.3 s found no exact path once on a loaded CI
    # machine; the limit is a budget, not a measure)
    s = OmplSettings(planner="RRTstar", space="dubins", turning_radius=TURN, time_limit=2.0, seed=5)
    p = ompl_plan(clear, START, GOAL, RADIUS, s)
    assert p.solved, p.message
    assert p.cusps == 0 and (p.direction == 1).all()
    assert p.max_curvature <= 1 / TURN + 1e-9 and p.min_clearance >= 0


def test_same_seed_same_path(ompl, clear):
    s = OmplSettings(planner="RRTConnect", time_limit=2.0, seed=11)
    a, b = (ompl_plan(clear, START, GOAL, RADIUS, s) for _ in range(2))
    assert a.solved and np.array_equal(a.poses, b.poses)


def test_enclosed_goal_fails_within_the_time_limit(ompl):
    s = OmplSettings(planner="RRTstar", time_limit=0.5)
    p = ompl_plan(room(enclosed=True), START, GOAL, RADIUS, s)
    assert not p.solved and p.poses.shape == (0, 3) and math.isnan(p.length)
    assert p.plan_time <= 0.5 + 0.25
    assert "no exact solution" in p.message
    with pytest.raises(ScenarioError, match="not solved"):
        timed(p, 1.0)


def test_blocked_or_outside_ends_fail_at_once(ompl, clear):
    p = ompl_plan(clear, START, (1.5, 0.5, 0.0), RADIUS, OmplSettings())  # in the wall
    assert not p.solved and p.status == "Invalid goal" and "clearance" in p.message
    p = ompl_plan(clear, (-1.0, 0.5, 0.0), GOAL, RADIUS, OmplSettings())
    assert not p.solved and p.status == "Invalid start" and "extent" in p.message
    with pytest.raises(ScenarioError, match="start"):
        ompl_plan(clear, (0.5, 0.5), GOAL, RADIUS)


def test_a_ros_map(ompl):
    clear = MapClearance(load_ros_map(MAPS / "tb3_sandbox.yaml"))
    s = OmplSettings(planner="BITstar", time_limit=0.5, seed=2)
    p = ompl_plan(clear, (-2.0, -0.5, 0.0), (1.5, 0.5, math.pi / 2), 0.2, s)
    assert p.solved, p.message
    assert (clear.clearance(p.poses[:, 0], p.poses[:, 1], 0.2) >= 0).all()
    assert p.max_curvature <= 1 / s.turning_radius + 1e-9
