"""Peer solvers for the benchmark, all on the same scenario and the same optimal control problem.

Each ``*_peer`` function sets a solver up on a scenario as a :class:`Peer`; :func:`measure` times
several peers on one scenario in interleaved rounds and gives each a :class:`PeerOutcome`:
success, cost, the end-state error and the median wall time of ``repeat`` solves after one
untimed warm-up solve (compilation, caches, IPOPT's first call). Each ``run_*`` function measures
one peer alone. End-state errors of indirect solutions are measured by re-integrating the
returned initial costate with the library's adaptive integrator (DOP853, rtol 1e-12, the same
check as :func:`~leapfrog_planner.planning.results.validate`); those of the direct method by
propagating its piecewise-constant controls along exact unicycle arcs.

- ``leapfrog-*``: :class:`~leapfrog_planner.planning.planner.Planner` with MNM, NM or NLEQ-ERR
  (``leapfrog-mnm-1path``: MNM from the first initial path only, as the ``*-path`` peers).
- ``shooting``: one simple shooting (MNM) over ``[0, T]`` from the affine costate guess.
- ``bvp-line`` / ``bvp-path``: :func:`scipy.integrate.solve_bvp` on the same canonical system
  (the library's compiled right-hand side), from the straight line with zero costates, or from
  the first initial path of the planner with the costates that reproduce its controls.
- ``direct-N<n>-line`` / ``-path`` / ``-paths``: CasADi/IPOPT, RK4 multiple shooting, the NLP
  of :class:`~leapfrog_planner.planning.direct.DirectTranscription` (built once per obstacle
  count and mesh, reused across scenarios), from the straight line, from the first initial path (the
  start of ``leapfrog-mnm-1path``), or from each of the planner's initial paths (the search of
  ``leapfrog-mnm``: one IPOPT solve per path, in one thread per path as the planner runs its
  paths, the cheapest success kept).

The ``*-path`` and ``*-paths`` peers' timed solves include planning those initial paths, as
Leapfrog's do.
"""

from __future__ import annotations

import math
import statistics
import time
import warnings
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ..planning.direct import cached_transcription
from ..planning.results import validate
from ..planning.scenario import Scenario

__all__ = [
    "Peer",
    "PeerOutcome",
    "bvp_peer",
    "casadi_available",
    "direct_peer",
    "leapfrog_peer",
    "measure",
    "random_scenarios",
    "run_bvp",
    "run_direct",
    "run_leapfrog",
    "run_shooting",
    "shooting_peer",
]

BVP_NODES = 41  # initial collocation mesh
BVP_TOL = 1e-8
BVP_MAX_NODES = 10_000


@dataclass(frozen=True)
class PeerOutcome:
    solver: str
    scenario: str
    success: bool
    cost: float
    end_state_error: float
    time_s: float  # median over the timed repetitions
    times_s: tuple[float, ...]
    message: str


@dataclass(frozen=True)
class Peer:
    """One solver set up on one scenario, ready to be timed: ``solve()`` runs it once, and
    ``judge(value, times)`` makes the :class:`PeerOutcome` of its last value."""

    solver: str
    solve: Callable[[], Any]
    judge: Callable[[Any, tuple[float, ...]], PeerOutcome]
    per_round: int = 1  # timed calls per round: more for a peer much faster than the others


def measure(
    peers: Sequence[Peer],
    repeat: int,
    *,
    more: Callable[[list], Sequence[Peer]] | None = None,
    progress: Callable[[str], None] | None = None,
) -> list[tuple[PeerOutcome, Any]]:
    """Time ``peers`` (on one scenario): each one's warm-up call, then ``repeat`` rounds that
    time every peer once in turn. Interleaved, a drift of the machine's speed falls on all the
    peers alike (on a shared 2-core machine it drifted by 1.5-2x within minutes, which one peer
    timed after the other turns into a false ratio). Returns ``(outcome, last value)`` per peer.

    A failed warm-up is timed and not repeated: failures of the peers take seconds (mesh or
    iteration limits) and their time is not the point. ``more(values)`` may add peers once the
    warm-ups are done, from their values (the floor starts from Leapfrog's answer).
    ``progress(label)`` is called before each warm-up and each round.
    """
    peers, values, times = list(peers), [], []

    def warm_up(peer: Peer):
        if progress is not None:
            progress(f"{peer.solver} (warm-up)")
        t = time.perf_counter()
        value = peer.solve()
        first = time.perf_counter() - t
        values.append(value)
        times.append([] if value.success else [first])

    for peer in peers:
        warm_up(peer)
    for peer in more(values) if more is not None else ():
        peers.append(peer)
        warm_up(peer)
    timed = [bool(v.success) for v in values]  # the warm-ups that succeeded
    for k in range(repeat):
        if progress is not None:
            progress(f"timing round {k + 1} of {repeat}")
        for i, peer in enumerate(peers):
            for _ in range(peer.per_round if timed[i] else 0):
                t = time.perf_counter()
                values[i] = peer.solve()
                times[i].append(time.perf_counter() - t)
    return [(p.judge(v, tuple(ts)), v) for p, v, ts in zip(peers, values, times, strict=True)]


def _outcome(solver, sc, ok, cost, err, times, message) -> PeerOutcome:
    return PeerOutcome(
        solver=solver,
        scenario=sc.name,
        success=bool(ok),
        cost=float(cost) if ok else math.nan,
        end_state_error=float(err),
        time_s=statistics.median(times),
        times_s=times,
        message=message,
    )


def leapfrog_peer(sc: Scenario, method: str, solver: str | None = None, **options) -> Peer:
    """Leapfrog with ``method`` (and planner ``options``); its value is the
    :class:`~leapfrog_planner.planning.results.PlanResult`."""
    from ..planning.planner import Planner

    name = solver or f"leapfrog-{method}"

    def judge(res, times):
        msg = f"{res.status}: {res.message}"
        return _outcome(name, sc, res.success, res.cost, res.end_state_error, times, msg)

    return Peer(name, Planner(sc, method=method, **options).plan, judge)


def shooting_peer(sc: Scenario, guess=None, solver: str = "shooting", per_round: int = 1) -> Peer:
    """Simple shooting with MNM over the whole horizon, from ``guess`` (default: affine)."""
    from ..bvp.shooting import ShootingSettings, solve_shooting
    from ..integrate.flow import Flow

    problem = sc.problem()
    settings = ShootingSettings(samples=0)
    flow = Flow(problem, settings.integrator)

    def solve():
        return solve_shooting(
            problem, 0.0, sc.start, sc.horizon, sc.goal, guess=guess, settings=settings, flow=flow
        )

    def judge(r, times):
        msg = f"{r.status}: {r.message}"
        return _checked(solver, sc, problem, r.success, r.costate0, times, msg)

    return Peer(solver, solve, judge, per_round)


def run_leapfrog(sc: Scenario, method: str, repeat: int, solver: str | None = None, **options):
    """:func:`leapfrog_peer` measured alone: the outcome and the last ``PlanResult``."""
    ((out, res),) = measure([leapfrog_peer(sc, method, solver, **options)], repeat)
    return out, res


def run_shooting(sc: Scenario, repeat: int, guess=None, solver: str = "shooting") -> PeerOutcome:
    """:func:`shooting_peer` measured alone."""
    return measure([shooting_peer(sc, guess, solver)], repeat)[0][0]


def _checked(solver, sc, problem, ok, costate0, times, message, cost=None) -> PeerOutcome:
    """Re-integrate ``costate0``; the cost is the re-integrated one unless ``cost`` is given."""
    err, c = math.inf, math.nan
    if ok and costate0 is not None and np.all(np.isfinite(costate0)):
        v = validate(problem, 0.0, sc.start, sc.horizon, sc.goal, costate0, samples=2)
        err, c = v.end_state_error, v.cost
    return _outcome(solver, sc, ok, c if cost is None else cost, err, times, message)


# --------------------------------------------------------------------------- solve_bvp


def _path_guesses(sc: Scenario, count: int | None = None):
    """A function of the times ``t``: for each initial path of the planner (its default number
    of paths, or ``count``), the path's states at ``t`` (constant speed) and the minimum-norm
    costates that give its controls (``omega = -l3``, ``v = -(l1, l2).heading``).

    The paths are planned on each call, as ``Planner.plan`` plans them, so that the ``*-path``
    peers are timed for the same work as Leapfrog: their guesses are not free (1.5-15 ms on the
    paper cases)."""
    from ..planning.planner import Planner

    planner = Planner(sc) if count is None else Planner(sc, initial_paths=count)

    def guesses(t: np.ndarray) -> list[np.ndarray]:
        out = []
        for path in planner.initial_paths():
            xy, th = path.curve(t / sc.horizon)
            v = path.length / sc.horizon
            omega = np.gradient(th, t)
            lam = np.column_stack([-v * np.cos(th), -v * np.sin(th), -omega])
            out.append(np.column_stack([xy, th, lam]))
        return out

    return guesses


def _path_guess(sc: Scenario):
    """The guess of :func:`_path_guesses` along the planner's first initial path only."""
    guesses = _path_guesses(sc, 1)
    return lambda t: guesses(t)[0]


def _line_guess(sc: Scenario, t: np.ndarray) -> np.ndarray:
    s = (t / sc.horizon)[:, None]
    return np.column_stack([sc.start + s * (sc.goal - sc.start), np.zeros((t.size, 3))])


def bvp_peer(sc: Scenario, start_from: str, tol: float = BVP_TOL) -> Peer:
    """``scipy.integrate.solve_bvp`` from ``"line"`` or ``"path"`` to ``tol``; the cost is a
    7th ODE."""
    from scipy.integrate import solve_bvp

    problem = sc.problem()
    K = problem.model.kernels
    nx = problem.model.nx
    p = np.asarray(problem.parameters, dtype=float)
    obs = np.ascontiguousarray(problem.obstacles)
    w, n = float(problem.penalty.weight), int(problem.penalty.exponent)

    def fun(_t, y):
        Z = np.ascontiguousarray(y.T)
        dZ = np.empty_like(Z)
        K.rhs_along(Z, p, obs, w, n, dZ)
        return dZ.T

    def bc(ya, yb):
        return np.concatenate([ya[:nx] - sc.start, yb[:nx] - sc.goal, ya[2 * nx :]])

    t = np.linspace(0.0, sc.horizon, BVP_NODES)
    path_guess = _path_guess(sc) if start_from == "path" else None

    def solve():
        guess = _line_guess(sc, t) if path_guess is None else path_guess(t)
        y0 = np.vstack([guess.T, np.zeros(t.size)])
        # Quiet: diverging iterates overflow inside scipy, and the library never prints.
        with warnings.catch_warnings(), np.errstate(all="ignore"):
            warnings.simplefilter("ignore", RuntimeWarning)
            return solve_bvp(fun, bc, t, y0, tol=tol, max_nodes=BVP_MAX_NODES)

    def judge(sol, times):
        msg = f"status {sol.status}: {sol.message} ({sol.x.size} nodes)"
        costate0, cost = sol.y[nx : 2 * nx, 0], float(sol.y[2 * nx, -1])
        return _checked(name, sc, problem, sol.success, costate0, times, msg, cost=cost)

    name = f"bvp-{start_from}"
    return Peer(name, solve, judge)


def run_bvp(sc: Scenario, start_from: str, repeat: int) -> PeerOutcome:
    """:func:`bvp_peer` measured alone."""
    return measure([bvp_peer(sc, start_from)], repeat)[0][0]


# --------------------------------------------------------------------------- direct method


def casadi_available() -> bool:
    try:
        import casadi  # noqa: F401
    except ImportError:
        return False
    return True


def direct_peer(sc: Scenario, intervals: int, start_from: str) -> Peer:
    """IPOPT from the straight line (``"line"``), from the planner's first initial path
    (``"path"``), or from each of its initial paths (``"paths"``, one thread per path; the
    cheapest successful solve is kept, the first path's on a tie)."""
    n_obstacles = sc.obstacles.shape[0]
    nodes = np.linspace(0.0, sc.horizon, intervals + 1)

    def solve_from(states, slot=0):
        return cached_transcription(n_obstacles, intervals, slot=slot).solve(
            sc.start,
            sc.goal,
            sc.horizon,
            sc.footprint_obstacles,
            weight=sc.weight,
            exponent=sc.exponent,
            guess_states=states,
        )

    if start_from != "paths":
        path_guess = _path_guess(sc) if start_from == "path" else None

        def solve():
            return solve_from(None if path_guess is None else path_guess(nodes)[:, :3])

    else:
        path_guesses = _path_guesses(sc)

        def solve():
            states = [g[:, :3] for g in path_guesses(nodes)]
            slots = range(len(states))
            for k in slots:  # built here, not in the threads: building is not thread-safe
                cached_transcription(n_obstacles, intervals, slot=k)
            if len(states) == 1:
                results = [solve_from(states[0])]
            else:
                with ThreadPoolExecutor(len(states), thread_name_prefix="ipopt-path") as pool:
                    results = list(pool.map(solve_from, states, slots))
            return _cheapest(results)

    def judge(r, times):
        return _outcome(name, sc, r.success, r.cost, r.end_state_error, times, r.message)

    name = f"direct-N{intervals}-{start_from}"
    return Peer(name, solve, judge)


def run_direct(sc: Scenario, intervals: int, start_from: str, repeat: int) -> PeerOutcome:
    """:func:`direct_peer` measured alone."""
    return measure([direct_peer(sc, intervals, start_from)], repeat)[0][0]


def _cheapest(results: list):
    """The cheapest successful :class:`~leapfrog_planner.planning.direct.DirectResult` (else
    the first), its message saying which path it came from and what the others did."""
    ok = [k for k, r in enumerate(results) if r.success]
    k = min(ok, key=lambda j: results[j].cost) if ok else 0
    each = ", ".join(f"{r.iterations}" + ("" if r.success else f" {r.status}") for r in results)
    return replace(
        results[k],
        message=f"{results[k].message}: path {k + 1} of {len(results)} kept "
        f"({len(ok)} succeeded; iterations per path: {each})",
    )


# --------------------------------------------------------------------------- random scenarios


def random_scenarios(n: int, seed: int = 0) -> list[Scenario]:
    """``n`` seeded scenarios of :mod:`.generate` in the box [0, 2]^2, T = 1: 2-5 discs of radius
    0.08-0.25 at least 0.05 apart, start and goal at least 1.2 apart and 0.1 clear of every
    disc, headings within 45 degrees of the start-goal direction. Scenario ``i`` depends only on
    ``(seed, i)``."""
    from ..batch.generate import GeneratorSpec, generate

    spec = GeneratorSpec(
        n=n,
        seed=seed,
        obstacles=(2, 5),
        radius=(0.08, 0.25),
        min_distance=1.2,
        clearance=0.1,
        obstacle_gap=0.05,
    )
    return list(generate(spec))
