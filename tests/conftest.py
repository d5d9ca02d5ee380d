"""Shared data and helpers for the tests of the numerical core.

The four paper cases are those of spec section 5 (all with ``T = 1``, ``W = 100``, ``n = 2``),
typed in here from the spec rather than read from the package, so that the tests check the
package against the spec and not against itself.
"""

from __future__ import annotations

import math
import os

# The suite compiles a model's Newton loops where it first needs them, as before the loops
# were compiled in a background process on a fresh machine: a test of the compiled loop must
# run it (tests/test_background_compile.py tests the background).
os.environ["LEAPFROG_COMPILE_IN_BACKGROUND"] = "0"
from dataclasses import dataclass

import numpy as np
import pytest
from hypothesis import settings

from leapfrog_planner import OptimalControlProblem

PI = math.pi


@dataclass(frozen=True)
class PaperCase:
    name: str
    start: np.ndarray
    goal: np.ndarray
    obstacles: np.ndarray  # (m, 3) rows [cx, cy, r]
    reference_cost: float  # spec section 5, about 1e-5 relative

    def problem(self, model: str = "unicycle", **kw) -> OptimalControlProblem:
        return OptimalControlProblem.create(model, self.obstacles, **kw)


def _case(name, start, goal, obstacles, cost) -> PaperCase:
    obs = np.asarray(obstacles, dtype=float).reshape(-1, 3)
    return PaperCase(name, np.array(start, float), np.array(goal, float), obs, cost)


CASES = {
    1: _case("paper-case-1", [-1.0, 2.0, PI / 2], [1.0, 2.0, PI / 2], [], 10.32320),
    2: _case(
        "paper-case-2",
        [0.0, 0.0, 0.0],
        [3.5, 3.5, 0.0],
        [[1.0, 1.2, 0.5], [2.5, 2.2, 0.5]],
        21.20621,
    ),
    3: _case(
        "paper-case-3",
        [0.0, 0.0, PI / 4],
        [1.0, 1.0, PI / 4],
        [[0.5, 0.5, 0.15], [0.2, 0.6, 0.1], [0.75, 0.3, 0.1]],
        3.274137,
    ),
    4: _case(
        "paper-case-4",
        [0.0, 0.0, 0.0],
        [2.0, 0.0, 0.0],
        [
            [0.4, 0.05, 0.1],
            [0.7, -0.15, 0.1],
            [1.0, 0.1, 0.1],
            [1.3, -0.1, 0.1],
            [1.6, 0.12, 0.1],
            [0.9, 0.4, 0.1],
            [1.2, -0.45, 0.1],
        ],
        5.663875,
    ),
}

# Costate guesses lambda(0) from which simple shooting reaches the spec's reference optimum.
# Case 1: the spec's hint (-4.676, 3.213, 3.213). Case 4: found by fitting lambda(0) to the
# controls of the direct solution (solve_direct, N = 400, straight-line start): along the given
# path the costate equations are linear in lambda(0), and v = -(l1 cos th + l2 sin th),
# omega = -l3 then give an overdetermined linear system; its least-squares solution,
# (1.0206, 11.6949, 1.5970), rounded to 2 decimals, is the guess below.
GOOD_GUESS = {1: np.array([-4.676, 3.213, 3.213]), 4: np.array([1.02, 11.69, 1.6])}
# The extremals those guesses converge to (shooting at the default tolerances, |F| < 1e-10).
EXTREMAL_COSTATE = {
    1: np.array([-4.67610985, 3.21297400, 3.21297400]),
    4: np.array([1.01738205, 11.69114489, 1.59786914]),
}


def rel_err(a, b) -> float:
    """Max-norm error of ``a`` relative to the max-norm of ``b``."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


def fd_jacobian(fun, x, delta: float) -> np.ndarray:
    """Fourth-order central differences (5-point stencil) of a vector function, column by column.

    Truncation error O(delta^4), rounding O(eps / delta): with delta ~ 1e-6 both are far below
    the 1e-6 relative agreement the tests ask for, even on sensitive flows where plain central
    differences (O(delta^2)) would need a delta so small that rounding takes over.
    """
    x = np.asarray(x, dtype=float)
    cols = []
    for j in range(x.size):
        e = np.zeros_like(x)
        e[j] = delta
        f2, f1, m1, m2 = (np.asarray(fun(x + c * e), float) for c in (2, 1, -1, -2))
        cols.append((-f2 + 8.0 * f1 - 8.0 * m1 + m2) / (12.0 * delta))
    return np.column_stack(cols)


def double_integrator_model():
    """A linear 3-state test model: ``x1' = x3``, ``x2' = u2``, ``x3' = u1``, ``L = |u|^2 / 2``.

    The first two states play the role of the position (the penalty would act on them); with no
    obstacles the canonical system is linear and has the closed form derived in
    ``test_shooting.test_double_integrator_closed_form``.
    """
    import sympy as sp

    from leapfrog_planner import VehicleModel

    x1, x2, x3 = sp.symbols("x1 x2 x3", real=True)
    u1, u2 = sp.symbols("u1 u2", real=True)
    return VehicleModel(
        name="test-double-integrator",
        states=(x1, x2, x3),
        controls=(u1, u2),
        dynamics=(x3, u2, u1),
        running_cost=(u1**2 + u2**2) / 2,
        description="test model: double integrator in x1 plus a single integrator in x2",
    )


@pytest.fixture(scope="session")
def double_integrator():
    return double_integrator_model()


# Hypothesis: no example database; examples are derandomised so that every run of the suite
# checks the same points (and a failure is reproduced by simply running it again).
settings.register_profile("leapfrog", database=None, derandomize=True, deadline=None)
settings.load_profile("leapfrog")


@pytest.fixture(scope="session")
def extremal():
    """``extremal(case)``: the ShootingResult of a paper case from its good guess (cached)."""
    from leapfrog_planner.bvp.shooting import solve_shooting

    cache = {}

    def get(case: int):
        if case not in cache:
            c = CASES[case]
            r = solve_shooting(c.problem(), 0.0, c.start, 1.0, c.goal, guess=GOOD_GUESS[case])
            assert r.success, r.message
            cache[case] = r
        return cache[case]

    return get
