"""Piecewise extremals: the frozen record a run hands back (:class:`Arcs`) and the working
copy that the sweeps update in place (:class:`Junctions`)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ...integrate.flow import Flow


@dataclass(frozen=True)
class Arcs:
    """A piecewise extremal: arc ``i`` runs from ``(t[i], X[i])`` with costate ``lam0[i]`` to
    ``(t[i + 1], X[i + 1])``, at the cost ``cost[i]`` (``None`` when not computed)."""

    t: np.ndarray
    X: np.ndarray
    lam0: np.ndarray
    cost: np.ndarray | None = None


@dataclass
class Junctions:
    """The piecewise-optimal trajectory of a level: arc ``i`` runs from ``(t[i], X[i])`` to
    ``(t[i + 1], X[i + 1])``, with its costates at both ends and its cost."""

    t: np.ndarray
    X: np.ndarray
    lam0: np.ndarray  # (q, nx) costate at the start of each arc
    lam1: np.ndarray  # (q, nx) costate at the end of each arc
    cost: np.ndarray  # (q,)
    # Junctions of this level whose local problem end-state continuation failed to solve: it
    # is not tried there again (see LocalSolver.sweep_solve).
    hopeless: set[int] = field(default_factory=set)

    @classmethod
    def from_pieces(cls, pieces: list, t_end: float, x_end: np.ndarray) -> Junctions:
        """From solved segments ``(t_a, x_a, lambda_a, lambda_b, cost)`` and the final state."""
        return cls(
            t=np.array([p[0] for p in pieces] + [t_end]),
            X=np.array([p[1] for p in pieces] + [x_end]),
            lam0=np.array([p[2] for p in pieces]),
            lam1=np.array([p[3] for p in pieces]),
            cost=np.array([p[4] for p in pieces]),
        )

    @property
    def q(self) -> int:
        return self.t.size - 1

    def max_jump(self) -> float:
        """The largest costate jump at a junction, relative to the costates' size."""
        if self.q < 2:
            return 0.0
        jumps = np.linalg.norm(self.lam1[:-1] - self.lam0[1:], axis=1)
        scale = max(1.0, float(np.abs(self.lam0).max()))
        return float(jumps.max() / scale)

    def refined(self, flow: Flow) -> Junctions:
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
        return Junctions(t=t, X=X, lam0=lam0, lam1=lam1, cost=cost)

    def halved(self) -> Junctions:
        """Every other junction kept. The merged arcs keep the costate of their first half, so
        they jump where a junction was dropped: a start for the next level, not an extremal."""
        keep = list(range(0, self.q, 2)) + [self.q]
        if keep[-2] == keep[-1]:
            keep.pop()
        starts, ends = keep[:-1], keep[1:]
        return Junctions(
            t=self.t[keep].copy(),
            X=self.X[keep].copy(),
            lam0=self.lam0[starts].copy(),
            lam1=self.lam1[[e - 1 for e in ends]].copy(),
            cost=np.array([self.cost[a:b].sum() for a, b in zip(starts, ends, strict=True)]),
        )

    def frozen(self) -> Arcs:
        """A frozen copy (of arcs that meet at their junctions: not of halved ones)."""
        return Arcs(self.t.copy(), self.X.copy(), self.lam0.copy(), self.cost.copy())
