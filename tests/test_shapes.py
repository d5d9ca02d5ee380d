"""Polygons and walls (world/shapes.py and the scenario's ``[[polygons]]`` and ``[[walls]]``):
their exact distance (closed forms), their field (a many-sided polygon gives a disc's penalty),
the clearance judged by their geometry, the file round trip, bad input, and a plan among them."""

import math
import re

import numpy as np
import pytest

from leapfrog_planner.errors import ScenarioError
from leapfrog_planner.planning.scenario import load_scenario_text
from leapfrog_planner.world import OccupancyMap
from leapfrog_planner.world.field import field_u
from leapfrog_planner.world.obstacle_map import ObstacleMap, with_shapes
from leapfrog_planner.world.shapes import Shapes

NOTCHED = [[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [1.0, 0.5], [0.0, 2.0]]  # a "V" cut from the top


def test_distance_to_a_square_and_a_notch_in_closed_form():
    s = Shapes(polygons=[NOTCHED])
    x = np.array([1.0, 1.0, -1.0, 3.0, 1.0, 0.5])
    y = np.array([0.25, 1.5, 0.0, 3.0, -0.5, 1.0])
    d = s.distance(x, y)
    # inside 0.25 above the bottom; in the notch above the vertex (1, 0.5): its distance to
    # the two edges; outside by 1 to the left; sqrt(2) from the corner (2, 2); below by 0.5.
    notch = 1.0 / math.hypot(1.0, 1.5)  # to the edge (0, 2)-(1, 0.5), normal (1.5, 1)
    assert d[:5] == pytest.approx([-0.25, notch, 1.0, math.sqrt(2.0), 0.5], abs=1e-12)
    assert d[5] < 0.0  # (0.5, 1) lies inside the left arm


def test_distance_to_a_wall_is_to_the_line_less_half_its_thickness():
    s = Shapes(walls=[[[0.0, 0.0], [4.0, 0.0], [4.0, 3.0]]], thickness=[0.2])
    d = s.distance(np.array([2.0, 5.0, 4.0, 3.0, -1.0]), np.array([1.0, 1.0, 4.0, 0.05, 0.0]))
    assert d == pytest.approx([0.9, 0.9, 0.9, -0.05, 0.9], abs=1e-12)


def test_the_union_of_shapes_takes_the_nearest():
    triangle = [[5, 0], [6, 0], [6, 1]]
    s = Shapes(polygons=[NOTCHED, triangle], walls=[[[0, 4], [6, 4]]], thickness=[1])
    d = s.distance(np.array([4.0, 3.0, 5.9]), np.array([0.5, 3.0, 0.5]))
    assert d[0] == pytest.approx(math.sqrt(1.25))  # the corner (5, 0) of the triangle
    assert d[1] == pytest.approx(0.5)
    assert d[2] < 0.0


def test_a_many_sided_polygon_gives_the_disc_penalty():
    """A regular 256-gon of radius R (within 1e-4 R of the circle) on a free grid, the length
    scale R: the penalty's level sets lie where the disc's do, to 1% of R, wherever the penalty
    is between 1e-3 W and W: the geometry is exact, not drawn into cells."""
    R, h = 0.5, 0.02
    a = np.linspace(0.0, 2 * math.pi, 256, endpoint=False)
    ring = np.column_stack([R * np.cos(a), R * np.sin(a)])
    grid = OccupancyMap(np.zeros((150, 150), np.int8), h, (-1.5, -1.5, 0.0))
    om = ObstacleMap(grid, 0.0, R, unknown_is_occupied=False, shapes=Shapes(polygons=[ring]))
    rng = np.random.default_rng(3)
    ang, r = rng.uniform(-math.pi, math.pi, 3000), R * rng.uniform(0.8, 2.2, 3000)
    xy = np.column_stack([r * np.cos(ang), r * np.sin(ang)])
    u = np.array([field_u(x, y, om.field, False)[0] for x, y in xy])
    P_disc = np.exp(-((r / R) ** 4))
    matters = (P_disc > 1e-3) & (P_disc < 1.0)
    assert matters.sum() > 1000
    assert np.abs(u - r / R)[matters].max() < 0.01


def test_clearance_is_the_shapes_geometry_and_routes_see_their_cells():
    grid = OccupancyMap(np.zeros((100, 100), np.int8), 0.05, (0.0, 0.0, 0.0))
    s = Shapes(polygons=[[[1.0, 1.0], [3.0, 1.2], [2.0, 3.0]]])
    om = ObstacleMap(grid, 0.1, 0.3, unknown_is_occupied=False, shapes=s)
    xy = np.array([[2.0, 0.5], [2.0, 2.0], [4.5, 4.5]])
    assert om.clearance_at(xy) == pytest.approx(s.distance(xy[:, 0], xy[:, 1]) - 0.1)
    blocked = om.route_cells.blocked
    centres = np.column_stack(grid.cell_center(*np.nonzero(np.ones((100, 100), bool))))
    inside = (s.distance(centres[:, 0], centres[:, 1]) <= 0).reshape(100, 100)
    assert blocked[inside].all() and not om.cells.blocked.any()  # every cell a shape covers
    assert blocked.sum() < inside.sum() * 1.3  # ... and not many more
    assert with_shapes(grid, s).data.dtype == np.int8


SCENE = """
name = "shapes"
horizon = 10.0
start = [0.0, 0.0, 0.0]
goal = [6.0, 0.5, 0.0]

[robot]
radius = 0.2

[penalty]
weight = 4.0

[[polygons]]
points = [[2.0, -1.0], [3.0, -0.8], [3.2, 1.0], [2.6, 0.2], [2.2, 1.2]]

[[walls]]
points = [[4.2, -2.0], [4.2, 0.3], [5.0, 1.5]]
thickness = 0.1
"""


def test_a_scenario_with_polygons_and_walls_round_trips():
    sc = load_scenario_text(SCENE, "<shapes>")
    assert len(sc.map.shapes) == 2 and sc.map.file is None
    again = load_scenario_text(sc.to_toml(), "<copy>")
    assert again == sc and again.map.shapes == sc.map.shapes
    assert "[[polygons]]" in sc.to_toml() and "[[walls]]" in sc.to_toml()
    xmin, xmax, ymin, ymax = sc.map.occupancy.extent  # the grid holds the shapes and the ends
    assert xmin < -0.2 and xmax > 6.2 and ymin < -2.0 and ymax > 1.5


@pytest.mark.parametrize(
    ("edit", "expected"),
    [
        (("[[walls]]", "[[polygons]]\npoints = [[0, 3], [1, 3]]\n\n[[walls]]"),
         "polygons[1].points: expected at least 3"),
        (("thickness = 0.1", "thickness = 0.0"), "walls[0].thickness: must be > 0"),
        (("thickness = 0.1", "thickness = 0.1\ncolour = 1"), "walls[0].colour: unknown key"),
        (("thickness = 0.1", ""), "walls[0].thickness: missing required key"),
        (("[2.0, -1.0],", "[2.0, nan],"), "polygons[0].points[0]"),
        (("goal = [6.0, 0.5, 0.0]", "goal = [2.6, -0.2, 0.0]"), "goal: (2.6, -0.2) is inside a"),
        (("goal = [6.0, 0.5, 0.0]", "goal = [3.25, 0.0, 0.0]"), "goal: the robot (radius 0.2)"),
        (("[penalty]", '[map]\nunknown = "free"\n\n[penalty]'), "map.unknown: only with a file"),
        (("[penalty]", "[map]\nresolution = -1\n\n[penalty]"), "map.resolution: must be > 0"),
        (("[[polygons]]", "[[polygons]]\npoints = [[0, 3], [1, 3], [2, 3]]\n\n[[polygons]]"),
         "polygons[0].points: the polygon has no area"),
    ],
)  # fmt: skip
def test_bad_shapes_are_one_line(edit, expected):
    with pytest.raises(ScenarioError, match=re.escape(expected)) as e:
        load_scenario_text(SCENE.replace(*edit), "<shapes>")
    assert "\n" not in str(e.value)


def test_a_plan_among_polygons_and_walls_converges_clear_of_their_geometry(tmp_path):
    """Through the command line: converged, and the motion's clearance (against the polygons'
    and walls' geometry, at the footprint) is what the shapes' exact distance says."""
    from tests.test_cli import run_cli

    from leapfrog_planner.planning.results import PlanResult

    (tmp_path / "shapes.toml").write_text(SCENE)
    out = run_cli(["solve", "shapes.toml", "--json", "r.json", "--quiet"], tmp_path)
    assert out.returncode == 0, out.stderr
    r = PlanResult.load(tmp_path / "r.json")
    assert r.success and r.task.map.shapes == load_scenario_text(SCENE, "<s>").map.shapes
    xy = r.trajectory.x[:, :2]
    clear = r.task.map.shapes.distance(xy[:, 0], xy[:, 1]) - 0.2
    assert clear.min() >= 0.0
    assert r.min_clearance <= clear.min() + 1e-9


def test_the_documented_polygons_and_walls_are_those_planned_here():
    from pathlib import Path

    page = (Path(__file__).parents[1] / "docs" / "maps.md").read_text(encoding="utf-8")
    (block,) = [b for b in page.split("```") if b.lstrip().startswith("[[polygons]]")]
    head = SCENE[: SCENE.index("[[polygons]]")]
    sc = load_scenario_text(head + block, "<readme>")
    assert sc.map.shapes == load_scenario_text(SCENE, "<shapes>").map.shapes


def test_a_grid_too_fine_for_the_shapes_is_refused():
    text = SCENE.replace("[penalty]", "[map]\nresolution = 1e-4\n\n[penalty]")
    with pytest.raises(ScenarioError, match=r"map.resolution: 0.0001 m makes a grid of .* cells"):
        load_scenario_text(text, "<shapes>")
