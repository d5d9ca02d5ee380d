"""The records of the planner's runs: what a run is asked to do (:class:`Round`,
:class:`RunRequest`, made by :mod:`.search`) and what it gave (:class:`PathRun`)."""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass

import numpy as np

from ..integrate.problem import OptimalControlProblem
from ..roots import RootSettings
from .initial_path import InitialPath
from .leapfrog import LeapfrogSolution
from .path_ranking import PathGuide
from .results import PathOutcome, PlanStatus, Validation
from .status import RunRecord

# A result whose re-integrated end state misses the goal by more than this (times the final
# solve's |F| tolerance) is not converged: 1e-8 by default. The re-integration runs at the final
# solve's tolerances (DOP853 at rtol 1e-12 by default), so that the final settings set the
# answer's accuracy in one place.
END_STATE_FACTOR = 100.0
END_STATE_TOLERANCE = END_STATE_FACTOR * RootSettings().tol


@dataclass(frozen=True)
class Round:
    """What the runs of a round share: Leapfrog's partitions, the fewest arcs its levels are
    halved down to, and the value of the model's planning aid (None for a model without one);
    ``reason`` says why the round runs."""

    partitions: int
    fewest_arcs: int
    aid: float | None
    reason: str
    doublings: int = 0  # the partitions doubled this many times from the first round's
    aid_step: int = 0  # the index of ``aid`` among the aid's values

    def suffix(self, aid_name: str) -> str:
        """What a run's label adds for its round (nothing in the first)."""
        arcs = f" down to {self.fewest_arcs} arcs" if self.fewest_arcs > 2 else ""
        finer = f", q = {self.partitions}{arcs}" if self.doublings else ""
        weaker = f", {aid_name.replace('_', ' ')} {self.aid:g}" if self.aid_step else ""
        return finer + weaker


@dataclass(frozen=True, eq=False)
class RunRequest:
    """One Leapfrog run to make: from ``path`` in ``round``, at obstacle weight ``weight`` (the
    scenario's raised ``raises`` times); ``stage`` asked for it, for ``reason``; ``label`` is
    the path's label with its round's."""

    path: InitialPath
    round: Round
    stage: str
    reason: str
    weight: float
    raises: int = 0
    label: str = ""
    # The run stops after a sweep that leaves its piecewise cost above this: a number, or the
    # bound its race's leaders set when they end (see :mod:`.search`).
    stop_above: float | LeadersBound = math.inf
    # The race whose leaders this run is one of: told when it ends.
    leads: LeadersBound | None = None


class LeadersBound:
    """The bound at which the runs raced against ``leaders`` others stop: ``factor`` times the
    cheapest collision-free extremal of the leaders, known when all of them have ended (no
    bound where none clears). The runs share it in threads (a :class:`.leapfrog.LateBound`):
    the leaders' runs tell it when they end (:meth:`ended`), the others ask for it."""

    def __init__(self, leaders: int, factor: float):
        self.factor = factor
        self._left = leaders
        self._clear: list[float] = []
        self._bound = math.inf
        self._known = threading.Event()
        self._lock = threading.Lock()
        if leaders <= 0:
            self._known.set()

    def ended(self, run: PathRun | None) -> None:
        """A leader's run ended (None: it raised)."""
        with self._lock:
            if run is not None and run.clear:
                self._clear.append(run.validation.cost)
            self._left -= 1
            if self._left == 0:
                self._bound = self.factor * min(self._clear, default=math.inf)
                self._known.set()

    def value(self) -> float | None:
        return self._bound if self._known.is_set() else None

    def wait(self) -> float:
        self._known.wait()
        return self._bound


@dataclass(frozen=True)
class PathRun:
    """Leapfrog from one initial path as a request asked (:class:`.search.RunRequest`): the
    run and its validated answer (``None`` when the run failed)."""

    request: RunRequest
    guide: PathGuide
    run: LeapfrogSolution
    junctions: tuple[np.ndarray, np.ndarray]  # (t, X) of the initial path
    validation: Validation | None
    validation_time_s: float
    # The problem whose piecewise extremal the run's Leapfrog iterate (``run.arcs``) is: the
    # car with its turn assist, or the bounds relaxed, where Leapfrog ran on those.
    iterate_problem: OptimalControlProblem
    end_tolerance: float = END_STATE_TOLERANCE
    margin: float = 0.0  # the clearance a clear run keeps (the scenario's robot margin)
    time_s: float = 0.0  # the run's wall time: Leapfrog, continuation and validation

    @property
    def path(self) -> InitialPath:
        return self.request.path

    @property
    def weight(self) -> float:
        return self.request.weight

    @property
    def raises(self) -> int:
        """How often the weight was raised from the scenario's for this run."""
        return self.request.raises

    def same_line(self, other: PathRun) -> bool:
        """From the same initial path in the same round (at whichever obstacle weight)."""
        return self.path is other.path and self.request.round is other.request.round

    @property
    def extremal(self) -> bool:
        """A validated extremal (through an obstacle or not)."""
        return valid(self.validation, self.end_tolerance)

    @property
    def collides(self) -> bool:
        return self.extremal and touches(self.validation.clearance, self.margin)

    @property
    def clear(self) -> bool:
        return self.extremal and not touches(self.validation.clearance, self.margin)

    @property
    def status(self) -> PlanStatus:
        if self.collides:
            return PlanStatus.COLLIDES
        return PlanStatus.CONVERGED if self.clear else PlanStatus.FAILED

    def outcome(self) -> PathOutcome:
        v = self.validation
        return PathOutcome(
            label=self.request.label,
            status=self.status,
            cost=v.cost if self.extremal else float("nan"),
            initial_cost=self.run.initial_cost,
            sweeps=len(self.run.history),
            message=self.run.message,
            weight=self.weight,
            trajectory=v.trajectory if self.extremal else None,
        )

    def record(self) -> RunRecord:
        """The run as the result's search lists it."""
        rq = self.request
        return RunRecord(
            stage=rq.stage,
            reason=rq.reason,
            label=rq.label,
            partitions=rq.round.partitions,
            weight=rq.weight,
            aid=rq.round.aid,
            status=self.status,
            cost=self.validation.cost if self.extremal else float("nan"),
            sweeps=len(self.run.history),
            time_s=self.time_s,
            message=self.run.message,
        )


def best_of(runs: list[PathRun]) -> PathRun:
    """A path's run to report: the first that clears, else the first extremal, else the last."""
    return next((r for r in runs if r.clear), None) or next(
        (r for r in runs if r.extremal), runs[-1]
    )


def touches(clearance: np.ndarray, margin: float = 0.0) -> bool:
    """Closer than ``margin`` to an obstacle (grown by the footprint), or through one."""
    return bool(clearance.size) and not clearance.min() >= margin


def valid(v, end_tolerance: float = END_STATE_TOLERANCE) -> bool:
    """A validated extremal: re-integrated without failure, reaching the goal."""
    return v is not None and np.isfinite(v.cost) and v.end_state_error <= end_tolerance


@dataclass(frozen=True)
class Searched:
    """What a plan's search ran: its runs, the seconds they took, and whether the time limit
    cut the search short (work was left undone)."""

    runs: list[PathRun]
    runs_s: float
    cut: bool
