"""Simple shooting for the Pontryagin boundary value problem.

The unknown is the initial costate ``s = lambda(t0)``. ``F(s) = x(t1; x0, s) - x1`` and its
Jacobian ``DF = dx(t1)/dlambda(t0)`` comes from the variational equations (the costate block of
``Phi``), never from finite differences.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import numpy as np
from scipy.linalg import expm, solve

from .._blas import blas_single_threaded
from ..compiled import background
from ..compiled.abi import (
    Accuracy,
    Arcs,
    Ends,
    History,
    NewtonOutcome,
    RootParams,
    Solver,
    StepParams,
    SweepOutcome,
)
from ..compiled.kernels import cached_entry_point, entry_point
from ..errors import ScenarioError, SettingsError, require_integer
from ..integrate.flow import Flow, FlowResult, FlowStatus, IntegratorSettings, Trajectory
from ..integrate.problem import OptimalControlProblem
from ..model.penalty import grid_penalty_terms
from ..roots import (
    STRATEGIES,
    ModifiedNewtonStep,
    NewtonStep,
    NleqErrStep,
    RootResult,
    RootSettings,
    RootStatus,
    get_strategy,
    messages,
    solve_root,
)
from ..roots.steps import vnorm


@dataclass(frozen=True)
class ShootingSettings:
    method: str = "modified-newton"
    root: RootSettings = field(default_factory=RootSettings)
    integrator: IntegratorSettings = field(default_factory=IntegratorSettings)
    samples: int = 201  # points of the dense trajectory returned; 0 for none
    # Inexact Newton: integrate loosely while |F| is large (tolerance ~ 1e-4 |F|, never looser
    # than 1e-6); the final iterations, and so the converged residual, use the full tolerance.
    inexact: bool = True
    # NM, MNM and NLEQ-ERR with an adaptive integrator run as one compiled loop (the same
    # iterates, bit for bit, as the shared Python loop, without its per-iteration overhead);
    # False forces the Python loop.
    compiled: bool = True

    def __post_init__(self):
        if isinstance(self.method, str) and self.method not in STRATEGIES:
            raise SettingsError(f"unknown method {self.method!r} (known: {', '.join(STRATEGIES)})")
        if not isinstance(self.root, RootSettings):
            raise SettingsError(f"root must be RootSettings, got {type(self.root).__name__}")
        if not isinstance(self.integrator, IntegratorSettings):
            raise SettingsError(
                f"integrator must be IntegratorSettings, got {type(self.integrator).__name__}"
            )
        require_integer("samples", self.samples, 0)
        for name in ("inexact", "compiled"):
            if not isinstance(getattr(self, name), bool):
                raise SettingsError(f"{name} must be true or false, got {getattr(self, name)!r}")


@dataclass(frozen=True)
class ShootingResult:
    status: RootStatus
    message: str
    t0: float
    t1: float
    x0: np.ndarray
    x1: np.ndarray  # the target
    costate0: np.ndarray  # lambda(t0), the shooting unknown
    costate1: np.ndarray  # lambda(t1)
    cost: float
    end_state_error: float  # |x(t1) - x1| of the returned costate
    max_dH_du: float  # Pontryagin's stationarity condition along the trajectory
    hamiltonian_variation: float  # max |H - H(t0)|: H is constant on an extremal
    trajectory: Trajectory | None
    root: RootResult

    @property
    def success(self) -> bool:
        return self.status is RootStatus.CONVERGED


class ShootingSystem:
    """``F(s) = x(t1; x0, s) - x1`` and ``DF(s)`` for the root solvers."""

    def __init__(self, flow: Flow, t0, x0, t1, x1, inexact: bool = False):
        self.flow, self.t0, self.t1 = flow, float(t0), float(t1)
        self.inexact = inexact and flow.tableau.adaptive
        self._base = (flow.settings.rtol, flow.settings.atol)
        self._norm = np.inf  # the smallest |F| so far, sets the next tolerance
        self._norm_used = np.inf  # the one the latest evaluation used
        # The compiled loop's view of the problem: end states and junction times, copies that
        # the Python evaluation reads too.
        self.ends = Ends.of(x0, x1, [self.t0, self.t1])
        self.x0, self.x1 = self.ends.x0, self.ends.x1
        self.nx = self.x0.size
        self._z0 = np.empty(2 * self.nx)
        self._z0[: self.nx] = self.x0
        self.last = None  # (s, FlowResult) of the latest evaluation, reused for the result

    def evaluate(self, s, jacobian):
        # The point just evaluated, again (F alone first, now with J: RootSettings.predict),
        # is integrated at the same tolerance, so that it has the same F.
        if not (self.last is not None and np.array_equal(self.last[0], s)):
            self._norm_used = self._norm
        self._z0[self.nx :] = s
        rtol, atol = self._base
        if self.inexact:
            loose = min(1e-6, 1e-4 * self._norm_used)
            rtol, atol = max(rtol, loose), max(atol, loose)
        sens = "costate" if jacobian else None
        r = self.flow(self.t0, self._z0, self.t1, sensitivity=sens, rtol=rtol, atol=atol)
        if r.status != FlowStatus.OK:
            self.last = None
            return None, None
        F = r.z[: self.nx] - self.x1
        norm = vnorm(F)
        if rtol > self._base[0] and norm <= 1e3 * rtol:
            # Too close to the integration error to trust: redo at the full tolerance.
            r = self.flow(self.t0, self._z0, self.t1, sensitivity=sens)
            if r.status != FlowStatus.OK:
                self.last = None
                return None, None
            F = r.z[: self.nx] - self.x1
            norm = vnorm(F)
        self._norm = min(self._norm, norm)
        self.last = (np.array(s, dtype=float), r)
        return F, (r.sensitivity[: self.nx] if jacobian else None)


@blas_single_threaded
def affine_costate_guess(
    problem: OptimalControlProblem,
    t0,
    x0,
    t1,
    x1,
    *,
    reverse: bool = False,
    flow: Flow | None = None,
) -> np.ndarray:
    r"""Initial costate of the affine (linear-quadratic) approximation of the local problem.

    The model is linearised about a nominal motion along the chord from ``x0`` to ``x1``: the
    midpoint state with its heading along the chord, and the control ``u_bar`` that moves along
    the chord at the speed ``|chord| / T`` (least squares, so any model works). With
    ``A = df/dx``, ``B = df/du``, ``c = f(x_bar, u_bar) - A x_bar - B u_bar``,
    ``R = d2L/du2`` and ``q = grad P(x_bar)`` the local problem becomes

        min int 1/2 u^T R u + q^T x dt,   xdot = A x + B u + c,   x(t0) = x0, x(t1) = x1,

    whose extremals satisfy ``u = -R^-1 B^T lambda``, ``lambdadot = -A^T lambda - q``. With
    ``T = t1 - t0``, ``M = [[A, -B R^-1 B^T], [0, -A^T]]`` and ``m = (c, -q)``, the flow is
    ``z(T) = e^{MT} z(0) + int_0^T e^{M(T - tau)} m dtau``, both terms from one matrix exponential
    of ``[[M, m], [0, 0]] T`` (Van Loan). Its upper-right block is ``-e^{AT} W`` with the
    controllability Gramian ``W = int_0^T e^{-A tau} B R^-1 B^T e^{-A^T tau} dtau``, so

        lambda(t0) = W^-1 (x0 + e^{-AT} (phi_x - x1)),   phi_x = (int_0^T e^{M(T - tau)} m dtau)_x,

    which is solved as the linear system ``-e^{AT} W lambda0 = x1 - e^{AT} x0 - phi_x``.
    ``reverse`` linearises about backward motion along the chord instead.
    """
    x0 = np.asarray(x0, dtype=float)
    x1 = np.asarray(x1, dtype=float)
    T = float(t1 - t0)
    model = problem.model
    nx, nu = model.nx, model.nu
    K = (flow or Flow(problem)).kernels
    p = np.asarray(problem.parameters, dtype=float)
    chord = x1[:2] - x0[:2]
    length = float(np.hypot(*chord))
    xbar = 0.5 * (x0 + x1)
    if length > 1e-9:
        heading = np.arctan2(chord[1], chord[0]) + (np.pi if reverse else 0.0)
        # Headings are not wrapped: take the chord's heading nearest the end states' mean, since
        # c = f - A x_bar - B u_bar would otherwise carry a 2 pi error times d f / d theta.
        xbar[2] = heading + 2.0 * np.pi * np.round((xbar[2] - heading) / (2.0 * np.pi))
        speed = length / T
    else:  # no chord to follow: keep the mean heading and a small forward speed for controllability
        speed = 1e-3 / T
    target = np.zeros(nx)
    target[0], target[1] = speed * np.cos(xbar[2]), speed * np.sin(xbar[2])
    if reverse:
        target[:2] *= -1
    target[2:] = (x1[2:] - x0[2:]) / T
    f = np.empty(nx)
    A = np.empty((nx, nx))
    B = np.empty((nx, nu))
    R = np.empty((nu, nu))
    u = np.zeros(nu)
    # Gauss-Newton for the least-squares control u_bar with f(x_bar, u_bar) ~ target; for f
    # affine in u (both built-in models) the first step is exact and the second changes nothing.
    K.linearize(xbar, u, p, f, A, B, R)
    for _ in range(3):
        du = np.linalg.lstsq(B, target - f, rcond=None)[0]
        u = u + du
        K.linearize(xbar, u, p, f, A, B, R)
        if np.abs(du).max() <= 1e-12 * (1.0 + np.abs(u).max()):
            break
    c = f - A @ xbar - B @ u
    q = np.zeros(nx)
    pen = problem.penalty
    if pen.any:
        _, q[0], q[1], *_ = grid_penalty_terms(
            xbar[0], xbar[1], pen.grid, pen.weight, pen.exponent, False
        )
    n2 = 2 * nx
    big = np.zeros((n2 + 1, n2 + 1))
    big[:nx, :nx] = A
    big[:nx, nx:n2] = -B @ solve(R, B.T, assume_a="pos")
    big[nx:n2, nx:n2] = -A.T
    big[:nx, n2] = c
    big[nx:n2, n2] = -q
    E = expm(big * T)
    rhs = x1 - E[:nx, :nx] @ x0 - E[:nx, n2]
    return np.linalg.lstsq(E[:nx, nx:n2], rhs, rcond=None)[0]


def _check_ends(x0, x1, nx):
    for name, v in (("x0", x0), ("x1", x1)):
        if v.shape != (nx,) or not np.isfinite(v).all():
            raise ScenarioError(f"{name} must be {nx} finite numbers, got {v.tolist()}")


@blas_single_threaded
def solve_shooting(
    problem: OptimalControlProblem,
    t0: float,
    x0,
    t1: float,
    x1,
    *,
    method: str | None = None,
    guess=None,
    settings: ShootingSettings | None = None,
    flow: Flow | None = None,
) -> ShootingResult:
    """Solve the two-point problem from ``(t0, x0)`` to ``(t1, x1)`` by simple shooting.

    ``guess`` is the initial costate ``lambda(t0)``; by default the affine approximation
    (:func:`affine_costate_guess`). ``method``: ``newton``, ``modified-newton`` or ``nleq-err``.
    """
    settings = settings or ShootingSettings()
    method = method or settings.method
    x0 = np.asarray(x0, dtype=float)
    x1 = np.asarray(x1, dtype=float)
    nx = problem.model.nx
    _check_ends(x0, x1, nx)
    if not t1 > t0:
        raise ScenarioError(f"need t1 > t0, got t0 = {t0}, t1 = {t1}")
    flow = flow or Flow(problem, settings.integrator)
    if guess is None:
        s0 = affine_costate_guess(problem, t0, x0, t1, x1, flow=flow)
    else:
        s0 = np.asarray(guess, dtype=float)
    system = ShootingSystem(flow, t0, x0, t1, x1, settings.inexact)
    strategy = get_strategy(method)
    if settings.compiled and runs_compiled(flow, strategy):
        root, last, _ = compiled_newton(system, s0, strategy, settings.root)
    else:
        root = solve_root(system, s0, strategy, settings.root)
        last = system.last
    return shooting_result(flow, t0, x0, t1, x1, root, settings.samples, last)


_FUSED = (NewtonStep, ModifiedNewtonStep, NleqErrStep)  # codes 0, 1, 2 of shoot_newton
_CODES = tuple(RootStatus)  # the compiled loop's status codes, in RootStatus order


def compiled_solver(flow: Flow, strategy, settings: RootSettings, inexact: bool) -> Solver:
    """How ``shoot_newton`` solves (its :class:`~..compiled.abi.Solver` record): the method's
    code, the root settings, the step's fields and the flow's accuracy."""
    # Every field converted to its record type: numba types a record by its fields, so an int
    # where a float belongs (RootSettings(divergence=100)) compiled the loop a second time.
    root = RootParams(
        float(settings.tol), int(settings.max_iterations), float(settings.max_cond),
        float(settings.divergence), int(settings.stall_window), float(settings.stall_factor),
        bool(settings.predict),
    )  # fmt: skip
    step = _step_params(strategy)
    accuracy = Accuracy(flow.control, bool(inexact and flow.tableau.adaptive), int(flow.nx))
    return Solver(_FUSED.index(type(strategy)), root, step, accuracy)


def _step_params(strategy) -> StepParams:
    """The step object's fields as the compiled loop reads them, zeros where it has none."""

    def field(name: str, default: float):
        return getattr(strategy, name, default)

    return StepParams(
        int(field("max_halvings", 0)),
        float(field("initial_damping", 1.0)),
        float(field("min_damping", 0.0)),
        float(field("xtol", 0.0)),
        int(field("max_trials", 0)),
    )


@dataclass(frozen=True, slots=True)
class LocalSolution:
    """What Leapfrog keeps of a local two-point problem (see :class:`LocalShooter`)."""

    status: RootStatus
    costate0: np.ndarray  # lambda(t0) of the last iterate
    costate1: np.ndarray  # lambda(t1) of the extremal (NaN unless success)
    cost: float  # of the extremal (NaN unless success)
    iterations: int
    f_evals: int

    @property
    def success(self) -> bool:
        return self.status is RootStatus.CONVERGED

    @classmethod
    def failure(cls, status: RootStatus, costate0, iterations: int = 0, f_evals: int = 0):
        """A failed local problem: ``status`` says how, ``costate0`` is its last iterate."""
        costate0 = np.asarray(costate0, dtype=float)
        nan = np.full(costate0.size, np.nan)
        return cls(status, costate0, nan, float("nan"), int(iterations), int(f_evals))


class LocalShooter:
    """Simple shooting for many small two-point problems with one flow, one method and one set
    of settings: Leapfrog solves hundreds per run, most of them in a few iterations, where the
    packaging of :func:`solve_shooting` (result objects, messages, checks of the ends) cost as
    much as the compiled loop itself (measured: 121 -> 83 us for a 3-iteration local solve of
    paper case 4). The compiled loop is called directly with its arguments packed once; the
    iterates, statuses, iterations and evaluations are those of :func:`solve_shooting`, bit for
    bit (tested). Its solves predict convergence (RootSettings.predict: the Jacobian is dropped
    where it would not be used), in the compiled loop and in the Python loop alike (methods the
    compiled loop does not fuse, or while it compiles, go through :func:`solve_shooting`).

    Not thread-safe: it reuses its history buffers (Leapfrog builds one per run).
    """

    def __init__(
        self, problem: OptimalControlProblem, flow: Flow, settings: ShootingSettings, method=None
    ):
        self.problem, self.flow, self.settings, self.method = problem, flow, settings, method
        self.strategy = get_strategy(method or settings.method)
        self._fused = settings.compiled and runs_compiled(flow, self.strategy)
        root = replace(settings.root, predict=True)
        self._plain = replace(settings, samples=0, root=root)  # for solve_shooting (not fused)
        if self._fused:
            m = root.max_iterations
            self._solver = compiled_solver(flow, self.strategy, root, settings.inexact)
            self._history = History(np.empty(m + 1), np.empty(m))
        self._newton = None  # shoot_newton's entry point, bound on the first call
        self._nx = problem.model.nx

    def __call__(self, t0: float, x0, t1: float, x1, guess=None) -> LocalSolution:
        """The local problem from ``(t0, x0)`` to ``(t1, x1)`` from the costate ``guess``, or
        from the affine guess when it is None. A converged iterate whose end cannot be
        integrated again (never seen: the loop's last evaluation is at that iterate) counts as
        a failure."""
        x0 = np.ascontiguousarray(x0, dtype=float).reshape(-1)
        x1 = np.ascontiguousarray(x1, dtype=float).reshape(-1)
        if guess is None:
            guess = affine_costate_guess(self.problem, t0, x0, t1, x1, flow=self.flow)
        s0 = np.array(guess, dtype=float).reshape(-1)
        if not self._fused:
            r = solve_shooting(
                self.problem, t0, x0, t1, x1, method=self.strategy, guess=s0,
                settings=self._plain, flow=self.flow,
            )  # fmt: skip
            if not (r.success and np.isfinite(r.cost)):
                status = r.status if not r.success else RootStatus.NON_FINITE
                return LocalSolution.failure(status, r.costate0, r.root.iterations, r.root.f_evals)
            return LocalSolution(
                r.status, r.costate0, r.costate1, r.cost, r.root.iterations, r.root.f_evals
            )
        out = self._loop(Ends.of(x0, x1, [t0, t1]), s0)
        x, its, evals, (last_s, Y, last_ok) = out.x, out.iterations, out.f_evals, out.last
        nx = self._nx
        if out.code != _CONVERGED:
            return LocalSolution.failure(_CODES[out.code], x, its, evals)
        if not (last_ok and (last_s == x).all()):  # as shooting_result: the end of x itself
            r = self.flow(t0, np.concatenate([x0, x]), t1)
            if r.status != FlowStatus.OK:
                return LocalSolution.failure(RootStatus.NON_FINITE, x, its, evals)
            Y = np.concatenate([r.z, [r.cost]])
        lam1, cost = Y[nx : 2 * nx].copy(), float(Y[2 * nx])
        return LocalSolution(RootStatus.CONVERGED, x, lam1, cost, int(its), int(evals))

    @property
    def fused(self) -> bool:
        """Whether the compiled loop runs this shooter's solves (and :meth:`warm_sweep` works)."""
        return self._fused

    def warm_sweep(self, T, X, L0, L1, C, i: int) -> SweepOutcome:
        """Leapfrog's sweep from junction ``i`` over the arcs ``(T, X, L0, L1, C)`` (in place),
        as long as each local problem converges from its warm guess: the model kernels'
        ``sweep_warm``."""
        arcs = Arcs(T, X, L0, L1, C)
        return self.flow.kernels.sweep_warm(
            arcs, i, self._solver, self.flow.dynamics, self._history
        )

    def _loop(self, ends: Ends, s0) -> NewtonOutcome:
        """The compiled loop (a method of its own so that the profiler can time it: see
        :mod:`.profiling`). ``__call__`` builds its arguments with the same types every time,
        so it is called through its entry point."""
        args = (ends, s0, self._solver, self.flow.dynamics, self._history)
        if self._newton is None:
            self._newton = entry_point(self.flow.kernels.shoot_newton, args)
        return self._newton(*args)


_CONVERGED = _CODES.index(RootStatus.CONVERGED)


def runs_compiled(flow: Flow, strategy) -> bool:
    """Whether :func:`compiled_newton` runs ``strategy`` on systems of ``flow``: a method it
    fuses, an adaptive integrator, and the loops compiled (:func:`loops_ready`)."""
    return flow.tableau.adaptive and type(strategy) in _FUSED and loops_ready(flow)


#: Kernel modules whose compiled loops are loaded: asked once, never again.
_READY: set[str] = set()
#: When the disk cache is to be asked again about a module's loops (time.monotonic()): not on
#: every local solve while they compile.
_NEXT_LOOK: dict[str, float] = {}
#: Kernel modules whose loops this process has had compiled in the background: once, so that a
#: background compile that keeps failing is not started again every few seconds.
_STARTED: set[str] = set()
LOOK_EVERY_S = 2.0


def loops_ready(flow: Flow) -> bool:
    """Whether the compiled Newton loops of ``flow``'s model are loaded or in the disk cache.
    Where they are not (a fresh machine), a built-in model's are compiled in a process of
    their own (see :mod:`..compiled.background`) and this answers False until they are there:
    the caller runs the Python loop, whose iterates are the same bit for bit. A model of the
    user's, or ``LEAPFROG_COMPILE_IN_BACKGROUND=0``: True (the loops compile when first run)."""
    K = flow.kernels
    if K.__name__ in _READY:
        return True
    model = flow.problem.model.definition
    if not (background.in_background() and isinstance(model, str)):
        return True
    now = time.monotonic()
    if now < _NEXT_LOOK.get(K.__name__, 0.0):
        return False
    _NEXT_LOOK[K.__name__] = now + LOOK_EVERY_S
    if loops_cached(flow):
        _READY.add(K.__name__)
        background.finished(K)
        return True
    if K.__name__ not in _STARTED:
        _STARTED.add(K.__name__)
        background.start(model, K)
    return False


def loops_cached(flow: Flow) -> bool:
    """Whether the compiled Newton loops of ``flow``'s model are loaded or in the disk cache
    (loaded from it if so): a look that compiles nothing and starts nothing."""
    return all(cached_entry_point(k, a) is not None for k, a in typical_loop_calls(flow))


def typical_loop_calls(flow: Flow) -> list[tuple]:
    """``(kernel, arguments)`` of a call of each compiled loop, with the types of every call
    (a record's fields have fixed types: see :func:`compiled_solver`)."""
    nx, m = flow.nx, RootSettings().max_iterations
    solver = compiled_solver(flow, NewtonStep(), RootSettings(), False)
    history = History(np.empty(m + 1), np.empty(m))
    zeros = np.zeros(nx)
    ends = Ends.of(zeros, zeros, [0.0, 1.0])
    arcs = Arcs(np.zeros(2), np.zeros((2, nx)), np.zeros((1, nx)), np.zeros((1, nx)), np.zeros(1))
    K = flow.kernels
    return [
        (K.shoot_newton, (ends, zeros.copy(), solver, flow.dynamics, history)),
        (K.sweep_warm, (arcs, 0, solver, flow.dynamics, history)),
    ]


def compiled_newton(
    system, s0, strategy, settings: RootSettings
) -> tuple[RootResult, tuple | None, int]:
    """NM, MNM or NLEQ-ERR in one compiled call (``shoot_newton`` of the model's kernels) on a
    :class:`ShootingSystem` or a multiple-shooting system (``MultipleShootingSystem``): the
    same iterates, bit for bit, statuses and counts as :func:`solve_root` with that strategy on
    ``system`` (tested), without the Python layers per iteration. The system gives its flow,
    its ``ends = (x0, x1, junction times)`` and whether it evaluates ``inexact``ly.

    Returns the root result, the latest evaluation ``(s, FlowResult)`` (of the last arc) and the
    accepted integrator steps of all evaluations."""
    flow = system.flow
    m = settings.max_iterations
    norms, lams = np.empty(m + 1), np.empty(m)
    s0 = np.array(s0, dtype=float).reshape(-1)
    solver = compiled_solver(flow, strategy, settings, system.inexact)
    out = flow.kernels.shoot_newton(system.ends, s0, solver, flow.dynamics, History(norms, lams))
    x, F, its, evals, n, cond = out.x, out.F, out.iterations, out.f_evals, out.n_norms, out.cond
    last_s, last_Y, last_ok = out.last
    status = _CODES[out.code]
    norms = norms[:n].copy()
    if status is RootStatus.CONVERGED:
        msg = messages.converged(norms[-1], settings.tol, its)
    elif status is RootStatus.MAX_ITERATIONS:
        msg = messages.max_iterations(norms[-1], m)
    elif status is RootStatus.STALLED:
        msg = messages.stalled(norms[-1], settings.stall_factor, settings.stall_window)
    elif status is RootStatus.SINGULAR_JACOBIAN:
        msg = messages.singular(cond, settings.max_cond)
    elif status is RootStatus.LINE_SEARCH_FAILED:
        msg = strategy.failure_message
    elif status is RootStatus.DIVERGED:
        msg = messages.diverged(vnorm(x), settings.divergence * (1.0 + vnorm(s0)))
    else:  # non-finite
        F = np.full(x.shape, np.nan)
        msg = messages.non_finite(its)
    root = RootResult(
        x=x, F=F, status=status, message=msg, iterations=int(its), f_evals=int(evals),
        jac_evals=int(out.jacobians), residual_norms=norms, step_sizes=lams[:its].copy(),
    )  # fmt: skip
    last = None
    if last_ok:
        nz = 2 * system.nx
        times = system.ends.times
        r = FlowResult(
            status=FlowStatus.OK, t0=float(times[-2]), t1=float(times[-1]), z=last_Y[:nz],
            cost=float(last_Y[nz]),
            sensitivity=None, steps=0, rejected=0,  # not counted by the compiled loop
        )  # fmt: skip
        last = (last_s, r)
    return root, last, int(out.steps)


def shooting_result(
    flow: Flow, t0, x0, t1, x1, root: RootResult, samples: int, last=None
) -> ShootingResult:
    """Package a root result with cost, trajectory and optimality checks.

    The flow is integrated once more when a dense trajectory is wanted; otherwise ``last``, the
    solver's own final evaluation ``(s, FlowResult)``, is reused when it was at ``root.x``.
    """
    nx = x0.size
    # (Element lists compare exactly, as np.array_equal does, at a fraction of its cost: Leapfrog
    # packages thousands of local solves.)
    if not samples and last is not None and last[0].tolist() == root.x.tolist():
        r = last[1]
    else:
        r = flow(t0, np.concatenate([x0, root.x]), t1, samples=samples)
    traj = r.trajectory
    ok = r.status == FlowStatus.OK
    if traj is not None:
        max_dH_du = float(np.abs(traj.dH_du).max())
        H = traj.hamiltonian[traj.at_step]  # interpolated rows carry interpolation error
        Hvar = float(np.abs(H - H[0]).max())
    else:
        max_dH_du = Hvar = float("nan")
    return ShootingResult(
        status=root.status,
        message=root.message,
        t0=float(t0),
        t1=float(t1),
        x0=x0,
        x1=x1,
        costate0=root.x.copy(),
        costate1=r.z[nx:].copy() if ok else np.full(nx, np.nan),
        cost=r.cost if ok else float("nan"),
        end_state_error=vnorm(r.z[:nx] - x1) if ok else float("inf"),
        max_dH_du=max_dH_du,
        hamiltonian_variation=Hvar,
        trajectory=traj,
        root=root,
    )
