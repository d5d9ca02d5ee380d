"""The optimal control problem: a vehicle model, the obstacle penalty and model parameters.

End states and times are not part of it: the same problem is solved between many pairs of
junctions by Leapfrog.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .. import checks
from ..compiled.kernels import ModelInfo, model_info
from ..errors import ScenarioError, require_integer
from ..model.penalty import ObstacleGrid, clearance, disc_penalty_values, obstacle_grid
from ..world.obstacle_map import ObstacleMap


@dataclass(frozen=True, eq=False)
class ObstaclePenalty:
    """``P(x, y) = sum_j W exp(-(|(x, y) - c_j|^2 / r_j^2)^n)`` over disc obstacles, plus the
    penalty field of a ``map`` (world/field.py: the same formula with a distance to the map's
    blocked cells in place of the distance to a centre)."""

    obstacles: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    weight: float = 100.0
    exponent: int = 2
    map: ObstacleMap | None = None

    def __post_init__(self):
        obs = self.obstacles
        if isinstance(obs, np.ndarray) and obs.ndim == 1 and obs.size % 3 == 0:
            obs = obs.reshape(-1, 3)  # a flat array of discs [cx, cy, r, cx, cy, r, ...]
        obs = np.ascontiguousarray(checks.obstacles(obs))
        obs.setflags(write=False)
        object.__setattr__(self, "obstacles", obs)
        object.__setattr__(self, "weight", checks.real(self.weight, "penalty.weight", ge=0))
        exponent = require_integer("penalty.exponent", self.exponent, 1, error=ScenarioError)
        object.__setattr__(self, "exponent", exponent)
        if self.map is not None:
            if not isinstance(self.map, ObstacleMap):
                raise ScenarioError(f"map: expected an ObstacleMap, got {self.map!r:.60}")
            if exponent < 2:
                raise ScenarioError(
                    "penalty.exponent: must be at least 2 with a map (its penalty is twice"
                    f" differentiable only then), got {exponent}"
                )

    @property
    def any(self) -> bool:
        """Whether there is any obstacle: a disc or a map."""
        return self.obstacles.shape[0] > 0 or self.map is not None

    @property
    def grid(self) -> ObstacleGrid:
        """The obstacles with a grid for the compiled penalty, which then visits only the
        obstacles near each point (the same sum, bit for bit); built once per penalty."""
        grid = self.__dict__.get("_grid")
        if grid is None:
            field = None if self.map is None else self.map.field
            grid = obstacle_grid(self.obstacles, self.weight, self.exponent, field)
            object.__setattr__(self, "_grid", grid)
        return grid

    def __call__(self, xy) -> np.ndarray:
        """Penalty values at points ``xy`` of shape ``(..., 2)``."""
        xy = np.asarray(xy, dtype=float)
        obs = self.obstacles
        base = 0.0 if self.map is None else self.map.penalty(xy, self.weight, self.exponent)
        if obs.shape[0] == 0:
            return base + np.zeros(xy.shape[:-1])
        # The compiled sum the kernels evaluate: a point visits the discs of its grid cell.
        flat = np.ascontiguousarray(xy.reshape(-1, 2))
        out = disc_penalty_values(flat, self.grid, float(self.weight), int(self.exponent))
        return base + out.reshape(xy.shape[:-1])[()]

    def clearance(self, xy, map_entry: float | None = None) -> np.ndarray:
        """Per obstacle, the smallest distance from the path ``xy`` to its edge; with a map, a
        last entry: the least clearance of the polyline ``xy`` against the map's blocked cells
        (exact at the points, a proven lower bound between them), or ``map_entry`` where the
        caller measured it more finely."""
        xy = np.asarray(xy, dtype=float).reshape(-1, 2)
        discs = clearance(xy, self.obstacles)
        if self.map is None:
            return discs
        return np.append(discs, self.map.path_clearance(xy) if map_entry is None else map_entry)

    def with_weight(self, weight: float) -> ObstaclePenalty:
        """The same obstacles with another weight."""
        return ObstaclePenalty(self.obstacles, weight, self.exponent, self.map)


def obstacle_penalty(obstacles=(), weight: float = 100.0, exponent: int = 2) -> ObstaclePenalty:
    """The obstacle penalty for ``obstacles`` given as rows ``[cx, cy, r]``."""
    return ObstaclePenalty(np.asarray(obstacles, dtype=float), weight, exponent)


@dataclass(frozen=True, eq=False)
class OptimalControlProblem:
    """``min int L_u(x, u) + P(x, y) dt`` subject to the model's dynamics."""

    model: ModelInfo  # a built-in name or a VehicleModel is accepted and converted
    penalty: ObstaclePenalty = field(default_factory=ObstaclePenalty)
    parameters: tuple[float, ...] = ()

    def __post_init__(self):
        model = model_info(self.model)
        object.__setattr__(self, "model", model)
        if not self.parameters:
            object.__setattr__(self, "parameters", model.parameter_values())
        if len(self.parameters) != len(model.parameters):
            raise ScenarioError(
                f"model {model.name!r} takes {len(model.parameters)} parameters,"
                f" got {len(self.parameters)}"
            )

    @classmethod
    def create(
        cls,
        model="unicycle",
        obstacles=(),
        *,
        weight: float = 100.0,
        exponent: int = 2,
        parameters: dict[str, float] | None = None,
    ) -> OptimalControlProblem:
        """Build a problem from plain values; ``parameters`` overrides model defaults by name."""
        model = model_info(model)
        return cls(
            model, obstacle_penalty(obstacles, weight, exponent), model.parameter_values(parameters)
        )

    @property
    def obstacles(self) -> np.ndarray:
        return self.penalty.obstacles

    @property
    def nx(self) -> int:
        return self.model.nx

    def with_weight(self, weight: float) -> OptimalControlProblem:
        """The same problem with another obstacle weight (for continuation; nothing recompiles)."""
        return OptimalControlProblem(self.model, self.penalty.with_weight(weight), self.parameters)

    def with_parameter(self, name: str, value: float) -> OptimalControlProblem:
        """The same problem with the model parameter ``name`` set to ``value``."""
        values = list(self.parameters)
        values[self.model.parameters.index(name)] = float(value)
        return OptimalControlProblem(self.model, self.penalty, tuple(values))

    def parameter(self, name: str) -> float:
        """The value of the model parameter ``name``."""
        return self.parameters[self.model.parameters.index(name)]

    def __reduce__(self):
        # Pickle by model definition (a name for built-ins), not by the loaded kernel module.
        return (
            _rebuild,
            (
                self.model.definition,
                self.penalty.obstacles,
                self.penalty.weight,
                self.penalty.exponent,
                self.parameters,
                self.penalty.map,
            ),
        )


def _rebuild(definition, obstacles, weight, exponent, parameters, obstacle_map=None):
    return OptimalControlProblem(
        definition, ObstaclePenalty(obstacles, weight, exponent, obstacle_map), parameters
    )
