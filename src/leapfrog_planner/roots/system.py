"""What a root solver needs from a problem: ``F(x)``, optionally with its Jacobian."""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

import numpy as np


class RootSystem(Protocol):
    def evaluate(
        self, x: np.ndarray, jacobian: bool
    ) -> tuple[np.ndarray | None, np.ndarray | None]:
        """``(F(x), DF(x) or None)``; ``F`` is ``None`` where it cannot be evaluated (e.g. the
        integrator blew up)."""


class FunctionSystem:
    """A root system from plain callables ``fun(x)`` and ``jac(x)``."""

    def __init__(self, fun: Callable, jac: Callable):
        self.fun = fun
        self.jac = jac

    def evaluate(self, x, jacobian):
        F = np.atleast_1d(np.asarray(self.fun(x), dtype=float))
        if not np.all(np.isfinite(F)):
            return None, None
        return F, (np.atleast_2d(np.asarray(self.jac(x), dtype=float)) if jacobian else None)
