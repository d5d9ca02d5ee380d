"""Explicit Runge-Kutta methods, each just its Butcher tableau.

The embedded pairs take their coefficients from SciPy's ``solve_ivp`` implementations rather
than retyping them: Dormand-Prince 5(4) (``RK45``) and Dormand-Prince 8(5,3) (``DOP853``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.integrate import DOP853 as _DOP853
from scipy.integrate import RK45 as _RK45

from ..errors import SettingsError


@dataclass(frozen=True, eq=False)
class ButcherTableau:
    name: str
    A: np.ndarray  # (s, s), strictly lower triangular
    b: np.ndarray  # (s,) weights of the propagated solution
    c: np.ndarray  # (s,) nodes
    order: int
    error_order: int = 0  # order of the embedded error estimate; 0 for fixed-step methods
    e: np.ndarray | None = None  # (s + 1,) error weights, last one on f(y_new)
    e3: np.ndarray | None = None  # (s + 1,) DOP853's third-order error weights

    @property
    def adaptive(self) -> bool:
        return self.e is not None

    @property
    def stages(self) -> int:
        return self.b.size


def _arr(a):
    return np.ascontiguousarray(a, dtype=np.float64)


def _square(a):
    """SciPy stores RK45's A without its (zero) last column."""
    a = _arr(a)
    return np.ascontiguousarray(np.pad(a, ((0, 0), (0, a.shape[0] - a.shape[1]))))


RK4 = ButcherTableau(
    name="rk4",
    A=_arr([[0, 0, 0, 0], [0.5, 0, 0, 0], [0, 0.5, 0, 0], [0, 0, 1, 0]]),
    b=_arr([1 / 6, 1 / 3, 1 / 3, 1 / 6]),
    c=_arr([0, 0.5, 0.5, 1]),
    order=4,
)

DP5 = ButcherTableau(
    name="dp5",
    A=_square(_RK45.A),
    b=_arr(_RK45.B),
    c=_arr(_RK45.C),
    order=_RK45.order,
    error_order=_RK45.error_estimator_order,
    e=_arr(_RK45.E),
)

DOP853 = ButcherTableau(
    name="dop853",
    A=_square(_DOP853.A),
    b=_arr(_DOP853.B),
    c=_arr(_DOP853.C),
    order=_DOP853.order,
    error_order=_DOP853.error_estimator_order,
    e=_arr(_DOP853.E5),
    e3=_arr(_DOP853.E3),
)

TABLEAUX: dict[str, ButcherTableau] = {t.name: t for t in (RK4, DP5, DOP853)}


def get_tableau(name: str) -> ButcherTableau:
    try:
        return TABLEAUX[name]
    except KeyError:
        raise SettingsError(f"unknown integrator {name!r} (known: {', '.join(TABLEAUX)})") from None
