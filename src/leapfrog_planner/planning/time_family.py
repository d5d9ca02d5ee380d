"""One family of extremals followed in the horizon ``T``: the root of ``k + H(T)`` along it.

Each new ``T`` is solved by shooting (:func:`.bounded.resolve`) from a guess predicted by the
family's last two solved horizons (states, and costates times ``T``, at uniform fractions of
``T``, extrapolated linearly in ``T``; from a single one, its extremal stretched). The step in
``T`` is controlled: a step that fails (or jumps to another family) is halved, and the next
one starts from that halved length, 1.5 times longer after each success (:data:`GROWTH`),
rather than from the whole distance again. ``g = k + H`` is close to linear in ``1/T^2``
(in free space ``H = -D^2 / (2 T^2)``): secant steps in ``1/T^2`` until the root is
bracketed, then Brent's method (SciPy's ``brentq``). A search that runs out of its solves
can be given more (:meth:`TimeSearch.allow`) and goes on where it stopped.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from ..bvp.shooting import ShootingSettings
from ..integrate.flow import Flow
from .bounded import JUNCTIONS, resolve
from .leapfrog import Arcs
from .results import piecewise_trajectory
from .status import MAX_MOVE, path_moved

#: ``|k + H|`` at most this times ``max(1, k)`` meets the free-time condition.
CONDITION_TOL = 1e-8
SHAPE_SAMPLES = 33
#: Shooting solves one family's continuation may make before it stops (it may be allowed more:
#: :meth:`TimeSearch.allow`).
MAX_SOLVES = 30
#: The largest change of ``T`` in one secant step, as a factor.
STEP_FACTOR = 8.0
#: The shortest step of the continuation, as ``|log(T1 / T0)|``: a family that fails even
#: there has folded (or the shooting cannot follow it).
MIN_REACH = 1e-4
#: After a successful step that the step control shortened, the next may be this much longer
#: (measured on the continuations of general 53 and 168: 1.5 made 68 solves, 26 of them failed,
#: where 2 made 83 (38) and 3 made 75 (37); without the linear prediction, 2 made 180 (94)).
GROWTH = 1.5


@dataclass(frozen=True)
class TimePoint:
    """An extremal of the fixed-horizon problem at ``T``: its arcs, ``H``, cost ``V``, least
    clearance (of 401 samples: to rank families, not to validate an answer), the path's shape
    and its states and costates times ``T`` at :data:`.bounded.JUNCTIONS` + 1 uniform fractions
    of ``T`` (the predictor's data)."""

    T: float
    arcs: Arcs
    H: float
    V: float
    clearance: float
    xy: np.ndarray  # positions at SHAPE_SAMPLES uniform fractions of T: the path's shape
    z: np.ndarray  # [x, T lambda] at JUNCTIONS + 1 uniform fractions of T

    def moved(self, other: TimePoint) -> float:
        """How far the path moved from ``other``'s (:func:`.status.path_moved`)."""
        return path_moved(self.xy, other.xy)

    def total(self, k: float) -> float:
        """The cost with the price of time."""
        return self.V + k * self.T


class Stuck(RuntimeError):
    """The continuation in ``T`` failed to reach a horizon even in small steps."""


class OutOfSolves(Stuck):
    """The continuation made all the solves it was allowed (it may be allowed more)."""


class _Met(Exception):
    """Raised inside Brent's method when a point meets the condition: no need to go on."""

    def __init__(self, point: TimePoint):
        super().__init__(point.T)
        self.point = point


class TimeSearch:
    """The root of ``k + H(T)`` along one family of extremals (the module's method)."""

    def __init__(
        self, problem, settings: ShootingSettings, k: float, limits, ends, first: Arcs,
        deadline: float = math.inf,
    ):  # fmt: skip
        self.problem, self.settings, self.k, self.ends = problem, settings, k, ends
        self.limits, self.deadline = limits, deadline
        self.flow = Flow(problem, settings.integrator)
        self.points = [self._point(first)]
        self.solves, self.budget = 0, MAX_SOLVES
        self.reach = math.inf  # the longest step, as |log(T1 / T0)|, the next solve may take
        self._from: dict[float, TimePoint] = {}  # T of a point -> the point it was solved from
        self._secant: tuple[TimePoint, float | None] = (self.points[0], None)  # where it is

    @property
    def last(self) -> TimePoint:
        """The horizon solved last."""
        return self.points[-1]

    def allow(self, solves: int) -> None:
        """Allow ``solves`` more solves: :meth:`solve` then goes on where it stopped."""
        self.budget = self.solves + solves

    def _point(self, arcs: Arcs) -> TimePoint:
        tr = piecewise_trajectory(self.flow, arcs, 401)
        T = float(arcs.t[-1])
        H = float(np.mean(tr.hamiltonian[tr.at_step]))
        clearance = float(np.min(self.problem.penalty.clearance(tr.x[:, :2]), initial=np.inf))
        z = tr.at(np.linspace(tr.t[0], tr.t[-1], JUNCTIONS + 1), np.hstack([tr.x, T * tr.lam]))
        xy = tr.at(np.linspace(tr.t[0], tr.t[-1], SHAPE_SAMPLES), tr.x[:, :2])
        return TimePoint(T, arcs, H, float(tr.cost[-1]), clearance, xy, z)

    def g(self, p: TimePoint) -> float:
        return self.k + p.H

    def met(self, p: TimePoint) -> bool:
        return abs(self.g(p)) <= CONDITION_TOL * max(1.0, self.k)

    def at(self, T: float) -> TimePoint:
        """The extremal at ``T``, continued from the solved horizon nearest to it."""
        base = min(self.points, key=lambda p: abs(math.log(p.T / T)))
        while base.T != T:
            step = math.log(T / base.T)
            short = base.T * math.exp(math.copysign(self.reach, step))
            T1 = T if abs(step) <= self.reach else short
            new = self._step(base, T1)
            if new is None:  # failed, or jumped to another family: a shorter step
                self.reach = abs(math.log(T1 / base.T)) / 2
                if self.reach < MIN_REACH:
                    raise Stuck(f"the continuation in T stopped between {base.T:.6g} and {T1:.6g}")
                continue
            if T1 != T:
                self.reach *= GROWTH
            self._from[new.T] = base
            self.points.append(new)
            base = new
        return base

    def _step(self, base: TimePoint, T1: float) -> TimePoint | None:
        """The extremal at ``T1`` from ``base`` (None: the solve failed or jumped away)."""
        if self.solves >= self.budget:
            raise OutOfSolves(f"the continuation in T made {self.solves} solves")
        if time.perf_counter() >= self.deadline:
            raise Stuck("the time limit ran out")
        self.solves += 1
        arcs = resolve(self.problem, self._guess(base, T1), self.problem, (0, T1), self.ends,
                       self.settings)  # fmt: skip
        new = None if arcs is None else self._point(arcs)
        return None if new is None or new.moved(base) > MAX_MOVE else new

    def _guess(self, base: TimePoint, T1: float) -> Arcs:
        """The predicted extremal at ``T1``: linear in ``T`` through ``base`` and the point it
        was solved from (``base`` stretched to ``T1`` when it was not solved from one)."""
        before = self._from.get(base.T)
        if before is None or before.T == base.T:
            return base.arcs
        z = base.z + (T1 - base.T) / (base.T - before.T) * (base.z - before.z)
        nx = z.shape[1] // 2
        X = z[:, :nx].copy()
        X[0], X[-1] = self.ends
        return Arcs(np.linspace(0.0, T1, JUNCTIONS + 1), X, z[:-1, nx:] / T1)

    def solve(self) -> tuple[TimePoint, str]:
        """The point where ``k + H = 0``, or the bound it lies beyond (and which bound). After
        :class:`OutOfSolves` and :meth:`allow`, it goes on where it stopped."""
        a, T = self._secant
        if T is None:
            if self.met(a):
                return a, ""
            T = first_step(a.T, a.H, self.k)
        lo, hi = self.limits
        while True:
            T = float(np.clip(T, max(lo, a.T / STEP_FACTOR), min(hi, a.T * STEP_FACTOR)))
            self._secant = (a, T)
            b = self.at(T)
            if self.met(b):
                return b, ""
            if (self.g(a) > 0) != (self.g(b) > 0):
                return self._bracketed(a, b), ""
            if b.T == lo and self.g(b) > 0:  # still too long at the shortest allowed
                return b, "shortest"
            if b.T == hi and self.g(b) < 0:
                return b, "longest"
            if b.T == a.T or self.g(b) == self.g(a):
                raise Stuck(f"the secant in T stalled at {b.T:.6g}")
            ua, ub = a.T**-2, b.T**-2  # the secant in 1/T^2
            u = ub - self.g(b) * (ub - ua) / (self.g(b) - self.g(a))
            T = u**-0.5 if u > 0 else b.T * STEP_FACTOR
            a = b

    def _bracketed(self, a: TimePoint, b: TimePoint) -> TimePoint:
        from scipy.optimize import brentq  # only here: SciPy's optimize takes 0.1 s to import

        def g(u):
            p = self.at(u**-0.5)
            if self.met(p):
                raise _Met(p)
            return self.g(p)

        try:
            u = brentq(g, a.T**-2, b.T**-2, xtol=1e-300, rtol=4 * np.finfo(float).eps)
            return self.at(u**-0.5)
        except _Met as met:
            return met.point

    def predicted(self) -> float:
        """The least cost with the price of time this family is heading for, from its last
        point, were ``H`` that of free space (``-c / T^2``) from there on, within the bounds."""
        p, k = self.last, self.k
        if p.H >= 0:
            return p.total(k)
        c = -p.H * p.T**2
        T = float(np.clip(math.sqrt(c / k), *self.limits))
        return p.V + c * (1 / T - 1 / p.T) + k * T


def first_step(T: float, H: float, k: float) -> float:
    """Where a search aims first from an extremal at ``T`` with Hamiltonian ``H``: the root of
    ``k + H`` were ``H`` that of free space, ``-c / T^2``; half ``T`` when ``H >= 0``."""
    return T * math.sqrt(-H / k) if H < 0 else T / 2
