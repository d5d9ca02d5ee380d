"""The JSON API of ``leapfrog serve``, in-process (Starlette's test client, real solver
processes): every endpoint, bad input (a 4xx with a one-line JSON message, the command line's
words), the time limit (a plan cut short at its share, or 504 and the worker replaced), the pool
bound (503) and a request superseded by a newer one of the same session (409)."""

from __future__ import annotations

import base64
import csv
import io
import json
import threading
import time
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

pytest.importorskip("starlette")
pytest.importorskip("httpx2")

from starlette.testclient import TestClient  # noqa: E402

from leapfrog_planner.planning.scenario import load_scenario  # noqa: E402
from leapfrog_planner.planning.scenario_map import ScenarioMap  # noqa: E402
from leapfrog_planner.web.app import create_app  # noqa: E402
from leapfrog_planner.web.maps import MAX_UPLOAD_BYTES  # noqa: E402
from leapfrog_planner.world import load_ros_map  # noqa: E402

CASE4 = load_scenario("paper-case-4").to_dict()
#: Options that make paper case 4 take seconds (16 initial paths, 256 junctions each).
HEAVY = {"initial_paths": 16, "partitions": 256}
#: A field of 1,600 discs: its initial paths alone take seconds, a step no time limit stops.
FIELD = {
    "name": "field",
    "horizon": 20.0,
    "start": [-1.0, 0.3, 0.0],
    "goal": [25.0, 23.7, 0.0],
    "obstacles": [
        {"center": [round(0.6 * i + 0.3 * (j % 2), 3), round(0.6 * j, 3)], "radius": 0.2}
        for i in range(40)
        for j in range(40)
    ],
}


@pytest.fixture(scope="module")
def client():
    with TestClient(create_app(workers=1, queue=4, time_limit=30.0)) as c:
        assert c.app.state.pool.wait_ready()  # the server answers at once; its solver is warming
        yield c


@pytest.fixture(scope="module")
def tight():
    """One solver process, nothing waiting, half a second per solve."""
    with TestClient(create_app(workers=1, queue=0, time_limit=0.5)) as c:
        assert c.app.state.pool.wait_ready()
        yield c


def _wait_for(client, key, value, timeout=20.0):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if client.get("/api/health").json()[key] >= value:
            return
        time.sleep(0.01)
    raise AssertionError(f"health {key} never reached {value}")


def _in_thread(client, body):
    out = {}
    th = threading.Thread(target=lambda: out.update(r=client.post("/api/plan", json=body)))
    th.start()
    return th, out


def test_page_and_assets_are_served(client):
    page = client.get("/")
    assert page.status_code == 200 and "text/html" in page.headers["content-type"]
    for asset in ("app.js", "app.css"):
        assert f"/static/{asset}" in page.text
        r = client.get(f"/static/{asset}")
        assert r.status_code == 200 and len(r.content) > 1000
    assert "https://" not in page.text  # nothing fetched from elsewhere


def test_builtin_scenarios_are_listed_in_the_file_layout(client):
    got = client.get("/api/scenarios").json()["scenarios"]
    assert [s["name"] for s in got] == [f"paper-case-{i}" for i in (1, 2, 3, 4)]
    assert got[3]["scenario"] == CASE4


def test_plan_gives_what_the_page_draws(client):
    r = client.post("/api/plan", json={"scenario": CASE4, "session": "a", "seq": 1})
    assert r.status_code == 200, r.text
    v = r.json()
    assert v["status"] == "converged" and v["optimal"]
    assert v["cost"] == pytest.approx(4.585248, abs=1e-6)
    assert v["energy"] + v["penalty"] == pytest.approx(v["cost"])
    assert v["min_clearance"] > 0
    assert v["cheaper_motion"] is None  # no other path left a cheaper motion
    path = v["path"]
    assert len(path["t"]) == len(path["x"]) == len(path["v"]) == len(path["reverse"]) == 401
    assert path["x"][0] == 0.0 and path["x"][-1] == pytest.approx(2.0, abs=1e-6)
    # the other runs, each with its path: the answer is the cheapest converged one
    converged = [a["cost"] for a in v["alternatives"] if a["status"] == "converged"]
    assert converged and min(converged) > v["cost"]
    assert all(len(a["path"]["x"]) > 1 for a in v["alternatives"])
    assert v["failed_alternatives"] == 0  # (more than 3 failed runs are counted, not listed)
    frames = v["frames"]
    assert frames[0]["sweep"] == 0 and len(frames) == v["sweeps"] + 1
    assert frames[-1]["cost"] == pytest.approx(v["cost"], rel=1e-3)
    assert len(frames[0]["x"]) == frames[0]["q"] + 1


def test_a_cheaper_motion_beside_a_converged_extremal_reaches_the_page():
    """A converged extremal with a cheaper collision-free motion seen beside it (a real one:
    tests/test_time_units.py): the page's view carries the number, from which the page marks
    the status as a caution; without one, null."""
    from dataclasses import replace

    from leapfrog_planner import plan
    from leapfrog_planner.web.view import result_view

    r = plan("paper-case-4")
    assert r.success and result_view(r)["cheaper_motion"] is None
    seen = replace(r, cheaper_motion=0.5 * r.cost)
    v = json.loads(json.dumps(result_view(seen)))
    assert v["status"] == "converged" and v["cheaper_motion"] == 0.5 * r.cost


def test_with_a_free_final_time_the_page_s_sweep_costs_include_the_price_of_time():
    """The page shows the result's cost (with k T) beside each sweep's: they include k T too."""
    from dataclasses import replace

    from leapfrog_planner import plan
    from leapfrog_planner.planning.status import FreeTimeReport
    from leapfrog_planner.web.view import result_view

    r = plan("paper-case-1", initial_paths=1)
    k, T = 0.5, r.task.horizon
    v = result_view(
        replace(r, cost=r.cost + k * T, free_time=FreeTimeReport(k, None, T, 0, "", ()))
    )
    assert v["frames"][0]["cost"] == pytest.approx(r.initial_cost + k * T)
    assert v["frames"][-1]["cost"] == pytest.approx(r.history[-1].cost + k * T)
    assert v["frames"][-1]["cost"] == pytest.approx(v["cost"], rel=1e-3)


def test_start_and_goal_not_connected_give_the_page_no_sweeps_to_draw():
    """No path was found: the page gets no frames (the initial path's were its two ends, drawn
    as a line through the wall) and no motion."""
    from tests.test_cli import ENCLOSED

    from leapfrog_planner import plan
    from leapfrog_planner.planning.scenario import load_scenario_text
    from leapfrog_planner.web.view import result_view

    v = json.loads(json.dumps(result_view(plan(load_scenario_text(ENCLOSED)))))
    assert v["status"] == "failed" and v["path"] is None and v["frames"] == []
    assert "not connected around the walls" in v["message"]


def test_options_are_used(client):
    options = {"method": "newton", "initial_paths": 1, "partitions": 4}
    v = client.post("/api/plan", json={"scenario": CASE4, "options": options}).json()
    assert v["method"] == "newton" and v["frames"][0]["q"] == 4


def test_a_failure_is_an_answer_with_its_message_and_best_motion(client):
    # a hundredth of the time: no extremal keeps clear of the obstacles
    sc = dict(CASE4, horizon=0.01, solver={"max_sweeps": 1})
    r = client.post("/api/plan", json={"scenario": sc, "options": {"initial_paths": 1}})
    assert r.status_code == 200
    v = r.json()
    assert v["status"] == "collides" and not v["optimal"] and not v["success"]
    assert v["message"].startswith("every extremal found passes through an obstacle")
    # the best collision-free motion computed: a Leapfrog iterate or the initial path
    assert (
        v["trajectory_source"].endswith(", not optimal")
        and "extremal" not in v["trajectory_source"]
    )
    assert len(v["path"]["x"]) == 401 and v["cost"] > 0


def test_scenario_download_plans_to_the_same_cost(client):
    body = {"scenario": CASE4, "options": {"partitions": 8, "method": "modified-newton"}}
    r = client.post("/api/toml", json=body)
    assert r.status_code == 200
    assert r.headers["content-disposition"] == 'attachment; filename="paper-case-4.toml"'
    from leapfrog_planner import plan
    from leapfrog_planner.planning.scenario import load_scenario_text

    sc = load_scenario_text(r.text, "download.toml")
    assert sc.solver == {"partitions": 8, "method": "modified-newton"}
    assert plan(sc).cost == pytest.approx(4.585248, abs=1e-6)


def test_result_downloads_are_the_command_lines_files(client):
    r = client.post("/api/result.json", json={"scenario": CASE4})
    assert r.status_code == 200 and r.headers["content-disposition"].endswith('.json"')
    d = r.json()
    assert d["schema"] == 3 and d["cost"] == pytest.approx(4.585248, abs=1e-6)
    assert d["scenario_file"]["obstacles"] == CASE4["obstacles"]
    r = client.post("/api/result.csv", json={"scenario": CASE4})
    assert r.status_code == 200 and r.headers["content-type"].startswith("text/csv")
    rows = list(csv.reader(io.StringIO(r.text)))
    assert rows[0] == [*"t x y theta v omega".split(), "linear_x", "angular_z"]
    assert len(rows) == 102


def test_a_scenario_file_is_opened_with_the_command_lines_messages(client):
    text = "\n".join(
        ["horizon = 1.0", "start = [0, 0, 0]", "goal = [2, 0, 0]", "[[obstacles]]"]
        + ["center = [1, 0.1]", "radius = 0.1", ""]
    )
    r = client.post("/api/open", json={"toml": text, "name": "room.toml"})
    assert r.status_code == 200
    assert r.json()["scenario"]["name"] == "room"
    r = client.post("/api/open", json={"toml": "horizon = -1\n", "name": "room.toml"})
    assert r.status_code == 400 and r.json() == {"error": "room.toml: start: missing required key"}
    r = client.post("/api/open", json={"toml": "horizon = = 1", "name": "room.toml"})
    assert r.status_code == 400 and r.json()["error"].startswith("room.toml: invalid TOML:")


#: A car with bounds on its speed and steering rate, a footprint and two waypoints: every
#: control of the page's Robot and Waypoints panels set.
CAR = {
    "name": "car-room",
    "horizon": 3.0,
    "start": [0.0, 0.0, 0.0, 0.0],
    "goal": [2.0, 0.0, 0.0, 0.0],
    "waypoints": [[0.7, 0.4], [1.4, 0.4]],
    "robot": {
        "model": "car",
        "wheelbase": 0.4,
        "radius": 0.05,
        "margin": 0.01,
        "v": [-1.0, 1.5],
        "sigma": [-2.0, 2.0],
    },
    "obstacles": [{"center": [1.0, 0.0], "radius": 0.15}],
}


def _robot(**keys) -> dict:
    return dict(CAR, robot=dict(CAR["robot"], **keys))


def test_the_models_are_listed_with_their_controls_and_parameters(client):
    got = {m["name"]: m for m in client.get("/api/models").json()["models"]}
    assert list(got) == ["unicycle", "diff-drive", "car"]
    assert got["unicycle"]["controls"] == ["v", "omega"] and got["unicycle"]["parameters"] == []
    assert got["diff-drive"]["controls"] == ["omega_R", "omega_L"]
    assert got["car"]["states"] == ["x", "y", "theta", "delta"]
    assert got["car"]["controls"] == ["v", "sigma", "omega"]
    parameters = {p["name"]: p for p in got["car"]["parameters"]}
    assert parameters["wheelbase"] == {"name": "wheelbase", "default": 0.5, "positive": True}
    for m in got.values():  # the planner's own bound parameters are not the robot's
        assert not any(p["name"].endswith(("_min", "_max", "_bounded")) for p in m["parameters"])


def test_a_plan_with_a_model_bounds_a_footprint_and_waypoints(client):
    """The car of the page's panels: converged, its footprint clear of the obstacle by the
    margin, its controls within their bounds (up to the smoothing), plotted by their names;
    the page's scenario file plans to the cost the page shows."""
    r = client.post("/api/plan", json={"scenario": CAR, "options": {"partitions": 8}})
    assert r.status_code == 200, r.text
    v = r.json()
    assert v["status"] == "converged" and v["optimal"] and v["model"] == "car"
    assert v["control_names"] == ["v", "sigma", "omega"]
    assert v["min_clearance"] >= CAR["robot"]["margin"]
    path = v["path"]
    centre = np.hypot(np.array(path["x"]) - 1.0, np.array(path["y"]))
    assert centre.min() > 0.15 + 0.05  # the disc of the robot never touches the obstacle
    for name in ("v", "sigma"):
        lo, hi = CAR["robot"][name]
        assert lo - 1e-3 <= min(path[name]) and max(path[name]) <= hi + 1e-3
    assert len(path["delta"]) == len(path["t"])  # the car's fourth state, drawn too
    text = client.post("/api/toml", json={"scenario": CAR, "options": {"partitions": 8}}).text
    from leapfrog_planner import plan
    from leapfrog_planner.planning.scenario import load_scenario_text

    sc = load_scenario_text(text, "car-room.toml")
    assert sc.to_dict()["robot"] == {**CAR["robot"], "turn_assist": 0.0}
    assert sc.waypoints.tolist() == CAR["waypoints"]
    assert plan(sc).cost == pytest.approx(v["cost"], rel=1e-9)


@pytest.mark.parametrize(
    ("scenario", "message"),
    [
        (
            _robot(wheel_radius=1.0),
            "scenario: robot.wheel_radius: unknown key for model 'car' (did you mean 'wheelbase'?",
        ),
        (
            dict(CAR, robot={"model": "diff-drive", "v": [0, 1]}),
            "scenario: robot.v: unknown key for model 'diff-drive' (allowed: model, radius,"
            " margin, wheel_radius, axle_length, omega_R, omega_L)",
        ),
        (
            _robot(model="tank"),
            "scenario: robot.model: unknown model 'tank' (known: unicycle, diff-drive, car)",
        ),
        (
            _robot(v=[1.5, -1.0]),
            "scenario: robot.v: expected [min, max] with min < max, got [1.5, -1.0]",
        ),
        (_robot(v=[0, 1, 2]), "scenario: robot.v: expected 2 numbers, got 3"),
        (_robot(sigma=["", 1]), "scenario: robot.sigma[0]: expected a number, got string ''"),
        (_robot(radius=-0.1), "scenario: robot.radius: must be >= 0, got -0.1"),
        (_robot(margin="wide"), "scenario: robot.margin: expected a number, got string 'wide'"),
        (_robot(wheelbase=0), "scenario: robot.wheelbase: must be > 0, got 0.0"),
        (dict(CAR, start=[0, 0, 0]), "scenario: start: expected 4 numbers, got 3"),
        (
            dict(CAR, waypoints=[[1.0, 0.1]]),
            "scenario: waypoints[0]: the robot (radius 0.05) at (1.0, 0.1) overlaps obstacles[0]",
        ),
        (dict(CAR, waypoints=[[1, 2, 3]]), "scenario: waypoints[0]: expected 2 numbers, got 3"),
    ],
)
def test_bad_robots_and_waypoints_are_a_400_with_the_message(client, scenario, message):
    r = client.post("/api/plan", json={"scenario": scenario})
    assert r.status_code == 400, r.text
    got = r.json()["error"]
    assert "\n" not in got and got.startswith(message)
    # the command line's words for the same file
    from leapfrog_planner.errors import ScenarioError
    from leapfrog_planner.planning.scenario import scenario_from_dict

    with pytest.raises(ScenarioError) as e:
        scenario_from_dict(scenario, "scenario")
    assert str(e.value) == got


@pytest.mark.parametrize(
    ("body", "message"),
    [
        (
            {"scenario": dict(CASE4, obstacles=[{"center": [1, 0.5], "radius": -1}])},
            "scenario: obstacles[0].radius: must be > 0, got -1.0",
        ),
        (
            {"scenario": dict(CASE4, horizon="abc")},
            "scenario: horizon: expected seconds or \"free\", got 'abc'",
        ),
        (
            {"scenario": dict(CASE4, start=[0.4, 0.05, 0])},
            "scenario: start: (0.4, 0.05) is inside obstacles[0] (center (0.4, 0.05), radius 0.1)",
        ),
        (
            {"scenario": dict(CASE4, colour="red")},
            "scenario: colour: unknown key (allowed: name, horizon, start, goal, waypoints, robot,"
            " penalty, solver, obstacles, map, polygons, walls, cost, time)",
        ),
        (
            {"scenario": CASE4, "options": {"method": "secant"}},
            "options.method: unknown method string 'secant' (known: newton, modified-newton,"
            " nleq-err)",
        ),
        (
            {"scenario": CASE4, "options": {"partitions": 1}},
            "options.partitions: must be an integer >= 2, got 1",
        ),
        (
            {"scenario": CASE4, "options": {"initial_paths": 2.5}},
            "options.initial_paths: expected an integer >= 1, got number 2.5",
        ),
        (
            {"scenario": CASE4, "options": {"partitions": 8.0}},
            "options.partitions: expected an integer >= 2, got number 8.0",
        ),
        (
            {"scenario": CASE4, "options": {"partitions": True}},
            "options.partitions: expected an integer >= 2, got boolean true",
        ),
        ({"scenario": CASE4, "options": {"speed": 1}}, "options: unknown key 'speed'"),
        ({"options": {}}, "request: scenario: missing required key"),
        ([1, 2], "request: expected a JSON object, got an array of 2"),
        (
            {"scenario": dict(CASE4, solver={"partitions": 1})},
            "scenario: solver.partitions: must be an integer >= 2, got 1",
        ),
    ],
)
def test_bad_input_is_a_400_with_the_message(client, body, message):
    r = client.post("/api/plan", json=body)
    assert r.status_code == 400, r.text
    got = r.json()["error"]
    assert "\n" not in got and got.startswith(message)


def test_malformed_requests_are_json_errors(client):
    r = client.post("/api/plan", content=b"{not json")
    assert r.status_code == 400 and r.json()["error"].startswith("request: not valid JSON")
    r = client.post("/api/plan", content=b"\xff\xfe")
    assert r.status_code == 400 and "not UTF-8" in r.json()["error"]
    r = client.post("/api/plan", content=b" " * (2 * 2**20 + 1))
    assert r.status_code == 413
    assert client.get("/api/nothing").json() == {"error": "Not Found"}
    assert client.get("/api/plan").status_code == 405
    for path in ("/api/toml", "/api/result.json", "/api/result.csv", "/api/open"):
        r = client.post(path, json=[])
        assert r.status_code == 400 and "error" in r.json()


def test_health_reports_the_pool(client):
    h = client.get("/api/health").json()
    assert h["workers"] == 1 and h["capacity"] == 5 and h["busy"] == 0 and len(h["pids"]) == 1


def test_an_older_waiting_request_is_superseded(client):
    first, a = _in_thread(client, {"scenario": CASE4, "options": HEAVY, "session": "s", "seq": 1})
    _wait_for(client, "busy", 1)
    second, b = _in_thread(client, {"scenario": CASE4, "session": "s", "seq": 2})
    _wait_for(client, "admitted", 2)
    c = client.post("/api/plan", json={"scenario": CASE4, "session": "s", "seq": 3})
    first.join()
    second.join()
    assert a["r"].status_code == 200
    assert b["r"].status_code == 409 and b["r"].json()["error"] == "superseded by a newer request"
    assert c.status_code == 200 and c.json()["cost"] == pytest.approx(4.585248, abs=1e-6)


def test_a_plan_past_its_share_of_the_time_limit_ends_with_its_best_answer():
    """A plan is given 0.8 of the server's limit as its own: one that would take minutes comes
    back with the best motion found by then, said to be cut short, not as a 504. (One path at
    a time, 8 s in all without a limit; the runs under way end their sweep and final solve past
    the plan's limit: 16 runs of 1,024 junctions at once overran the server's fifth.)"""
    with TestClient(create_app(workers=1, queue=0, time_limit=5.0, threads=1)) as c:
        assert c.app.state.pool.wait_ready()
        r = c.post("/api/plan", json={"scenario": CASE4, "options": HEAVY})
    assert r.status_code == 200, r.text
    v = r.json()
    assert "the time limit of 4 s cut the search short" in v["message"]
    assert v["path"] is not None and (v["status"] == "converged") == v["success"]


def test_a_solve_past_the_time_limit_is_stopped_and_its_worker_replaced(tight):
    pid = tight.get("/api/health").json()["pids"]
    t0 = time.monotonic()
    r = tight.post("/api/plan", json={"scenario": FIELD})
    assert time.monotonic() - t0 < 3.0
    assert r.status_code == 504
    assert r.json() == {"error": "time limit: the solve ran past 0.5 s and was stopped"}
    _wait_for(tight, "ready", 1)
    assert tight.get("/api/health").json()["pids"] != pid
    # The new worker plans: a straight line, well inside the half second even on a loaded machine
    line = {"name": "line", "horizon": 1.0, "start": [0.0, 0.0, 0.0], "goal": [1.0, 0.0, 0.0]}
    r = tight.post("/api/plan", json={"scenario": line, "options": {"initial_paths": 1}})
    assert r.status_code == 200, r.text


def test_requests_beyond_the_pool_get_503(tight):
    _wait_for(tight, "ready", 1)
    first, a = _in_thread(tight, {"scenario": FIELD})
    _wait_for(tight, "busy", 1)
    r = tight.post("/api/plan", json={"scenario": CASE4})
    first.join()
    assert r.status_code == 503
    assert r.json()["error"].startswith("busy: 1 requests are being solved or waiting (at most 1)")
    assert a["r"].status_code == 504


# ------------------------------------------------------------------ maps opened on the page

MAPS = Path(__file__).parent / "data" / "maps"
#: Between two rows of the TurtleBot3 arena's pillars (1.1 m apart about the origin).
ARENA = {
    "name": "arena",
    "horizon": 6.4,
    "start": [-1.6, -0.55, 0.0],
    "goal": [1.6, -0.55, 0.0],
    "robot": {"radius": 0.2},
    "penalty": {"weight": 1.0, "exponent": 2},
}


def _file(name: str, data: bytes | None = None) -> dict:
    raw = (MAPS / name).read_bytes() if data is None else data
    return {"name": name, "data": base64.b64encode(raw).decode()}


def _open_map(client, yaml="tb3_sandbox.yaml", image="tb3_sandbox.pgm"):
    return client.post("/api/maps", json={"yaml": _file(yaml), "image": _file(image)})


@pytest.fixture(scope="module")
def arena(client):
    r = _open_map(client)
    assert r.status_code == 200, r.text
    return r.json()


def test_a_map_is_opened_and_drawn_as_ros_shows_it(client, arena):
    assert arena["name"] == "tb3_sandbox.yaml"
    assert (arena["columns"], arena["rows"], arena["resolution"]) == (384, 384, 0.05)
    assert arena["origin"] == [-10.0, -10.0, 0.0]
    assert arena["extent"] == pytest.approx([-10.0, 9.2, -10.0, 9.2])
    xmin, xmax, ymin, ymax = arena["known"]  # the arena, not the unknown square about it
    assert -3.5 < xmin < -2.5 < 2.5 < xmax < 3.5 and -3.5 < ymin < -2.5 < 2.5 < ymax < 3.5
    assert arena["radius"] == 0.2 and arena["speed"] == 0.5
    r = client.get(arena["image"])
    assert r.status_code == 200 and r.headers["content-type"] == "image/png"
    image = Image.open(io.BytesIO(r.content))
    assert image.size == (384, 384) and image.mode == "L"
    assert {v for _, v in image.getcolors()} == {0, 205, 254}  # occupied, unknown, free
    occ = load_ros_map(MAPS / "tb3_sandbox.yaml")
    rows = np.asarray(image)[::-1]  # the image's top row is the map's last
    assert np.array_equal(rows == 0, occ.data == 100) and np.array_equal(rows == 205, occ.data < 0)
    assert client.get("/api/maps/nothing.png").status_code == 404
    # the suggested ends: in free cells with room for the robot, a few metres apart
    world = ScenarioMap(str(MAPS / "tb3_sandbox.yaml"), occupancy=occ).obstacles(0.2)
    start, goal = np.array(arena["start"]), np.array(arena["goal"])
    assert (world.clearance_at(np.array([start[:2], goal[:2]])) > 0.2).all()
    assert 2.0 < np.hypot(*(goal - start)[:2]) < 4.0


def test_a_plan_on_the_map_converges_clear_of_its_cells(client, arena):
    sc = dict(ARENA, map={"id": arena["id"]})
    r = client.post("/api/plan", json={"scenario": sc})
    assert r.status_code == 200, r.text
    v = r.json()
    assert v["status"] == "converged" and v["optimal"] and v["min_clearance"] > 0
    occ = load_ros_map(MAPS / "tb3_sandbox.yaml")
    x, y = np.array(v["path"]["x"]), np.array(v["path"]["y"])
    assert (occ.value_at(x, y) == 0).all()  # every point of the path in a free cell
    world = ScenarioMap(str(MAPS / "tb3_sandbox.yaml"), occupancy=occ).obstacles(0.2)
    assert world.clearance_at(np.stack([x, y], axis=1)).min() > 0  # the robot's disc too
    assert x[0] == pytest.approx(-1.6) and x[-1] == pytest.approx(1.6, abs=1e-6)


def test_the_scenario_and_result_downloads_name_the_maps_file(client, arena, tmp_path):
    sc = dict(ARENA, map={"id": arena["id"], "unknown": "free"})
    text = client.post("/api/toml", json={"scenario": sc}).text
    assert '[map]\nfile = "tb3_sandbox.yaml"\nunknown = "free"\n' in text
    assert "leapfrog-map-" not in text  # no server folder in the file
    r = client.post("/api/open", json={"toml": text, "name": "arena.toml"})
    assert r.status_code == 200
    assert r.json()["map"] == {"unknown": "free", "file": "tb3_sandbox.yaml"}
    assert "map" not in r.json()["scenario"]  # the page opens the map's files itself
    result = client.post("/api/result.json", json={"scenario": sc})
    assert result.status_code == 200 and "leapfrog-map-" not in result.text
    assert result.json()["scenario_file"]["map"]["file"] == "tb3_sandbox.yaml"


@pytest.mark.parametrize(
    ("files", "message"),
    [
        (
            {"yaml": _file("bad.yaml", b"image: ["), "image": "tb3_sandbox.pgm"},
            "bad.yaml: invalid YAML: expected the node content, but found '<stream end>'",
        ),
        (
            {
                "yaml": _file("m.yaml", b"image: tb3_sandbox.pgm\n"),
                "image": "tb3_sandbox.pgm",
            },
            "m.yaml: resolution: missing required key",
        ),
        ({"image": "tb3_sandbox.pgm"}, "map: yaml: missing: choose the map's YAML file"),
        (
            {"yaml": "tb3_sandbox.yaml", "image": None},
            "map: image: missing: choose the map's image (PGM or PNG) with its YAML file",
        ),
        (
            {"yaml": "tb3_sandbox.yaml", "image": "depot.pgm"},
            "tb3_sandbox.yaml: image: names 'tb3_sandbox.pgm', but the image chosen is 'depot.pgm'",
        ),
        (
            {"yaml": "depot.yaml", "image": _file("depot.pgm", b"P5 10 10")},
            "depot.yaml: image: 'depot.pgm': not a PGM image",
        ),
        (
            {"yaml": "depot.yaml", "image": {"name": "depot.pgm", "data": "%%"}},
            "map: image.data: not valid base64",
        ),
    ],
)
def test_bad_map_files_are_a_400_with_the_loaders_message(client, files, message):
    body = {}
    for key, f in files.items():
        body[key] = _file(f) if isinstance(f, str) else f
    r = client.post("/api/maps", json=body)
    assert r.status_code == 400, r.text
    got = r.json()["error"]
    assert "\n" not in got and got.startswith(message)
    assert "leapfrog-map-" not in got and "/tmp" not in got  # the files as the user named them


def test_a_map_upload_too_large_is_refused_at_once(client):
    r = client.post("/api/maps", content=b" " * (MAX_UPLOAD_BYTES + 1))
    assert r.status_code == 413
    assert r.json() == {"error": "map: the YAML file and its image are larger than 64 MB"}


def test_a_plan_names_its_map_by_an_id_the_server_keeps(client, arena):
    def error(map_table):
        r = client.post("/api/plan", json={"scenario": dict(ARENA, map=map_table)})
        assert r.status_code == 400, r.text
        return r.json()["error"]

    assert error({"id": "gone"}).startswith(
        "scenario: map.id: no map 'gone' on the server (it keeps the last 4 opened, while it"
        " runs): open the map again"
    )
    assert error({"file": "/etc/hostname"}).startswith(
        "scenario: map.file: unknown key: the page names a map by its id"
    )
    assert error({"id": arena["id"], "unknown": "maybe"}).startswith("scenario: map.unknown:")
    assert error({"id": arena["id"]} | {"x": 1}).startswith("scenario: map.x: unknown key")
    r = client.post(
        "/api/plan", json={"scenario": dict(ARENA, start=[0, 0, 0], map={"id": arena["id"]})}
    )
    assert r.json()["error"] == "scenario: start: (0.0, 0.0) is in an unknown cell of the map"
    # the oldest of more than four maps is forgotten, its folder removed
    first = _open_map(client, "tiny_yaw.yaml", "tiny.png").json()["id"]
    folder = client.app.state.maps.find(first).folder
    for _ in range(4):
        assert _open_map(client, "tiny_yaw.yaml", "tiny.png").status_code == 200
    assert error({"id": first}).startswith(f"scenario: map.id: no map '{first}' on the server")
    assert not Path(folder).exists()


def _asgi_post(app, receive) -> int:
    """POST /api/plan straight to the application with ``receive`` feeding the body; the
    response's status."""
    import anyio

    sent = []

    async def send(message):
        sent.append(message)

    scope = {
        "type": "http", "asgi": {"version": "3.0"}, "http_version": "1.1", "method": "POST",
        "scheme": "http", "path": "/api/plan", "raw_path": b"/api/plan", "query_string": b"",
        "root_path": "", "headers": [(b"content-type", b"application/json")],
        "client": ("127.0.0.1", 1), "server": ("127.0.0.1", 80),
    }  # fmt: skip
    anyio.run(app, scope, receive, send)
    return next(m for m in sent if m["type"] == "http.response.start")["status"]


def test_a_body_that_dribbles_in_is_cut_off(client, monkeypatch):
    import anyio

    from leapfrog_planner.web import app as app_module

    monkeypatch.setattr(app_module, "BODY_SECONDS", 0.3)

    async def receive():
        await anyio.sleep(0.1)
        return {"type": "http.request", "body": b" ", "more_body": True}

    assert _asgi_post(client.app, receive) == 408


def test_a_body_too_large_is_refused_while_it_arrives(client):
    """No Content-Length, 64 kB chunks without end: refused after the limit, not read whole."""
    chunks = []

    async def receive():
        chunks.append(1)
        return {"type": "http.request", "body": b" " * 65536, "more_body": True}

    assert _asgi_post(client.app, receive) == 413
    assert len(chunks) <= 2 * 2**20 // 65536 + 2
