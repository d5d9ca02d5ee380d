"""Maps opened on the page of ``leapfrog serve``: a ROS map_server YAML file and its image,
uploaded together, written into a private temporary folder and read by the project's loader
(every check of :func:`~leapfrog_planner.world.load_ros_map` applies, its one-line message
naming the files as the user chose them). The server keeps the last few maps (:data:`MAX_MAPS`)
by an id it gives the page; a plan names its map by that id.

``POST /api/maps`` ``{"yaml": {"name", "data"}, "image": {"name", "data"}}`` (``data``: the
file's bytes in base64) answers with what the page needs to draw the map and place the robot
(:meth:`LoadedMap.info`); ``GET /api/maps/<id>.png`` is the map drawn as ROS shows it, one
pixel a cell.
"""

from __future__ import annotations

import base64
import binascii
import io
import math
import os
import re
import secrets
import shutil
import tempfile
import threading
from collections import OrderedDict
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import ScenarioError, describe
from ..planning.scenario_map import MAP_KEYS, ScenarioMap
from ..world import FREE, UNKNOWN, OccupancyMap, load_ros_map
from ..world.ros_map import read_map_yaml
from .schema import RequestError

#: Maps kept at once; opening one more forgets the least recently used.
MAX_MAPS = 4
#: Maps as a scenario's ``[map]`` kept with their field (one robot radius each).
MAX_BUILT = 8
#: The largest upload: the YAML file and its image together, before base64.
MAX_MAP_BYTES = 64 * 2**20
#: The request body's bound (base64 makes 4 bytes of 3, plus the JSON around it).
MAX_UPLOAD_BYTES = MAX_MAP_BYTES * 4 // 3 + 2**16

#: The robot radius the page sets when a map is opened, and the speed of its horizon.
DEFAULT_RADIUS = 0.2
HORIZON_SPEED = 0.5
#: Room left about the suggested start and goal, beyond the robot's radius (metres).
SUGGESTED_ROOM = 0.25
#: The suggested goal lies about this far from the start (metres).
SUGGESTED_DISTANCE = 3.0
#: Goals tried (nearest that distance first) for one in sight of the start.
SUGGESTED_TRIES = 512

#: The keys of a plan's ``map`` table: the map's id and the ``[map]`` table's options.
REQUEST_MAP_KEYS = ("id", "unknown", "length")

_SAFE = re.compile(r"[^A-Za-z0-9._-]+")


def _safe_name(name: str, fallback: str) -> str:
    stem = _SAFE.sub("-", os.path.basename(name)).strip("-.")[:100]
    return stem or fallback


@dataclass(frozen=True, eq=False)
class LoadedMap:
    """A map opened on the page: its ``id``, the files as the user named them and where they
    are (``yaml``, ``image``: in ``folder``), the cells, and the map drawn as a PNG."""

    id: str
    name: str
    image_name: str
    folder: str
    yaml: str
    image: str
    occupancy: OccupancyMap
    png: bytes

    def scenario_map(self, unknown: str = "occupied", length: float | None = None) -> ScenarioMap:
        """The map as a scenario's ``[map]`` (its cells as loaded; the files are not read)."""
        return ScenarioMap(self.yaml, unknown, length, occupancy=self.occupancy)

    def info(self) -> dict[str, Any]:
        """What the page draws: the image's place (the origin's pose, the cell size, the cells
        across and up), the box of its known cells, and a start and goal in open space."""
        occ = self.occupancy
        rows, cols = occ.shape
        start, goal = suggested_ends(occ, DEFAULT_RADIUS)
        return {
            "id": self.id,
            "name": self.name,
            "image": f"/api/maps/{self.id}.png",
            "columns": cols,
            "rows": rows,
            "resolution": occ.resolution,
            "origin": list(occ.origin),
            "extent": list(occ.extent),
            "known": known_extent(occ),
            "counts": occ.counts(),
            "radius": DEFAULT_RADIUS,
            "speed": HORIZON_SPEED,
            "start": start,
            "goal": goal,
        }


def map_png(occ: OccupancyMap) -> bytes:
    """The map as ROS shows it (free 254, occupied 0, unknown 205), one grey pixel a cell, its
    top row the map's last."""
    from PIL import Image

    from ..viz.style import map_grey

    grey = np.rint(map_grey(occ.data[::-1]) * 255.0).astype(np.uint8)
    out = io.BytesIO()
    Image.fromarray(np.ascontiguousarray(grey), mode="L").save(out, format="PNG")
    return out.getvalue()


def known_extent(occ: OccupancyMap) -> list[float]:
    """``[xmin, xmax, ymin, ymax]``: the world box of the cells that are not unknown (the whole
    map when all are)."""
    known = occ.data != UNKNOWN
    rows, cols = np.flatnonzero(known.any(axis=1)), np.flatnonzero(known.any(axis=0))
    if rows.size == 0:
        return list(occ.extent)
    u = np.array([cols[0], cols[-1] + 1, cols[-1] + 1, cols[0]], dtype=float)
    v = np.array([rows[0], rows[0], rows[-1] + 1, rows[-1] + 1], dtype=float)
    xs, ys = occ.grid_to_world(u, v)
    return [float(xs.min()), float(xs.max()), float(ys.min()), float(ys.max())]


def suggested_ends(occ: OccupancyMap, radius: float):
    """A start and a goal ``[x, y, heading]`` in the open (the freest cell, and a cell with
    room about :data:`SUGGESTED_DISTANCE` from it, heading from one to the other); ``None``
    when the map has no free cell with room for the robot."""
    from scipy.ndimage import distance_transform_edt

    free = np.pad(occ.data == FREE, 1)  # the world beyond the map is not free
    room = distance_transform_edt(free)[1:-1, 1:-1] * occ.resolution
    best = float(room.max()) if room.size else 0.0
    if best <= radius:
        return None, None
    ok = room >= min(radius + SUGGESTED_ROOM, 0.5 * (best + radius))
    i0, j0 = np.unravel_index(int(np.argmax(room)), room.shape)
    ii, jj = np.nonzero(ok)
    far = np.abs(np.hypot(ii - i0, jj - j0) * occ.resolution - SUGGESTED_DISTANCE)
    order = np.argsort(far, kind="stable")[:SUGGESTED_TRIES]
    # the first in sight of the start: the robot fits all along the straight line between
    s = np.linspace(0.0, 1.0, 64)[:, None]
    rows = np.rint(i0 + s * (ii[order] - i0)).astype(int)
    cols = np.rint(j0 + s * (jj[order] - j0)).astype(int)
    seen = np.flatnonzero((room[rows, cols] > radius).all(axis=0))
    k = order[seen[0] if seen.size else 0]
    xs, ys = occ.grid_to_world(np.array([j0, jj[k]]) + 0.5, np.array([i0, ii[k]]) + 0.5)
    heading = math.atan2(ys[1] - ys[0], xs[1] - xs[0])
    ends = [
        [round(float(x), 3), round(float(y), 3), round(heading, 4)]
        for x, y in zip(xs, ys, strict=True)
    ]
    return ends[0], ends[1]


# --------------------------------------------------------------------------- the upload


def _file(data: Mapping, key: str, what: str) -> tuple[str, bytes]:
    if key not in data or data[key] is None:
        raise RequestError(f"map: {key}: missing: choose the map's {what}")
    f = data[key]
    if not isinstance(f, Mapping) or set(f) - {"name", "data"}:
        raise RequestError(f"map: {key}: expected {{name, data}}, got {describe(f)}")
    name, raw = f.get("name"), f.get("data")
    if not isinstance(name, str) or not name.strip():
        raise RequestError(f"map: {key}.name: expected a file name, got {describe(name)}")
    if not isinstance(raw, str):
        raise RequestError(f"map: {key}.data: expected base64 text, got {describe(raw)}")
    try:
        return os.path.basename(name.strip())[:200], base64.b64decode(raw, validate=True)
    except (binascii.Error, ValueError):
        raise RequestError(f"map: {key}.data: not valid base64") from None


def parse_upload(data: Any) -> tuple[str, bytes, str, bytes]:
    """The YAML file's name and bytes, and the image's, of an upload."""
    if not isinstance(data, Mapping):
        raise RequestError(f"map: expected a JSON object, got {describe(data)}")
    unknown = [k for k in data if k not in ("yaml", "image")]
    if unknown:
        raise RequestError(f"map: unknown key {unknown[0]!r} (allowed: yaml, image)")
    yaml_name, yaml_bytes = _file(data, "yaml", "YAML file")
    image_name, image_bytes = _file(data, "image", "image (PGM or PNG) with its YAML file")
    if len(yaml_bytes) + len(image_bytes) > MAX_MAP_BYTES:
        raise RequestError(
            f"map: the YAML file and its image are larger than {MAX_MAP_BYTES // 2**20} MB", 413
        )
    return yaml_name, yaml_bytes, image_name, image_bytes


def _load(folder: str, yaml_name: str, image_name: str) -> OccupancyMap:
    """The map of the files in ``folder``: the YAML file must name the image chosen with it
    (its folder aside: the YAML file may name it where it lay on the user's machine)."""
    yaml_path = os.path.join(folder, _safe_name(yaml_name, "map.yaml"))
    image_path = os.path.join(folder, _safe_name(image_name, "map.pgm"))
    named = os.path.basename(read_map_yaml(yaml_path).image)
    if named != image_name:
        raise ScenarioError(
            f"{yaml_name}: image: names {named!r}, but the image chosen is {image_name!r}"
        )
    return load_ros_map(yaml_path, image=image_path)


class MapStore:
    """The maps the page opened, by id, at most ``limit`` (each in its own temporary folder,
    removed when the map is forgotten or the store is closed)."""

    def __init__(self, limit: int = MAX_MAPS):
        self.limit = limit
        self._maps: OrderedDict[str, LoadedMap] = OrderedDict()
        self._built: OrderedDict[tuple, ScenarioMap] = OrderedDict()
        self._lock = threading.Lock()

    def add(self, yaml_name: str, yaml_bytes: bytes, image_name: str, image_bytes: bytes):
        """Write the files, load them and keep the map; a bad file raises the loader's one-line
        message (as a :class:`RequestError`, the files named as the user named them)."""
        folder = tempfile.mkdtemp(prefix="leapfrog-map-")
        try:
            yaml_path = os.path.join(folder, _safe_name(yaml_name, "map.yaml"))
            image_path = os.path.join(folder, _safe_name(image_name, "map.pgm"))
            if yaml_path == image_path:
                raise ScenarioError(f"{yaml_name}: the image must be another file")
            for path, raw in ((yaml_path, yaml_bytes), (image_path, image_bytes)):
                with open(path, "wb") as f:
                    f.write(raw)
            occ = _load(folder, yaml_name, image_name)
            m = LoadedMap(
                secrets.token_urlsafe(9), yaml_name, image_name, folder, yaml_path, image_path,
                occ, map_png(occ),
            )  # fmt: skip
        except ScenarioError as e:
            shutil.rmtree(folder, ignore_errors=True)
            raise RequestError(str(e).replace(folder + os.sep, "")) from None
        except BaseException:
            shutil.rmtree(folder, ignore_errors=True)
            raise
        with self._lock:
            self._maps[m.id] = m
            while len(self._maps) > self.limit:
                _, old = self._maps.popitem(last=False)
                shutil.rmtree(old.folder, ignore_errors=True)
                for key in [k for k in self._built if k[0] == old.id]:
                    del self._built[key]
        return m

    def scenario_map(self, m: LoadedMap, unknown: Any, length: Any, radius: float) -> ScenarioMap:
        """``m`` as a scenario's ``[map]``, its field for ``radius`` built once (the last
        :data:`MAX_BUILT` are kept: a map of 2000 x 2000 cells takes half a second)."""
        sm = m.scenario_map(unknown, length)  # checks the options
        key = (m.id, sm.unknown, sm.length, radius)
        with self._lock:
            if key in self._built:
                self._built.move_to_end(key)
                return self._built[key]
            self._built[key] = sm
            while len(self._built) > MAX_BUILT:
                self._built.popitem(last=False)
        return sm

    def request(self, table: Any) -> tuple[LoadedMap, str, float | None]:
        """The map a plan names and its options (:func:`request_map`)."""
        return request_map(table, self)

    def get(self, map_id: Any) -> LoadedMap:
        """The map of ``map_id``, or a 400 naming what to do."""
        if not isinstance(map_id, str) or not map_id:
            raise RequestError(f"scenario: map.id: expected a map's id, got {describe(map_id)}")
        with self._lock:
            m = self._maps.get(map_id)
            if m is not None:
                self._maps.move_to_end(map_id)
        if m is None:
            raise RequestError(
                f"scenario: map.id: no map {map_id[:40]!r} on the server (it keeps the last"
                f" {self.limit} opened, while it runs): open the map again"
            )
        return m

    def find(self, map_id: str) -> LoadedMap | None:
        with self._lock:
            return self._maps.get(map_id)

    def close(self) -> None:
        with self._lock:
            maps = list(self._maps.values())
            self._maps.clear()
            self._built.clear()
        for m in maps:
            shutil.rmtree(m.folder, ignore_errors=True)


def request_map(table: Any, store: MapStore | None) -> tuple[LoadedMap, str, float | None]:
    """The map a plan names (``{"id", "unknown", "length"}``) and its options."""
    if not isinstance(table, Mapping):
        raise RequestError(f"scenario: map: expected a table, got {describe(table)}")
    for k in table:
        if k not in REQUEST_MAP_KEYS:
            hint = ": the page names a map by its id" if k in MAP_KEYS else ""
            raise RequestError(
                f"scenario: map.{str(k)[:40]}: unknown key{hint} (allowed:"
                f" {', '.join(REQUEST_MAP_KEYS)})"
            )
    if "id" not in table:
        raise RequestError("scenario: map.id: missing required key (open the map on the page)")
    if store is None:
        raise RequestError("scenario: map: this server does not keep maps")
    m = store.get(table["id"])
    return m, table.get("unknown", "occupied"), table.get("length")
