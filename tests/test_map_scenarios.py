"""Scenarios with a map: the ``[map]`` table, ``--map``, and bad input as one line with exit 2."""

import shutil
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from leapfrog_planner.errors import ScenarioError
from leapfrog_planner.planning.scenario import load_scenario, load_scenario_text
from leapfrog_planner.planning.scenario_map import ScenarioMap

MAPS = Path(__file__).parent / "data" / "maps"

DEPOT = """
name = "depot aisle"
horizon = 40.0
start = [13.0, 4.5, 0.0]
goal = [28.0, 4.5, 0.0]

[robot]
radius = 0.2

[map]
file = "{file}"
"""


@pytest.fixture
def depot_folder(tmp_path):
    for name in ("depot.yaml", "depot.pgm"):
        shutil.copy(MAPS / name, tmp_path / name)
    return tmp_path


def test_the_map_file_is_found_beside_the_scenario(depot_folder, monkeypatch):
    path = depot_folder / "aisle.toml"
    path.write_text(DEPOT.format(file="depot.yaml"))
    monkeypatch.chdir("/")
    sc = load_scenario(str(path))
    assert sc.map.file == str(depot_folder / "depot.yaml")
    assert sc.map.occupancy.shape == (307, 604)
    assert sc.map.unknown == "occupied" and sc.map.length is None
    again = load_scenario_text(sc.to_toml(), "<copy>")
    assert again == sc and again.map == sc.map


def test_the_problem_carries_the_maps_penalty(depot_folder):
    path = depot_folder / "aisle.toml"
    path.write_text(DEPOT.format(file="depot.yaml"))
    problem = load_scenario(str(path)).problem()
    world = problem.penalty.map
    assert world.radius == 0.2 and world.length == pytest.approx(0.4)
    near_rack, open_floor = problem.penalty(np.array([[15.2, 4.0], [10.0, 8.0]]))
    assert near_rack > 50.0 and open_floor == 0.0


@pytest.mark.parametrize(
    ("table", "expected"),
    [
        ('file = "depot.yaml"\ncolour = 1', "map.colour: unknown key"),
        ('unknown = "occupied"', "map.file: missing required key"),
        ('file = "depot.yaml"\nunknown = "maybe"', "map.unknown: expected one of"),
        ('file = "depot.yaml"\nlength = -1.0', "map.length: must be > 0"),
        ('file = "depot.yaml"\nlength = "big"', "map.length: expected a number"),
        ('file = "none.yaml"', "none.yaml"),
        ("file = 3", "map.file: expected a file name"),
    ],
)
def test_a_bad_map_table_is_one_line(depot_folder, table, expected):
    text = DEPOT.split("[map]")[0] + "[map]\n" + table + "\n"
    path = depot_folder / "bad.toml"
    path.write_text(text)
    with pytest.raises(ScenarioError, match=expected) as info:
        load_scenario(str(path))
    assert "\n" not in str(info.value)


@pytest.mark.parametrize(
    ("start", "expected"),
    [
        ([40.0, 4.5, 0.0], "start: (40.0, 4.5) is outside the map"),
        ([14.78, 3.2, 0.0], "start: (14.78, 3.2) is in an occupied cell of the map"),
        ([14.6, 3.2, 0.0], "start: the robot (radius 0.2) at (14.6, 3.2) overlaps a blocked cell"),
    ],
)
def test_an_end_off_the_map_or_in_a_wall_is_refused(depot_folder, start, expected):
    path = depot_folder / "aisle.toml"
    path.write_text(DEPOT.format(file="depot.yaml"))
    sc = load_scenario(str(path))
    with pytest.raises(ScenarioError, match=expected.replace("(", r"\(").replace(")", r"\)")):
        replace(sc, start=np.array(start))


def test_an_unknown_cell_is_free_only_when_the_scenario_says_so():
    m = ScenarioMap(str(MAPS / "tb3_sandbox.yaml"))
    with pytest.raises(ScenarioError, match="in an unknown cell"):
        m.check_point((-9.0, -9.0), "goal", 0.0)
    ScenarioMap(str(MAPS / "tb3_sandbox.yaml"), "free").check_point((-9.0, -9.0), "goal", 0.0)


def test_waypoints_and_exponent_one_are_refused_with_a_map(depot_folder):
    path = depot_folder / "aisle.toml"
    path.write_text(DEPOT.format(file="depot.yaml"))
    sc = load_scenario(str(path))
    with pytest.raises(ScenarioError, match="waypoints: not supported with a map"):
        replace(sc, waypoints=np.array([[20.0, 4.5]]))
    with pytest.raises(ScenarioError, match="penalty.exponent: must be at least 2 with a map"):
        replace(sc, exponent=1)
