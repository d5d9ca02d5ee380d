"""The ``[map]`` table of a scenario: a ROS map_server map the robot plans in.

```toml
[map]
file = "depot.yaml"     # the map's YAML, relative to the scenario file (or absolute)
unknown = "occupied"    # unknown cells (and the world beyond the map): "occupied" or "free"
length = 0.4            # the penalty's length scale in metres (default: max(2 radius, 4 cells))
```
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field

import numpy as np

from .. import checks
from ..errors import ScenarioError, describe
from ..world import OCCUPIED, UNKNOWN, OccupancyMap, load_ros_map
from ..world.obstacle_map import ObstacleMap

MAP_KEYS = ("file", "unknown", "length")
UNKNOWN_POLICIES = ("occupied", "free")


@dataclass(frozen=True, eq=False)
class ScenarioMap:
    """A scenario's map: the YAML ``file`` (an absolute path once read), what ``unknown`` cells
    count as, the penalty's ``length`` scale (None: the default) and the ``occupancy`` read from
    the file (loaded on construction unless given)."""

    file: str
    unknown: str = "occupied"
    length: float | None = None
    occupancy: OccupancyMap | None = field(default=None, repr=False)

    def __post_init__(self):
        if not isinstance(self.file, str | os.PathLike) or not str(self.file):
            raise ScenarioError(f"map.file: expected a file name, got {describe(self.file)}")
        if self.unknown not in UNKNOWN_POLICIES:
            raise ScenarioError(
                f"map.unknown: expected one of {', '.join(map(repr, UNKNOWN_POLICIES))},"
                f" got {describe(self.unknown)}"
            )
        if self.length is not None:
            length = checks.real(self.length, "map.length", gt=0)
            checks.in_range(length, "map.length", (0.0, checks.COORDINATE_MAX))
            object.__setattr__(self, "length", length)
        path = os.path.abspath(os.fspath(self.file))
        object.__setattr__(self, "file", path)
        if self.occupancy is None:
            object.__setattr__(self, "occupancy", load_ros_map(path))

    @property
    def unknown_is_occupied(self) -> bool:
        return self.unknown == "occupied"

    def obstacles(self, radius: float) -> ObstacleMap:
        """The map's penalty field and clearance for a robot of ``radius`` (built once per
        radius: a 2000 x 2000 map takes about half a second)."""
        cache = self.__dict__.setdefault("_built", {})
        if radius not in cache:
            cache[radius] = ObstacleMap(
                self.occupancy, radius, self.length, self.unknown_is_occupied
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
        clear = float(self.obstacles(radius).clearance_at(np.array([x, y])))
        if clear < 0.0:
            raise ScenarioError(
                f"{key}: the robot (radius {radius:g}) at {checks.fmt_point((x, y))} overlaps"
                f" a blocked cell of the map ({-clear:.3g} too close)"
            )

    def to_dict(self) -> dict:
        out = {"file": self.file, "unknown": self.unknown}
        if self.length is not None:
            out["length"] = self.length
        return out

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, ScenarioMap):
            return NotImplemented
        return self.to_dict() == other.to_dict()

    __hash__ = None  # type: ignore[assignment]

    def __getstate__(self):
        return {k: v for k, v in self.__dict__.items() if k != "_built"}


def map_from_table(table, folder: str) -> ScenarioMap:
    """The ``[map]`` table of a scenario file in ``folder`` (relative files are found there)."""
    unknown_keys = [k for k in table if k not in MAP_KEYS]
    if unknown_keys:
        raise ScenarioError(f"map.{unknown_keys[0]}: unknown key (allowed: {', '.join(MAP_KEYS)})")
    if "file" not in table:
        raise ScenarioError("map.file: missing required key")
    name = table["file"]
    if not isinstance(name, str) or not name or "\0" in name:
        raise ScenarioError(f"map.file: expected a file name, got {describe(name)}")
    path = name if os.path.isabs(name) else os.path.join(folder, name)
    length = table.get("length")
    if length is not None and not (isinstance(length, int | float) and math.isfinite(length)):
        raise ScenarioError(f"map.length: expected a number, got {describe(length)}")
    return ScenarioMap(path, table.get("unknown", "occupied"), length)
