"""The final solve at ``q = 2``: simple shooting over the whole horizon from the first arc's
costate; if it fails (``final="auto"``), multiple shooting over the junctions of the last level
with ``q > 2`` (Newton, then Levenberg-Marquardt from the same start where Newton fails), then
over twice as many (every arc split at its middle: shorter arcs, a better conditioned system),
and so on up to ``final_refinements`` times (none begun that would end past a plan's time
limit; a run cut short by it tries multiple shooting only on a level of a few arcs)."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace

import numpy as np

from ...bvp.multiple_shooting import (
    MultipleShootingSystem,
    solve_multiple_shooting,
    within_costate_scale,
)
from ...bvp.shooting import solve_shooting
from ...integrate.flow import Flow
from ...roots import RootResult, RootStatus, solve_least_squares
from .arcs import Arcs, Junctions
from .local import LocalSolver


@dataclass(frozen=True)
class FinalSolution:
    """The final solve: its status (the last root solve's), the extremal's arcs (one arc for
    simple shooting, the junctions of multiple shooting; None when every solve failed), which
    solver found it, and the last root result."""

    extremal: Arcs | None
    solver: str | None
    root: RootResult

    @property
    def status(self) -> RootStatus:
        return RootStatus.CONVERGED if self.extremal is not None else self.root.status

    @property
    def success(self) -> bool:
        return self.extremal is not None


#: Past a plan's time limit, multiple shooting is tried only on a level of at most this many
#: arcs (its Newton system then has at most 32 times the state's size unknowns: milliseconds).
LATE_ARCS = 16
#: A refined level (twice the arcs) costs at least this many times the level before it (twice
#: the flows; its dense Newton system grows faster still): none is begun that would end past a
#: plan's time limit (on 100 arcs and more, a refinement begun just before it ran 3 s past).
REFINED_COSTS = 2.0


class FinalSolver:
    """The final solves of one run, from ``start`` at ``T0`` to ``goal`` at ``T1``."""

    def __init__(
        self, local: LocalSolver, flow: Flow, start, goal, T0: float, T1: float,
        deadline: float = math.inf,
    ):  # fmt: skip
        """``deadline`` (a ``time.perf_counter()`` value: a plan's time limit): no refinement
        is begun that would end past it (:data:`REFINED_COSTS`), and past it multiple shooting
        runs only on a level of at most
        :data:`LATE_ARCS` arcs. A run cut short by the limit may not have merged its arcs: on
        hundreds of them a multiple-shooting solve is a dense Newton system of thousands of
        unknowns, and 16 such runs of paper case 4 at 512 partitions took 6 minutes past a
        limit of 2.4 s (the same plan takes 7 s without a limit)."""
        s = local.settings
        self.deadline = deadline
        self.local, self.settings = local, s
        self.shooting = s.final_solves()
        self.flow = flow
        self.start, self.goal, self.T0, self.T1 = start, goal, T0, T1
        # Multiple shooting's first stage: the local problems' integrator and tolerance, with
        # the final solve's step bound and iteration rules.
        self.coarse_flow = local.flow.with_settings(
            replace(local.flow.settings, max_steps=self.shooting.integrator.max_steps)
        )
        self.coarse_root = replace(self.shooting.root, tol=local.shooting.root.tol)

    def solve(self, lam0, junctions: Junctions) -> FinalSolution:
        """Simple shooting from ``lam0``, else multiple shooting over ``junctions`` (and their
        refinements), as the settings' ``final`` allows."""
        root = None
        count, final = self.local.count, self.settings.final
        if final in ("auto", "shooting"):
            r = solve_shooting(
                self.local.problem, self.T0, self.start, self.T1, self.goal,
                guess=lam0, settings=self.shooting, flow=self.flow,
            )  # fmt: skip
            count.add(r)
            root = r.root
            if r.success:
                t, ends = np.array([self.T0, self.T1]), np.array([self.start, self.goal])
                return FinalSolution(Arcs(t, ends, r.costate0[None, :]), "shooting", root)
        if final in ("auto", "multiple-shooting"):
            level, took = junctions, 0.0
            for refinements in range(self.settings.final_refinements + 1):
                now = time.perf_counter()
                if refinements and now + REFINED_COSTS * took > self.deadline:
                    break  # (the refined level would end past it)
                if now >= self.deadline and level.q > LATE_ARCS:
                    break
                if refinements:
                    level = level.refined(self.local.flow)
                found = self.multiple_shooting(level, trust_region=not refinements)
                took = time.perf_counter() - now
                root = found.root
                if found.success:
                    return found
        return FinalSolution(None, None, root)

    def multiple_shooting(self, junctions: Junctions, trust_region: bool = False) -> FinalSolution:
        """Multiple shooting from the arcs ``junctions``; where Newton fails and
        ``trust_region``, Levenberg-Marquardt from the same start (at most
        ``final_least_squares`` trial points: :mod:`...roots.least_squares`). Only on the
        level Leapfrog left, not on its refinements: on the runs of an office route of 72
        length scales it converged 5 of the 8 levels Leapfrog left where Newton stalled, and
        none of the 6 refinements it was tried on, which took 95% of its time there.

        Converged first with the local problems' tolerances (rtol 1e-7, |F| <= 1e-5), then
        polished with the final ones (one or two iterations): an evaluation integrates every
        arc with its full sensitivities, 3 ms at rtol 1e-12 for the 8 arcs of paper case 4
        (measured there: 43 -> 14 ms for the fallback, the same answer). When the coarse solve
        fails the fallback has failed: solving again at rtol 1e-12 from the start never
        converged instead (measured on 2 x 150 random scenarios and the paper cases)."""
        count, method, compiled = self.local.count, self.settings.method, self.shooting.compiled
        Z = np.hstack([junctions.X[:-1], junctions.lam0])
        ms = MultipleShootingSystem(self.coarse_flow, junctions.t, self.start, self.goal)
        w0 = ms.pack(junctions.lam0[0], Z)
        root = solve_multiple_shooting(ms, w0, method, self.coarse_root, compiled)
        evaluations = self.settings.final_least_squares
        if not root.success and trust_region and evaluations:
            count.add(root)
            root = solve_least_squares(ms, w0, self.coarse_root, evaluations)
        if root.success:
            count.add(root)
            ms = MultipleShootingSystem(self.flow, junctions.t, self.start, self.goal)
            root = within_costate_scale(
                solve_multiple_shooting(ms, root.x, method, self.shooting.root, compiled),
                ms, self.shooting.root.tol,
            )  # fmt: skip
        count.add(root)
        if not root.success:
            return FinalSolution(None, None, root)
        Z = ms.unpack(root.x)
        nx = self.start.size
        ends = np.vstack([Z[:, :nx], self.goal[None, :]])
        return FinalSolution(Arcs(ms.t.copy(), ends, Z[:, nx:].copy()), "multiple-shooting", root)
