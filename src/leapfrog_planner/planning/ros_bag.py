"""A result's motion as a ROS 2 bag that ``ros2 bag play`` replays, written without ROS by the
optional package ``rosbags`` (``pip install 'leapfrog-planner[ros]'``), imported only here.

The bag (a folder) holds, on the uniform grid of step ``dt`` (times from ``start_ns``):

- ``/plan``, ``nav_msgs/msg/Path``: once, at the start, every pose of the motion (the poses of
  :func:`.export.ros_path`); offered transient-local, so a late subscriber (RViz) still gets it;
- ``/pose``, ``geometry_msgs/msg/PoseStamped``: the pose at each time;
- ``/cmd_vel``, ``geometry_msgs/msg/Twist`` (what Humble's controllers and Nav2 take), or
  ``TwistStamped`` in the frame ``base_frame`` (which ros2_control's diff-drive controller
  requires from Jazzy on, and Nav2 takes with ``enable_stamped_cmd_vel``): at each time but the
  last the body velocities ``linear_x``, ``angular_z`` of
  :func:`.export.body_velocities`, held until the next (what a base does with them); at the end
  a zero command, so that the base stops.

Storage: SQLite 3 (``.db3``), metadata version 8, by default: the one format ROS 2 Humble
plays as installed (MCAP needs its plugin there; Jazzy plays both, MCAP its default for
recording, and version 9 metadata, which Humble cannot parse). ``storage="mcap"`` writes MCAP.
The same result, ``dt`` and options give the same bytes: no clock time is written.
"""

from __future__ import annotations

import math
import os
import shutil
import tempfile
from pathlib import Path

from .export import ExportError, heading_quaternion, motion_columns, ros_stamp

INSTALL = "pip install 'leapfrog-planner[ros]'"
STORAGES = ("sqlite3", "mcap")
#: The messages' definitions, as ROS 2 Jazzy has them (those used here are alike since Humble).
STORE = "ROS2_JAZZY"
BAG_VERSION = 8  # read by Humble (its QoS written as numbers) and by every later distribution


def require_rosbags() -> None:
    """Raise :class:`.export.ExportError` saying how to install ``rosbags`` when it is missing."""
    try:
        import rosbags.rosbag2  # noqa: F401
        import rosbags.typesys  # noqa: F401
    except ImportError:
        raise ExportError(f"a ROS 2 bag needs the package rosbags: {INSTALL}") from None


def _qos(latched: bool):
    """Reliable, keep the last 10; transient-local for a message sent once."""
    from rosbags.interfaces import (
        Qos,
        QosDurability,
        QosHistory,
        QosLiveliness,
        QosReliability,
        QosTime,
    )

    zero = QosTime(0, 0)  # unspecified: the middleware's default (infinite)
    durability = QosDurability.TRANSIENT_LOCAL if latched else QosDurability.VOLATILE
    return Qos(
        QosHistory.KEEP_LAST, 10, QosReliability.RELIABLE, durability,
        zero, zero, QosLiveliness.AUTOMATIC, zero, False,
    )  # fmt: skip


class _Messages:
    """The typestore's message classes, built from plain values."""

    def __init__(self, store):
        self.store, self.types = store, store.types

    def header(self, t: float, start_ns: int, frame_id: str):
        stamp = self.types["builtin_interfaces/msg/Time"](**ros_stamp(t, start_ns))
        return self.types["std_msgs/msg/Header"](stamp=stamp, frame_id=frame_id)

    def pose(self, t, x, y, theta, start_ns, frame_id):
        g = "geometry_msgs/msg/"
        pose = self.types[g + "Pose"](
            position=self.types[g + "Point"](x=x, y=y, z=0.0),
            orientation=self.types[g + "Quaternion"](**heading_quaternion(theta)),
        )
        return self.types[g + "PoseStamped"](header=self.header(t, start_ns, frame_id), pose=pose)

    def twist(self, v: float, omega: float):
        vector = self.types["geometry_msgs/msg/Vector3"]
        return self.types["geometry_msgs/msg/Twist"](
            linear=vector(x=v, y=0.0, z=0.0), angular=vector(x=0.0, y=0.0, z=omega)
        )


def bag_messages(result, dt: float, frame_id="map", start_ns=0, stamped=False, base_frame=""):
    """``{topic: (type, [(time in ns, message), ...])}``: what :func:`write_bag` writes, as the
    typestore's message objects."""
    from rosbags.typesys import Stores, get_typestore

    if tuple(result.state_names[:3]) != ("x", "y", "theta"):
        raise ExportError(f"a ROS bag needs states x, y, theta; got {result.state_names}")
    cols = motion_columns(result, dt)
    if "linear_x" not in cols:
        raise ExportError(f"model {result.model!r}: no body velocities for /cmd_vel")
    m = _Messages(get_typestore(getattr(Stores, STORE)))
    t = cols["t"].tolist()
    stamps = [ros_stamp(s, start_ns) for s in t]
    times = [s["sec"] * 1_000_000_000 + s["nanosec"] for s in stamps]
    rows = zip(t, *(cols[k].tolist() for k in ("x", "y", "theta")), strict=True)
    poses = [m.pose(*row, start_ns, frame_id) for row in rows]
    plan = m.types["nav_msgs/msg/Path"](header=m.header(t[0], start_ns, frame_id), poses=poses)
    speeds = zip(cols["linear_x"].tolist(), cols["angular_z"].tolist(), strict=True)
    twists = [m.twist(v, w) for v, w in speeds][:-1] + [m.twist(0.0, 0.0)]  # stop at the end
    twist_type = "geometry_msgs/msg/Twist"
    if stamped:
        twist_type += "Stamped"
        twists = [
            m.types[twist_type](header=m.header(s, start_ns, base_frame), twist=tw)
            for s, tw in zip(t, twists, strict=True)
        ]
    return {
        "/plan": ("nav_msgs/msg/Path", [(times[0], plan)]),
        "/pose": ("geometry_msgs/msg/PoseStamped", list(zip(times, poses, strict=True))),
        "/cmd_vel": (twist_type, list(zip(times, twists, strict=True))),
    }


def _write(folder: Path, topics: dict, storage: str) -> None:
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(getattr(Stores, STORE))
    plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
    with Writer(folder, version=BAG_VERSION, storage_plugin=plugin) as writer:
        for topic, (msgtype, messages) in topics.items():
            qos = [_qos(latched=topic == "/plan")]
            conn = writer.add_connection(topic, msgtype, typestore=store, offered_qos_profiles=qos)
            for ns, msg in messages:
                writer.write(conn, ns, store.serialize_cdr(msg, msgtype))


def write_bag(
    result,
    path,
    dt: float,
    frame_id: str = "map",
    *,
    start: float = 0.0,
    stamped: bool = False,
    base_frame: str = "base_link",
    storage: str = "sqlite3",
) -> Path:
    """Write the ROS 2 bag of the module's documentation to the new folder ``path``, times from
    ``start`` (seconds since the epoch; 0 by default). The folder must not exist; the bag is
    written beside it under a temporary name and renamed when whole, so no half bag stays."""
    require_rosbags()
    if storage not in STORAGES:
        raise ExportError(f"storage must be one of {', '.join(STORAGES)}, got {storage!r}")
    if not (isinstance(start, int | float) and 0 <= start < 2**63 / 1e9):
        raise ExportError(f"the start time must be in [0, 9.2e9) seconds, got {start!r}")
    path = Path(path)
    if os.path.lexists(path):
        raise ExportError(f"{str(path)!r} exists; a bag is written to a new folder")
    start_ns = math.floor(start) * 1_000_000_000 + round((start % 1) * 1e9)  # exact to the ns
    topics = bag_messages(result, dt, frame_id, start_ns, stamped, base_frame)
    parent = path.parent if str(path.parent) else Path(".")
    tmp = Path(tempfile.mkdtemp(dir=parent, prefix=f".{path.name}."))
    try:
        _write(tmp / path.name, topics, storage)  # the files are named after the folder
        if os.path.lexists(path):  # made meanwhile: never replaced
            raise ExportError(f"{str(path)!r} exists; a bag is written to a new folder")
        os.rename(tmp / path.name, path)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return path
