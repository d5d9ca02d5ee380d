"""Root-finding results: a frozen result with the iteration history, and its status (declared
with the compiled kernels' codes, in :mod:`..compiled.status`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..compiled.status import RootStatus


@dataclass(frozen=True)
class RootResult:
    x: np.ndarray  # last iterate (the solution when converged)
    F: np.ndarray  # residual at x
    status: RootStatus
    message: str
    iterations: int
    f_evals: int  # residual evaluations, with or without Jacobian
    jac_evals: int  # Jacobian evaluations
    residual_norms: np.ndarray  # |F| at each accepted iterate, starting with x0
    step_sizes: np.ndarray  # damping factor of each accepted step (1 for a full Newton step)

    @property
    def success(self) -> bool:
        return self.status is RootStatus.CONVERGED

    @property
    def residual_norm(self) -> float:
        return float(np.linalg.norm(self.F))
