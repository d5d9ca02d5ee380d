"""The world of a scenario beyond its discs: a ROS map_server map, polygons and walls.

```toml
[map]
file = "depot.yaml"     # the map's YAML, relative to the scenario file (or absolute)
unknown = "occupied"    # unknown cells (and the world beyond the map): "occupied" or "free"
length = 0.4            # the penalty's length scale in metres (default: max(2 radius, 4 cells))

[[polygons]]            # any number; convex or not
points = [[1.0, 1.0], [2.0, 1.0], [1.5, 2.0]]

[[walls]]               # thick polylines
points = [[0.0, 3.0], [4.0, 3.0], [4.0, 5.0]]
thickness = 0.1
```

Polygons and walls may come alone: the penalty's field is then laid on a grid of its own round
them and the ends (``[map]`` may give its ``length`` and ``resolution``; beyond the grid the
world is free).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field, replace

import numpy as np

from .. import checks
from ..errors import ScenarioError, describe
from ..world import FREE, OCCUPIED, UNKNOWN, OccupancyMap, load_ros_map
from ..world.obstacle_map import ObstacleMap
from ..world.shapes import Shapes

MAP_KEYS = ("file", "unknown", "length", "resolution")
UNKNOWN_POLICIES = ("occupied", "free")
POLYGON_KEYS = ("points",)
WALL_KEYS = ("points", "thickness")
#: Without a map file: the default length scale is the larger of twice the robot's radius and
#: this share of the region's size, the cells an eighth of it, and the grid at most this many
#: cells across.
SHAPES_LENGTH_SHARE = 1.0 / 50.0
SHAPES_CELLS_PER_LENGTH = 8.0
SHAPES_GRID_MAX = 2000
#: ... and with a resolution given, at most this many cells (the field takes 8 bytes a cell).
SHAPES_CELLS_MAX = 16_000_000


@dataclass(frozen=True, eq=False)
class ScenarioMap:
    """A scenario's map: the YAML ``file`` (an absolute path once read; None for polygons and
    walls alone), what ``unknown`` cells count as, the penalty's ``length`` scale (None: the
    default), the ``occupancy`` read from the file (loaded on construction unless given), the
    polygons and walls of ``shapes``, and without a file the cells' ``resolution`` (None: the
    default) of the grid the shapes' field is laid on."""

    file: str | None = None
    unknown: str = "occupied"
    length: float | None = None
    occupancy: OccupancyMap | None = field(default=None, repr=False)
    shapes: Shapes | None = None
    resolution: float | None = None

    def __post_init__(self):
        if self.unknown not in UNKNOWN_POLICIES:
            raise ScenarioError(
                f"map.unknown: expected one of {', '.join(map(repr, UNKNOWN_POLICIES))},"
                f" got {describe(self.unknown)}"
            )
        for key in ("length", "resolution"):
            value = getattr(self, key)
            if value is not None:
                value = checks.real(value, f"map.{key}", gt=0)
                checks.in_range(value, f"map.{key}", 0.0, checks.COORDINATE_MAX)
                object.__setattr__(self, key, value)
        if self.shapes is not None and not isinstance(self.shapes, Shapes):
            raise ScenarioError(f"polygons: expected Shapes, got {describe(self.shapes)}")
        if self.shapes is not None and not len(self.shapes):
            object.__setattr__(self, "shapes", None)
        if self.file is None:
            self._check_without_file()
            return
        if not isinstance(self.file, str | os.PathLike) or not str(self.file):
            raise ScenarioError(f"map.file: expected a file name, got {describe(self.file)}")
        if self.resolution is not None:
            raise ScenarioError("map.resolution: only without a file (a map has its own)")
        path = os.path.abspath(os.fspath(self.file))
        object.__setattr__(self, "file", path)
        if self.occupancy is None:
            object.__setattr__(self, "occupancy", load_ros_map(path))

    def _check_without_file(self) -> None:
        if self.shapes is None:
            raise ScenarioError("map.file: missing required key (or give polygons or walls)")
        if self.unknown != "occupied":
            raise ScenarioError("map.unknown: only with a file (beyond the shapes all is free)")
        h, length = self.resolution, self.length
        if h is not None and length is not None and length < 2.0 * h:  # both given: name both
            raise ScenarioError(
                f"map.resolution: cells of {h:g} m are too coarse for map.length {length:g} m"
                " (the length spans at least two cells)"
            )

    @property
    def where(self) -> str:
        """Where start and goal are joined, in words (a message's): "on the map", "on the map
        with its walls", "around the polygons", "around the walls and polygons"."""
        shapes = self.shapes
        kinds = [k for k in ("walls", "polygons") if shapes is not None and getattr(shapes, k)]
        named = " and ".join(kinds)
        if self.file is None:
            return f"around the {named}"
        return f"on the map with its {named}" if named else "on the map"

    @property
    def placed(self) -> bool:
        """Whether the cells are known (always with a file; see :meth:`around`)."""
        return self.occupancy is not None

    def around(self, points, radius: float) -> ScenarioMap:
        """Without a file: this world on a free grid that holds the shapes, the ``points``
        (start, goal) and room round them (itself if its grid already does)."""
        if self.file is not None:
            return self
        pts = np.asarray(points, dtype=float).reshape(-1, 2)
        length = self._length(radius, 0.0)
        if self.occupancy is not None:
            xmin, xmax, ymin, ymax = self.occupancy.extent
            room = np.minimum.reduce(
                [pts[:, 0] - xmin, xmax - pts[:, 0], pts[:, 1] - ymin, ymax - pts[:, 1]]
            )
            if room.min() >= 2.0 * (radius + length):
                return self
        xmin, xmax, ymin, ymax = self.shapes.box
        xmin, xmax = min(xmin, pts[:, 0].min()), max(xmax, pts[:, 0].max())
        ymin, ymax = min(ymin, pts[:, 1].min()), max(ymax, pts[:, 1].max())
        pad = max(0.1 * max(xmax - xmin, ymax - ymin), 2.0 * (radius + length))
        width, height = xmax - xmin + 2 * pad, ymax - ymin + 2 * pad
        h = self.resolution
        if h is None:
            h = max(length / SHAPES_CELLS_PER_LENGTH, max(width, height) / SHAPES_GRID_MAX)
        cols, rows = int(math.ceil(width / h)), int(math.ceil(height / h))
        if rows * cols > SHAPES_CELLS_MAX:
            raise ScenarioError(
                f"map.resolution: {h:g} m makes a grid of {rows} x {cols} cells round the"
                f" shapes (at most {SHAPES_CELLS_MAX})"
            )
        data = np.full((rows, cols), FREE, dtype=np.int8)
        occ = OccupancyMap(data, h, (xmin - pad, ymin - pad, 0.0), "polygons and walls")
        return replace(self, occupancy=occ)

    def _length(self, radius: float, h: float) -> float:
        """The length scale: given, or with a map file None (:func:`.default_length`), or
        without one the largest of twice the radius, a share of the shapes' size and 2 cells."""
        if self.length is not None or self.file is not None:
            return self.length
        xmin, xmax, ymin, ymax = self.shapes.box
        size = max(xmax - xmin, ymax - ymin)
        return max(2.0 * radius, SHAPES_LENGTH_SHARE * size, 2.0 * h)

    @property
    def unknown_is_occupied(self) -> bool:
        return self.unknown == "occupied" and self.file is not None

    def obstacles(self, radius: float) -> ObstacleMap:
        """The map's penalty field and clearance for a robot of ``radius`` (built once per
        radius: a 2000 x 2000 map takes about half a second)."""
        if self.occupancy is None:
            raise ScenarioError("map: polygons and walls alone need the ends (around())")
        cache = self.__dict__.setdefault("_built", {})
        if radius not in cache:
            length = self._length(radius, self.occupancy.resolution)
            cache[radius] = ObstacleMap(
                self.occupancy, radius, length, self.unknown_is_occupied, self.shapes
            )
        return cache[radius]

    def check_point(self, point, key: str, radius: float) -> None:
        """A one-line :class:`ScenarioError` when the robot, centred at ``point``, is off the
        map, in an occupied or unknown cell, or overlaps one."""
        x, y = float(point[0]), float(point[1])
        occ = self.occupancy
        if not bool(occ.contains(x, y)):
            xmin, xmax, ymin, ymax = occ.extent
            raise ScenarioError(
                f"{key}: {checks.fmt_point((x, y))} is outside the map"
                f" ({xmin:g} <= x <= {xmax:g}, {ymin:g} <= y <= {ymax:g})"
            )
        value = int(occ.value_at(x, y))
        if value >= OCCUPIED or (value == UNKNOWN and self.unknown_is_occupied):
            what = "an unknown" if value == UNKNOWN else "an occupied"
            raise ScenarioError(f"{key}: {checks.fmt_point((x, y))} is in {what} cell of the map")
        if self.shapes is not None and float(self.shapes.distance(x, y)) < 0.0:
            raise ScenarioError(f"{key}: {checks.fmt_point((x, y))} is inside a polygon or wall")
        world = self.obstacles(radius)
        clear = float(world.clearance_at(np.array([x, y])))
        if clear < 0.0:
            cells = float(world.cells.clearance(x, y, radius))
            what = "a blocked cell of the map" if cells < 0.0 else "a polygon or wall"
            raise ScenarioError(
                f"{key}: the robot (radius {radius:g}) at {checks.fmt_point((x, y))} overlaps"
                f" {what} ({-clear:.3g} too close)"
            )

    def to_dict(self) -> dict:
        """The ``[map]`` table of a scenario file (empty for shapes alone at the defaults)."""
        out: dict = {}
        if self.file is not None:
            out.update(file=self.file, unknown=self.unknown)
        for key in ("length", "resolution"):
            if getattr(self, key) is not None:
                out[key] = getattr(self, key)
        return out

    def shapes_dict(self) -> dict:
        """The ``polygons`` and ``walls`` arrays of tables of a scenario file."""
        return {} if self.shapes is None else self.shapes.to_dict()

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, ScenarioMap):
            return NotImplemented
        return (self.to_dict(), self.shapes_dict()) == (other.to_dict(), other.shapes_dict())

    __hash__ = None  # type: ignore[assignment]

    def __getstate__(self):
        return {k: v for k, v in self.__dict__.items() if k != "_built"}


def map_from_tables(table, polygons, walls, folder: str) -> ScenarioMap | None:
    """The ``[map]`` table (or None), ``[[polygons]]`` and ``[[walls]]`` of a scenario file in
    ``folder`` (relative files are found there); None when there are none of them."""
    shapes = shapes_from_tables(polygons, walls)
    if table is None:
        return None if shapes is None else ScenarioMap(shapes=shapes)
    unknown_keys = [k for k in table if k not in MAP_KEYS]
    if unknown_keys:
        raise ScenarioError(f"map.{unknown_keys[0]}: unknown key (allowed: {', '.join(MAP_KEYS)})")
    for key in ("length", "resolution"):
        value = table.get(key)
        if value is not None and not (isinstance(value, int | float) and math.isfinite(value)):
            raise ScenarioError(f"map.{key}: expected a number, got {describe(value)}")
    if "file" not in table:
        if shapes is None:
            raise ScenarioError("map.file: missing required key (or give polygons or walls)")
        if "unknown" in table:
            raise ScenarioError("map.unknown: only with a file (beyond the shapes all is free)")
        return ScenarioMap(None, length=table.get("length"), shapes=shapes,
                           resolution=table.get("resolution"))  # fmt: skip
    name = table["file"]
    if not isinstance(name, str) or not name or "\0" in name:
        raise ScenarioError(f"map.file: expected a file name, got {describe(name)}")
    path = name if os.path.isabs(name) else os.path.join(folder, name)
    return ScenarioMap(path, table.get("unknown", "occupied"), table.get("length"), shapes=shapes,
                       resolution=table.get("resolution"))  # fmt: skip


def shapes_from_tables(polygons, walls) -> Shapes | None:
    """The ``[[polygons]]`` and ``[[walls]]`` arrays of tables (None: not given)."""
    rings, lines, thickness = [], [], []
    for key, raw, keys in (("polygons", polygons, POLYGON_KEYS), ("walls", walls, WALL_KEYS)):
        if raw is None:
            continue
        if not isinstance(raw, list | tuple):
            raise ScenarioError(
                f"{key}: expected an array of tables ([[{key}]]), got {describe(raw)}"
            )
        for j, item in enumerate(raw):
            where = f"{key}[{j}]"
            if not isinstance(item, dict):
                raise ScenarioError(f"{where}: expected a table, got {describe(item)}")
            extra = [k for k in item if k not in keys]
            if extra:
                raise ScenarioError(f"{where}.{extra[0]}: unknown key (allowed: {', '.join(keys)})")
            for k in keys:
                if k not in item:
                    raise ScenarioError(f"{where}.{k}: missing required key")
            if key == "polygons":
                rings.append(item["points"])
            else:
                lines.append(item["points"])
                thickness.append(item["thickness"])
    if not rings and not lines:
        return None
    return Shapes(tuple(rings), tuple(lines), tuple(thickness))
