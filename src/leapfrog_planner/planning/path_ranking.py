"""Rank initial paths by an estimate of their cost before any shooting.

The initial path decides which local optimum Leapfrog finds, and length predicts that badly: a
short path that squeezes through a gap pays penalty, one whose smoothed curve turns sharply pays
control energy. Following the path at constant speed over the horizon gives a feasible motion
whose cost is cheap to evaluate and ranks the local optima well (paper cases 3 and 4: the
cheapest estimates lead to the cheapest optima, which the shortest paths miss).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..integrate.flow import Trajectory
from ..integrate.problem import OptimalControlProblem
from .initial_path import InitialPath

if TYPE_CHECKING:
    from .scenario import Scenario


def estimated_cost(
    problem: OptimalControlProblem, path: InitialPath, horizon: float, samples: int = 201
) -> float:
    """Cost of following ``path`` at constant speed over ``horizon``.

    The controls at each sample are the least-squares solution of ``f(x, u) = xdot`` (exact for
    the built-in models, which are affine in ``u``), charged ``1/2 u^T R u`` with ``R = d2L/du2``
    (their control cost is quadratic); the obstacle penalty is added, and the trapezoidal rule
    integrates both.
    """
    return float(estimated_costs(problem, [path], horizon, samples)[0])


def estimated_costs(
    problem: OptimalControlProblem,
    paths: list[InitialPath],
    horizon: float,
    samples: int = 201,
    ends=None,
) -> np.ndarray:
    """:func:`estimated_cost` of each path, as an array.

    The paths go through each step together: every step acts row by row (per sample, or per
    path for the sums), so the costs are exactly those of separate calls, and the fixed costs of
    the NumPy calls are paid once, not once per path. ``ends`` (the full start and goal
    states) fill a model's further states (see :func:`path_states`).
    """
    t, X, u, R = _followed(problem, paths, horizon, samples, ends)
    energy = 0.5 * np.einsum("kni,knij,knj->kn", u, R, u)
    running = energy + problem.penalty(X[:, :, :2])
    return np.sum(0.5 * (running[:, 1:] + running[:, :-1]) * np.diff(t), axis=1)  # trapezoid


def _followed(problem, paths, horizon, samples, ends):
    """Times ``(samples,)``, and per path the states ``(samples, nx)``, the controls
    ``(samples, nu)`` that follow it (least squares of ``f(x, u) = xdot``) and the control cost
    Hessians ``R``, for all paths at once."""
    s = np.linspace(0.0, 1.0, samples)
    t = s * horizon
    model = problem.model
    K = model.kernels
    p = np.asarray(problem.parameters, dtype=float)
    nx, nu = model.nx, model.nu
    X = np.empty((len(paths), samples, nx))
    for k, path in enumerate(paths):
        X[k] = path_states(path, s, ends)
    Xdot = np.gradient(X, t, axis=1)
    n = X.shape[0] * samples
    f = np.empty((n, nx))
    A = np.empty((n, nx, nx))
    B = np.empty((n, nx, nu))
    R = np.empty((n, nu, nu))
    K.linearize_rows(X.reshape(n, nx), np.zeros(nu), p, f, A, B, R)
    r = Xdot.reshape(n, nx) - f
    Bt = np.swapaxes(B, 1, 2)
    u = np.linalg.solve(Bt @ B, (Bt @ r[..., None]))[..., 0]  # least squares, all samples
    shape = (len(paths), samples)
    return t, X, u.reshape(*shape, nu), R.reshape(*shape, nu, nu)


def drivable(
    problem: OptimalControlProblem,
    paths: list[InitialPath],
    horizon: float,
    bounds: dict[str, tuple[float, float]],
    ends=None,
    samples: int = 201,
) -> list[bool]:
    """Per path: whether the controls that follow it keep the signs the ``bounds`` (control
    name: ``(lo, hi)``) allow. A robot that cannot reverse (``v = [0, vmax]``) cannot follow a
    path driven backwards or a three-point turn, however it is timed: such a path leads Leapfrog
    to an extremal that the continuation to the bounds loses (measured on random layouts with
    any headings: the cheapest optimum lost on 8 of 50). Magnitudes are not judged: a slower or
    faster clock changes them, a sign it does not."""
    if not bounds or not paths:
        return [True] * len(paths)
    u = _followed(problem, paths, horizon, samples, ends)[2]
    names = problem.model.controls
    ok = np.ones(len(paths), dtype=bool)
    for c, (lo, hi) in bounds.items():
        uc = u[:, :, names.index(c)]
        tol = _SIGN_TOLERANCE * (hi - lo)
        if lo >= 0.0:
            ok &= uc.min(axis=1) >= -tol
        if hi <= 0.0:
            ok &= uc.max(axis=1) <= tol
    return ok.tolist()


#: A control counts as of the wrong sign beyond this share of its bounds' range.
_SIGN_TOLERANCE = 1e-3


def path_states(path: InitialPath, s: np.ndarray, ends=None) -> np.ndarray:
    """The states along ``path`` at normalised times ``s``: its poses ``(x, y, heading)`` and,
    given the full end ``states`` (start, goal) of a model with more, the further states (the
    car's steering angle) moving linearly from their start to their goal values."""
    xy, th = path.curve(s)
    X = np.column_stack([xy, th])
    if ends is None or len(ends[0]) == 3:
        return X
    a, b = np.asarray(ends[0][3:], dtype=float), np.asarray(ends[1][3:], dtype=float)
    return np.column_stack([X, a[None, :] + np.asarray(s)[:, None] * (b - a)[None, :]])


def rank_paths(
    problem: OptimalControlProblem, paths: list[InitialPath], horizon: float, ends=None
) -> list[tuple[float, InitialPath]]:
    """``(estimated cost, path)`` sorted cheapest first (ties keep the given order)."""
    costs = estimated_costs(problem, paths, horizon, ends=ends).tolist()
    order = sorted(range(len(paths)), key=lambda i: costs[i])
    return [(costs[i], paths[i]) for i in order]


class PathGuide:
    """An initial path followed over ``[t0, t0 + horizon]`` as :meth:`InitialPath.curve` times
    it: the state at any time, and the costate whose minimising control follows the path there.

    Leapfrog takes both from it: the states split a segment whose two-point problem fails, the
    costates start the segments' shooting. The control is the least-squares solution of
    ``f(x, u) = xdot`` (``xdot`` by a central difference in time), and the costate the
    minimum-norm solution of ``dH/du = 0`` for it, ``B^T lambda = -R u`` (exact for the built-in
    models, affine in ``u`` with a quadratic control cost). It knows the direction of travel, so
    it starts a reversing segment or a turn in place where the affine guess, which linearises
    about forward motion along the chord, does not.
    """

    def __init__(
        self, problem: OptimalControlProblem, path: InitialPath, horizon, t0=0.0, ends=None
    ):
        self.problem, self.path, self.ends = problem, path, ends
        self.t0, self.horizon = float(t0), float(horizon)

    def _poses(self, s: np.ndarray) -> np.ndarray:
        return path_states(self.path, s, self.ends)

    def state(self, t: float) -> np.ndarray:
        return self._poses(np.array([(t - self.t0) / self.horizon]))[0]

    def costate(self, t: float) -> np.ndarray:
        return self._costates(np.array([t]))[0]

    def _costates(self, t: np.ndarray) -> np.ndarray:
        """Costates at the times ``t`` (rows): each from the states a little before, at and a
        little after it (all of them evaluated and linearised at once), then two small
        least-squares solves."""
        n = len(t)
        s = (np.asarray(t, dtype=float) - self.t0) / self.horizon
        ds = _DIFFERENCE_STEP
        lo, at, hi = (
            np.maximum(0.0, s - ds),
            np.minimum(np.maximum(s, 0.0), 1.0),
            np.minimum(1.0, s + ds),
        )
        X = self._poses(np.concatenate([lo, at, hi]))
        xdot = (X[2 * n :] - X[:n]) / ((hi - lo) * self.horizon)[:, None]
        model = self.problem.model
        nx, nu = model.nx, model.nu
        f, A = np.empty((n, nx)), np.empty((n, nx, nx))
        B, R = np.empty((n, nx, nu)), np.empty((n, nu, nu))
        p = np.asarray(self.problem.parameters, dtype=float)
        model.kernels.linearize_rows(X[n : 2 * n], np.zeros(nu), p, f, A, B, R)
        lam = np.empty((n, nx))
        for k in range(n):
            u = np.linalg.lstsq(B[k], xdot[k] - f[k], rcond=None)[0]
            lam[k] = np.linalg.lstsq(B[k].T, -R[k] @ u, rcond=None)[0]
        return lam

    def trajectory(self, samples: int = 1001) -> Trajectory:
        """The path followed, sampled uniformly: a feasible motion, not an extremal (``dH_du``
        and the Hamiltonian are NaN); ``cost`` is the running cost integrated by the trapezoidal
        rule, as in :func:`estimated_costs`."""
        t = self.t0 + self.horizon * np.linspace(0.0, 1.0, samples)
        X = self._poses(np.linspace(0.0, 1.0, samples))
        lam = self._costates(t)
        model = self.problem.model
        nx, nu = model.nx, model.nu
        f, A = np.empty((samples, nx)), np.empty((samples, nx, nx))
        B, R = np.empty((samples, nx, nu)), np.empty((samples, nu, nu))
        p = np.asarray(self.problem.parameters, dtype=float)
        model.kernels.linearize_rows(X, np.zeros(nu), p, f, A, B, R)
        u = -np.linalg.solve(R, np.einsum("nij,ni->nj", B, lam)[..., None])[..., 0]
        running = 0.5 * np.einsum("ni,nij,nj->n", u, R, u) + self.problem.penalty(X[:, :2])
        cost = np.concatenate(([0.0], np.cumsum(0.5 * (running[1:] + running[:-1]) * np.diff(t))))
        nan = np.full(samples, np.nan)
        return Trajectory(
            t=t, x=X, lam=lam, u=u, cost=cost, hamiltonian=nan,
            dH_du=np.full((samples, nu), np.nan), at_step=np.zeros(samples, dtype=bool),
        )  # fmt: skip


#: Step in normalised time of the central difference of :meth:`PathGuide.costate`.
_DIFFERENCE_STEP = 1e-4


def penalty_timed(
    problem: OptimalControlProblem, path: InitialPath, horizon: float, samples: int = 2001
) -> InitialPath:
    """``path`` with its time shared by the penalty: followed at the speed that is optimal for
    its own geometry. Along a fixed curve, ``int (v^2 / 2 + P) dt`` in a fixed time is least when
    ``v^2 / 2 - P`` is constant (Beltrami's identity), so the robot hurries where the penalty is
    high (next to an obstacle it starts beside) and slows where it is low. ``v`` is the speed in
    the unicycle's metric (a turn in place counts its radians as path), the constant is found by
    bisection so that the whole path takes ``horizon``."""
    u = np.linspace(0.0, 1.0, samples)
    xy, th = path.curve(u)
    plane = np.hypot(np.diff(xy[:, 0]), np.diff(xy[:, 1]))
    step = np.where(plane > 1e-9 * plane.sum(), plane, np.abs(np.diff(th)))  # drive, or turn
    P = problem.penalty(0.5 * (xy[1:] + xy[:-1]))
    if not step.sum() > 0.0 or not np.all(np.isfinite(P)):
        return path

    def duration(c: float) -> np.ndarray:
        return np.cumsum(step / np.sqrt(2.0 * (P + c)))

    lo, hi = -P.min() + 1e-300, 1.0
    while duration(hi)[-1] > horizon:  # faster until the path takes no more than the horizon
        hi *= 4.0
    for _ in range(200):  # the duration falls as c grows
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if duration(mid)[-1] > horizon else (lo, mid)
    t = np.concatenate(([0.0], duration(hi)))
    sigma = np.interp(np.linspace(0.0, t[-1], samples), t, u)
    sigma[0], sigma[-1] = 0.0, 1.0
    return path.retimed(sigma, f"{path.label}, penalty-timed")


#: The penalty-aware margin keeps the initial path where the penalty is at most this multiple of
#: the running energy of driving the straight line at constant speed over the horizon.
PENALTY_TO_ENERGY = 1.0


def penalty_margin(scenario: Scenario) -> float:
    """How far from an obstacle of mean radius ``r`` the penalty falls to the running energy.

    ``W exp(-(d / r)^(2n)) = c e`` at ``d = r ln(W / (c e))^(1/2n)`` with ``e = (L / T)^2 / 2``
    (``L`` the start-goal distance, at least the mean radius); the margin is ``d - r`` (0 when
    the penalty never exceeds ``c e``). Units of time enter the problem only through ``W T^2``
    (for control-affine models with a quadratic control cost, time scaling maps ``(T, W)`` to
    ``(1, W T^2)``), and so they do here.
    """
    radii = scenario.footprint_obstacles[:, 2].tolist()
    if scenario.map is not None:  # the map's length scale stands for its obstacles' radius
        radii.append(scenario.map.obstacles(scenario.robot_radius).length)
    if not radii or not scenario.weight > 0.0:
        return 0.0
    r = float(np.mean(radii))
    length = max(float(np.hypot(*(scenario.goal[:2] - scenario.start[:2]))), r)
    energy = 0.5 * (length / scenario.horizon) ** 2
    ratio = scenario.weight / (PENALTY_TO_ENERGY * energy)
    if not ratio > np.e:
        return 0.0
    return r * (np.log(ratio) ** (1.0 / (2 * scenario.exponent)) - 1.0)
