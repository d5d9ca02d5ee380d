"""A map as the planner sees it: its smooth penalty field and the exact clearance of a motion.

The penalty (:mod:`.field`) steers the optimisation; the clearance (:mod:`.clearance`) judges the
answer against the cells themselves and the polygons and walls (:mod:`.shapes`) by their
geometry, never against the smoothed field.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from .. import checks
from ..errors import ScenarioError
from .clearance import MapClearance
from .field import FieldPlan, MapField, build_field, field_penalty_rows, field_plan
from .occupancy import OCCUPIED, OccupancyMap
from .shapes import Shapes, grid_distance

#: The default length scale is this many times the robot's radius (small obstacles then still
#: reach nearly the full weight)...
LENGTH_PER_RADIUS = 2.0
#: ... and at least this many cells (the spline needs a few nodes across the profile).
LENGTH_CELLS = 4.0


def default_length(radius: float, resolution: float) -> float:
    """The length scale used when none is given: ``max(2 rho, 4 h)``."""
    return max(LENGTH_PER_RADIUS * radius, LENGTH_CELLS * resolution)


@dataclass(frozen=True, eq=False)
class ObstacleMap:
    """The blocked cells of ``occupancy`` (occupied, and unknown ones and the world beyond the
    map if ``unknown_is_occupied``) and the polygons and walls of ``shapes``, for a round robot
    of ``radius``: the penalty field with the length scale ``length`` (metres; default
    :func:`default_length`) and the exact clearance.

    ``cells`` is the exact clearance against the map's own cells; ``route_cells`` marks the
    cells the shapes touch as occupied too (what the search for initial routes reads)."""

    occupancy: OccupancyMap
    radius: float = 0.0
    length: float | None = None
    unknown_is_occupied: bool = True
    shapes: Shapes | None = None
    plan: FieldPlan = dataclasses.field(init=False, repr=False)
    field: MapField = dataclasses.field(init=False, repr=False)
    cells: MapClearance = dataclasses.field(init=False, repr=False)
    route_cells: MapClearance = dataclasses.field(init=False, repr=False)

    def __post_init__(self):
        occ = self.occupancy
        if not isinstance(occ, OccupancyMap):
            raise ScenarioError(f"map: expected an OccupancyMap, got {occ!r:.60}")
        radius = checks.real(self.radius, "robot.radius", ge=0)
        h = occ.resolution
        length = default_length(radius, h) if self.length is None else self.length
        length = checks.real(length, "map.length", gt=0)
        if length < 2.0 * h:
            raise ScenarioError(
                f"map.length: {length:g} m is less than two cells ({2 * h:g} m) of the map"
            )
        shapes = self.shapes if self.shapes is not None and len(self.shapes) else None
        if shapes is not None and not isinstance(shapes, Shapes):
            raise ScenarioError(f"shapes: expected Shapes, got {shapes!r:.60}")
        unknown = bool(self.unknown_is_occupied)
        cells = MapClearance(occ, unknown)
        route_cells = cells if shapes is None else MapClearance(with_shapes(occ, shapes), unknown)
        plan = field_plan(length, radius, h)
        values = build_field(cells.blocked, h, occ.origin, plan, unknown, shapes)
        for name, value in (("radius", radius), ("length", length), ("plan", plan),
                            ("field", values), ("cells", cells), ("route_cells", route_cells),
                            ("shapes", shapes), ("unknown_is_occupied", unknown)):  # fmt: skip
            object.__setattr__(self, name, value)

    def penalty(self, xy, weight: float, exponent: int) -> np.ndarray:
        """The map's penalty ``P`` at points ``xy`` of shape ``(..., 2)``."""
        xy = np.asarray(xy, dtype=float)
        flat = np.ascontiguousarray(xy.reshape(-1, 2))
        out = np.empty((flat.shape[0], 6))
        field_penalty_rows(flat, self.field, float(weight), int(exponent), False, out)
        return out[:, 0].reshape(xy.shape[:-1])[()]

    def clearance_at(self, xy) -> np.ndarray:
        """The exact clearance of the robot centred at each point of ``xy`` (``(..., 2)``): the
        distance to the nearest blocked cell or shape less the radius (metres)."""
        xy = np.asarray(xy, dtype=float)
        clear = self.cells.clearance(xy[..., 0], xy[..., 1], self.radius)
        if self.shapes is not None:
            clear = np.minimum(clear, self.shapes.distance(xy[..., 0], xy[..., 1]) - self.radius)
        return clear

    def path_clearance(self, xy) -> float:
        """A lower bound of the clearance along the polyline through the points ``xy``
        (``(N, 2)``), exact at the points: the distance to the blocked cells is 1-Lipschitz, so
        on a segment of length ``L`` whose ends have clearances ``a`` and ``b`` it is at least
        ``(a + b - L) / 2`` (and at least ``min(a, b) - L / 2``)."""
        xy = np.asarray(xy, dtype=float).reshape(-1, 2)
        return polyline_bound(xy, self.clearance_at(xy))


def segment_bounds(xy: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Lower bounds of the clearance on each segment of the polyline through ``xy``
    (``(N, 2)``) whose points' clearances are ``c``: the distance to the blocked cells is
    1-Lipschitz, so on a segment of length ``L`` with end clearances ``a`` and ``b`` it is at
    least ``(a + b - L) / 2``."""
    return 0.5 * (c[:-1] + c[1:] - np.hypot(*np.diff(xy, axis=0).T))


def polyline_bound(xy: np.ndarray, c: np.ndarray) -> float:
    """A lower bound of the clearance along the polyline through ``xy``, exact at its points
    (clearances ``c``): the least of ``c`` and of :func:`segment_bounds`."""
    return float(min(c.min(initial=np.inf), segment_bounds(xy, c).min(initial=np.inf)))


def with_shapes(occupancy: OccupancyMap, shapes: Shapes) -> OccupancyMap:
    """``occupancy`` with every cell that a shape touches marked occupied: those whose centre
    lies within half a cell's diagonal of a shape (a superset of the cells a shape overlaps)."""
    h = occupancy.resolution
    x0, y0 = occupancy.cell_center(0, 0)
    reach = h * math.sqrt(0.5)
    d = grid_distance(shapes, (float(x0), float(y0), occupancy.origin[2]), h, occupancy.shape,
                      reach, np.inf)  # fmt: skip
    data = np.where(d <= reach, np.int8(OCCUPIED), occupancy.data)
    return OccupancyMap(data, h, occupancy.origin, occupancy.name)
