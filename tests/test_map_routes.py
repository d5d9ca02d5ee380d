"""Initial routes on occupancy maps (:func:`map_routes`): the exact clearance field against
:class:`MapClearance`, routes that are clear (sampled densely against the map's exact
clearance), start and goal first and last, two classes round a block in a corridor, a maze's
length against a fine-grid Dijkstra, no route between parts that do not meet (at once, also on
2000 x 2000 cells), a turned map, ends near a wall, the margin's fallback, determinism."""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np
import pytest
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra

from leapfrog_planner.errors import ScenarioError
from leapfrog_planner.planning.initial_path import map_routes as mr
from leapfrog_planner.planning.initial_path.map_grid import clearance_field
from leapfrog_planner.planning.initial_path.map_routes import MapRoute, map_routes
from leapfrog_planner.world import OCCUPIED, UNKNOWN, MapClearance, OccupancyMap, load_ros_map

MAPS = Path(__file__).parent / "data" / "maps"


def grid_map(blocked, resolution=0.05, origin=(0.0, 0.0, 0.0)) -> OccupancyMap:
    return OccupancyMap(np.where(blocked, OCCUPIED, 0).astype(np.int8), resolution, origin)


def world(occ: OccupancyMap, u, v) -> np.ndarray:
    """World ``x, y`` of grid coordinates ``(u, v)`` (cells)."""
    return np.array(occ.grid_to_world(u, v), dtype=float)


def corridor(origin=(0.0, 0.0, 0.0)) -> OccupancyMap:
    """80 x 40 cells of 5 cm with a wall round them and an 11 x 11 block in the middle (its
    centre cell at (40, 20))."""
    b = np.zeros((40, 80), bool)
    b[0] = b[-1] = b[:, 0] = b[:, -1] = True
    b[15:26, 35:46] = True
    return grid_map(b, origin=origin)


def maze() -> OccupancyMap:
    """60 x 60 cells of 10 cm: walls two cells thick every 15 rows, open at alternate ends."""
    b = np.zeros((60, 60), bool)
    b[:2] = b[-2:] = b[:, :2] = b[:, -2:] = True
    for k, row in enumerate((15, 30, 45)):
        b[row : row + 2, 2:46] = True
        if k % 2:
            b[row : row + 2] = np.roll(b[row : row + 2], 12, axis=1)
            b[row : row + 2, :2] = True
    return grid_map(b, resolution=0.1)


def sampled_clearance(clear: MapClearance, points: np.ndarray, radius: float) -> float:
    """The least clearance at samples every 1/10 cell along a polyline."""
    step = clear.occupancy.resolution / 10
    parts = []
    for a, b in zip(points[:-1], points[1:], strict=True):
        t = np.linspace(0.0, 1.0, max(2, int(np.hypot(*(b - a)) / step) + 2))[:, None]
        parts.append(a + t * (b - a))
    p = np.vstack(parts)
    return float(clear.clearance(p[:, 0], p[:, 1], radius).min())


def check_routes(clear, routes, start, goal, radius, max_detour=3.0):
    """What every answer keeps: ends, lengths, order, distinct classes, exact clearance."""
    assert routes, "no route"
    for r in routes:
        assert isinstance(r, MapRoute)
        assert not r.points.flags.writeable and r.points.shape[1] == 2
        assert np.array_equal(r.points[0], start) and np.array_equal(r.points[-1], goal)
        assert r.length == pytest.approx(np.hypot(*np.diff(r.points, axis=0).T).sum())
        sampled = sampled_clearance(clear, r.points, radius)
        assert sampled >= r.clearance - 1e-9  # the reported clearance is the least ...
        assert sampled <= r.clearance + clear.occupancy.resolution / 10  # ... exactly
    lengths = [r.length for r in routes]
    assert lengths == sorted(lengths) and lengths[-1] <= max_detour * lengths[0] + 1e-9
    assert len({r.signature for r in routes}) == len(routes)
    assert len({r.margin for r in routes}) == 1


def test_the_clearance_field_is_the_exact_distance_of_the_centres():
    rng = np.random.default_rng(3)
    for unknown in (True, False):
        for _ in range(6):
            rows, cols = rng.integers(3, 40, 2)
            blocked = rng.random((rows, cols)) < rng.uniform(0.0, 0.2)
            clear = MapClearance(grid_map(blocked, resolution=1.0), unknown)
            d = clearance_field(np.pad(blocked, 1, constant_values=unknown))[1:-1, 1:-1]
            v, u = np.indices(blocked.shape) + 0.5
            ref = clear.grid_distance(u.ravel(), v.ravel()).reshape(blocked.shape)
            assert np.array_equal(np.isinf(d), np.isinf(ref))
            fin = np.isfinite(ref)
            np.testing.assert_allclose(d[fin], ref[fin], rtol=0, atol=1e-12)


def test_two_classes_round_the_block_of_a_corridor():
    occ = corridor()
    clear = MapClearance(occ)
    start, goal = world(occ, 5.5, 20.5), world(occ, 75.5, 20.5)  # on the block's centre line
    routes = map_routes(clear, start, goal, radius=0.1, margin=0.05)
    check_routes(clear, routes, start, goal, 0.1)
    assert len(routes) == 2
    assert sorted(r.signature for r in routes) == [(-1,), (1,)]  # opposite sides
    ys = [r.points[1:-1, 1] for r in routes]
    assert sorted(int(np.all(y > 1.3)) - int(np.all(y < 0.75)) for y in ys) == [-1, 1]
    assert routes[0].length == pytest.approx(routes[1].length, rel=0.01)
    for r in routes:
        assert r.margin == 0.05 and r.clearance >= 0.05 - 1e-9
        # round the block's corners at the margin: within 1 % of the exact length (straight
        # legs tangent to the circles of radius 0.15 m round its corners)
        assert r.length == pytest.approx(exact_corridor_length(), rel=0.01)


def exact_corridor_length() -> float:
    """The shortest way from (0.275, 1.025) to (3.775, 1.025) round the square [1.75, 2.3]
    x [0.75, 1.3] (metres) at 0.15 m: tangent to the circles round its two upper corners."""
    R, a, c = 0.15, np.array([0.275, 1.025]), np.array([1.75, 1.3])
    d = np.hypot(*(c - a))
    tangent = math.sqrt(d * d - R * R)
    turn = math.atan2(c[1] - a[1], c[0] - a[0]) + math.asin(R / d)  # the tangent's heading
    return 2 * (tangent + R * turn) + 0.55


def fine_grid_length(clear: MapClearance, start, goal, keep: float, sub: int = 2) -> float:
    """Dijkstra over points ``sub`` times finer than the cells, 32 neighbours, kept where the
    point, and the midpoint of a move, keep ``keep`` metres from the blocked cells."""
    occ = clear.occupancy
    rows, cols = occ.shape[0] * sub, occ.shape[1] * sub
    fv, fu = (np.indices((2 * rows, 2 * cols)) / 2 + 0.5) / sub  # half-steps for midpoints
    ok2 = (clear.distance(*occ.grid_to_world(fu, fv)) >= keep).reshape(fu.shape)
    ok = ok2[::2, ::2]
    idx = np.arange(ok.size).reshape(ok.shape)
    src, dst, wgt = [], [], []
    moves = [(1, 0), (0, 1), (1, 1), (1, -1), (1, 2), (2, 1), (1, -2), (2, -1), (1, 3), (3, 1)]
    moves += [(1, -3), (3, -1), (2, 3), (3, 2), (2, -3), (3, -2)]
    for dj, di in moves:
        a = np.s_[max(0, -di) : rows - max(0, di), 0 : cols - dj]
        b = np.s_[max(0, di) : rows + min(0, di), dj:cols]
        mid = ok2[max(0, -di) * 2 + di : 2 * rows - max(0, di) * 2 + di : 2, dj : 2 * cols - dj : 2]
        good = ok[a] & ok[b] & mid
        src.append(idx[a][good])
        dst.append(idx[b][good])
        wgt.append(np.full(int(good.sum()), math.hypot(dj, di) / sub * occ.resolution))
    n = ok.size
    graph = coo_matrix((np.concatenate(wgt), (np.concatenate(src), np.concatenate(dst))), (n, n))
    cells = [np.floor(np.array(occ.world_to_grid(*p)) * sub).astype(int) for p in (start, goal)]
    s, g = (idx[c[1], c[0]] for c in cells)
    ends = [
        np.hypot(*(world(occ, *((c + 0.5) / sub)) - p))
        for c, p in zip(cells, (start, goal), strict=True)
    ]
    return float(dijkstra(graph.tocsr(), directed=False, indices=s)[g]) + sum(ends)


def test_the_maze_route_is_within_two_per_cent_of_a_fine_grid_dijkstra():
    """32 neighbours: the grid's paths are at most 1.3 % longer than straight lines in any
    direction (1 / cos of half the widest angle between two moves, atan(1/3)); the route is
    exact (with its clearance measured), so it lies below the reference, by less than that."""
    occ = maze()
    clear = MapClearance(occ)
    start, goal = world(occ, 6.25, 6.25), world(occ, 6.25, 53.75)
    routes = map_routes(clear, start, goal, radius=0.15, margin=0.05)
    check_routes(clear, routes, start, goal, 0.15)
    assert len(routes) == 1 and routes[0].margin == 0.05  # one way through, at the margin
    assert routes[0].clearance >= 0.05 - 1e-9
    reference = fine_grid_length(clear, start, goal, 0.2)
    assert reference / 1.02 <= routes[0].length <= reference
    assert len(routes[0].points) <= 24  # a few vertices round each end of a wall


def test_no_route_between_parts_that_do_not_meet():
    b = np.zeros((40, 60), bool)
    b[0] = b[-1] = b[:, 0] = b[:, -1] = True
    b[:, 30:32] = True  # a wall across
    occ = grid_map(b)
    clear = MapClearance(occ)
    left, right = world(occ, 10.5, 20.5), world(occ, 50.5, 20.5)
    assert map_routes(clear, left, right, 0.1, 0.05) == []
    assert map_routes(clear, left, world(occ, 31.0, 20.5), 0.1, 0.05) == []  # goal in the wall
    assert map_routes(clear, left, world(occ, -5.0, 20.5), 0.1, 0.05) == []  # goal off the map
    b[18:23, 30:32] = False  # a door of 25 cm: too narrow for a robot of 0.15 m
    clear = MapClearance(grid_map(b))
    assert map_routes(clear, left, right, 0.15, 0.0) == []
    routes = map_routes(clear, left, right, 0.1, 0.05)  # ... wide enough for 0.1 m and 0.025
    check_routes(clear, routes, left, right, 0.1)
    assert routes[0].margin == 0.025 and routes[0].clearance >= 0.025 - 1e-9


def test_unknown_cells_are_obstacles_or_not_as_the_clearance_says():
    occ = corridor()
    data = occ.data.copy()
    data[1:-1, 20:24] = UNKNOWN  # across the corridor
    occ = OccupancyMap(data, occ.resolution)
    start, goal = world(occ, 5.5, 10.5), world(occ, 75.5, 10.5)
    assert map_routes(MapClearance(occ), start, goal, 0.1, 0.05) == []
    clear = MapClearance(occ, unknown_is_occupied=False)
    routes = map_routes(clear, start, goal, 0.1, 0.05)
    check_routes(clear, routes, start, goal, 0.1)
    assert routes[0].length == pytest.approx(3.5)  # straight through the unknown cells
    for r in routes:
        assert np.all(occ.contains(*r.points.T))  # on the map, though the world off it is free


def test_no_route_answer_is_at_once_on_a_map_of_2000_by_2000_cells():
    data = np.zeros((2000, 2000), np.int8)
    data[:, 1000:1004] = OCCUPIED
    data[:300, :300] = UNKNOWN
    clear = MapClearance(OccupancyMap(data, 0.05))
    left, right = (20.0, 50.0), (80.0, 50.0)
    assert map_routes(clear, left, right, 0.2, 0.1) == []  # prepares the map
    start = time.perf_counter()
    assert map_routes(clear, (20.0, 60.0), (80.0, 30.0), 0.2, 0.1) == []
    assert time.perf_counter() - start < 0.1


def test_a_turned_and_moved_map_gives_the_same_routes_turned():
    yaw, shift = 0.7, np.array([3.0, -2.0])
    plain, turned = corridor(), corridor(origin=(*shift, yaw))
    rot = np.array([[math.cos(yaw), -math.sin(yaw)], [math.sin(yaw), math.cos(yaw)]])
    start, goal = world(plain, 6.2, 12.3), world(plain, 71.9, 30.4)
    a = map_routes(MapClearance(plain), start, goal, 0.1, 0.05)
    ends = [shift + rot @ p for p in (start, goal)]
    clear = MapClearance(turned)
    b = map_routes(clear, *ends, 0.1, 0.05)
    check_routes(clear, b, *ends, 0.1)
    assert [r.signature for r in a] == [r.signature for r in b]
    for ra, rb in zip(a, b, strict=True):
        assert rb.length == pytest.approx(ra.length, rel=1e-9)
        np.testing.assert_allclose(rb.points, shift + ra.points @ rot.T, atol=1e-9)


def test_routes_on_the_turtlebot_sandbox_are_clear_and_in_world_coordinates():
    occ = load_ros_map(str(MAPS / "tb3_sandbox.yaml"))  # origin (-10, -10), 5 cm
    clear = MapClearance(occ)
    for start, goal in [((-1.8, -0.6), (1.9, 0.5)), ((0.0, -1.6), (0.1, 1.7))]:
        routes = map_routes(clear, start, goal, 0.15, 0.05)
        check_routes(clear, routes, np.array(start), np.array(goal), 0.15)
        assert len(routes) == 3  # round different pillars
        for r in routes:
            assert r.margin == 0.05 and r.clearance >= 0.05 - 1e-9
            assert np.all(np.abs(r.points) < 2.5)  # metres, in the arena round (0, 0)


def test_an_end_near_a_wall_leaves_it_gradually():
    occ = corridor()
    clear = MapClearance(occ)
    start, goal = world(occ, 3.0, 20.5), world(occ, 75.5, 5.5)  # start 0.1 m from the wall
    routes = map_routes(clear, start, goal, radius=0.05, margin=0.1)
    check_routes(clear, routes, start, goal, 0.05)
    for r in routes:
        assert r.margin == 0.1  # the margin is kept where the ends allow
        assert r.clearance == pytest.approx(clear.clearance(*start, 0.05), abs=1e-9)
        far = np.hypot(*(r.points - start).T) > 0.25
        assert sampled_clearance(clear, r.points[far], 0.05) >= 0.1 - 1e-9


def test_blocks_of_cells_give_the_routes_of_the_cells(monkeypatch):
    occ = load_ros_map(str(MAPS / "depot.yaml"))
    clear = MapClearance(occ)
    start, goal = (2.0, 2.0), (27.0, 13.0)
    coarse = map_routes(clear, start, goal, 0.2, 0.1)
    assert mr._prepared(clear).block(0.3 / occ.resolution) > 1
    monkeypatch.setattr(mr, "GRAPH_NODES", 10**9)
    fine = map_routes(MapClearance(occ), start, goal, 0.2, 0.1)
    check_routes(clear, coarse, np.array(start), np.array(goal), 0.2)
    assert coarse[0].length == pytest.approx(fine[0].length, rel=0.01)


def test_the_answer_is_deterministic():
    occ = load_ros_map(str(MAPS / "depot.yaml"))
    args = ((3.0, 3.0), (26.0, 12.0), 0.2, 0.1)
    a = map_routes(MapClearance(occ), *args, k=4)
    b = map_routes(MapClearance(occ), *args, k=4)
    c = map_routes(MapClearance(occ), *args, k=4, max_detour=1.005)
    assert len(a) == 4 and len(c) < 4
    check_routes(MapClearance(occ), c, *map(np.array, args[:2]), 0.2, max_detour=1.005)
    for ra, rb in zip(a, b, strict=True):
        assert np.array_equal(ra.points, rb.points) and ra.signature == rb.signature
        assert (ra.length, ra.clearance, ra.margin) == (rb.length, rb.clearance, rb.margin)
    one = map_routes(MapClearance(occ), *args, k=1)
    assert len(one) == 1 and one[0].length == pytest.approx(a[0].length, rel=1e-3)


@pytest.mark.parametrize(
    "kw, message",
    [
        (dict(radius=-0.1), "radius"),
        (dict(margin=math.nan), "margin"),
        (dict(k=0), "k"),
        (dict(k=2.0), "k"),
        (dict(max_detour=0.5), "max_detour"),
        (dict(start_xy=(1.0, 2.0, 3.0)), "start_xy"),
        (dict(goal_xy=(1.0, math.inf)), "goal_xy"),
    ],
)
def test_bad_input_is_refused(kw, message):
    clear = MapClearance(corridor())
    args = dict(start_xy=(0.3, 1.0), goal_xy=(3.7, 1.0), radius=0.1, margin=0.05) | kw
    with pytest.raises(ScenarioError, match=message):
        map_routes(clear, **args)
    with pytest.raises(ScenarioError, match="MapClearance"):
        map_routes(corridor(), (0.3, 1.0), (3.7, 1.0), 0.1, 0.05)
