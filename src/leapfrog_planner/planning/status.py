"""How a plan ended, and the summary of one initial path's run."""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum

from ..integrate.flow import Trajectory


class PlanStatus(StrEnum):
    CONVERGED = "converged"  # a collision-free extremal that meets Pontryagin's conditions
    COLLIDES = "collides"  # every extremal found passes through an obstacle
    FAILED = "failed"  # no extremal found


@dataclass(frozen=True)
class PathOutcome:
    """Summary of Leapfrog from one initial path."""

    label: str
    status: PlanStatus
    cost: float
    initial_cost: float
    sweeps: int
    message: str
    weight: float  # the obstacle weight of its last run
    trajectory: Trajectory | None = None  # its extremal, when it found one
