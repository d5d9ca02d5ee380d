"""How a plan ended, and the summary of one initial path's run."""

from __future__ import annotations

import math
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


@dataclass(frozen=True)
class RunRecord:
    """One Leapfrog run of a plan's search: the stage that asked for it and why, what it ran
    (the path's label, the partitions, the obstacle weight, the value of the model's planning
    aid, None without one) and what it gave."""

    stage: str
    reason: str
    label: str
    partitions: int
    weight: float
    aid: float | None
    status: PlanStatus
    cost: float  # of its extremal (NaN without one)
    sweeps: int
    time_s: float  # its Leapfrog run, continuation and validation
    message: str


#: More runs without an extremal than this are counted, not listed, among a plan's other paths
#: (in the command line's table and the figure's legend): a car's plan can try 18 paths.
FAILED_LISTED = 3


def listed_alternatives(
    alternatives: tuple[PathOutcome, ...],
) -> tuple[list[PathOutcome], int]:
    """The other paths to list one by one, and how many runs without an extremal are only
    counted (all of them, when there are more than :data:`FAILED_LISTED`; else none)."""
    failed = [a for a in alternatives if not math.isfinite(a.cost)]
    if len(failed) <= FAILED_LISTED:
        return list(alternatives), 0
    return [a for a in alternatives if math.isfinite(a.cost)], len(failed)


@dataclass(frozen=True)
class TimeStep:
    """One horizon the search solved: ``H`` of the fixed-horizon extremal there (the rate of
    change of its cost with ``T``), its cost with the price of time (``V + k T``), and how it
    was found: ``"plan"`` (the whole search) or ``"continued"`` (shooting from a known one)."""

    horizon: float
    hamiltonian: float
    cost: float
    source: str


@dataclass(frozen=True)
class FreeTimeReport:
    """How the final time was chosen: the price of time ``k`` (and the cruise speed it was
    given as), the answer's ``T``, its ``k + H`` (zero at a free-time optimum), the bound ``T``
    rests on (``""``, ``"shortest"`` or ``"longest"``) and every horizon solved."""

    time_weight: float
    cruise_speed: float | None
    horizon: float
    condition: float
    bound: str
    steps: tuple[TimeStep, ...]

    @property
    def time_cost(self) -> float:
        return self.time_weight * self.horizon
