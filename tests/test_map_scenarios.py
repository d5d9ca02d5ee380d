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


# --------------------------------------------------------------------------- the command line


def write_rooms(folder: Path, door: bool) -> Path:
    """Two 2 x 2 m rooms at 5 cm, side by side, with a wall between them (a 0.6 m door in it,
    or none) and an outer wall: a PGM and its YAML."""
    n_y, n_x = 40, 80
    cells = np.full((n_y, n_x), 254, np.uint8)
    cells[:2, :] = cells[-2:, :] = cells[:, :2] = cells[:, -2:] = 0
    cells[:, 39:41] = 0
    if door:
        cells[14:26, 39:41] = 254
    (folder / "rooms.pgm").write_bytes(f"P5\n{n_x} {n_y}\n255\n".encode() + cells[::-1].tobytes())
    (folder / "rooms.yaml").write_text(
        "image: rooms.pgm\nresolution: 0.05\norigin: [0.0, 0.0, 0.0]\nnegate: 0\n"
        "occupied_thresh: 0.65\nfree_thresh: 0.25\n"
    )
    return folder / "rooms.yaml"


ROOMS = """
name = "next door"
horizon = 8.0
start = [0.8, 1.0, 0.0]
goal = [3.2, 1.0, 3.14159]

[robot]
radius = 0.15

[penalty]
weight = 1.0
"""


def test_solve_with_map_converges_through_the_door(tmp_path):
    from tests.test_cli import run_cli

    write_rooms(tmp_path, door=True)
    (tmp_path / "task.toml").write_text(ROOMS)
    out = run_cli(["solve", "task.toml", "--map", "rooms.yaml", "--json", "r.json", "--quiet"],
                  tmp_path)  # fmt: skip
    assert out.returncode == 0, out.stderr
    from leapfrog_planner.planning.results import PlanResult

    r = PlanResult.load(tmp_path / "r.json")
    assert r.success and r.min_clearance >= 0.0
    assert r.task.map is not None and r.task.map.file == str(tmp_path / "rooms.yaml")
    xy = r.trajectory.x[:, :2]
    world = r.task.map.obstacles(0.15)
    assert world.path_clearance(xy) >= 0.0
    door = np.abs(xy[:, 0] - 2.0) < 0.05
    assert door.any() and np.all(np.abs(xy[door, 1] - 1.0) < 0.3)  # it went through the door


def test_start_and_goal_not_connected_fail_at_once_with_exit_1(tmp_path):
    from tests.test_cli import run_cli

    write_rooms(tmp_path, door=False)
    (tmp_path / "task.toml").write_text(ROOMS + '\n[map]\nfile = "rooms.yaml"\n')
    out = run_cli(["solve", "task.toml", "--json", "r.json", "--quiet"], tmp_path)
    assert out.returncode == 1
    assert "are not connected on the map for a robot of radius 0.15" in out.stderr
    assert len(out.stderr.strip().splitlines()) == 1
    from leapfrog_planner.planning.results import PlanResult

    r = PlanResult.load(tmp_path / "r.json")
    assert r.status == "failed" and r.trajectory is None and r.wall_time_s < 1.0


@pytest.mark.parametrize(
    ("args", "expected"),
    [
        (["--map", "missing.yaml"], "missing.yaml"),
        (["--map", "task.toml"], "task.toml"),
    ],
)
def test_solve_with_a_bad_map_is_one_line_and_exit_2(tmp_path, args, expected):
    from tests.test_cli import run_cli

    (tmp_path / "task.toml").write_text(ROOMS)
    out = run_cli(["solve", "task.toml", *args, "--json", "r.json"], tmp_path)
    assert out.returncode == 2 and expected in out.stderr
    assert len(out.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "r.json").exists()


def test_generate_on_a_map_writes_the_protocols_queries(tmp_path):
    from tests.test_cli import run_cli

    out = run_cli(["generate", "--map", str(MAPS / "depot.yaml"), "--n", "4", "--seed", "3",
                   "--out", "q"], tmp_path)  # fmt: skip
    assert out.returncode == 0, out.stderr
    files = sorted((tmp_path / "q").glob("*.toml"))
    assert len(files) == 4
    for f in files:
        sc = load_scenario(str(f))
        world = sc.map.obstacles(sc.robot_radius)
        assert sc.robot_radius == 0.2 and sc.weight == 1.0
        assert np.hypot(*(sc.goal[:2] - sc.start[:2])) > 3.0
        assert world.clearance_at(sc.start[:2]) >= 0.1 and world.clearance_at(sc.goal[:2]) >= 0.1
        assert sc.horizon >= np.hypot(*(sc.goal[:2] - sc.start[:2])) / 0.5 - 1e-9
    again = run_cli(["generate", "--map", str(MAPS / "depot.yaml"), "--n", "4", "--seed", "3",
                     "--out", "q"], tmp_path)  # fmt: skip
    assert again.returncode == 0  # the same set again: the same files, left alone


#: A query of navigation2's depot by the planner-benchmark protocol (seed 0, query 7): the goal
#: lies up and to the right, behind the start's heading. Backing along the lower aisle costs
#: 3.6323 (the cheapest of Leapfrog from 27 initial paths and of IPOPT from the planner's
#: paths); turning round, or backing along the upper aisle, 4.05 to 4.16.
DEPOT_QUERY = """
name = "depot query"
horizon = 20.40510024321638
start = [17.523808348160852, 8.971426980407147, 2.217167455995847]
goal = [26.321186872148527, 14.07931501767954, 2.269664239291938]

[robot]
radius = 0.2

[penalty]
weight = 1.0

[map]
file = "depot.yaml"
"""


def test_each_route_of_a_map_is_a_class_of_its_own(depot_folder):
    """The first paths of a plan are one per class and direction: on a map the classes are
    the routes round its islands of blocked cells. When every route of a map counted as one
    class, backing along the lower aisle (the map's first route, reversed) was never run and
    the plan returned 4.048."""
    from leapfrog_planner.planning.planner import Planner
    from leapfrog_planner.planning.search import family

    path = depot_folder / "query.toml"
    path.write_text(DEPOT_QUERY)
    planner = Planner(str(path))
    first = planner.initial_paths()
    assert len({family(p) for p in first}) == len(first)
    assert len({p.signature for p in first if not p.modes.cusp}) >= 2  # two routes at least
    r = planner.plan()
    assert r.status.value == "converged" and r.min_clearance >= 0.0
    assert r.cost <= 3.6323


def test_a_long_route_starts_with_more_partitions_halved_down_to_more_arcs(depot_folder):
    """The first round fits the route: the depot aisle's route of 15 m is 38 of the penalty's
    length scales (0.4 m), under the default ``long_route`` of 64, so the first round is the
    settings' (q = 8 halved down to 2 arcs); with ``long_route = 16`` it is a long route: q =
    32 halved down to 16 arcs, and more where the settings ask for more. Without a map, and
    with ``long_route = 0``, never."""
    from leapfrog_planner.planning.planner import Planner

    path = depot_folder / "aisle.toml"
    path.write_text(DEPOT.format(file="depot.yaml"))

    def first(scenario, **options):
        planner = Planner(scenario, **options)
        return planner.search(planner.path_selection()).first

    default = first(str(path))
    assert (default.partitions, default.fewest_arcs) == (8, 2)
    assert default.reason == "the initial paths"
    long = first(str(path), long_route=16)
    assert (long.partitions, long.fewest_arcs, long.doublings) == (32, 16, 0)
    assert "a route of 38 length scales: q = 32, halved down to 16 arcs" in long.reason
    more = first(str(path), long_route=16, partitions=64, fewest_arcs=24)
    assert (more.partitions, more.fewest_arcs) == (64, 24)
    assert first(str(path), long_route=0).partitions == 8
    assert first("paper-case-3", long_route=1e-3).partitions == 8


def test_a_long_route_plan_converges_with_its_finer_first_round(tmp_path):
    """Through the door of two rooms (a route of 8 length scales) with ``long_route = 4``:
    every run of the first round at q = 32, the answer a collision-free extremal no dearer than
    the plan at q = 8 (1.4368 both ways today), the round's reason in the result's search, and
    the levels in the sweeps row of ``leapfrog solve``."""
    from leapfrog_planner.planning.planner import plan

    write_rooms(tmp_path, door=True)
    (tmp_path / "task.toml").write_text(ROOMS + '\n[map]\nfile = "rooms.yaml"\n')
    short = plan(str(tmp_path / "task.toml"))
    assert {rec.partitions for rec in short.search} == {8}
    r = plan(str(tmp_path / "task.toml"), long_route=4)
    assert r.status.value == "converged" and r.min_clearance >= 0.0
    assert r.cost <= short.cost * (1 + 1e-9)
    first = [rec for rec in r.search if rec.stage == "paths"]
    assert first and all(rec.partitions == 32 for rec in first)
    assert "length scales: q = 32, halved down to 16 arcs" in first[0].reason
    from tests.test_cli import run_cli

    out = run_cli(["solve", "task.toml", "--option", "long_route=4"], tmp_path)
    assert out.returncode == 0, out.stderr
    assert "(levels of 32 down to 16 arcs)" in " ".join(out.stdout.split())  # the sweeps row


def test_a_long_route_that_falls_short_runs_again_with_twice_the_fewest_arcs(tmp_path, monkeypatch):
    """Every answer dropped (as if no extremal were confirmed): a long route's rounds are q =
    32 halved down to 16 arcs, twice the partitions (64, down to 16), then twice the fewest
    arcs (64, down to 32), each said in the result's search; a short route's only q = 8 and
    16 (tests/test_search.py)."""
    from tests.test_search import _failing

    from leapfrog_planner.planning.planner import plan

    write_rooms(tmp_path, door=True)
    (tmp_path / "task.toml").write_text(ROOMS + '\n[map]\nfile = "rooms.yaml"\n')
    seen = []
    _failing(monkeypatch, seen)
    r = plan(str(tmp_path / "task.toml"), long_route=4, initial_paths=1, extra_paths=0)
    assert r.status.value == "failed"
    rounds = list(dict.fromkeys((q.round.partitions, q.round.fewest_arcs) for q in seen))
    assert rounds == [(32, 16), (64, 16), (64, 32)]
    reasons = list(dict.fromkeys(q.round.reason for q in seen))
    assert "twice the fewest arcs, levels halved down to 32" in reasons[2]
    assert any(rec.label.endswith("q = 64 down to 32 arcs") for rec in r.search)


def test_the_clearance_on_a_map_is_exact_between_sparse_samples(tmp_path):
    """Between two samples the clearance is known only as a bound, up to half their spacing
    low: validation integrates the stretches that hide a lower value again, so the clearance of
    an extremal sampled at 5 points is that of 100,001 points, to CLEARANCE_TOLERANCE."""
    from leapfrog_planner.integrate.flow import Flow
    from leapfrog_planner.planning.leapfrog import Arcs
    from leapfrog_planner.planning.planner import plan
    from leapfrog_planner.planning.results import CLEARANCE_TOLERANCE, VALIDATION, validate_arcs

    write_rooms(tmp_path, door=True)
    (tmp_path / "task.toml").write_text(ROOMS + '\n[map]\nfile = "rooms.yaml"\n')
    sc = load_scenario(tmp_path / "task.toml")
    r = plan(sc, initial_paths=1, extra_paths=0)
    assert r.success
    problem = sc.problem()
    world = problem.penalty.map
    z0 = np.concatenate([sc.start, r.costate0])
    dense = Flow(problem, VALIDATION)(0.0, z0, sc.horizon, samples=100_001).trajectory
    exact = float(world.clearance_at(dense.x[:, :2]).min())
    arcs = Arcs(np.array([0.0, sc.horizon]), np.array([sc.start, sc.goal]), r.costate0[None])
    sparse = validate_arcs(problem, arcs, samples=5)
    polyline = world.path_clearance(sparse.trajectory.x[:, :2])
    assert polyline < exact - 10 * CLEARANCE_TOLERANCE  # the bound alone reads low
    assert exact - 1.5 * CLEARANCE_TOLERANCE <= sparse.clearance[-1] <= exact + 1e-12
    assert abs(r.min_clearance - exact) <= 1.5 * CLEARANCE_TOLERANCE


def test_levenberg_marquardt_converges_where_newtons_multiple_shooting_stalls(tmp_path):
    """A long office route (72 length scales, T = 57 s): from a Leapfrog level of 20 arcs
    (tests/data/office_level.json), the final solver's multiple shooting with Newton alone
    stalls: its damped steps lower |F| only by steps of a few hundredths of Newton's. With
    Levenberg-Marquardt after it (the default), the same level converges within the final
    solver's budget of evaluations, polished at the final tolerance: an extremal that the
    planner found this way, its end state reached."""
    import json

    from leapfrog_planner.bvp.multiple_shooting import MultipleShootingSystem
    from leapfrog_planner.integrate.flow import Flow
    from leapfrog_planner.planning.leapfrog.arcs import Junctions
    from leapfrog_planner.planning.leapfrog.final import FinalSolver
    from leapfrog_planner.planning.leapfrog.local import LocalSolver
    from leapfrog_planner.planning.planner import Planner
    from leapfrog_planner.planning.scenario import scenario_from_dict
    from leapfrog_planner.roots import RootStatus
    from leapfrog_planner.world import office_maze, save_ros_map

    data = json.loads((Path(__file__).parent / "data" / "office_level.json").read_text())
    save_ros_map(office_maze(size=1000, seed=0), tmp_path / "office.yaml")
    table = {**data["scenario"], "map": {"file": str(tmp_path / "office.yaml")}}
    planner = Planner(scenario_from_dict(table))
    s = planner.settings.leapfrog
    t, X, lam0 = (np.array(data[k]) for k in ("t", "X", "lam0"))
    level = Junctions(t, X, lam0, lam0, np.zeros(len(lam0)))  # (only t, X, lam0 are read)
    local = LocalSolver(planner.problem, Flow(planner.problem, s.shooting.integrator), s)
    final = FinalSolver(local, planner.flow, X[0], X[-1], t[0], t[-1])

    newton = final.multiple_shooting(level, trust_region=False)
    assert not newton.success and newton.root.status is RootStatus.STALLED
    assert newton.root.residual_norm > 100 * final.coarse_root.tol
    found = final.multiple_shooting(level, trust_region=True)
    assert found.success and found.solver == "multiple-shooting"
    assert found.root.residual_norm <= s.final_shooting.root.tol  # the polish at 1e-10
    ms = MultipleShootingSystem(planner.flow, found.extremal.t, X[0], X[-1])
    w = ms.pack(found.extremal.lam0[0], np.hstack([found.extremal.X[:-1], found.extremal.lam0]))
    assert np.linalg.norm(ms.evaluate(w, False)[0]) <= 1e-9  # continuous, and at the goal
