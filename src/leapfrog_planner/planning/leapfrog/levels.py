"""When a level ends, and what follows it: the rule for reducing ``q``, as a pure function.

After a sweep, the level ends when the sweep had no failed local problem and lowered the cost by
less than ``reduce_tol`` (relative) or brought the largest costate jump below ``jump_tol``; when
two sweeps in a row made no such progress (failures or not); when a sweep moved no junction
(each local problem failed or was rejected: the next sweep would only repeat it); or when
``sweeps_per_level`` sweeps were made at this ``q``. A level that ends with a local problem
still failing is refined (every arc split at its middle: shorter local problems) rather than
halved, at most ``max_refinements`` times per run: halving on would hand the final solve a
large costate jump. After ``k`` refinements a level must lower the cost by less than
``reduce_tol * 0.1**k`` to count as settled. A level that would be halved to fewer than
``fewest_arcs`` arcs is the last: the final solves start from it.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

from .settings import LeapfrogSettings
from .sweep import SweepRecord


class Level(Enum):
    STAY = "stay"  # sweep on at this q
    HALVE = "halve"  # keep every other junction
    REFINE = "refine"  # split every arc at its middle
    FINAL = "final"  # halving would leave fewer than ``fewest_arcs``: the final solves start here


@dataclass(frozen=True)
class LevelState:
    sweeps: int = 0  # sweeps made at this level
    stalls: int = 0  # sweeps in a row that made no progress
    refinements: int = 0  # levels refined so far in the run


def next_level(
    rec: SweepRecord, cost_before: float, state: LevelState, settings: LeapfrogSettings
) -> tuple[Level, LevelState]:
    """What follows sweep ``rec`` (whose level cost ``cost_before`` before it), and the state
    of the level after it (reset when the level ends)."""
    sweeps = state.sweeps + 1
    decrease = (cost_before - rec.cost) / max(abs(rec.cost), 1e-12)
    settled = (
        decrease < settings.reduce_tol * 0.1**state.refinements
        or rec.max_costate_jump < settings.jump_tol
    )
    stalls = state.stalls + 1 if settled else 0
    ended = (settled and rec.failures == 0) or stalls >= 2 or idle(rec)
    if not (ended or sweeps >= settings.sweeps_per_level):
        return Level.STAY, LevelState(sweeps, stalls, state.refinements)
    if rec.failures and state.refinements < settings.max_refinements:
        return Level.REFINE, LevelState(0, 0, state.refinements + 1)
    if (rec.q + 1) // 2 < settings.fewest_arcs:  # (a halved level keeps ceil(q / 2) arcs)
        return Level.FINAL, LevelState(0, 0, state.refinements)
    return Level.HALVE, LevelState(0, 0, state.refinements)


def idle(rec: SweepRecord) -> bool:
    """The sweep moved no junction: its ``q - 1`` local problems all failed or were rejected
    (at 1000 obstacles, three such sweeps in a row took 0.7 s of a stuck path's 1.9)."""
    return rec.failures > 0 and rec.failures + rec.rejected >= rec.q - 1
