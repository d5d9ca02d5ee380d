"""The local two-point problems of a Leapfrog run and the strategies that solve them.

A local problem is tried from a warm start for at most ``attempt_iterations`` Newton iterations
(cut short when ``|F|`` stalls over ``attempt_stall_window`` iterations). When that fails, in a
sweep: as two arcs through the current middle junction (multiple shooting; its only starting
residual is the costate jump there), then by continuation in the obstacle weight from 0 to ``W``,
then by continuation in the end state (once per junction and level). On the initial path: from
the path's own costate, by continuation in the weight and in the end state, from the affine
guess, and then split at its middle (up to ``max_split_depth`` times). The Newton method itself
(classical Newton included) is never changed: the robustness lives at the Leapfrog level.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ...bvp.multiple_shooting import MultipleShootingSystem, solve_multiple_shooting
from ...bvp.shooting import LocalShooter, LocalSolution, ShootingResult
from ...integrate.flow import Flow
from ...integrate.problem import OptimalControlProblem
from ...roots import RootResult, RootStatus
from ..path_ranking import PathGuide
from .arcs import Junctions
from .settings import LeapfrogSettings


class Counter:
    """Newton iterations and F evaluations of every solve of a run."""

    def __init__(self):
        self.iterations = 0
        self.f_evals = 0

    def add(self, r: ShootingResult | RootResult | LocalSolution):
        root = r.root if isinstance(r, ShootingResult) else r
        self.iterations += root.iterations
        self.f_evals += root.f_evals


class Strategies:
    """How the initial path's segments were solved: per strategy, the segments it solved;
    ``failed`` (every strategy failed) and ``split`` (segments split in two after failing)."""

    def __init__(self):
        self.counts: dict[str, int] = {}

    def solved(self, name: str, r):
        self.counts[name] = self.counts.get(name, 0) + 1
        return r

    def failed(self, r):
        self.counts["failed"] = self.counts.get("failed", 0) + 1
        return r

    def split(self):
        self.counts["split"] = self.counts.get("split", 0) + 1


@dataclass(frozen=True)
class Piece:
    """A solved segment of the initial path."""

    t0: float
    x0: np.ndarray
    lam0: np.ndarray
    lam1: np.ndarray
    cost: float


class LocalSolver:
    """Solves the local problems of one run: its problem, flow and settings do not change under
    it. Not thread-safe (its shooters reuse buffers); Leapfrog builds one per run."""

    def __init__(
        self,
        problem: OptimalControlProblem,
        flow: Flow,
        settings: LeapfrogSettings,
        guide: PathGuide | None = None,
    ):
        self.problem, self.flow, self.settings, self.guide = problem, flow, settings, guide
        self.step = settings.local_step()
        self.shooting = settings.local_solves()
        # A direct attempt that has not converged after a few iterations is failing: the next
        # strategy is then cheaper than more Newton steps on the hard problem.
        self.attempt = replace(
            self.shooting,
            root=replace(
                self.shooting.root,
                max_iterations=settings.attempt_iterations,
                stall_window=settings.attempt_stall_window,
            ),
        )
        self.W = problem.penalty.weight
        self.has_obstacles = problem.penalty.any and self.W > 0
        self.count = Counter()
        self.strategies = Strategies()
        self._shooters: dict[tuple, LocalShooter] = {}
        self._weighted: dict[float, tuple[OptimalControlProblem, Flow]] = {}
        # The sweeps' local problems that failed: whether the end-state continuation was tried,
        # and the failure.
        self._failed: dict[bytes, tuple[bool, LocalSolution]] = {}

    # ------------------------------------------------------------------ one solve

    def shooter(self, local: OptimalControlProblem, flow: Flow, settings) -> LocalShooter:
        """The shooter of a problem, flow and settings. Keyed by identity: hashing the settings
        cost more than a local solve's bookkeeping (the shooter holds them, so the ids stay)."""
        key = (id(flow), id(settings))
        shoot = self._shooters.get(key)
        if shoot is None:
            shoot = self._shooters[key] = LocalShooter(local, flow, settings, self.step)
        return shoot

    def solve(self, ta, xa, tb, xb, guess=None, local=None, flow=None, settings=None):
        """A local two-point problem (by default the run's problem, as an attempt)."""
        local = self.problem if local is None else local
        flow = self.flow if flow is None else flow
        r = self.shooter(local, flow, settings or self.attempt)(ta, xa, tb, xb, guess)
        self.count.add(r)
        return r

    def at_weight(self, w: float) -> tuple[OptimalControlProblem, Flow]:
        """The problem with obstacle weight ``w`` and its flow (built once per run)."""
        if w not in self._weighted:
            p = self.problem.with_weight(w)
            self._weighted[w] = (p, Flow(p, self.flow.settings))
        return self._weighted[w]

    # ------------------------------------------------------------------ strategies

    def direct(self, ta, xa, tb, xb, guess, local=None, flow=None, mid=None, warm_failed=False):
        """The warm guess (unless it was tried and ``warm_failed``); in a sweep (``mid``
        given), two arcs through the middle junction; otherwise the affine guess.

        The affine guess is not tried after the two arcs: where both attempts from the current
        arcs fail, it succeeded too rarely to pay; continuation takes over."""
        if not warm_failed and guess is not None:
            r = self.solve(ta, xa, tb, xb, guess, local, flow)
            if r.success:
                return r
        if mid is not None and self.settings.two_arc_attempt:
            return self.two_arcs(ta, xa, tb, xb, guess, mid)
        return self.solve(ta, xa, tb, xb, None, local, flow)

    def two_arcs(self, ta, xa, tb, xb, guess, mid) -> LocalSolution:
        """The local problem as two arcs through the junction ``mid = (t_i, x_i, lambda_i)``.

        Unknowns ``(lambda_a, x_i, lambda_i)`` start at the current arcs, so the only residual is
        the costate jump at ``t_i``. A solution is an extremal from ``xa`` to ``xb``; one simple
        shooting from its ``lambda_a`` (already a root) returns it as a local solve does.
        """
        ms = MultipleShootingSystem(self.flow, np.array([ta, mid[0], tb]), xa, xb)
        w0 = np.concatenate([guess, mid[1], mid[2]])
        a = self.attempt
        root = solve_multiple_shooting(ms, w0, self.step, a.root, a.compiled)
        self.count.add(root)
        if not root.success:
            return LocalSolution.failure(root.status, guess)
        return self.solve(ta, xa, tb, xb, root.x[: xa.size])

    def weight_continuation(self, ta, xa, tb, xb, guess) -> LocalSolution:
        """Raise the obstacle weight from 0 to W (:func:`continuation`), from a solve at
        weight 0 (the direct attempts there)."""
        r = self.direct(ta, xa, tb, xb, guess, *self.at_weight(0.0))
        if not r.success:
            return r

        def at(w, g):
            return self.solve(ta, xa, tb, xb, g, *self.at_weight(w))

        return continuation(at, r.costate0, self.W, self.settings)

    def end_state_continuation(self, ta, xa, tb, xb, guess) -> LocalSolution:
        """Move the end state from where ``guess`` leads (there ``guess`` is exact) to ``xb``
        (:func:`continuation`): a problem family that starts solved, for any method."""
        r = self.flow(ta, np.concatenate([xa, guess]), tb)
        if not r.ok:
            return LocalSolution.failure(RootStatus.NON_FINITE, guess)
        reached = r.x

        def at(p, g):
            return self.solve(ta, xa, tb, reached + p * (xb - reached), g)

        return continuation(at, guess, 1.0, self.settings)

    # ------------------------------------------------------------------ the two uses

    def sweep_solve(self, ta, xa, tb, xb, guess, mid, warm_failed, level: Junctions, i: int):
        """In a sweep, the local problem of junction ``i`` of ``level``: the warm ``guess``
        (unless it was tried and ``warm_failed``: the compiled sweep tries it), then the
        direct attempts, then continuation in the obstacle weight, then in the end state (once
        per junction and level: where it fails once it fails again, and each try costs up to
        ``continuation_steps`` solves).

        Where the warm guess fails on a problem that failed before in this run with the very
        same data (ends, guess, middle junction) and the same strategies or more, the rest
        fails at once: every strategy is deterministic, so it would fail again. Where a stretch
        of junctions is stuck, the next sweep poses the same problems (1,000 obstacles: 3 to
        14 repeats a plan, each a failed continuation of 10 to 80 ms). The warm attempt itself
        is always made, as the compiled sweep makes it: the same work either way."""
        if not warm_failed:
            r = self.solve(ta, xa, tb, xb, guess)
            if r.success:
                return r
        key = np.concatenate([(ta, tb, mid[0]), xa, xb, guess, mid[1], mid[2]]).tobytes()
        end_state = i not in level.hopeless
        before = self._failed.get(key)
        if before is not None and (before[0] or not end_state):
            return before[1]
        r = self.direct(ta, xa, tb, xb, guess, mid=mid, warm_failed=True)
        if not r.success and self.has_obstacles:
            r = self.weight_continuation(ta, xa, tb, xb, guess)
        if not r.success and end_state:
            r = self.end_state_continuation(ta, xa, tb, xb, guess)
            if not r.success:
                level.hopeless.add(i)
        if not r.success:
            self._failed[key] = (end_state or (before is not None and before[0]), r)
        return r

    def segment_solve(self, ta, xa, tb, xb, warm) -> LocalSolution:
        """A segment of the initial path, by the first of these that succeeds (counted in
        :attr:`strategies`): from the costate ``warm`` at the end of the segment before (if
        any); from the path's own costate (or, with neither, from the affine guess); by
        continuation in the obstacle weight, then in the end state, from the first of these;
        from the affine guess.

        Continuation comes before the affine guess at the full weight: there the affine guess
        mostly failed too, and its failing iterates run long flows near the obstacles (paper
        case 4, second path: 5 segments, 96 evaluations and 17 ms), while continuation solved
        each segment in 2 ms."""
        solve, s = self.solve, self.strategies
        first = warm
        if warm is not None and (r := solve(ta, xa, tb, xb, warm)).success:
            return s.solved("warm", r)
        if self.guide is not None:  # computed only when needed: 40-80 us, paper case 1's are 8
            lam = self.guide.costate(ta)
            first = warm if warm is not None else lam
            if (r := solve(ta, xa, tb, xb, lam)).success:
                return s.solved("path costate", r)
        elif warm is None and (r := solve(ta, xa, tb, xb, None)).success:
            return s.solved("affine guess", r)
        if self.has_obstacles and (r := self.weight_continuation(ta, xa, tb, xb, first)).success:
            return s.solved("weight continuation", r)
        if first is not None and (r := self.end_state_continuation(ta, xa, tb, xb, first)).success:
            return s.solved("end-state continuation", r)
        if first is not None and (r := solve(ta, xa, tb, xb, None)).success:
            return s.solved("affine guess", r)
        return s.failed(r)

    def fit(self, ta, xa, tb, xb, warm, depth: int = 0) -> list[Piece] | None:
        """The segment from ``(ta, xa)`` to ``(tb, xb)`` solved, split in two at the path's
        state at its middle time while it fails (up to ``max_split_depth``)."""
        r = self.segment_solve(ta, xa, tb, xb, warm)
        if r.success:
            return [Piece(ta, xa, r.costate0, r.costate1, r.cost)]
        if depth >= self.settings.max_split_depth or self.guide is None:
            return None
        self.strategies.split()
        tm = 0.5 * (ta + tb)
        xm = self.guide.state(tm)
        left = self.fit(ta, xa, tm, xm, warm, depth + 1)
        right = self.fit(tm, xm, tb, xb, left[-1].lam1, depth + 1) if left is not None else None
        return None if right is None else left + right


def continuation(solve_at, s0, end: float, settings: LeapfrogSettings) -> LocalSolution:
    """Natural-parameter continuation: ``solve_at(p, guess)`` solves the problem at parameter
    ``p`` (a :class:`LocalSolution`); ``s0`` solves it at ``p = 0``. ``p`` goes to ``end``: the
    step (first ``continuation_first_step * end``) doubles after a success and halves after a
    failure, down to ``continuation_min_step * end``; each guess is extrapolated from the last
    two solutions (secant predictor), else the last one is tried too; at most
    ``continuation_steps`` steps. Returns the solution at ``end``, or the failure that ended
    it (the step budget spent: ``max-iterations``)."""
    p, s, prev = 0.0, s0, None
    dp = settings.continuation_first_step * end
    min_dp = settings.continuation_min_step * end
    for _ in range(settings.continuation_steps):
        pn = min(end, p + dp)
        pred = s if prev is None else s + (pn - p) * (s - prev[1]) / (p - prev[0])
        r = solve_at(pn, pred)
        if not r.success and prev is not None:
            r = solve_at(pn, s)
        if not r.success:
            if dp <= min_dp:
                return r
            dp = max(0.5 * dp, min_dp)
            continue
        prev, p, s = (p, s), pn, r.costate0
        if p >= end:
            return r
        dp *= 2.0
    return LocalSolution.failure(RootStatus.MAX_ITERATIONS, s)  # the step budget is spent
