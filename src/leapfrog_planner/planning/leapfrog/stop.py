"""When a run of Leapfrog is abandoned: after a sweep that leaves its cost above a bound, a
number known from the start or a :class:`LateBound` that runs in other threads set when they
end (the planner's extra paths, raced against its first: see :mod:`..search`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

from .arcs import Arcs
from .sweep import SweepRecord


class LateBound(Protocol):
    """A bound on a run's cost known only later (when runs in other threads have ended)."""

    def value(self) -> float | None:
        """The bound, or None while it is not known."""

    def wait(self) -> float:
        """The bound, once it is known."""


@dataclass(frozen=True)
class Snapshot:
    """A run after a sweep, as much of it as an abandoned run reports."""

    cost: float
    sweeps: tuple[SweepRecord, ...]
    arcs: Arcs  # the last level with q > 2 (a piecewise extremal from start to goal)
    max_jump: float
    initial_cost: float
    increases: int
    iterations: int
    f_evals: int
    fit_strategies: dict[str, int]
    time_s: float


#: The first sweep that is judged: a run's first sweep from a poor fit may barely move it
#: (metric layout 16 of seed 1: 51.70 after its first sweep, 18.98 after its second, 6.94 at
#: the end, the plan's answer, against a bound of 26.04 that the first would have failed).
FIRST_JUDGED_SWEEP = 2


class StopRule:
    """Whether a run is abandoned: at the first sweep (from :data:`FIRST_JUDGED_SWEEP`) that
    leaves its cost above the bound.
    While a :class:`LateBound` is not known, each sweep is kept (:class:`Snapshot`) and judged
    when it is, so that the outcome does not depend on when that was."""

    def __init__(self, stop_above: float | LateBound):
        self.late = None if isinstance(stop_above, (int, float)) else stop_above
        self.bound = float(stop_above) if self.late is None else None
        self.pending: list[Snapshot] = []

    def asks(self, cost: float, sweep: int) -> bool:
        """Whether sweep number ``sweep``, which left the run at ``cost``, is to be judged
        (:meth:`judge`): one from :data:`FIRST_JUDGED_SWEEP` on, above the bound or while
        the bound is not known yet."""
        return sweep >= FIRST_JUDGED_SWEEP and (self.bound is None or cost > self.bound)

    def judge(self, after_sweep: Snapshot) -> Snapshot | None:
        """The run as it is abandoned, or None: it goes on."""
        if self.bound is not None:
            return after_sweep if after_sweep.cost > self.bound else None
        self.pending.append(after_sweep)
        self.bound = self.late.value()
        return None if self.bound is None else self._judged()

    def before_final(self) -> Snapshot | None:
        """The run as it is abandoned, once the bound is known, or None."""
        if self.bound is None:
            self.bound = self.late.wait()
            return self._judged()
        return None

    def _judged(self) -> Snapshot | None:
        lost = next((s for s in self.pending if s.cost > self.bound), None)
        self.pending = []
        return lost
