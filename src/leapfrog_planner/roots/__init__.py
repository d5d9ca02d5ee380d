"""Newton-type root solvers: one loop, interchangeable step strategies."""

from ..compiled.status import RootStatus
from .least_squares import solve_least_squares
from .loop import RootSettings, solve_root
from .result import RootResult
from .steps import STRATEGIES, ModifiedNewtonStep, NewtonStep, NleqErrStep, get_strategy
from .system import FunctionSystem, RootSystem

__all__ = [
    "STRATEGIES",
    "FunctionSystem",
    "ModifiedNewtonStep",
    "NewtonStep",
    "NleqErrStep",
    "RootResult",
    "RootSettings",
    "RootStatus",
    "RootSystem",
    "get_strategy",
    "solve_least_squares",
    "solve_root",
]
