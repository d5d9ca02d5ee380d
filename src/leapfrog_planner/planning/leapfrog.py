"""The Leapfrog algorithm of Kaya and Noakes, as the paper uses it (spec section 2).

The piecewise-optimal trajectory is kept as ``q`` arcs between junctions ``(t_i, z_i)``; each arc
is an extremal with known initial and final costate and cost. A sweep visits ``i = 1 .. q-1``
(Gauss-Seidel): it solves the local problem from junction ``i-1`` to ``i+1`` by simple shooting,
warm-started with the costate of arc ``i-1``, and moves junction ``i`` to the middle time of that
local extremal. The two new arcs replace the old ones only if they are not more expensive, so the
cost never increases (a local solve may land on a worse extremal; that is counted as a rejection).

Rule for reducing ``q`` (documented defaults in :class:`LeapfrogSettings`): after a sweep, ``q`` is
halved (every other junction kept) when the sweep had no failed local problem and lowered the
cost by less than ``reduce_tol`` (relative) or brought the largest costate jump at the junctions
below ``jump_tol`` (relative to the costate size), or when ``sweeps_per_level`` sweeps were made
at this ``q``. At ``q = 2`` the final
simple shooting over the whole horizon runs from the costate of the first arc; if it fails, a
multiple-shooting Newton solve over the junctions of the last level with ``q > 2`` takes over. If
both fail, that level is swept on (at most ``final_retry_sweeps`` more sweeps, until its jump is
below ``final_retry_jump``) and both are tried again from there.

Local failures: a local problem is tried from the warm start, for at most ``attempt_iterations``
Newton iterations (cut short when ``|F|`` stalls over ``attempt_stall_window`` iterations); then, in
a sweep, as a two-arc multiple-shooting problem through the current middle junction, whose only
initial residual is the costate jump there; then by continuation in the obstacle weight from 0 to
``W`` with step-size control and a secant predictor. On the initial path a segment that still fails
is tried from the affine guess (which starts the first segment) and then split at its middle (up to
``max_split_depth`` times). In a sweep, a failed local problem leaves its junction where it is, so
the arcs and the cost stay defined; ``q`` is not reduced while a level still has failures (unless
two sweeps in a row made no progress, or its sweep budget is spent); a level that ends with a local
problem still failing is refined (every arc split at its middle) rather than halved, at most
``max_refinements`` times, and the refined level must converge ten times further before q is halved
again. The method itself (classical Newton included) is never changed: this robustness lives at the
Leapfrog level.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np

from .._blas import blas_single_threaded
from ..bvp.multiple_shooting import MultipleShootingSystem, solve_multiple_shooting
from ..bvp.shooting import (
    LocalShooter,
    LocalSolution,
    ShootingResult,
    ShootingSettings,
    solve_shooting,
)
from ..errors import SettingsError, require_integer
from ..integrate.flow import Flow, IntegratorSettings
from ..model.problem import OptimalControlProblem
from ..roots import STRATEGIES, ModifiedNewtonStep, RootResult, RootSettings
from .path_ranking import PathGuide

log = logging.getLogger(__name__)

# Sweeps call the compiled warm sweep (the kernels' ``sweep_warm``) where the local shooter is
# compiled; False runs every junction from Python (the tests compare the two, bit for bit).
_FUSED_SWEEPS = True

FINAL_MODES = ("auto", "shooting", "multiple-shooting")


@dataclass(frozen=True)
class LeapfrogSettings:
    method: str = "modified-newton"  # local solver: newton, modified-newton or nleq-err
    partitions: int = 8  # initial q
    max_sweeps: int = 60  # over all levels
    sweeps_per_level: int = 10
    reduce_tol: float = 1e-3
    jump_tol: float = 1e-6
    final: str = "auto"
    # When both final solves fail (final="auto"), the last level with q > 2 is swept on, at most
    # this many more sweeps (beyond max_sweeps), until its costate jump is below final_retry_jump
    # or a sweep no longer lowers the cost, and both are tried again from there; 0 disables.
    # The level was left at a cost decrease below reduce_tol, which on some random scenarios
    # still left a jump of 0.05 (measured), too far for classical Newton over the whole horizon.
    final_retry_sweeps: int = 10
    final_retry_jump: float = 1e-4
    max_split_depth: int = 4
    # Levels that end with a failing local problem are split (q doubled) instead of halved, at
    # most this many times per run.
    max_refinements: int = 2
    # Iterations of a direct attempt at a local problem (warm guess, two arcs, affine guess) before
    # continuation in the obstacle weight takes over; converging local solves need 3 to 8.
    attempt_iterations: int = 10
    # A direct attempt whose |F| is not below half the largest of its last this-many norms is
    # creeping (measured on failing attempts: 40 iterations at |F| ~ 0.05) and is cut short
    # (RootSettings.stall_window); 0 disables. Random scenarios: a third fewer failed-attempt
    # evaluations, the same successes.
    attempt_stall_window: int = 3
    # A local problem whose warm attempt fails is next solved as two arcs through the current
    # junction (multiple shooting, same Newton method, unknowns lambda_a, x_i, lambda_i): its
    # starting residual is only the costate jump at the junction, and its Jacobian is far better
    # conditioned than the full local shot. Paper case 3 (MNM): continuation work 447 -> 25 flow
    # evaluations. False keeps the paper's local simple shooting only.
    two_arc_attempt: bool = True
    # Weight continuation: first increment and smallest increment, as fractions of W.
    continuation_first_step: float = 0.25
    continuation_min_step: float = 1.0 / 64
    # Weight steps tried (successful or not) before a continuation counts as failed. Most need 3
    # to 6; the paper cases need up to 24 somewhere (fewer changes their results), and the bound
    # keeps a hopeless local problem from costing seconds (measured: a random scenario of the
    # benchmark, 24 s unbounded, 10 s with 24).
    continuation_steps: int = 24
    # MNM's line search in the local problems stops at 2^-3: a step eight times shorter than
    # Newton's that still fails the test means the local problem is failing from this guess,
    # and Leapfrog handles that. Measured against 2^-10 on 2 x 150 random scenarios: the same
    # successes and optima, about 30% fewer integrator steps for MNM; paper cases: the same
    # optima. The initial path's segments, which start from the path's own costates, need no
    # longer search: 2^-10 there gave the same successes and optima on 500 random scenarios
    # and 200 of the general preset (the affine guess had needed it).
    local_halvings: int = 3
    # Local problems are short and warm-started: a solve that needs more than 25 iterations, whose
    # costates grow a thousandfold, or whose flow needs more than 200 steps, is failing and is cut
    # short (failures are handled). Converging local flows take 10 steps on average and at most
    # about 150; failing attempts ran flows of up to 1000 steps. Measured on the paper cases (25
    # iterations, 1000 steps): same results, 40% fewer steps; 200 steps instead of 1000, on 150
    # random scenarios: the same results, 7-9% fewer steps.
    # They are solved to |F| <= 1e-5 at rtol 1e-7: the sweeps only move junctions, and the final
    # solve below restores full accuracy. Measured against 1e-8 at rtol 1e-10: same optima on the
    # paper cases, same successes on 100 random scenarios, 20-25% less integration work. Then
    # 1e-5 at rtol 1e-7 against 1e-6 at rtol 1e-8: the same successes and optima on the paper
    # cases and 3 x 150 random scenarios, 12-20% fewer steps; on 500 more, NM won one and MNM
    # lost one (its old final solve had converged from a costate jump of 0.89 to an extremal
    # dearer than its own piecewise path). 1e-4 at rtol 1e-6 lost a scenario of the 150, and
    # 3e-5 at rtol 3e-7 three of the 500.
    shooting: ShootingSettings = field(
        default_factory=lambda: ShootingSettings(
            samples=0,
            root=RootSettings(tol=1e-5, max_iterations=25, divergence=1e3),
            integrator=IntegratorSettings(rtol=1e-7, atol=1e-7, max_steps=200),
        )
    )
    # The final simple shooting over [0, T] (and the multiple-shooting fallback). A flow of more
    # than 5000 steps fails: converging final solves take at most about 170 steps per flow (200
    # random scenarios and the paper cases), while a failing final solve, whose iterates had run
    # flows of up to 65000 steps, took 0.2-0.4 s of paper case 4 with NM. Measured on 2 x 150
    # random scenarios: the same results, 5-10% fewer steps for NM (whose final solves fail
    # more often). A final solve whose |F| is not 10% below the largest of its 4 norms before is
    # stalled and stops (the fallback or the retry takes over): a failing one of paper case 4's
    # third path creeps 0.1249, 0.1245, 0.1241, ... with MNM steps of 2^-7 (9 iterations, 67
    # evaluations until |F| had not halved in 8, the rule before), while converging ones creep
    # for up to 6 iterations at 6% or more each (one went 0.113, 0.105, 0.098, 0.092, 0.081,
    # 0.067, then converged). Measured on 3 x 150 random scenarios and the paper cases against
    # "not halved over 8": the same results, 0.2-2.5% fewer steps.
    final_shooting: ShootingSettings = field(
        default_factory=lambda: ShootingSettings(
            samples=0,
            root=RootSettings(max_iterations=25, divergence=1e3, stall_window=4, stall_factor=0.9),
            integrator=IntegratorSettings(max_steps=5000),
        )
    )

    def __post_init__(self):
        if self.method not in STRATEGIES:
            raise SettingsError(f"unknown method {self.method!r} (known: {', '.join(STRATEGIES)})")
        require_integer("partitions", self.partitions, 2)
        require_integer("max_sweeps", self.max_sweeps)
        require_integer("sweeps_per_level", self.sweeps_per_level)
        if not (self.reduce_tol > 0 and self.jump_tol > 0 and self.final_retry_jump > 0):
            raise SettingsError("reduce_tol, jump_tol and final_retry_jump must be > 0")
        require_integer("final_retry_sweeps", self.final_retry_sweeps, 0)
        if self.final not in FINAL_MODES:
            raise SettingsError(
                f"final must be one of {', '.join(FINAL_MODES)}, got {self.final!r}"
            )
        require_integer("local_halvings", self.local_halvings)
        require_integer("attempt_iterations", self.attempt_iterations)
        require_integer("attempt_stall_window", self.attempt_stall_window, 0)
        if not isinstance(self.two_arc_attempt, bool):
            raise SettingsError(
                f"two_arc_attempt must be true or false, got {self.two_arc_attempt!r}"
            )
        require_integer("continuation_steps", self.continuation_steps)
        if not 0 < self.continuation_min_step <= self.continuation_first_step <= 1:
            raise SettingsError(
                "need 0 < continuation_min_step <= continuation_first_step <= 1, got "
                f"{self.continuation_min_step} and {self.continuation_first_step}"
            )
        require_integer("max_refinements", self.max_refinements, 0)
        require_integer("max_split_depth", self.max_split_depth, 0)


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
class LeapfrogRun:
    """What the algorithm produced for one initial path (before validation)."""

    success: bool
    message: str
    costate0: np.ndarray | None  # lambda(0) of the final extremal
    # The final extremal as its solver found it: one arc (simple shooting) or the junctions of
    # multiple shooting, whose re-integration arc by arc checks it where one long shot from
    # lambda(0) is too ill-conditioned to reach the goal to 1e-8 (long horizons, tight turns).
    extremal: Arcs | None
    final_solver: str | None  # "shooting" or "multiple-shooting"
    initial_cost: float
    max_costate_jump: float  # at the junctions when the sweeps ended (before the final solve)
    history: tuple[SweepRecord, ...]
    newton_iterations: int
    f_evals: int
    cost_increases: int  # sweeps whose piecewise cost rose (should stay 0)
    sweep_time_s: float
    final_time_s: float
    final_root: RootResult | None
    # The last piecewise extremal whose arcs meet at their junctions (the last level with
    # q > 2, or the initial path's arcs): a feasible motion from start to goal even when the
    # final solve fails. None when the initial path's segments failed.
    arcs: Arcs | None = None
    # How the initial path's segments were solved: segments per strategy ("warm", "path
    # costate", "weight continuation", "end-state continuation", "affine guess"), "failed"
    # (every strategy failed) and "split" (segments split in two after failing).
    fit_strategies: dict[str, int] = field(default_factory=dict)


@dataclass(frozen=True)
class Arcs:
    """A piecewise extremal: arc ``i`` runs from ``(t[i], X[i])`` with costate ``lam0[i]`` to
    ``(t[i + 1], X[i + 1])``, at the cost ``cost[i]`` (``None`` when not computed)."""

    t: np.ndarray
    X: np.ndarray
    lam0: np.ndarray
    cost: np.ndarray | None = None


@dataclass
class _Arcs:
    """The piecewise-optimal trajectory: arc i runs from (t[i], X[i]) to (t[i+1], X[i+1])."""

    t: np.ndarray
    X: np.ndarray
    lam0: np.ndarray  # (q, nx) costate at the start of each arc
    lam1: np.ndarray  # (q, nx) costate at the end of each arc
    cost: np.ndarray  # (q,)
    # Junctions of this level whose local problem end-state continuation failed to solve: it
    # is not tried there again (see local_solve).
    hopeless: set[int] = field(default_factory=set)

    @property
    def q(self) -> int:
        return self.t.size - 1

    def max_jump(self) -> float:
        if self.q < 2:
            return 0.0
        jumps = np.linalg.norm(self.lam1[:-1] - self.lam0[1:], axis=1)
        scale = max(1.0, float(np.abs(self.lam0).max()))
        return float(jumps.max() / scale)

    def refined(self, flow: Flow) -> _Arcs:
        """Every arc split at its middle time: the same piecewise extremal, twice the junctions."""
        nx = self.X.shape[1]
        q = self.q
        t = np.empty(2 * q + 1)
        X = np.empty((2 * q + 1, nx))
        lam0, lam1 = np.empty((2 * q, nx)), np.empty((2 * q, nx))
        cost = np.empty(2 * q)
        for j in range(q):
            tm = 0.5 * (self.t[j] + self.t[j + 1])
            half = flow(self.t[j], np.concatenate([self.X[j], self.lam0[j]]), tm)
            t[2 * j], t[2 * j + 1] = self.t[j], tm
            X[2 * j], X[2 * j + 1] = self.X[j], half.x
            lam0[2 * j], lam0[2 * j + 1] = self.lam0[j], half.lam
            lam1[2 * j], lam1[2 * j + 1] = half.lam, self.lam1[j]
            cost[2 * j], cost[2 * j + 1] = half.cost, self.cost[j] - half.cost
        t[-1], X[-1] = self.t[-1], self.X[-1]
        return _Arcs(t=t, X=X, lam0=lam0, lam1=lam1, cost=cost)

    def halved(self) -> _Arcs:
        keep = list(range(0, self.q, 2)) + [self.q]
        if keep[-2] == keep[-1]:
            keep.pop()
        starts, ends = keep[:-1], keep[1:]
        return _Arcs(
            t=self.t[keep].copy(),
            X=self.X[keep].copy(),
            lam0=self.lam0[starts].copy(),
            lam1=self.lam1[[e - 1 for e in ends]].copy(),
            cost=np.array([self.cost[a:b].sum() for a, b in zip(starts, ends, strict=True)]),
        )


class _Counter:
    def __init__(self):
        self.iterations = 0
        self.f_evals = 0

    def add(self, r: ShootingResult | RootResult | LocalSolution):
        root = r.root if isinstance(r, ShootingResult) else r
        self.iterations += root.iterations
        self.f_evals += root.f_evals


@blas_single_threaded
def leapfrog(
    problem: OptimalControlProblem,
    t: np.ndarray,
    X: np.ndarray,
    *,
    guide: PathGuide | None = None,
    settings: LeapfrogSettings | None = None,
    flow: Flow | None = None,
    progress: Callable[[SweepRecord], None] | None = None,
) -> LeapfrogRun:
    """Run Leapfrog from the junctions ``(t, X)`` of a feasible path from ``X[0]`` to ``X[-1]``.

    ``guide`` is that path followed in time (:class:`.path_ranking.PathGuide`): its costates
    start the initial segments' shooting, and its states split a segment whose two-point
    problem fails. ``progress`` is called after each sweep.
    """
    settings = settings or LeapfrogSettings()
    final_settings = replace(settings.final_shooting, samples=0, method=settings.method)
    shoot_settings = replace(settings.shooting, samples=0, method=settings.method)
    # ``flow`` is reused for whichever stage it was built for; the other gets its own.
    final_flow = flow if flow is not None and flow.settings == final_settings.integrator else None
    final_flow = final_flow or Flow(problem, final_settings.integrator)
    if flow is None or flow.settings != shoot_settings.integrator:
        flow = Flow(problem, shoot_settings.integrator)
    local_method = settings.method
    if settings.method == "modified-newton":
        local_method = ModifiedNewtonStep(max_halvings=settings.local_halvings)
    count = _Counter()
    strategies = _Strategies()

    # By identity: hashing the settings cost more than a local solve's bookkeeping. The shooter
    # holds its flow, settings and method, so the ids stay theirs while it is in the table.
    shooters: dict[tuple, LocalShooter] = {}

    def shooter(local, local_flow, settings) -> LocalShooter:
        key = (id(local_flow), id(settings), id(local_method))
        shoot = shooters.get(key)
        if shoot is None:
            shoot = shooters[key] = LocalShooter(local, local_flow, settings, local_method)
        return shoot

    def solve(ta, xa, tb, xb, guess=None, local=problem, local_flow=flow, settings=shoot_settings):
        """A local two-point problem; None when it fails (the callers handle failures)."""
        r = shooter(local, local_flow, settings)(ta, xa, tb, xb, guess)
        count.add(r)
        return r if r.success else None

    t = np.asarray(t, dtype=float)
    X = np.asarray(X, dtype=float)
    start, goal = X[0].copy(), X[-1].copy()
    T0, T1 = float(t[0]), float(t[-1])
    W = problem.penalty.weight
    has_obstacles = problem.obstacles.shape[0] > 0 and W > 0
    # A direct attempt that has not converged after a few iterations is failing: continuation
    # in the weight is then cheaper than more Newton steps on the hard problem.
    attempt = replace(
        shoot_settings,
        root=replace(
            shoot_settings.root,
            max_iterations=settings.attempt_iterations,
            stall_window=settings.attempt_stall_window,
        ),
    )
    weighted: dict[float, tuple[OptimalControlProblem, Flow]] = {}

    def at_weight(w):
        if w not in weighted:
            p = problem.with_weight(w)
            weighted[w] = (p, Flow(p, flow.settings))
        return weighted[w]

    def direct(
        ta, xa, tb, xb, guess, local=problem, local_flow=flow, mid=None, warm_failed=False
    ) -> LocalSolution | None:
        """The warm guess (unless it was tried and ``warm_failed``); in a sweep (``mid``
        given), two arcs through the middle junction; otherwise the affine guess. Each attempt
        gets ``attempt_iterations`` iterations.

        The affine guess is not tried after the two arcs: where both attempts from the current
        arcs fail, it succeeded too rarely to pay (2 x 150 random scenarios without it: the same
        successes and optima, 5% fewer integrator steps); continuation takes over."""
        r = (
            not warm_failed
            and guess is not None
            and solve(ta, xa, tb, xb, guess, local, local_flow, attempt)
        )
        if not r and mid is not None and settings.two_arc_attempt:
            return two_arcs(ta, xa, tb, xb, guess, mid)
        return r or solve(ta, xa, tb, xb, None, local, local_flow, attempt)

    def continuation(ta, xa, tb, xb, guess) -> LocalSolution | None:
        """Raise the obstacle weight from 0 to W (:func:`_continuation`), from a solve at
        weight 0 (the direct attempts there)."""
        r = direct(ta, xa, tb, xb, guess, *at_weight(0.0))
        if r is None:
            return None

        def at(w, g):
            return solve(ta, xa, tb, xb, g, *at_weight(w), attempt)

        return _continuation(at, r.costate0, W, settings)

    def target_continuation(ta, xa, tb, xb, guess) -> LocalSolution | None:
        """Move the end state from where ``guess`` leads (there ``guess`` is exact) to ``xb``
        (:func:`_continuation`): a problem family that starts solved, for any method."""
        r = flow(ta, np.concatenate([xa, guess]), tb)
        if not r.ok:
            return None
        reached = r.x

        def at(p, g):
            return solve(ta, xa, tb, reached + p * (xb - reached), g, settings=attempt)

        return _continuation(at, guess, 1.0, settings)

    def two_arcs(ta, xa, tb, xb, guess, mid) -> LocalSolution | None:
        """The local problem as two arcs through the junction ``mid = (t_i, x_i, lambda_i)``.

        Unknowns ``(lambda_a, x_i, lambda_i)`` start at the current arcs, so the only residual is
        the costate jump at ``t_i``. A solution is an extremal from ``xa`` to ``xb``; one simple
        shooting from its ``lambda_a`` (already a root) returns it as a local solve does.
        """
        ms = MultipleShootingSystem(flow, np.array([ta, mid[0], tb]), xa, xb)
        w0 = np.concatenate([guess, mid[1], mid[2]])
        root = solve_multiple_shooting(ms, w0, local_method, attempt.root, attempt.compiled)
        count.add(root)
        return solve(ta, xa, tb, xb, root.x[: xa.size], settings=attempt) if root.success else None

    def local_solve(ta, xa, tb, xb, guess, mid, warm_failed, level, i) -> LocalSolution | None:
        """In a sweep, the local problem of junction ``i`` of ``level``: the direct attempts,
        then continuation in the obstacle weight, then in the end state (once per junction
        and level: where it fails once it fails again, measured, and each try costs up to
        ``continuation_steps`` solves)."""
        r = direct(ta, xa, tb, xb, guess, mid=mid, warm_failed=warm_failed)
        if r is None and has_obstacles:
            r = continuation(ta, xa, tb, xb, guess)
        if r is None and i not in level.hopeless:
            r = target_continuation(ta, xa, tb, xb, guess)
            if r is None:
                level.hopeless.add(i)
        return r

    def segment_solve(ta, xa, tb, xb, warm) -> LocalSolution | None:
        """A segment of the initial path, by the first of these that succeeds (counted in
        ``fit_strategies``): from the costate ``warm`` at the end of the segment before (if
        any); from the path's own costate (or, with neither, from the affine guess); by
        continuation in the obstacle weight, then in the end state, from the first of these;
        from the affine guess.

        Continuation comes before the affine guess at the full weight: there the affine guess
        mostly failed too, and its failing iterates run long flows near the obstacles (paper
        case 4, second path: 5 segments, 96 evaluations and 17 ms), while continuation solved
        each segment in 2 ms."""
        first = warm
        if warm is not None and (r := solve(ta, xa, tb, xb, warm, settings=attempt)):
            return strategies.solved("warm", r)
        if guide is not None:  # computed only when needed: 40-80 us, paper case 1's are 8
            lam = guide.costate(ta)
            first = warm if warm is not None else lam
            if r := solve(ta, xa, tb, xb, lam, settings=attempt):
                return strategies.solved("path costate", r)
        elif warm is None and (r := solve(ta, xa, tb, xb, None, settings=attempt)):
            return strategies.solved("affine guess", r)
        if has_obstacles and (r := continuation(ta, xa, tb, xb, first)) is not None:
            return strategies.solved("weight continuation", r)
        if first is not None and (r := target_continuation(ta, xa, tb, xb, first)) is not None:
            return strategies.solved("end-state continuation", r)
        if first is not None and (r := solve(ta, xa, tb, xb, None, settings=attempt)):
            return strategies.solved("affine guess", r)
        return strategies.failed()

    def fit(ta, xa, tb, xb, depth, warm) -> list | None:
        r = segment_solve(ta, xa, tb, xb, warm)
        if r is not None:
            return [(ta, xa, r.costate0, r.costate1, r.cost)]
        if depth >= settings.max_split_depth or guide is None:
            return None
        strategies.split()
        tm = 0.5 * (ta + tb)
        xm = guide.state(tm)
        left = fit(ta, xa, tm, xm, depth + 1, warm)
        right = fit(tm, xm, tb, xb, depth + 1, left[-1][3]) if left is not None else None
        return None if right is None else left + right

    t_start = time.perf_counter()
    pieces = []
    for i in range(t.size - 1):
        seg = fit(t[i], X[i], t[i + 1], X[i + 1], 0, pieces[-1][3] if pieces else None)
        if seg is None:
            tried = "warm start, path costate, weight and end-state continuation, affine guess"
            if guide is not None and settings.max_split_depth:
                tried += f", split {settings.max_split_depth} times"
            return _failed(
                f"the two-point problem of initial segment {i} failed ({tried})",
                count,
                strategies.counts,
                time.perf_counter() - t_start,
            )
        pieces += seg
    arcs = _Arcs(
        t=np.array([p[0] for p in pieces] + [T1]),
        X=np.array([p[1] for p in pieces] + [goal]),
        lam0=np.array([p[2] for p in pieces]),
        lam1=np.array([p[3] for p in pieces]),
        cost=np.array([p[4] for p in pieces]),
    )
    initial_cost = float(arcs.cost.sum())
    history: list[SweepRecord] = []
    increases = 0

    def last_cost() -> float:
        return history[-1].cost if history else initial_cost

    def sweep(arcs: _Arcs) -> SweepRecord:
        """One Gauss-Seidel sweep over the junctions of ``arcs`` (updated in place), recorded."""
        nonlocal increases
        t_sweep = time.perf_counter()
        it0, fe0 = count.iterations, count.f_evals
        failures = rejected = 0
        # The warm attempts run in one compiled call while they converge (the same arithmetic
        # as below); the junction of a failed one comes back here for its fallbacks.
        warm = shooter(problem, flow, attempt)
        fused = _FUSED_SWEEPS and warm.fused
        i = 0
        while (i := i + 1) < arcs.q:
            warm_failed = False
            if fused:
                code, i, its, evals, rej, *_ = warm.warm_sweep(
                    arcs.t, arcs.X, arcs.lam0, arcs.lam1, arcs.cost, i
                )
                count.iterations += its
                count.f_evals += evals
                rejected += rej
                if code == flow.kernels.SWEEP_DONE:
                    break
                # otherwise SWEEP_WARM_FAILED, or SWEEP_PYTHON: junction i from the start
                warm_failed = code == flow.kernels.SWEEP_WARM_FAILED
            ta, tb = arcs.t[i - 1], arcs.t[i + 1]
            xa, xb = arcs.X[i - 1], arcs.X[i + 1]
            mid = (arcs.t[i], arcs.X[i], arcs.lam0[i])
            r = local_solve(ta, xa, tb, xb, arcs.lam0[i - 1], mid, warm_failed, arcs, i)
            if r is None:
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
        cost = float(arcs.cost.sum())
        before = last_cost()
        increases += cost > before + 1e-9 * max(1.0, abs(before))
        jump = arcs.max_jump()
        rec = SweepRecord(
            sweep=len(history) + 1,
            q=arcs.q,
            cost=cost,
            max_costate_jump=jump,
            newton_iterations=count.iterations - it0,
            f_evals=count.f_evals - fe0,
            failures=failures,
            rejected=rejected,
            time_s=time.perf_counter() - t_sweep,
            t=arcs.t.copy(),
            X=arcs.X.copy(),
        )
        history.append(rec)
        log.debug("sweep %d: q=%d cost=%.10g jump=%.3g", rec.sweep, rec.q, cost, jump)
        if progress is not None:
            progress(rec)
        return rec

    last_multi = arcs  # junctions for the multiple-shooting fallback
    sweeps_here = stalls = refinements = 0
    while arcs.q > 2 and len(history) < settings.max_sweeps:
        before = last_cost()
        rec = sweep(arcs)
        sweeps_here += 1
        decrease = (before - rec.cost) / max(abs(rec.cost), 1e-12)
        # A level with failed local problems keeps sweeping while that still pays (their
        # neighbours move, and the next attempt may succeed); two sweeps in a row without
        # progress, or the level's sweep budget, end it anyway.
        # After a refinement the level must converge further before q is halved again.
        settled = (
            decrease < settings.reduce_tol * 0.1**refinements
            or rec.max_costate_jump < settings.jump_tol
        )
        stalls = stalls + 1 if settled else 0
        if (
            (settled and rec.failures == 0)
            or stalls >= 2
            or sweeps_here >= settings.sweeps_per_level
        ):
            if rec.failures and refinements < settings.max_refinements:
                # A level that ends with a local problem still failing would hand the final
                # solve a large costate jump: split every arc instead (shorter local problems)
                # and sweep on.
                arcs = arcs.refined(flow)
                refinements += 1
            else:
                last_multi = arcs
                arcs = arcs.halved()
            sweeps_here = stalls = 0
    sweep_time = time.perf_counter() - t_start
    final_jump = arcs.max_jump()

    # The multiple-shooting fallback's first stage (see final_solve): the local problems'
    # integrator and tolerance, with the final solve's step bound and iteration rules.
    coarse_flow = flow.with_settings(
        replace(flow.settings, max_steps=final_settings.integrator.max_steps)
    )
    coarse_root = replace(final_settings.root, tol=shoot_settings.root.tol)

    def final_solve(lam0, junctions: _Arcs):
        """Simple shooting over the whole horizon from ``lam0``; if it fails (``final="auto"``),
        multiple shooting over ``junctions``. Returns (the extremal's arcs, solver name, last
        root result): one arc for simple shooting, the junctions of multiple shooting."""
        root = None
        if settings.final in ("auto", "shooting"):
            r = solve_shooting(
                problem, T0, start, T1, goal, guess=lam0, settings=final_settings, flow=final_flow
            )
            count.add(r)
            root = r.root
            if r.success:
                one = Arcs(np.array([T0, T1]), np.array([start, goal]), r.costate0[None, :])
                return one, "shooting", root
        if settings.final in ("auto", "multiple-shooting"):
            # Over the level's junctions, then over twice as many (every arc split at its
            # middle): shorter arcs, a better conditioned system. With the end-state
            # continuation of the initial segments, on the general preset (500 scenarios, 3
            # paths): MNM 497 -> 499 converged, NM 492 -> 495.
            for level in (junctions, junctions.refined(flow)):
                extremal, root = multiple_shooting(level)
                if extremal is not None:
                    return extremal, "multiple-shooting", root
        return None, None, root

    def multiple_shooting(junctions: _Arcs):
        """Multiple shooting from the arcs ``junctions``: (its extremal or None, root result).

        Converged first with the local problems' tolerances (rtol 1e-7, |F| <= 1e-5), then
        polished with the final ones (one or two iterations): an evaluation integrates every
        arc with its full sensitivities, 3 ms at rtol 1e-12 for the 8 arcs of paper case 4
        (measured there: 43 -> 14 ms for the fallback, the same answer). When the coarse solve
        fails the fallback has failed: on 2 x 150 random scenarios and the paper cases, solving
        again at rtol 1e-12 from the start never converged instead (its diverging iterates cost
        70-100 ms on case 4 with NM)."""
        Z = np.hstack([junctions.X[:-1], junctions.lam0])
        ms = MultipleShootingSystem(coarse_flow, junctions.t, start, goal)
        w0 = ms.pack(junctions.lam0[0], Z)
        root = solve_multiple_shooting(
            ms, w0, settings.method, coarse_root, final_settings.compiled
        )
        if root.success:
            count.add(root)
            ms = MultipleShootingSystem(final_flow, junctions.t, start, goal)
            root = solve_multiple_shooting(
                ms, root.x, settings.method, final_settings.root, final_settings.compiled
            )
        count.add(root)
        if not root.success:
            return None, root
        Z = ms.unpack(root.x)
        nx = start.size
        ends = np.vstack([Z[:, :nx], goal[None, :]])
        return Arcs(ms.t.copy(), ends, Z[:, nx:].copy()), root

    # Final step: simple shooting over the whole horizon from the first arc's costate.
    t_final = time.perf_counter()
    retry_time = 0.0
    first_failure = None  # the root result of the first final solves, when they were retried
    sweeps_before_retry = len(history)
    extremal, solver, root = final_solve(arcs.lam0[0], last_multi)
    level = last_multi
    if extremal is None and settings.final_retry_sweeps and arcs.q == 2 and level.q > 2:
        # Both final solves failed after the sweeps reached q = 2 from a level that was left with
        # a large costate jump: sweep that level on (at most final_retry_sweeps more sweeps, until
        # the jump is below final_retry_jump or a sweep no longer lowers the cost) and try both
        # again. (A run that spent max_sweeps before reaching q = 2 is not retried.)
        t_more = time.perf_counter()
        first_failure = root
        for _ in range(settings.final_retry_sweeps):
            before = last_cost()
            rec = sweep(level)
            if rec.max_costate_jump < settings.final_retry_jump or not rec.cost < before:
                break
        retry_time = time.perf_counter() - t_more
        final_jump = level.max_jump()
        extremal, solver, root = final_solve(level.lam0[0], level)
    final_time = time.perf_counter() - t_final - retry_time
    sweep_time += retry_time
    more = len(history) - sweeps_before_retry
    if extremal is None:
        msg = f"final solve failed ({root.status}: {root.message})" if root else "no final solve"
        if first_failure is not None:
            msg += f", also after {more} more sweeps at q = {level.q}"
    else:
        msg = f"converged by {solver} after {len(history)} sweeps"
        if first_failure is not None:
            msg += (
                f" ({more} of them at q = {level.q} after the final solves had failed:"
                f" {first_failure.status})"
            )
    return LeapfrogRun(
        success=extremal is not None,
        message=msg,
        costate0=None if extremal is None else extremal.lam0[0].copy(),
        extremal=extremal,
        final_solver=solver,
        initial_cost=initial_cost,
        max_costate_jump=final_jump,
        history=tuple(history),
        newton_iterations=count.iterations,
        f_evals=count.f_evals,
        cost_increases=increases,
        sweep_time_s=sweep_time,
        final_time_s=final_time,
        final_root=root,
        arcs=_exact(arcs if arcs.q > 2 or arcs is last_multi else level),
        fit_strategies=dict(strategies.counts),
    )


def _continuation(solve_at, s0, end: float, settings: LeapfrogSettings):
    """Natural-parameter continuation: ``solve_at(p, guess)`` solves the problem at parameter
    ``p`` (None on failure); ``s0`` solves it at ``p = 0``. ``p`` goes to ``end``: the step
    (first ``continuation_first_step * end``) doubles after a success and halves after a
    failure, down to ``continuation_min_step * end``; each guess is extrapolated from the last
    two solutions (secant predictor), else the last one is tried too; at most
    ``continuation_steps`` steps. Returns the solution at ``end``, or None."""
    p, s, prev = 0.0, s0, None
    dp = settings.continuation_first_step * end
    min_dp = settings.continuation_min_step * end
    for _ in range(settings.continuation_steps):
        pn = min(end, p + dp)
        pred = s if prev is None else s + (pn - p) * (s - prev[1]) / (p - prev[0])
        r = solve_at(pn, pred)
        if r is None and prev is not None:
            r = solve_at(pn, s)
        if r is None:
            if dp <= min_dp:
                return None
            dp = max(0.5 * dp, min_dp)
            continue
        prev, p, s = (p, s), pn, r.costate0
        if p >= end:
            return r
        dp *= 2.0
    return None  # the step budget is spent: a failure, handled like any other


class _Strategies:
    """How the initial path's segments were solved: per strategy, the segments it solved;
    segments that failed every strategy, and splits."""

    def __init__(self):
        self.counts: dict[str, int] = {}

    def solved(self, name: str, r):
        self.counts[name] = self.counts.get(name, 0) + 1
        return r

    def failed(self):
        self.counts["failed"] = self.counts.get("failed", 0) + 1
        return None

    def split(self):
        self.counts["split"] = self.counts.get("split", 0) + 1


def _exact(arcs: _Arcs) -> Arcs:
    """A frozen copy of arcs that meet at their junctions (not of halved ones, which jump)."""
    return Arcs(arcs.t.copy(), arcs.X.copy(), arcs.lam0.copy(), arcs.cost.copy())


def _failed(message, count, strategies, sweep_time) -> LeapfrogRun:
    """A run whose initial path's segments could not all be solved."""
    return LeapfrogRun(
        success=False,
        message=message,
        costate0=None,
        extremal=None,
        final_solver=None,
        initial_cost=np.inf,
        max_costate_jump=float("nan"),
        history=(),
        newton_iterations=count.iterations,
        f_evals=count.f_evals,
        cost_increases=0,
        sweep_time_s=sweep_time,
        final_time_s=0.0,
        final_root=None,
        fit_strategies=dict(strategies),
    )
