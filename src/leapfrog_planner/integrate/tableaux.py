"""Explicit Runge-Kutta methods, each just its Butcher tableau.

The embedded pairs take their coefficients from SciPy's ``solve_ivp`` implementations rather
than retyping them: Dormand-Prince 5(4) (``RK45``) and Dormand-Prince 8(5,3) (``DOP853``).
Importing ``scipy.integrate`` costs about half a second of start-up, so the coefficients are
copied once into the user's cache directory (keyed by SciPy's version) and read from there.
"""

from __future__ import annotations

import logging
import zipfile
from dataclasses import dataclass
from functools import cache, lru_cache

import numpy as np
import scipy

from .._atomic import write_atomic
from .._cache import cache_dir
from ..compiled.abi import Tableau
from ..errors import SettingsError

log = logging.getLogger(__name__)


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

    def record(self) -> Tableau:
        """The tableau as the compiled kernels read it (empty error weights where it has none)."""
        none = np.zeros(0)
        e3 = none if self.e3 is None else self.e3
        return Tableau(self.A, self.b, none if self.e is None else self.e, e3, self.error_order)


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


def _from_scipy() -> dict[str, np.ndarray]:
    from scipy.integrate import DOP853, RK45

    return {
        "dp5_A": _square(RK45.A), "dp5_b": _arr(RK45.B), "dp5_c": _arr(RK45.C),
        "dp5_e": _arr(RK45.E), "dp5_orders": _arr([RK45.order, RK45.error_estimator_order]),
        "dop853_A": _square(DOP853.A), "dop853_b": _arr(DOP853.B), "dop853_c": _arr(DOP853.C),
        "dop853_e": _arr(DOP853.E5), "dop853_e3": _arr(DOP853.E3),
        "dop853_orders": _arr([DOP853.order, DOP853.error_estimator_order]),
    }  # fmt: skip


_KEYS = {f"{m}_{k}" for m in ("dp5", "dop853") for k in ("A", "b", "c", "e", "orders")} | {
    "dop853_e3"
}


@lru_cache(maxsize=1)
def _coefficients() -> dict[str, np.ndarray]:
    path = cache_dir() / f"tableaux-scipy-{scipy.__version__}.npz"
    try:
        with np.load(path) as f:
            cached = {k: _arr(f[k]) for k in f.files}
        if set(cached) >= _KEYS:
            return cached
    except (FileNotFoundError, NotADirectoryError):  # not built yet, or no cache folder
        pass
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile) as exc:
        log.warning(
            "warning: damaged cache file %s (%s): rebuilding it", path.name, type(exc).__name__
        )
    data = _from_scipy()
    try:
        path.parent.mkdir(parents=True, exist_ok=True)

        def write(tmp):
            with open(tmp, "wb") as fh:
                np.savez(fh, **data)

        write_atomic(path, write)
    except OSError:  # a read-only cache costs start-up time, nothing else
        pass
    return data


@cache
def _embedded(name: str) -> ButcherTableau:
    k = _coefficients()
    order, error_order = (int(v) for v in k[f"{name}_orders"])
    return ButcherTableau(
        name=name, A=k[f"{name}_A"], b=k[f"{name}_b"], c=k[f"{name}_c"], order=order,
        error_order=error_order, e=k[f"{name}_e"], e3=k.get(f"{name}_e3"),
    )  # fmt: skip


TABLEAUX = ("rk4", "dp5", "dop853")


def get_tableau(name: str) -> ButcherTableau:
    if name == "rk4":
        return RK4
    if name in TABLEAUX:
        return _embedded(name)
    raise SettingsError(f"unknown integrator {name!r} (known: {', '.join(TABLEAUX)})")
