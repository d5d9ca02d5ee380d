"""The Leapfrog algorithm of Kaya and Noakes, as the paper uses it.

The piecewise-optimal trajectory is kept as ``q`` arcs between junctions ``(t_i, z_i)``; each arc
is an extremal with known initial and final costate and cost. A sweep visits ``i = 1 .. q-1``
(Gauss-Seidel): it solves the local problem from junction ``i-1`` to ``i+1`` by simple shooting,
warm-started with the costate of arc ``i-1``, and moves junction ``i`` to the middle time of that
local extremal. The two new arcs replace the old ones only if they are not more expensive, so the
cost never increases (a local solve may land on a worse extremal; that is counted as a rejection).

Rule for reducing ``q`` (defaults in :class:`LeapfrogSettings`): after a sweep, ``q`` is
halved (every other junction kept) when the sweep had no failed local problem and lowered the
cost by less than ``reduce_tol`` (relative) or brought the largest costate jump at the junctions
below ``jump_tol`` (relative to the costate size), or when ``sweeps_per_level`` sweeps were made
at this ``q``. At ``q = 2`` the final
simple shooting over the whole horizon runs from the costate of the first arc; if it fails, a
multiple-shooting Newton solve over the junctions of the last level with ``q > 2`` takes over
(then over those arcs split in two, ``final_refinements`` times). If both fail, that level (or
the level at ``fewest_arcs`` where a long route stops halving) is swept on (at most
``final_retry_sweeps`` more sweeps, 20 times as many on a level of more than 4 arcs, until its
jump is below ``final_retry_jump``) and both are tried again from there.

Local problems that fail are retried by other strategies (:mod:`.local`); in a sweep, a failed
local problem leaves its junction where it is. A level that ends with a local problem still
failing is refined rather than halved (:mod:`.levels`). The Newton method itself (classical Newton
included) is never changed: this robustness lives at the Leapfrog level.

The pieces: :mod:`.settings`, :mod:`.arcs` (piecewise extremals), :mod:`.local` (the local
problems and their strategies), :mod:`.sweep` (the initial path's arcs, one sweep),
:mod:`.levels` (the rule for q), :mod:`.stop` (when a run raced against others is abandoned),
:mod:`.final` (the final solve) and :mod:`.driver` (init, step, terminate, postprocess).
"""

from __future__ import annotations

from .arcs import Arcs, Junctions
from .driver import LeapfrogSolution, LeapfrogStatus, leapfrog
from .levels import Level, LevelState, next_level
from .local import LocalSolver, continuation
from .settings import FINAL_MODES, LOCAL_STEPS, LeapfrogSettings
from .stop import LateBound
from .sweep import SweepRecord

#: The old name of :class:`LeapfrogSolution`, kept for one release.
LeapfrogRun = LeapfrogSolution

__all__ = [
    "FINAL_MODES",
    "LOCAL_STEPS",
    "Arcs",
    "Junctions",
    "LateBound",
    "LeapfrogRun",
    "LeapfrogSettings",
    "LeapfrogSolution",
    "LeapfrogStatus",
    "Level",
    "LevelState",
    "LocalSolver",
    "SweepRecord",
    "continuation",
    "leapfrog",
    "next_level",
]
