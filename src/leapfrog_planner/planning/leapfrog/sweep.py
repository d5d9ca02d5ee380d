"""The initial path's arcs, and the Gauss-Seidel sweep of the midpoint map over a level.

A sweep visits ``i = 1 .. q-1``: it solves the local problem from junction ``i-1`` to ``i+1``,
warm-started with the costate of arc ``i-1``, and moves junction ``i`` to the middle time of that
local extremal. The two new arcs replace the old ones only if they are not more expensive, so the
cost never increases (a local solve may land on a worse extremal; that is counted as a
rejection). A failed local problem leaves its junction where it is, so the arcs and the cost stay
defined.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass

import numpy as np

from ...compiled.status import SweepCode
from .arcs import Junctions
from .local import LocalSolver

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class SweepRecord:
    sweep: int
    q: int
    cost: float  # of the piecewise-optimal trajectory after the sweep
    max_costate_jump: float
    newton_iterations: int
    f_evals: int
    failures: int  # local problems that did not converge
    rejected: int  # converged local problems whose arcs would have cost more
    time_s: float
    t: np.ndarray  # junction times after the sweep
    X: np.ndarray  # junction states after the sweep


@dataclass(frozen=True)
class InitialFit:
    """The initial path's arcs (``arcs``), each segment a local extremal; where a segment's
    two-point problem failed every strategy, no arcs, the segment and the message."""

    arcs: Junctions | None
    message: str
    failed_segment: int | None = None

    @property
    def success(self) -> bool:
        return self.arcs is not None


def fit_initial_path(local: LocalSolver, t: np.ndarray, X: np.ndarray) -> InitialFit:
    """The arcs through the initial path's junctions ``(t, X)``, each segment a local extremal
    (split where it fails); or, when a segment fails every strategy, which one and what was
    tried."""
    pieces = []
    for i in range(t.size - 1):
        warm = pieces[-1].lam1 if pieces else None
        seg = local.fit(t[i], X[i], t[i + 1], X[i + 1], warm)
        if seg is None:
            tried = "warm start, path costate, weight and end-state continuation, affine guess"
            if local.guide is not None and local.settings.max_split_depth:
                tried += f", split {local.settings.max_split_depth} times"
            message = f"the two-point problem of initial segment {i} failed ({tried})"
            return InitialFit(None, message, i)
        pieces += seg
    arcs = Junctions.from_pieces(
        [(p.t0, p.x0, p.lam0, p.lam1, p.cost) for p in pieces], float(t[-1]), X[-1].copy()
    )
    return InitialFit(arcs, f"{len(pieces)} segments")


def sweep(arcs: Junctions, local: LocalSolver, number: int) -> SweepRecord:
    """Sweep number ``number`` over the junctions of ``arcs`` (updated in place), recorded."""
    t_sweep = time.perf_counter()
    count, flow = local.count, local.flow
    it0, fe0 = count.iterations, count.f_evals
    failures = rejected = 0
    # The warm attempts run in one compiled call while they converge (the same arithmetic as
    # below); the junction of a failed one comes back here for its fallbacks.
    warm = local.shooter(local.problem, flow, local.attempt)
    fused = local.settings.fused_sweeps and warm.fused
    i = 0
    while (i := i + 1) < arcs.q:
        warm_failed = False
        if fused:
            out = warm.warm_sweep(arcs.t, arcs.X, arcs.lam0, arcs.lam1, arcs.cost, i)
            count.iterations += out.iterations
            count.f_evals += out.f_evals
            rejected += out.rejected
            i = out.junction
            if out.code == SweepCode.DONE:
                break
            # otherwise WARM_FAILED, or PYTHON: junction i from the start
            warm_failed = out.code == SweepCode.WARM_FAILED
        ta, tb = arcs.t[i - 1], arcs.t[i + 1]
        xa, xb = arcs.X[i - 1], arcs.X[i + 1]
        mid = (arcs.t[i], arcs.X[i], arcs.lam0[i])
        r = local.sweep_solve(ta, xa, tb, xb, arcs.lam0[i - 1], mid, warm_failed, arcs, i)
        if not r.success:
            failures += 1
            continue
        old = arcs.cost[i - 1] + arcs.cost[i]
        if r.cost > old + 1e-10 * max(1.0, abs(old)):
            rejected += 1
            continue
        tm = 0.5 * (ta + tb)
        half = flow(ta, np.concatenate([xa, r.costate0]), tm)
        arcs.t[i], arcs.X[i] = tm, half.x
        arcs.lam0[i - 1], arcs.lam1[i - 1], arcs.cost[i - 1] = r.costate0, half.lam, half.cost
        arcs.lam0[i], arcs.lam1[i], arcs.cost[i] = half.lam, r.costate1, r.cost - half.cost
    rec = SweepRecord(
        sweep=number,
        q=arcs.q,
        cost=float(arcs.cost.sum()),
        max_costate_jump=arcs.max_jump(),
        newton_iterations=count.iterations - it0,
        f_evals=count.f_evals - fe0,
        failures=failures,
        rejected=rejected,
        time_s=time.perf_counter() - t_sweep,
        t=arcs.t.copy(),
        X=arcs.X.copy(),
    )
    log.debug("sweep %d: q=%d cost=%.10g jump=%.3g", number, rec.q, rec.cost, rec.max_costate_jump)
    return rec
