"""What Python and the compiled kernels exchange: typed records, and the status codes.

The compiled Newton loop (``shoot_newton``) and the warm sweep (``sweep_warm``) of a model's
kernels take their settings as the records below and return :class:`NewtonOutcome` and
:class:`SweepOutcome`; numba compiles them as named tuples, so both sides read fields by name.
The status codes are declared in :mod:`.status`.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


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
    rtol: float
    atol: float
    max_steps: int
    inexact: bool  # integrate loosely while |F| is large (ShootingSettings.inexact)
    nx: int


class Dynamics(NamedTuple):
    """The integrator's tableau and the problem's data."""

    A: np.ndarray
    b: np.ndarray
    e: np.ndarray
    e3: np.ndarray
    error_order: int
    parameters: np.ndarray
    obstacles: object  # model.penalty.ObstacleGrid (or a plain (m, 3) array)
    weight: float
    exponent: int
    no_T: np.ndarray  # empty arrays of the right types (see Flow)
    no_Z: np.ndarray


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
