"""The flow of the canonical system, with exact sensitivities, as a Python object.

``Flow(problem, settings)(t0, z0, t1, sensitivity=...)`` integrates ``zdot = G(z)`` with
``z = (x, lambda)``, the running cost as a quadrature state and, on request, the variational
equations ``Sdot = DG(z) S`` for the columns of ``S`` that the caller needs: the costate columns
(``dz(t1)/dlambda(t0)``, what simple shooting needs) or all of ``Phi = dz(t1)/dz(t0)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..compiled.abi import Dynamics, Equation, Samples, StepControl
from ..compiled.kernels import entry_point
from ..compiled.status import FlowStatus
from ..errors import SettingsError, require_integer
from .problem import OptimalControlProblem
from .tableaux import TABLEAUX, get_tableau


@dataclass(frozen=True)
class IntegratorSettings:
    """How to integrate. ``method``: ``rk4`` (fixed ``steps``), ``dp5`` or ``dop853`` (adaptive)."""

    method: str = "dop853"
    # Two orders below the shooting tolerance (1e-10), so that Newton never chases integrator noise.
    rtol: float = 1e-12
    atol: float = 1e-12
    steps: int = 200
    max_steps: int = 100_000

    def __post_init__(self):
        if self.method not in TABLEAUX:
            raise SettingsError(
                f"unknown integrator {self.method!r} (known: {', '.join(TABLEAUX)})"
            )
        if not (0 < self.rtol < 1) or not (self.atol > 0):
            raise SettingsError(
                f"integrator tolerances need 0 < rtol < 1, atol > 0; got {self.rtol}, {self.atol}"
            )
        require_integer("integrator steps", self.steps)
        require_integer("integrator max_steps", self.max_steps)


@dataclass(frozen=True)
class Trajectory:
    """A sampled extremal: times, states, costates, controls and the accumulated cost."""

    t: np.ndarray
    x: np.ndarray  # (N, nx)
    lam: np.ndarray  # (N, nx)
    u: np.ndarray  # (N, nu)
    cost: np.ndarray  # (N,) running cost integrated from t[0]
    hamiltonian: np.ndarray  # (N,)
    dH_du: np.ndarray  # (N, nu), zero up to rounding on an extremal
    at_step: np.ndarray  # (N,) bool: rows computed by the integrator itself (not interpolated)

    def at(self, times, values: np.ndarray | None = None) -> np.ndarray:
        """The columns of ``values`` (rows along :attr:`t`; default: the states) at ``times``,
        linear between rows; a time repeated (a junction of arcs) counts once."""
        values = self.x if values is None else values
        keep = np.append(np.diff(self.t) > 0, True)
        t, rows = self.t[keep], values[keep]
        return np.column_stack([np.interp(times, t, rows[:, i]) for i in range(rows.shape[1])])


@dataclass(frozen=True)
class FlowResult:
    status: FlowStatus
    t0: float
    t1: float
    z: np.ndarray  # (2 nx,) state and costate at t1
    cost: float  # integral of the running cost over [t0, t1]
    sensitivity: np.ndarray | None  # (2 nx, k): dz(t1)/d(seed), see Flow.__call__
    steps: int
    rejected: int
    trajectory: Trajectory | None = None

    @property
    def ok(self) -> bool:
        return self.status == FlowStatus.OK

    @property
    def x(self) -> np.ndarray:
        return self.z[: self.z.size // 2]

    @property
    def lam(self) -> np.ndarray:
        return self.z[self.z.size // 2 :]


_SEEDS = (None, "costate", "full")
_STATUS = tuple(FlowStatus)  # kernel status code -> enum, without the enum call


class Flow:
    """Compiled flow of one problem; cheap to call many times (obstacles are arrays, not code).

    ``dynamics`` (the equation's data and the method's tableau) and ``control`` (the settings'
    tolerances) are the records of the compiled calls (:mod:`..compiled.abi`), the flow's own
    and the compiled Newton loop's."""

    def __init__(self, problem: OptimalControlProblem, settings: IntegratorSettings | None = None):
        self.problem = problem
        self.settings = s = settings or IntegratorSettings()
        self.tableau = get_tableau(s.method)
        self.kernels = problem.model.kernels
        self.nx = problem.model.nx
        self.nz = 2 * self.nx
        penalty = problem.penalty
        equation = Equation(
            np.asarray(problem.parameters, dtype=np.float64),
            penalty.grid,  # obstacles and their grid (model/penalty.py)
            float(penalty.weight),
            int(penalty.exponent),
        )
        no_samples = Samples(np.zeros(0), np.zeros((0, self.nz + 1)))
        self.dynamics = Dynamics(equation, self.tableau.record(), no_samples)
        self.control = StepControl(float(s.rtol), float(s.atol), int(s.max_steps))
        eye = np.eye(self.nz)
        self._seed = {None: eye[:, :0], "costate": eye[:, self.nx :], "full": eye}
        # Initial augmented states [z, cost, seed] per named seed: a call copies one and writes z.
        self._Y0 = {
            key: np.concatenate([np.zeros(self.nz + 1), seed.ravel()])
            for key, seed in self._seed.items()
        }
        self._integrate = None  # the integrator's entry point, bound on the first call

    def with_settings(self, settings: IntegratorSettings) -> Flow:
        return Flow(self.problem, settings)

    def _run(self, t0, z0, t1, seed, samples, rtol=None, atol=None, Y0=None):
        """The integrator's kernel from ``(t0, z0)`` to ``t1`` with the sensitivity ``seed``:
        ``(Y, status, accepted steps, rejected steps)``. Every argument is built here with the
        same types on every call, so the kernel is called through its entry point."""
        nz = self.nz
        k = seed.shape[1]
        if Y0 is None:
            Y0 = np.empty(nz + 1 + nz * k)
            Y0[nz] = 0.0
            Y0[nz + 1 :] = seed.ravel()
        Y0[:nz] = z0
        if not self.tableau.adaptive:
            budget = int(self.settings.steps)
        elif rtol is None and atol is None:
            budget = self.control
        else:
            c = self.control
            budget = StepControl(float(rtol or c.rtol), float(atol or c.atol), c.max_steps)
        args = (Y0, float(t0), float(t1), k, self.dynamics, budget, samples)
        if self._integrate is None:
            K = self.kernels
            self._integrate = entry_point(
                K.erk_adaptive if self.tableau.adaptive else K.erk_fixed, args
            )
        Y, status, acc, rej = self._integrate(*args)
        return Y, _STATUS[status], acc, rej

    def __call__(
        self,
        t0: float,
        z0,
        t1: float,
        *,
        sensitivity: str | None | np.ndarray = None,
        samples: int = 0,
        rtol: float | None = None,
        atol: float | None = None,
    ) -> FlowResult:
        """Integrate from ``(t0, z0)`` to ``t1``.

        ``sensitivity``: ``None`` (flow only), ``"costate"`` (``dz(t1)/dlambda(t0)``, shape
        ``(2nx, nx)``), ``"full"`` (``Phi = dz(t1)/dz(t0)``) or a seed matrix ``(2nx, k)``.
        ``samples > 0`` also returns a trajectory: the integrator's own steps, and for a dense
        view ``samples`` uniform times interpolated by cubic Hermite splines between steps.
        ``rtol``, ``atol`` override the settings' tolerances for this call (adaptive methods).
        """
        Y0 = None
        if isinstance(sensitivity, np.ndarray):
            seed = np.ascontiguousarray(sensitivity, dtype=np.float64).reshape(self.nz, -1)
        elif sensitivity in _SEEDS:
            seed = self._seed[sensitivity]
            Y0 = self._Y0[sensitivity].copy()
        else:
            raise SettingsError(
                f"sensitivity must be one of {_SEEDS} or an array, got {sensitivity!r}"
            )
        z0 = np.asarray(z0, dtype=np.float64)
        if samples:
            cap = (
                self.settings.steps if not self.tableau.adaptive else self.settings.max_steps
            ) + 1
            record = Samples(np.empty(cap), np.empty((cap, self.nz + 1)))
        else:
            record = self.dynamics.no_samples
        Y, status, acc, rej = self._run(t0, z0, t1, seed, record, rtol, atol, Y0)
        nz = self.nz
        k = seed.shape[1]
        traj = None
        if samples and status == FlowStatus.OK:
            traj = self._trajectory(record.T[: acc + 1], record.Z[: acc + 1], samples)
        return FlowResult(
            status=status,
            t0=float(t0),
            t1=float(t1),
            # Views: the kernel returns a new Y on every call.
            z=Y[:nz],
            cost=float(Y[nz]),
            sensitivity=Y[nz + 1 :].reshape(nz, k) if k else None,
            steps=int(acc),
            rejected=int(rej),
            trajectory=traj,
        )

    def _trajectory(self, T, Z, samples) -> Trajectory:
        if samples > 1 and T.size > 1:
            dZ = np.empty_like(Z)
            self.kernels.rhs_along(Z, *self.dynamics.equation, dZ)
            t = np.unique(np.concatenate([np.linspace(T[0], T[-1], samples), T]))
            if T[-1] < T[0]:
                t = t[::-1]
            Zs = np.empty((t.size, Z.shape[1]))
            self.kernels.hermite_dense(T, Z, dZ, t, Zs)
            at_step = np.zeros(t.size, dtype=bool)
            idx = np.searchsorted(t, T) if T[-1] > T[0] else np.searchsorted(-t, -T)
            Zs[idx] = Z  # exact values at the steps
            at_step[idx] = True
        else:
            t, Zs, at_step = T.copy(), Z.copy(), np.ones(T.size, dtype=bool)
        return self.evaluate(t, Zs[:, : self.nz], Zs[:, self.nz], at_step)

    def evaluate(self, t, Z, cost=None, at_step=None) -> Trajectory:
        """Controls, H and dH/du along given rows ``Z = (x, lambda)``."""
        Z = np.ascontiguousarray(Z, dtype=np.float64)
        nu = self.problem.model.nu
        U = np.empty((Z.shape[0], nu))
        H = np.empty(Z.shape[0])
        dHdu = np.empty((Z.shape[0], nu))
        self.kernels.along_path(Z, self.dynamics.equation, U, H, dHdu)
        return Trajectory(
            t=np.asarray(t, dtype=float),
            x=Z[:, : self.nx].copy(),
            lam=Z[:, self.nx :].copy(),
            u=U,
            cost=np.zeros(Z.shape[0]) if cost is None else np.asarray(cost, dtype=float),
            hamiltonian=H,
            dH_du=dHdu,
            at_step=np.ones(Z.shape[0], dtype=bool) if at_step is None else at_step,
        )
