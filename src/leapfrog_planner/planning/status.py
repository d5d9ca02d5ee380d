"""How a plan ended, and the summary of one initial path's run."""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import StrEnum

import numpy as np

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
#: Two paths' extremals are one (found from both) when their costs agree to this relative
#: tolerance and their positions, at the same shares of their horizons, to this share of the
#: path's extent: mirror-image extremals of a symmetric scene cost the same, but part by metres.
SAME_COST, SAME_PATH = 1e-6, 1e-4
#: A path followed from another (a step of the continuation in ``T``, a warm re-plan) that
#: moves further than this share of its length has jumped to another family (measured: a step
#: of 1.5x in ``T`` from a path round a disc landed on one through it).
MAX_MOVE = 0.15


def same_extremal(a, b) -> bool:
    """Whether ``a`` and ``b`` (a result, a :class:`PathOutcome`) hold the same extremal: both
    with a path and a cost, the costs and the paths alike (:data:`SAME_COST`, :data:`SAME_PATH`)."""
    ta, tb = a.trajectory, b.trajectory
    if ta is None or tb is None or not (math.isfinite(a.cost) and math.isfinite(b.cost)):
        return False
    if abs(a.cost - b.cost) > SAME_COST * max(1.0, abs(a.cost), abs(b.cost)):
        return False
    share = np.linspace(0.0, 1.0, 101)
    xy = [tr.at(tr.t[0] + share * (tr.t[-1] - tr.t[0]), tr.x[:, :2]) for tr in (ta, tb)]
    extent = float(np.ptp(xy[0], axis=0).max())
    return float(np.abs(xy[0] - xy[1]).max()) <= SAME_PATH * max(extent, 1e-300)


def path_moved(new_xy: np.ndarray, old_xy: np.ndarray, *, less_start: bool = False) -> float:
    """How far the path ``new_xy`` lies from ``old_xy`` (positions at the same shares of their
    horizons), relative to the longer path's length; ``less_start``: less the start's own
    move (a re-plan from a moved start). Above :data:`MAX_MOVE`, another family."""
    moved = np.linalg.norm(new_xy - old_xy, axis=1)
    if less_start:
        moved = moved - moved[0]
    length = max(_length(new_xy), _length(old_xy), 1e-12)
    return float(moved.max()) / length


def _length(xy: np.ndarray) -> float:
    return float(np.linalg.norm(np.diff(xy, axis=0), axis=1).sum())


def listed_alternatives(alternatives: tuple[PathOutcome, ...], answer=None):
    """The other paths to list one by one, and how many runs without an extremal are only
    counted (all of them, when there are more than :data:`FAILED_LISTED`; else none). An
    extremal found from several paths is listed once, under the first; the ``answer``'s (a
    result) never: it is the answer, not another path."""
    distinct: list[PathOutcome] = []
    for a in alternatives:
        again = [*distinct, answer] if answer is not None else distinct
        if not any(same_extremal(a, b) for b in again):
            distinct.append(a)
    failed = [a for a in distinct if not math.isfinite(a.cost)]
    if len(failed) <= FAILED_LISTED:
        return distinct, 0
    return [a for a in distinct if math.isfinite(a.cost)], len(failed)


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
