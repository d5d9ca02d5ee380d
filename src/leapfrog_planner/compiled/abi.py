"""What Python and the compiled kernels exchange: typed records.

numba compiles these as named tuples, so both sides read fields by name, and a kernel's
signature is a few records instead of a long list of positional arguments. As in diffrax, the
equation (:class:`Equation`), the stepping method (:class:`Tableau`: a Runge-Kutta method is
just its tableau) and the step-size controller (:class:`StepControl`) are apart:

- the integrator: ``erk_adaptive(Y0, t0, t1, k, dynamics, control, samples)`` and
  ``erk_fixed(Y0, t0, t1, k, dynamics, nsteps, samples)``, with :class:`Dynamics`,
  :class:`StepControl` and :class:`Samples`; ``along_path(Z, equation, U, H, dHdu)``;
- the Newton loop: ``shoot_newton(ends, s0, solver, dynamics, history)`` and
  ``sweep_warm(arcs, i, solver, dynamics, history)``, with :class:`Ends` (or :class:`Arcs`),
  :class:`Solver` and :class:`History`; they return :class:`NewtonOutcome` and
  :class:`SweepOutcome`.

:class:`Residual` and :class:`Iterate` are built and read inside the Newton loop only. A
kernel unpacks its records once: the functions it calls per step or per stage of the integrator
take the fields (see flow_template.py). The status codes are declared in :mod:`.status`.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

# -- The flow -----------------------------------------------------------------------------------


class Equation(NamedTuple):
    """The data of the canonical system (its code is the model's, compiled in): the model's
    parameters and the obstacle penalty."""

    parameters: np.ndarray
    obstacles: object  # model.penalty.ObstacleGrid (or a plain (m, 3) array)
    weight: float
    exponent: int


class Tableau(NamedTuple):
    """A Runge-Kutta method as the kernels read it (:class:`.integrate.tableaux.ButcherTableau`
    without its nodes: the system is autonomous)."""

    A: np.ndarray  # (s, s), strictly lower triangular
    b: np.ndarray  # (s,)
    e: np.ndarray  # (s + 1,) error weights, the last on f(y_new); empty for a fixed-step method
    e3: np.ndarray  # (s + 1,) DOP853's third-order error weights; empty for the others
    error_order: int  # 0 for a fixed-step method


class Samples(NamedTuple):
    """Where the integrator records ``(t, z, cost)`` at its steps: arrays with a row per step
    (and the initial point), or empty ones for no record."""

    T: np.ndarray  # (N,)
    Z: np.ndarray  # (N, NZ + 1)


class Dynamics(NamedTuple):
    """What a flow integrates, and by which method; the same record for the flow's own calls
    and for the Newton loop (:attr:`.integrate.flow.Flow.dynamics`)."""

    equation: Equation
    tableau: Tableau
    no_samples: Samples  # empty, of the right types: a call that records nothing


class StepControl(NamedTuple):
    """The adaptive step-size controller: tolerances on ``(z, cost)`` and the step budget."""

    rtol: float
    atol: float
    max_steps: int


# -- The Newton loop ----------------------------------------------------------------------------


class RootParams(NamedTuple):
    """:class:`.roots.RootSettings` as the compiled loop reads them."""

    tol: float
    max_iterations: int
    max_cond: float
    divergence: float
    stall_window: int
    stall_factor: float
    predict: bool  # evaluate F alone where convergence is predicted (see shoot_newton)


class StepParams(NamedTuple):
    """The step object's fields (zeros where the method has none)."""

    max_halvings: int
    initial_damping: float
    min_damping: float
    xtol: float
    max_trials: int


class Accuracy(NamedTuple):
    """How the loop integrates: the flow's controller, loosened while ``|F|`` is large where
    ``inexact`` (ShootingSettings.inexact), and ``k`` the sensitivity columns (= NX)."""

    control: StepControl
    inexact: bool
    k: int


class Solver(NamedTuple):
    """How ``shoot_newton`` solves: the method (0 Newton, 1 the modified Newton method, 2
    NLEQ-ERR) and its settings."""

    method: int
    root: RootParams
    step: StepParams
    accuracy: Accuracy


class History(NamedTuple):
    """Buffers for the loop's histories."""

    norms: np.ndarray  # (max_iterations + 1,) |F| of each iterate
    lams: np.ndarray  # (max_iterations,) damping factor of each step


class Ends(NamedTuple):
    """A boundary value problem's end states and junction times: ``(t0, t1)`` for simple
    shooting, ``t0 < t1 < ... < tq`` for multiple shooting."""

    x0: np.ndarray
    x1: np.ndarray
    times: np.ndarray

    @classmethod
    def of(cls, x0, x1, times) -> Ends:
        """Ends of writable, contiguous float copies: numba types an array by its flags too, and
        a read-only one (a scenario's end state) compiled the Newton loop a second time (23 s
        on the first plan with bounded controls, measured)."""
        return cls(*(np.array(a, dtype=float, order="C") for a in (x0, x1, times)))


class Arcs(NamedTuple):
    """Leapfrog's arcs, which ``sweep_warm`` updates in place: junction times ``T`` (q + 1,),
    states ``X`` (q + 1, NX), the costates at the start and end of each arc ``L0``, ``L1`` (q, NX)
    and the arcs' costs ``C`` (q,)."""

    T: np.ndarray
    X: np.ndarray
    L0: np.ndarray
    L1: np.ndarray
    C: np.ndarray


class Residual(NamedTuple):
    """What an evaluation of the shooting residual needs (built by ``shoot_newton``)."""

    ends: Ends
    accuracy: Accuracy
    dynamics: Dynamics
    # True, as a run-time bool: numba compiles the evaluation (and the flow below it) once per
    # argument type, and a literal True is a type of its own (measured: 6 s of compilation).
    jacobian: bool


class Iterate(NamedTuple):
    """A Newton iterate with its residual and Jacobian (zero where F was evaluated alone)."""

    x: np.ndarray
    F: np.ndarray
    J: np.ndarray


class NewtonOutcome(NamedTuple):
    """What ``shoot_newton`` returns."""

    code: int  # index in RootStatus
    x: np.ndarray  # the last iterate
    F: np.ndarray  # its residual
    iterations: int
    f_evals: int
    n_norms: int  # entries of the norms buffer filled
    cond: float  # of the last Jacobian
    last: tuple  # the latest evaluation: (s, Y, ok), Y = (z, cost) at the end of the last arc
    steps: int  # accepted integrator steps of all evaluations
    jacobians: int  # evaluations that carried the variational equations


class SweepOutcome(NamedTuple):
    """What ``sweep_warm`` returns."""

    code: int  # a SweepCode
    junction: int  # where it stopped (q when done)
    iterations: int
    f_evals: int
    rejected: int  # extremals dearer than the two arcs they would replace
    steps: int  # accepted integrator steps
    integrations: int
    jacobians: int  # integrations with the variational equations
