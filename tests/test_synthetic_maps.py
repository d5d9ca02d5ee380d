"""Synthetic maps (world/synthetic.py) and writing maps as ROS map_server files
(world/ros_map_write.py): sizes, determinism, closed outer walls, walls 2 cells thick, every
room of an office reachable, every opening wide enough for a robot of radius 0.2 m, shapes of
the field apart; the write/read round trip, and every refusal as one line."""

from __future__ import annotations

import math
import os
import time

import numpy as np
import pytest
import yaml
from scipy import ndimage

from leapfrog_planner.errors import ScenarioError
from leapfrog_planner.world import FREE, OCCUPIED, UNKNOWN, OccupancyMap, load_ros_map
from leapfrog_planner.world.ros_map_write import FREE_THRESH, save_ros_map
from leapfrog_planner.world.synthetic import nonconvex_field, office_maze, warehouse

GENERATORS = (office_maze, warehouse, nonconvex_field)
ROBOT = 0.2  # metres


@pytest.fixture(scope="module")
def maps():
    """Each generator's map at its defaults, and at seed 1."""
    return {g.__name__: (g(), g(seed=1)) for g in GENERATORS}


def clear_cells(occ: OccupancyMap, radius: float) -> np.ndarray:
    """Cells whose centre is at least ``radius`` from every occupied cell's square (the map's
    edge counted as a wall), computed here independently of world/queries.py: the nearest
    centre of a distance transform, less half a cell (exact for walls along the grid)."""
    free = np.pad(occ.data == FREE, 1)
    return (ndimage.distance_transform_edt(free)[1:-1, 1:-1] - 0.5) * occ.resolution >= radius


@pytest.mark.parametrize("gen", GENERATORS, ids=lambda g: g.__name__)
def test_maps_are_1000_cells_square_free_or_occupied_and_named(maps, gen):
    occ = maps[gen.__name__][0]
    assert occ.shape == (1000, 1000)
    assert occ.resolution == 0.05 and occ.origin == (0.0, 0.0, 0.0)
    assert occ.data.dtype == np.int8 and not occ.data.flags.writeable
    assert set(np.unique(occ.data).tolist()) == {FREE, OCCUPIED}
    assert occ.name == f"{gen.__name__}_1000_s0"


@pytest.mark.parametrize("gen", GENERATORS, ids=lambda g: g.__name__)
def test_the_same_seed_gives_the_same_map_and_another_seed_another(maps, gen):
    first, other = maps[gen.__name__]
    assert np.array_equal(gen(seed=0).data, first.data)
    assert not np.array_equal(first.data, other.data)


@pytest.mark.parametrize("gen", GENERATORS, ids=lambda g: g.__name__)
def test_2000_cells_square_in_well_under_a_second(gen):
    gen(size=1000)  # imports and first calls out of the timing
    best = math.inf
    for _ in range(2):
        t0 = time.perf_counter()
        occ = gen(size=2000, seed=3)
        best = min(best, time.perf_counter() - t0)
    assert occ.shape == (2000, 2000)
    assert best < 0.5, best


@pytest.mark.parametrize("gen", GENERATORS, ids=lambda g: g.__name__)
def test_a_closed_outer_wall_and_every_obstacle_2_cells_thick(maps, gen):
    for occ in maps[gen.__name__]:
        blocked = occ.data == OCCUPIED
        ring = np.ones_like(blocked)
        ring[3:-3, 3:-3] = False  # 0.15 m: 3 cells
        assert blocked[ring].all()
        # every occupied cell lies in a 2 x 2 square of occupied cells
        opened = ndimage.binary_opening(blocked, np.ones((2, 2), bool), border_value=1)
        assert np.array_equal(opened, blocked)


def test_walls_keep_2_cells_at_a_coarse_resolution():
    occ = office_maze(resolution=0.1)  # 0.15 m rounds to 2 cells, not 1
    assert (occ.data[:2] == OCCUPIED).all() and (occ.data[2, 2:-2] == FREE).any()


def test_every_room_of_an_office_is_reachable(maps):
    for occ in maps["office_maze"]:
        _, count = ndimage.label(occ.data == FREE)  # joined by sides
        assert count == 1
        # and there are rooms: many walls inside, not one hall
        inner = occ.data[3:-3, 3:-3] == OCCUPIED
        assert inner.mean() > 0.03


@pytest.mark.parametrize("gen", GENERATORS, ids=lambda g: g.__name__)
def test_every_door_and_aisle_lets_a_robot_of_radius_0_2_through(maps, gen):
    """Eroded by the robot's radius, the free space stays in one piece: one component holds at
    least 95% of the clear cells (in fact all of them), and erosion keeps most of the floor."""
    for occ in maps[gen.__name__]:
        clear = clear_cells(occ, ROBOT + 0.05)  # with 5 cm to spare
        labels, _ = ndimage.label(clear)
        sizes = np.bincount(labels.ravel())[1:]
        assert sizes.max() >= 0.95 * clear.sum()
        assert clear.sum() >= 0.6 * (occ.data == FREE).sum()


def test_the_field_has_many_shapes_that_touch_neither_each_other_nor_the_wall(maps):
    for occ in maps["nonconvex_field"]:
        blocked = occ.data == OCCUPIED
        labels, count = ndimage.label(blocked, np.ones((3, 3), bool))
        assert count >= 30  # the wall and the shapes: many ways round them
        # grown by half the gap less a cell, no two of them merge: they are 1.2 m apart
        grown = ndimage.distance_transform_edt(~blocked) * occ.resolution <= 0.6 - 0.05
        _, merged = ndimage.label(grown, np.ones((3, 3), bool))
        assert merged == count


def test_the_warehouse_has_long_rack_rows_cut_by_cross_aisles(maps):
    occ = maps["warehouse"][0]
    rows = (occ.data[:, 100:-100] == OCCUPIED).mean(axis=1)  # inside the main aisles
    racks = rows > 0.7
    starts = np.flatnonzero(racks[1:] & ~racks[:-1])
    assert len(starts) >= 6
    row = occ.data[starts[0] + 2, 100:-100] == OCCUPIED
    gaps = np.flatnonzero(row[1:] != row[:-1])
    assert len(gaps) >= 4  # at least two cross aisles cut this row


@pytest.mark.parametrize(
    ("kw", "words"),
    [
        ({"size": 999}, "size: must be an integer >= 1000"),
        ({"size": 1000.0}, "size: expected an integer"),
        ({"resolution": 0.5}, "resolution: must be between 0.01 and 0.1"),
        ({"seed": -1}, "seed: must be an integer >= 0"),
        ({"wall": 0.0}, "wall: must be > 0"),
    ],
)
def test_bad_arguments_are_refused_in_one_line(kw, words):
    for gen in GENERATORS:
        with pytest.raises(ScenarioError, match=words) as err:
            gen(**kw)
        assert "\n" not in str(err.value)


def test_openings_too_narrow_for_the_robot_are_refused():
    for call, key in (
        (lambda: office_maze(door_width=0.4), "door_width"),
        (lambda: warehouse(aisle=0.5), "aisle"),
        (lambda: nonconvex_field(gap=0.3), "gap"),
    ):
        with pytest.raises(ScenarioError, match=f"{key}: must be between 0.6") as err:
            call()
        assert "\n" not in str(err.value)


# --------------------------------------------------------------------------- ROS files


def test_a_synthetic_map_reads_back_from_its_ros_files_cell_for_cell(maps, tmp_path):
    occ = maps["warehouse"][0]
    yaml_path, image = save_ros_map(occ, tmp_path / "warehouse.yaml")
    assert image == tmp_path / "warehouse.pgm"
    back = load_ros_map(yaml_path)
    assert np.array_equal(back.data, occ.data)
    assert (back.resolution, back.origin, back.name) == (occ.resolution, occ.origin, "warehouse")
    doc = yaml.safe_load(yaml_path.read_text())
    assert doc == {
        "image": "warehouse.pgm",
        "mode": "trinary",
        "resolution": 0.05,
        "origin": [0.0, 0.0, 0.0],
        "negate": 0,
        "occupied_thresh": 0.65,
        "free_thresh": 0.196,
    }
    assert image.read_bytes().startswith(b"P5\n")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["warehouse.pgm", "warehouse.yaml"]


def test_unknown_cells_an_odd_resolution_and_a_turned_origin_read_back_exactly(tmp_path):
    rng = np.random.default_rng(4)
    data = rng.choice(np.array([FREE, OCCUPIED, UNKNOWN], np.int8), size=(7, 11))
    occ = OccupancyMap(data, 0.0371, (-12.5, 3.25, -2.9), "odd")
    back = load_ros_map(save_ros_map(occ, tmp_path / "odd.yaml")[0])
    assert np.array_equal(back.data, occ.data)
    assert back.resolution == occ.resolution and back.origin == occ.origin
    # the image's top row is the map's last row
    pixels = (tmp_path / "odd.pgm").read_bytes()[-11 * 7 :]
    top = np.frombuffer(pixels[:11], np.uint8)
    assert np.array_equal(top, np.select([data[-1] == 0, data[-1] == 100], [254, 0], 205))


def test_free_thresh_0_25_would_read_the_unknown_grey_back_as_free(tmp_path):
    """Why the YAML says 0.196: nav2 map_saver's default 0.25 turns grey 205 into free."""
    assert FREE_THRESH < 1 - 205 / 255 < 0.25
    occ = OccupancyMap(np.array([[UNKNOWN, FREE, OCCUPIED]], np.int8), 0.05)
    yaml_path, _ = save_ros_map(occ, tmp_path / "m.yaml")
    assert load_ros_map(yaml_path).data.tolist() == [[UNKNOWN, FREE, OCCUPIED]]
    yaml_path.write_text(yaml_path.read_text().replace("0.196", "0.25"))
    assert load_ros_map(yaml_path).data.tolist() == [[FREE, FREE, OCCUPIED]]


def test_existing_files_are_kept_unless_overwrite_is_asked(tmp_path):
    occ = OccupancyMap(np.zeros((3, 4), np.int8), 0.1, name="a")
    yaml_path, image = save_ros_map(occ, tmp_path / "a.yaml")
    before = (yaml_path.read_bytes(), image.read_bytes())
    other = OccupancyMap(np.full((3, 4), OCCUPIED, np.int8), 0.2)
    for path in (yaml_path, image):
        with pytest.raises(ScenarioError, match="exists already") as err:
            save_ros_map(other, yaml_path)
        assert "\n" not in str(err.value)
        assert (yaml_path.read_bytes(), image.read_bytes()) == before
        path.unlink()  # either file alone is enough to refuse
        save_ros_map(occ, yaml_path, overwrite=True)
    save_ros_map(other, yaml_path, overwrite=True)
    assert (load_ros_map(yaml_path).data == OCCUPIED).all()
    assert sorted(os.listdir(tmp_path)) == ["a.pgm", "a.yaml"]  # no temporary file left


def test_what_a_trinary_image_cannot_hold_is_refused_before_anything_is_written(tmp_path):
    occ = OccupancyMap(np.array([[0, 50, 100]], np.int8), 0.05, name="scale")
    with pytest.raises(ScenarioError, match="1 cells hold values between 1 and 99") as err:
        save_ros_map(occ, tmp_path / "s.yaml")
    assert "\n" not in str(err.value)
    assert not list(tmp_path.iterdir())
    with pytest.raises(ScenarioError, match="must not end in .pgm"):
        save_ros_map(OccupancyMap(np.zeros((2, 2), np.int8), 0.05), tmp_path / "m.pgm")
    with pytest.raises(ScenarioError, match="cannot write .*missing"):
        save_ros_map(OccupancyMap(np.zeros((2, 2), np.int8), 0.05), tmp_path / "missing/m.yaml")
    with pytest.raises(ScenarioError, match="expected an OccupancyMap"):
        save_ros_map(np.zeros((2, 2)), tmp_path / "m.yaml")
