"""What a ROS user plays: the body velocities of a motion (in the CSV and on /cmd_vel) agree with
the path they drive, and the ROS 2 bag of ``leapfrog export --bag``, read back with rosbags,
holds the path, the poses and the commands of the result, the same bytes every time."""

from __future__ import annotations

import csv
import math
import os
import subprocess
import sys
from dataclasses import replace

import numpy as np
import pytest
import yaml
from tests.test_cli import cli_env

from leapfrog_planner.cli.main import main
from leapfrog_planner.planning import ros_bag
from leapfrog_planner.planning.export import (
    ExportError,
    motion_columns,
    ros_path,
    ros_stamp,
    write_csv,
)
from leapfrog_planner.planning.planner import plan
from leapfrog_planner.planning.ros_bag import write_bag
from leapfrog_planner.planning.scenario import load_scenario

rosbags = pytest.importorskip("rosbags")
from rosbags.rosbag2 import Reader  # noqa: E402
from rosbags.typesys import Stores, get_typestore  # noqa: E402

DT = 0.01


@pytest.fixture(scope="module")
def case4():
    return plan("paper-case-4", threads=1)


def _read(path) -> dict[str, list]:
    """``{topic: [(bag time in ns, message), ...]}`` and the reader's view of the bag."""
    store = get_typestore(Stores.ROS2_JAZZY)
    out = {}
    with Reader(path) as reader:
        for conn, ns, raw in reader.messages():
            out.setdefault(conn.topic, []).append((ns, store.deserialize_cdr(raw, conn.msgtype)))
        out["types"] = {c.topic: c.msgtype for c in reader.connections}
    info = yaml.safe_load((path / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    out["storage"], out["version"] = info["storage_identifier"], info["version"]
    return out


@pytest.fixture(scope="module")
def bag(case4, tmp_path_factory):
    path = tmp_path_factory.mktemp("bags") / "c4"
    write_bag(case4, path, DT)
    return _read(path)


def test_the_bag_holds_the_path_once_and_a_pose_and_a_command_every_dt(bag):
    assert bag["types"] == {
        "/plan": "nav_msgs/msg/Path",
        "/pose": "geometry_msgs/msg/PoseStamped",
        "/cmd_vel": "geometry_msgs/msg/Twist",
    }
    assert bag["storage"] == "sqlite3" and bag["version"] == 8  # what Humble plays as installed
    assert [len(bag[k]) for k in ("/plan", "/pose", "/cmd_vel")] == [1, 101, 101]
    times = [ns for ns, _ in bag["/pose"]]
    assert times == [round(k * DT * 1e9) for k in range(101)]
    assert [ns for ns, _ in bag["/cmd_vel"]] == times and bag["/plan"][0][0] == 0
    for ns, msg in bag["/pose"]:
        assert msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec == ns
        assert msg.header.frame_id == "map"


def _pose_values(msg) -> tuple:
    p, q = msg.pose.position, msg.pose.orientation
    return (p.x, p.y, p.z, q.x, q.y, q.z, q.w)


def test_the_poses_are_the_ros_paths_and_the_csvs(case4, bag, tmp_path):
    expected = ros_path(case4, DT)
    plan_msg = bag["/plan"][0][1]
    assert plan_msg.header.frame_id == "map" and len(plan_msg.poses) == len(expected["poses"])
    for msg, (_, pose), want in zip(plan_msg.poses, bag["/pose"], expected["poses"], strict=True):
        p, q = want["pose"]["position"], want["pose"]["orientation"]
        values = (p["x"], p["y"], p["z"], q["x"], q["y"], q["z"], q["w"])
        assert _pose_values(msg) == _pose_values(pose) == values
        stamp = (msg.header.stamp.sec, msg.header.stamp.nanosec)
        assert stamp == (want["header"]["stamp"]["sec"], want["header"]["stamp"]["nanosec"])
    write_csv(case4, tmp_path / "c4.csv", DT)
    rows = list(csv.DictReader((tmp_path / "c4.csv").open()))
    for row, (_, pose) in zip(rows, bag["/pose"], strict=True):
        theta = float(row["theta"])
        assert (pose.pose.position.x, pose.pose.position.y) == (float(row["x"]), float(row["y"]))
        assert pose.pose.orientation.z == math.sin(theta / 2)


def test_the_commands_are_the_velocity_columns_and_stop_at_the_end(case4, bag):
    cols = motion_columns(case4, DT)
    twists = [msg for _, msg in bag["/cmd_vel"]]
    got = np.array([[m.linear.x, m.angular.z] for m in twists])
    np.testing.assert_array_equal(got[:-1, 0], cols["linear_x"][:-1])
    np.testing.assert_array_equal(got[:-1, 1], cols["angular_z"][:-1])
    assert got[-1].tolist() == [0.0, 0.0]  # the base stops at the end
    assert all(m.linear.y == m.linear.z == m.angular.x == m.angular.y == 0.0 for m in twists)
    # the unicycle's controls are its forward speed and turn rate
    np.testing.assert_allclose(cols["linear_x"], cols["v"], rtol=0, atol=1e-14)
    np.testing.assert_array_equal(cols["angular_z"], cols["omega"])


def _case1(model: str, params: dict, extra: int):
    base = load_scenario("paper-case-1")
    sc = replace(
        base,
        name=f"{model}-1",
        model=model,
        model_parameters=params,
        start=[*base.start, *[0.0] * extra],
        goal=[*base.goal, *[0.0] * extra],
    )
    return plan(sc, threads=1)


@pytest.fixture(scope="module")
def results(case4):
    return {
        "unicycle": case4,
        "diff-drive": _case1("diff-drive", {"wheel_radius": 0.5, "axle_length": 1.0}, 0),
        "car": _case1("car", {"wheelbase": 0.4}, 1),
    }


@pytest.mark.parametrize("model", ["unicycle", "diff-drive", "car"])
def test_the_velocities_drive_the_path(results, model):
    """Central differences of x, y, theta on a grid of 1 ms: the forward speed is the speed
    along the heading, nothing moves sideways, and the turn rate is theta's. To 3e-4 of the
    largest speeds: the path is a spline through the integrator's rows, whose derivative is off
    by up to 1e-4 of them (as much on a grid of 0.1 ms)."""
    r = results[model]
    assert r.success, r.message
    cols = motion_columns(r, 1e-3)
    t = cols["t"]
    dx, dy, dth = (np.gradient(cols[k], t)[1:-1] for k in ("x", "y", "theta"))
    th = cols["theta"][1:-1]
    v, w = cols["linear_x"][1:-1], cols["angular_z"][1:-1]
    tol = 3e-4 * (np.abs(v).max() + np.abs(w).max())
    assert np.abs(dx * np.cos(th) + dy * np.sin(th) - v).max() < tol
    assert np.abs(-dx * np.sin(th) + dy * np.cos(th)).max() < tol
    assert np.abs(dth - w).max() < tol


def test_each_model_gives_its_own_velocities(results):
    """From the model's equations at the scenario's parameters: the differential drive's wheel
    speeds (radius 0.5, axle 1), the car's speed and steering (wheelbase 0.4)."""
    dd = motion_columns(results["diff-drive"], DT)
    np.testing.assert_allclose(dd["linear_x"], 0.5 * (dd["omega_R"] + dd["omega_L"]) / 2)
    np.testing.assert_allclose(dd["angular_z"], 0.5 * (dd["omega_R"] - dd["omega_L"]) / 1.0)
    car = motion_columns(results["car"], DT)
    np.testing.assert_allclose(car["linear_x"], car["v"], atol=1e-14)
    np.testing.assert_allclose(car["angular_z"], car["v"] * np.tan(car["delta"]) / 0.4)
    assert np.abs(car["angular_z"]).max() > 1.0  # it turns, by steering


def test_the_same_result_gives_the_same_bytes(case4, tmp_path):
    for folder in ("a", "b"):
        (tmp_path / folder).mkdir()
        write_bag(case4, tmp_path / folder / "bag", 0.05)
        write_bag(case4, tmp_path / folder / "mcap", 0.05, storage="mcap")
    for name in ("bag/bag.db3", "bag/metadata.yaml", "mcap/mcap.mcap", "mcap/metadata.yaml"):
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes()


def test_stamped_commands_mcap_and_a_start_time(case4, tmp_path):
    start = 1_700_000_000.25
    write_bag(case4, tmp_path / "b", 0.25, "odom", start=start, stamped=True, storage="mcap")
    got = _read(tmp_path / "b")
    assert got["storage"] == "mcap" and got["types"]["/cmd_vel"].endswith("TwistStamped")
    t0 = 1_700_000_000_250_000_000
    assert [ns for ns, _ in got["/cmd_vel"]] == [t0 + k * 250_000_000 for k in range(5)]
    for ns, msg in got["/cmd_vel"]:
        assert msg.header.frame_id == "base_link"
        assert msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec == ns
    assert got["/plan"][0][1].header.frame_id == "odom"
    cols = motion_columns(case4, 0.25)
    assert got["/cmd_vel"][1][1].twist.angular.z == cols["angular_z"][1]


def test_a_stamp_just_below_a_second_is_that_second():
    assert ros_stamp(0.29 * 100) == {"sec": 29, "nanosec": 0}  # 28.999999999999996
    assert ros_stamp(1.5, 10**9) == {"sec": 2, "nanosec": 500_000_000}


def _cli(args, capsys) -> tuple[int, str]:
    with pytest.raises(SystemExit) as e:
        main(args)
    return e.value.code, capsys.readouterr().err


@pytest.fixture(scope="module")
def saved(case4, tmp_path_factory):
    path = tmp_path_factory.mktemp("saved") / "c4.json"
    case4.save_json(path)
    return path


def test_the_command_line_writes_a_bag_and_refuses_an_existing_folder(saved, tmp_path, capsys):
    out = tmp_path / "c4-bag"
    code, err = _cli(["export", str(saved), "--bag", str(out), "--dt", "0.1"], capsys)
    assert code == 0, err
    counts = {k: len(v) for k, v in _read(out).items() if k.startswith("/")}
    assert counts == {"/plan": 1, "/pose": 11, "/cmd_vel": 11}
    before = sorted(os.listdir(out))
    code, err = _cli(["export", str(saved), "--bag", str(out), "--csv", "x.csv"], capsys)
    assert code == 2 and err.count("\n") == 1
    assert "exists" in err and "--bag" in err
    assert sorted(os.listdir(out)) == before and os.listdir(tmp_path) == ["c4-bag"]


def test_without_rosbags_one_line_says_how_to_install_it(saved, tmp_path, capsys, monkeypatch):
    for name in ("rosbags", "rosbags.rosbag2", "rosbags.typesys"):
        monkeypatch.setitem(sys.modules, name, None)
    code, err = _cli(["export", str(saved), "--bag", str(tmp_path / "b")], capsys)
    assert code == 2 and err.count("\n") == 1
    assert "pip install 'leapfrog-planner[ros]'" in err
    assert os.listdir(tmp_path) == []
    with pytest.raises(ExportError, match="rosbags"):
        write_bag(None, tmp_path / "b", 0.1)


def test_the_library_and_the_command_line_import_without_rosbags():
    code = (
        "import sys; sys.modules['rosbags'] = None; "
        "import leapfrog_planner.planning.ros_bag, leapfrog_planner.cli.results"
    )
    p = subprocess.run([sys.executable, "-c", code], env=cli_env(), capture_output=True)
    assert p.returncode == 0, p.stderr


def test_a_bag_failing_midway_leaves_no_folder(case4, tmp_path, monkeypatch):
    def fail(folder, topics, storage):
        folder.mkdir()
        (folder / "half.db3").write_bytes(b"half")
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(ros_bag, "_write", fail)
    with pytest.raises(OSError, match="No space"):
        write_bag(case4, tmp_path / "bag", 0.1)
    assert os.listdir(tmp_path) == []
    with pytest.raises(ExportError, match="exists"):
        write_bag(case4, tmp_path, 0.1)
