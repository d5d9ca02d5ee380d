"""Multiple shooting over the Leapfrog junctions: the fallback for the final simple shooting.

Unknowns ``w = (lambda_0, z_1, ..., z_{q-1})`` with ``z_j = (x_j, lambda_j)``; residuals are the
continuity defects ``z(t_{j+1}; t_j, z_j) - z_{j+1}`` and the end-state error. Leapfrog gives an
excellent starting point: its junctions and the costates of its piecewise-optimal arcs.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..compiled.abi import Ends
from ..integrate.flow import Flow, FlowStatus
from ..roots import RootResult, RootSettings, RootStatus, get_strategy, solve_root
from ..roots.messages import converged
from . import shooting


class MultipleShootingSystem:
    # Evaluated at the flow's own tolerances (simple shooting may integrate loosely while |F|
    # is large; see ShootingSettings.inexact).
    inexact = False

    def __init__(self, flow: Flow, t: np.ndarray, x0: np.ndarray, x1: np.ndarray):
        self.flow = flow
        # The compiled loop's view of the problem (as ShootingSystem's): ends, junction times,
        # copies that the Python evaluation reads too (the caller's arrays may change after).
        self.ends = Ends.of(x0, x1, t)
        self.x0, self.x1, self.t = self.ends
        self.nx = self.x0.size
        self.q = self.t.size - 1

    def pack(self, lam0, Z) -> np.ndarray:
        """Unknown vector from the first costate and the interior junction states ``Z[1:q]``."""
        return np.concatenate([np.asarray(lam0, float), np.asarray(Z, float)[1 : self.q].ravel()])

    def unpack(self, w) -> np.ndarray:
        """All junction values ``(q, 2 nx)``: ``z_j`` at the start of each arc."""
        nx, nz = self.nx, 2 * self.nx
        Z = np.empty((self.q, nz))
        Z[0, :nx] = self.x0
        Z[0, nx:] = w[:nx]
        Z[1:] = w[nx:].reshape(self.q - 1, nz)
        return Z

    def evaluate(self, w, jacobian):
        nx, nz, q = self.nx, 2 * self.nx, self.q
        Z = self.unpack(w)
        n = w.size
        F = np.empty(n)
        J = np.zeros((n, n)) if jacobian else None
        for j in range(q):
            # The first arc's state is fixed (x0): only its costate columns are unknowns.
            sens = None if not jacobian else ("costate" if j == 0 else "full")
            r = self.flow(self.t[j], Z[j], self.t[j + 1], sensitivity=sens)
            if r.status != FlowStatus.OK:
                return None, None
            rows = slice(j * nz, (j + 1) * nz) if j < q - 1 else slice(j * nz, j * nz + nx)
            target = Z[j + 1] if j < q - 1 else self.x1
            end = r.z if j < q - 1 else r.z[:nx]
            F[rows] = end - target
            if jacobian:
                Phi = r.sensitivity if j < q - 1 else r.sensitivity[:nx]
                # Column block of z_j: lambda_0 only for the first arc, all of z_j afterwards.
                if j == 0:
                    J[rows, :nx] = Phi
                else:
                    c = nx + (j - 1) * nz
                    J[rows, c : c + nz] = Phi
                if j < q - 1:
                    c = nx + j * nz
                    J[rows, c : c + nz] -= np.eye(nz)
        return F, J


def solve_multiple_shooting(
    system: MultipleShootingSystem, w0, method, settings: RootSettings, compiled: bool = True
) -> RootResult:
    """:func:`solve_root` on ``system``; in one compiled call where the method and the integrator
    allow it, unless ``compiled`` is False (``ShootingSettings.compiled`` of the caller's stage):
    the same iterates, statuses and counts, bit for bit (tested). In the Python loop
    Leapfrog's two-arc attempts cost about three times their flows (measured on paper case 3,
    whose serial CPU time fell by 10% with the compiled loop)."""
    strategy = get_strategy(method)
    if compiled and shooting.runs_compiled(system.flow, strategy):
        return shooting.compiled_newton(system, w0, strategy, settings)[0]
    return solve_root(system, w0, strategy, settings)


def within_costate_scale(root: RootResult, ms: MultipleShootingSystem, tol: float) -> RootResult:
    """The polish's root, counted as converged where it failed with ``|F|`` within ``tol``
    times the costates' magnitude (when above 1). Its defects are integrated at rtol 1e-12,
    and the states' rounding grows with the costates: costates of a few hundred (a
    differential drive with small wheels, whose wheel cost is ``1/r^2`` times the motion's)
    leave the defects at 1e-10 to 1e-9, where the line search finds no decrease: measured on
    a TurtleBot3 on its map (``r = 0.033``, costates about 300), polishes stalled at 1.6e-10
    and 2.2e-10 from 3e-6. The answer is validated as every other (re-integrated, its end
    state within the end tolerance), so a false root is not taken for an extremal."""
    if root.success or not np.isfinite(root.F).all():
        return root
    scale = max(1.0, float(np.abs(ms.unpack(root.x)[:, ms.nx :]).max()))
    norm = root.residual_norm
    if scale == 1.0 or not norm <= tol * scale:
        return root
    message = converged(norm, tol * scale, root.iterations) + " (tolerance times the costates)"
    return replace(root, status=RootStatus.CONVERGED, message=message)
