"""Bounded controls: from a problem Leapfrog can solve to the sharp bounds, by continuation.

Leapfrog solves the problem whose controls saturate smoothly with the widest width (see
:mod:`..model.bounds`); where the initial paths ask more of the controls than the bounds allow,
it solves the problem with those controls' bounds relaxed far outside instead (only those: a
turn-rate bound relaxed keeps a forward-only speed bound, and with it the forward-only family;
relaxing both, that family was measured to fold before the bounds were reached, and the
cheapest class was lost on 1 of 100 layouts). That extremal is continued
along ``s`` from 0 to 1: the bounds move linearly from where Leapfrog solved to the scenario's,
and the width shrinks geometrically to the narrowest. Each step is warm from the extremal before:
simple shooting, else multiple shooting over :data:`JUNCTIONS` arcs of that extremal (better
conditioned where a control rides its bound). A step that fails is tried again half as long, at
most :data:`MAX_HALVINGS` times in all.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from ..bvp.multiple_shooting import MultipleShootingSystem, solve_multiple_shooting
from ..bvp.shooting import ShootingSettings, solve_shooting
from ..integrate.flow import Flow, Trajectory
from ..integrate.problem import OptimalControlProblem
from ..model.bounds import SMOOTHING, bound_names, switch_name
from .leapfrog import Arcs, LeapfrogSolution, LeapfrogStatus
from .results import piecewise_trajectory

MAX_HALVINGS = 10
#: How a run's message says that its continuation did not reach the scenario's problem (it
#: goes on with where it stopped).
STOPPED = "the continuation to the problem itself stopped"
JUNCTIONS = 16
#: Relaxed bounds lie this many ranges outside the scenario's.
RELAXED = 10.0


def schedule(
    problem: OptimalControlProblem,
    bounds: dict[str, tuple[float, float]],
    widths: tuple[float, ...],
    relaxed: tuple[str, ...] = (),
    aid: tuple[str, float, float] | None = None,
) -> Callable[[float], OptimalControlProblem]:
    """The problem at ``s`` in [0, 1]: the bounds of the ``relaxed`` controls from relaxed at 0
    to the scenario's at 1 (the others at the scenario's throughout), the width from
    ``widths[0]`` to ``widths[-1]`` geometrically, and the model's planning aid ``aid = (its
    parameter, from, to)`` (the car's turn assist) linearly from ``from`` to ``to``."""
    names = problem.model.parameters
    base = np.array(problem.parameters, dtype=float)
    used = (*sum((bound_names(c) for c in bounds), ()), *((SMOOTHING,) if bounds else ()))
    index = {n: names.index(n) for n in (*used, *((aid[0],) if aid else ()))}

    def at(s: float) -> OptimalControlProblem:
        p = base.copy()
        for c, (lo, hi) in bounds.items():
            pull = RELAXED * (hi - lo) * (1.0 - s) if c in relaxed else 0.0
            lo_name, hi_name = bound_names(c)
            p[index[lo_name]], p[index[hi_name]] = lo - pull, hi + pull
        if bounds:
            p[index[SMOOTHING]] = widths[0] ** (1.0 - s) * widths[-1] ** s
        if aid:
            name, start, end = aid
            p[index[name]] = start + s * (end - start)
        return replace(problem, parameters=tuple(p.tolist()))

    return at


def exceeded(bounds: dict[str, tuple[float, float]], names, u: np.ndarray) -> tuple[str, ...]:
    """The bounded controls that the controls ``u`` (rows; columns ``names``) leave their
    bounds at, all of them if none does."""
    tol = 1e-9
    out = tuple(
        c for c, (lo, hi) in bounds.items()
        if np.any(u[:, names.index(c)] < lo - tol) or np.any(u[:, names.index(c)] > hi + tol)
    )  # fmt: skip
    return out or tuple(bounds)


def arcs_of(tr: Trajectory, tau: float | None = None, pieces: int = JUNCTIONS) -> Arcs:
    """The extremal ``tr`` from time ``tau`` (default: its start) on, as ``pieces`` arcs of
    equal length with times from 0 (states and costates read off the trajectory: each arc then
    integrates accurately however long the horizon): a guess for :func:`resolve`."""
    start = tr.t[0] if tau is None else tau
    t = np.linspace(start, tr.t[-1], pieces + 1)
    X, lam = tr.at(t), tr.at(t, tr.lam)
    if tau is None:
        X[0] = tr.x[0]
    X[-1] = tr.x[-1]
    return Arcs(t - start, X, lam[:-1])


@dataclass(frozen=True)
class Continued:
    run: LeapfrogSolution  # the run, its extremal the one at the last ``s`` reached
    problem: OptimalControlProblem  # the problem there
    reached: bool  # ``s = 1`` was reached


@dataclass(frozen=True)
class _Stage:
    """The end points of the solves and how they are made."""

    t: tuple[float, float]
    ends: tuple[np.ndarray, np.ndarray]
    settings: ShootingSettings


def _simple(stage: _Stage, problem, arcs: Arcs, scale: float) -> Arcs | None:
    (t0, t1), (start, goal) = stage.t, stage.ends
    guess = arcs.lam0[0] / scale
    r = solve_shooting(problem, t0, start, t1, goal, guess=guess, settings=stage.settings)
    if not r.success:
        return None
    return Arcs(np.array([t0, t1]), np.array([start, goal]), r.costate0[None, :])


def _multiple(stage: _Stage, previous, arcs: Arcs, problem, scale: float) -> Arcs | None:
    """Multiple shooting for ``problem`` from the extremal ``arcs`` of ``previous``, sampled at
    :data:`JUNCTIONS` uniform times (its time stretched by ``scale``)."""
    (t0, t1), (start, goal) = stage.t, stage.ends
    s = stage.settings
    try:
        tr = piecewise_trajectory(Flow(previous, s.integrator), arcs, 2001)
    except ValueError:
        return None
    t = np.linspace(t0, t1, JUNCTIONS + 1)
    t[0], t[-1] = t0, t1
    old = t0 + (t[:-1] - t0) / scale
    Z = tr.at(old, np.hstack([tr.x, tr.lam / scale]))
    ms = MultipleShootingSystem(Flow(problem, s.integrator), t, start, goal)
    nx = start.size
    root = solve_multiple_shooting(ms, ms.pack(Z[0, nx:], Z), s.method, s.root, s.compiled)
    if not root.success:
        return None
    Z = ms.unpack(root.x)
    return Arcs(t, np.vstack([Z[:, :nx], goal[None, :]]), Z[:, nx:].copy())


def resolve(
    previous: OptimalControlProblem,
    arcs: Arcs,
    problem: OptimalControlProblem,
    t: tuple[float, float],
    ends: tuple[np.ndarray, np.ndarray],
    settings: ShootingSettings,
) -> Arcs | None:
    """An extremal of ``problem`` from ``t[0]`` to ``t[1]`` between ``ends``, near ``arcs``
    (an extremal of ``previous`` from ``t[0]``): simple shooting from its first costate, else
    multiple shooting from its trajectory; None when both fail. When ``t`` is longer or
    shorter than ``arcs``, the guess is ``arcs`` stretched to it (the costates, like the
    controls, scaled by the inverse)."""
    stage = _Stage(t, ends, settings)
    scale = (t[1] - t[0]) / (arcs.t[-1] - arcs.t[0])
    return _simple(stage, problem, arcs, scale) or _multiple(stage, previous, arcs, problem, scale)


def continue_to_bounds(
    at: Callable[[float], OptimalControlProblem],
    run: LeapfrogSolution,
    t: tuple[float, float],
    ends: tuple[np.ndarray, np.ndarray],
    steps: int,
    settings: ShootingSettings,
    deadline: float = math.inf,
) -> Continued:
    """Continue ``run`` (an extremal of ``at(0)``) to ``at(1)`` in ``steps`` equal steps; past
    ``deadline`` (a ``time.perf_counter()`` reading: a plan's time limit) no step starts, and
    the run says where it stopped."""
    arcs, s, current, halvings = run.extremal, 0.0, at(0.0), 0
    todo = list(np.linspace(0.0, 1.0, steps + 1)[1:])
    timed_out = False
    while todo and arcs is not None:
        if time.perf_counter() >= deadline:
            timed_out = True
            break
        trial = at(todo[0])
        new = resolve(current, arcs, trial, t, ends, settings)
        if new is not None:
            arcs, s, current = new, todo.pop(0), trial
        elif halvings < MAX_HALVINGS:
            halvings += 1
            todo.insert(0, (s + todo[0]) / 2)
        else:
            break
    reached = s == 1.0
    if reached:
        note = f"; continued to the problem itself ({_what(current)})"
    else:
        done = np.floor(1000.0 * s) / 10.0  # never rounded up to a 100% that was not reached
        why = ", at the time limit" if timed_out else ""
        note = f"; {STOPPED} at {done:g}% ({_what(current)}){why}"
    one = arcs is not None and arcs.t.size == 2
    run = replace(
        run,
        status=run.status if reached else LeapfrogStatus.CONTINUATION_STOPPED,
        message=run.message + note,
        costate0=arcs.lam0[0] if reached else run.costate0,
        extremal=arcs if reached else run.extremal,
        final_solver=("shooting" if one else "multiple-shooting") if reached else run.final_solver,
    )
    return Continued(run, current if reached else at(0.0), reached)


def _what(problem: OptimalControlProblem) -> str:
    parts = []
    if any(problem.parameter(switch_name(c)) for c in problem.model.controls):
        width = problem.parameter(SMOOTHING)
        parts.append(f"controls saturated sharply at the bounds, smoothing width {width:.2g}")
    aid = problem.model.aid
    if aid is not None:
        parts.append(f"{aid.parameter.replace('_', ' ')} {problem.parameter(aid.parameter):g}")
    return ", ".join(parts)  # within a message's part: "; " separates the parts
