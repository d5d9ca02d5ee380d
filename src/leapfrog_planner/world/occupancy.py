"""An occupancy grid placed in the world: the cells of a map and where they lie.

:class:`OccupancyMap` holds the values of a ``nav_msgs/OccupancyGrid`` (:data:`FREE` 0,
:data:`OCCUPIED` 100, :data:`UNKNOWN` -1, and in between 1..99 from a ``scale`` or ``raw`` map)
as an ``int8`` array whose row 0 is the *bottom* row (the row of the origin), the cell size and
the pose ``(x, y, yaw)`` of the lower-left corner of cell ``(0, 0)``.

Cell ``(i, j)`` (row ``i`` from the bottom, column ``j``) is the closed square
``[j, j + 1] x [i, i + 1]`` in grid coordinates ``(u, v)`` (units of cells), and a world point
is ``origin + R(yaw) (u, v) * resolution``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import checks
from ..errors import ScenarioError, describe, require_integer

FREE = 0
OCCUPIED = 100
UNKNOWN = -1

#: The largest map, in cells (10^8: 100 MB of cell values, a 500 m square at 5 cm).
MAX_CELLS = 10**8
#: The largest cell size and offset of the origin accepted (the scenario's coordinate bound).
RESOLUTION_MAX = checks.COORDINATE_MAX


def _grid_values(data) -> np.ndarray:
    """``data`` as a read-only 2-D ``int8`` array of OccupancyGrid values (copied unless it
    already is a read-only ``int8`` array owning its memory, as the loader makes it)."""
    arr = data if isinstance(data, np.ndarray) else np.asarray(data)
    if arr.ndim != 2 or arr.size == 0:
        raise ScenarioError(f"data: expected a non-empty 2-D array, got {describe(arr)}")
    if arr.size > MAX_CELLS:
        raise ScenarioError(f"data: at most {MAX_CELLS} cells, got {arr.size}")
    if arr.dtype.kind not in "iu":
        raise ScenarioError(f"data: expected integers, got dtype {arr.dtype}")
    low, high = int(arr.min()), int(arr.max())
    if low < UNKNOWN or high > OCCUPIED:
        bad = low if low < UNKNOWN else high
        raise ScenarioError(f"data: values must be -1 (unknown) or 0..100, got {bad}")
    owned = arr.dtype == np.int8 and arr.base is None and arr.flags.c_contiguous
    if not (owned and not arr.flags.writeable):
        arr = np.array(arr, dtype=np.int8, order="C")
        arr.setflags(write=False)
    return arr


@dataclass(frozen=True, eq=False)
class OccupancyMap:
    """The cells of a map and their place in the world. Construction checks every field.

    ``data[i, j]`` is the value of cell ``(i, j)``, row 0 at the bottom (read-only);
    ``resolution`` the cell size (metres); ``origin`` the pose ``(x, y, yaw)`` of the map's
    lower-left corner (yaw counterclockwise, radians); ``name`` names the map in messages."""

    data: np.ndarray
    resolution: float
    origin: tuple[float, float, float] = (0.0, 0.0, 0.0)
    name: str = "map"

    def __post_init__(self):
        data = _grid_values(self.data)
        resolution = checks.real(self.resolution, "resolution", gt=0)
        checks.in_range(resolution, "resolution", 0.0, RESOLUTION_MAX)
        x, y, yaw = checks.vector(self.origin, 3, "origin", " [x, y, yaw]").tolist()
        checks.magnitude((x, y), "origin", checks.COORDINATE_MAX)
        if not abs(yaw) <= checks.HEADING_MAX:
            raise ScenarioError(f"origin[2]: must be at most {checks.HEADING_MAX:g} in size")
        object.__setattr__(self, "data", data)
        object.__setattr__(self, "resolution", resolution)
        object.__setattr__(self, "origin", (x, y, yaw))
        object.__setattr__(self, "name", str(self.name))

    @property
    def shape(self) -> tuple[int, int]:
        """``(rows, columns)``: the map is ``columns * resolution`` wide along its x axis."""
        return self.data.shape

    @property
    def extent(self) -> tuple[float, float, float, float]:
        """``(xmin, xmax, ymin, ymax)``: the world box holding the map (its rotated corners)."""
        rows, cols = self.shape
        xs, ys = self.grid_to_world(np.array([0.0, cols, cols, 0.0]), np.array([0, 0, rows, rows]))
        return float(xs.min()), float(xs.max()), float(ys.min()), float(ys.max())

    def counts(self) -> dict[str, int]:
        """How many cells are free, occupied, unknown, and in between (scale and raw maps)."""
        d = self.data
        free, occupied, unknown = (int(np.count_nonzero(d == v)) for v in (FREE, OCCUPIED, UNKNOWN))
        return {
            "free": free,
            "occupied": occupied,
            "unknown": unknown,
            "between": d.size - free - occupied - unknown,
        }

    def blocked(self, unknown_is_occupied: bool = True, threshold: int = OCCUPIED) -> np.ndarray:
        """The cells that are obstacles (a new boolean array, row 0 at the bottom): value at
        least ``threshold`` (100: occupied only, as nav2's static layer by default), and the
        unknown ones if ``unknown_is_occupied``."""
        threshold = require_integer("threshold", threshold, 1, OCCUPIED, error=ScenarioError)
        mask = self.data >= threshold
        if unknown_is_occupied:
            mask |= self.data == UNKNOWN
        return mask

    def world_to_grid(self, x, y) -> tuple[np.ndarray, np.ndarray]:
        """Grid coordinates ``(u, v)`` (cells, float) of world points: cell ``(i, j)`` holds
        ``j <= u <= j + 1``, ``i <= v <= i + 1``; the yaw is undone."""
        x0, y0, yaw = self.origin
        c, s = math.cos(yaw), math.sin(yaw)
        dx = np.asarray(x, dtype=float) - x0
        dy = np.asarray(y, dtype=float) - y0
        return (c * dx + s * dy) / self.resolution, (c * dy - s * dx) / self.resolution

    def grid_to_world(self, u, v) -> tuple[np.ndarray, np.ndarray]:
        """World points of grid coordinates ``(u, v)`` (the inverse of :meth:`world_to_grid`)."""
        x0, y0, yaw = self.origin
        c, s = math.cos(yaw), math.sin(yaw)
        gu = np.asarray(u, dtype=float) * self.resolution
        gv = np.asarray(v, dtype=float) * self.resolution
        return x0 + c * gu - s * gv, y0 + s * gu + c * gv

    def cell_index(self, x, y) -> tuple[np.ndarray, np.ndarray]:
        """``(i, j)``: row and column of the cell holding each world point (integers, which lie
        outside ``0..rows-1``, ``0..columns-1`` for a point off the map; a point on an edge
        between two cells goes to the upper or right one)."""
        u, v = self.world_to_grid(x, y)
        return np.floor(v).astype(np.int64), np.floor(u).astype(np.int64)

    def cell_center(self, i, j) -> tuple[np.ndarray, np.ndarray]:
        """World coordinates of the centre of cell ``(i, j)``."""
        return self.grid_to_world(
            np.asarray(j, dtype=float) + 0.5, np.asarray(i, dtype=float) + 0.5
        )

    def contains(self, x, y) -> np.ndarray:
        """Whether each world point lies on the map (its edge included)."""
        u, v = self.world_to_grid(x, y)
        rows, cols = self.shape
        return (u >= 0) & (u <= cols) & (v >= 0) & (v <= rows)

    def value_at(self, x, y) -> np.ndarray:
        """The value of the cell under each world point; :data:`UNKNOWN` off the map."""
        i, j = self.cell_index(x, y)
        rows, cols = self.shape
        on = (i >= 0) & (i < rows) & (j >= 0) & (j < cols)
        out = np.full(np.shape(i), UNKNOWN, dtype=np.int8)
        out[on] = self.data[i[on], j[on]]
        return out
