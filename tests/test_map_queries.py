"""Random planning queries on maps (world/queries.py), by nav2's planner-benchmark protocol:
clearance, distance, headings, connection, determinism; the shortest path's length against an
exact reference (a disc round a rectangle: the convex hull's shorter side) and against the
search on finer blocks; every refusal as one line."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import ndimage
from scipy.spatial import ConvexHull

from leapfrog_planner.errors import ScenarioError
from leapfrog_planner.world import FREE, OCCUPIED, MapClearance, OccupancyMap
from leapfrog_planner.world.queries import FreeSpace, MapQuery, random_queries
from leapfrog_planner.world.synthetic import nonconvex_field, office_maze

RADIUS = 0.2


@pytest.fixture(scope="module")
def office():
    """An office map, its clearance, its free space at the robot's radius and 40 queries."""
    clear = MapClearance(office_maze(seed=7))
    space = FreeSpace(clear, RADIUS)
    return clear, space, random_queries(clear, 40, seed=5, space=space)


def test_queries_are_poses_with_their_distance_and_shortest_length(office):
    _, _, queries = office
    assert len(queries) == 40
    for q in queries:
        assert isinstance(q, MapQuery)
        assert len(q.start) == 3 and len(q.goal) == 3
        assert all(type(v) is float for v in (*q.start, *q.goal, q.distance, q.shortest))
        assert q.distance == math.hypot(q.goal[0] - q.start[0], q.goal[1] - q.start[1])


def test_starts_and_goals_keep_the_clearance_and_the_distance(office):
    clear, _, queries = office
    pts = np.array([p[:2] for q in queries for p in (q.start, q.goal)])
    assert clear.distance(pts[:, 0], pts[:, 1]).min() >= RADIUS + 0.1  # the default margin
    assert min(q.distance for q in queries) > 3.0
    headings = np.array([p[2] for q in queries for p in (q.start, q.goal)])
    assert (headings >= -math.pi).all() and (headings < math.pi).all()
    assert headings.min() < -2 and headings.max() > 2  # spread over the circle


def test_starts_and_goals_are_spread_over_the_whole_map(office):
    clear, _, queries = office
    pts = np.array([p[:2] for q in queries for p in (q.start, q.goal)])
    xs = np.histogram(pts[:, 0], bins=4, range=(0, 50))[0]
    assert (xs >= 8).all(), xs  # 80 points, 20 a quarter on average


def test_start_and_goal_are_joined_in_the_free_space_eroded_by_the_radius(office):
    """Checked against the clear cells' components computed here, independently."""
    clear, space, queries = office
    occ = clear.occupancy
    free = np.pad(occ.data == FREE, 1)
    dist = (ndimage.distance_transform_edt(free)[1:-1, 1:-1] - 0.5) * occ.resolution
    labels, _ = ndimage.label(dist >= RADIUS)
    for q in queries:
        (si, sj), (gi, gj) = (occ.cell_index(p[0], p[1]) for p in (q.start, q.goal))
        assert labels[si, sj] > 0 and labels[si, sj] == labels[gi, gj]
        s, g = space.component([q.start[0], q.goal[0]], [q.start[1], q.goal[1]])
        assert s >= 0 and s == g


def test_the_same_seed_gives_the_same_queries_and_another_seed_others(office):
    clear, space, queries = office
    again = random_queries(clear, 12, seed=5, space=space)  # the same draws, fewer of them
    assert again == queries[:12]
    assert random_queries(clear, 3, seed=6, space=space)[0] != queries[0]
    fresh = random_queries(clear, 2, seed=5)  # the free space built anew: the same
    assert fresh == queries[:2]


def test_the_shortest_path_is_at_least_the_straight_line_and_stays_clear(office):
    clear, space, queries = office
    res = clear.occupancy.resolution
    assert all(q.shortest >= q.distance for q in queries)
    longer = sum(q.shortest > 1.01 * q.distance for q in queries)
    for q in queries[:12]:
        path = space.path(q.start[:2], q.goal[:2])
        assert path[0].tolist() == list(q.start[:2]) and path[-1].tolist() == list(q.goal[:2])
        assert np.hypot(*np.diff(path, axis=0).T).sum() == pytest.approx(q.shortest, rel=1e-12)
        t = np.linspace(0, 1, 50)[:, None]
        dense = np.vstack([a + t * (b - a) for a, b in zip(path[:-1], path[1:], strict=True)])
        # sight is checked on clear cells: a path may graze the eroded space by a cell
        assert clear.distance(dense[:, 0], dense[:, 1]).min() >= RADIUS - 1.5 * res
    assert longer >= 10  # an office: most paths turn through doors


def rounded_rectangle(box, r, n=400):
    """Points on the outline of ``box`` (x0, x1, y0, y1) grown by ``r`` (arcs at corners)."""
    x0, x1, y0, y1 = box
    pts = []
    for k, (cx, cy) in enumerate(((x1, y1), (x0, y1), (x0, y0), (x1, y0))):
        a = np.linspace(k * math.pi / 2, (k + 1) * math.pi / 2, n)
        pts.append(np.column_stack([cx + r * np.cos(a), cy + r * np.sin(a)]))
    return np.vstack(pts)


def exact_shortest(s, g, box, r) -> float:
    """The shortest path of a disc of radius ``r`` from ``s`` to ``g`` round the rectangle
    ``box`` alone: the straight line if it keeps ``r`` from the box, else the shorter of the
    two sides of the convex hull of the grown box, ``s`` and ``g``."""
    s, g = np.asarray(s, float), np.asarray(g, float)
    x0, x1, y0, y1 = box
    seg = s + np.linspace(0, 1, 4001)[:, None] * (g - s)
    dx = np.maximum(np.maximum(x0 - seg[:, 0], seg[:, 0] - x1), 0)
    dy = np.maximum(np.maximum(y0 - seg[:, 1], seg[:, 1] - y1), 0)
    if np.hypot(dx, dy).min() >= r:
        return float(np.hypot(*(g - s)))
    pts = np.vstack([rounded_rectangle(box, r), s, g])
    ring = list(ConvexHull(pts).vertices)  # counterclockwise
    a, b = ring.index(len(pts) - 2), ring.index(len(pts) - 1)
    ring = ring[a:] + ring[:a]  # s first
    b = (b - a) % len(ring)
    one, other = pts[ring[: b + 1]], pts[ring[b:] + ring[:1]]
    return min(float(np.hypot(*np.diff(c, axis=0).T).sum()) for c in (one, other))


def test_the_shortest_length_is_within_2_percent_of_an_exact_reference():
    """A 10 m room with a 2 m x 1.5 m block in the middle: the length of the disc's exact
    shortest path (tangents and arcs, the convex hull) against ``shortest``."""
    data = np.zeros((200, 200), np.int8)
    data[:3], data[-3:], data[:, :3], data[:, -3:] = OCCUPIED, OCCUPIED, OCCUPIED, OCCUPIED
    data[80:110, 80:120] = OCCUPIED  # x 4.0..6.0 m, y 4.0..5.5 m
    clear = MapClearance(OccupancyMap(data, 0.05, name="block"))
    space = FreeSpace(clear, RADIUS)
    assert space.k == 1
    queries = random_queries(clear, 30, seed=1, space=space)
    errors, detours = [], 0
    for q in queries:
        ref = exact_shortest(q.start[:2], q.goal[:2], (4.0, 6.0, 4.0, 5.5), RADIUS)
        detours += ref > q.distance + 1e-9
        errors.append(q.shortest / ref - 1)
    errors = np.abs(errors)
    assert detours >= 8  # round the block, not only straight lines
    assert errors.max() <= 0.02, errors.max()
    assert errors.mean() <= 0.005, errors.mean()


def test_coarser_blocks_give_lengths_within_2_percent_of_the_cell_search():
    """A 20 m corner of a field of shapes, searched on its cells and on blocks of 2 and 5."""
    occ = nonconvex_field(seed=2)
    corner = OccupancyMap(occ.data[:400, :400], occ.resolution, name="corner")
    clear = MapClearance(corner)
    fine = FreeSpace(clear, RADIUS, max_nodes=400 * 400)
    assert fine.k == 1
    queries = random_queries(clear, 15, seed=3, space=fine)
    for blocks in (2, 5):
        coarse = FreeSpace(clear, RADIUS, max_nodes=(400 // blocks) ** 2)
        assert coarse.k == blocks
        for q in queries:
            assert coarse.shortest(q.start[:2], q.goal[:2]) == pytest.approx(q.shortest, rel=0.02)


def test_a_large_map_is_searched_on_blocks():
    clear = MapClearance(office_maze(size=2000, seed=1))
    space = FreeSpace(clear, RADIUS)
    assert space.k == 6 and space.label.size <= 150_000
    q = random_queries(clear, 2, seed=0, space=space)
    assert all(x.shortest >= x.distance > 3 for x in q)


def test_border_keeps_places_off_the_map_edges_as_nav2s_side_buffer():
    clear = MapClearance(OccupancyMap(np.zeros((200, 200), np.int8), 0.05, name="hall"))
    queries = random_queries(clear, 10, seed=0, clearance=0.2, border=2.0)
    pts = np.array([p[:2] for q in queries for p in (q.start, q.goal)])
    assert pts.min() >= 2.0 and pts.max() <= 8.0
    assert all(q.shortest == q.distance for q in queries)  # an empty hall: straight lines


def one_line(call, words: str) -> None:
    with pytest.raises(ScenarioError, match=words) as err:
        call()
    assert "\n" not in str(err.value)


def test_a_map_without_room_is_refused_in_one_line():
    walls = MapClearance(OccupancyMap(np.full((50, 50), OCCUPIED, np.int8), 0.05, name="rock"))
    one_line(lambda: random_queries(walls, 3), "map 'rock': no free cell is 0.3 m from")
    rock = FreeSpace(walls, RADIUS)
    assert rock.label.size == 0 and rock.component(1.0, 1.0) == -1
    assert rock.shortest((0.5, 0.5), (2.0, 2.0)) == math.inf
    hall = MapClearance(OccupancyMap(np.zeros((60, 60), np.int8), 0.05, name="hall"))
    one_line(lambda: random_queries(hall, 3, clearance=2.0), "no free cell is 2 m from")
    one_line(lambda: random_queries(hall, 3, border=1.5), "and 1.5 m inside the edges")


def test_too_few_valid_places_stop_after_a_bounded_number_of_draws():
    hall = MapClearance(OccupancyMap(np.zeros((40, 40), np.int8), 0.05, name="closet"))
    one_line(  # 2 m square: no two places 3 m apart
        lambda: random_queries(hall, 3), r"map 'closet': only 0 of 3 queries after 8192 draws"
    )
    one_line(lambda: random_queries(hall, 3, max_draws=1000), "only 0 of 3 queries after 1024")
    data = np.zeros((100, 300), np.int8)
    data[:, 148:152] = OCCUPIED  # two rooms 7.4 m x 5 m, no door
    rooms = MapClearance(OccupancyMap(data, 0.05, name="rooms"))
    q = random_queries(rooms, 5, seed=2, min_distance=1.0)
    assert all((p.start[0] < 7.5) == (p.goal[0] < 7.5) for p in q)  # never across the wall
    # 8.5 m apart: only across the wall (a room's places span 6.8 m x 4.4 m, 8.1 m corner to
    # corner)
    one_line(lambda: random_queries(rooms, 2, min_distance=8.5), "only 0 of 2 queries")


@pytest.mark.parametrize(
    ("kw", "words"),
    [
        ({"n": 0}, "n: must be an integer >= 1"),
        ({"n": 2.0}, "n: expected an integer"),
        ({"radius": -0.1}, "radius: must be >= 0"),
        ({"clearance": 0.1}, "clearance: must be at least the radius 0.2"),
        ({"min_distance": float("nan")}, "min_distance: must be finite"),
        ({"border": -1}, "border: must be >= 0"),
        ({"seed": -3}, "seed: must be an integer >= 0"),
        ({"max_draws": 0}, "max_draws: must be an integer >= 1"),
    ],
)
def test_bad_arguments_are_refused_in_one_line(office, kw, words):
    clear, space, _ = office
    args = {"n": 2, **kw}
    one_line(lambda: random_queries(clear, **args), words)


def test_a_free_space_of_another_map_or_radius_is_refused(office):
    clear, space, _ = office
    other = MapClearance(clear.occupancy)
    one_line(lambda: random_queries(other, 2, space=space), "space: built for another map")
    one_line(lambda: random_queries(clear, 2, radius=0.3, space=space), "or radius")
    one_line(lambda: random_queries(clear.occupancy, 2), "clear: expected a MapClearance")
