"""The Newton loop's status messages, shared by the Python loop and its compiled twin (the
shooting loop in the model kernels), so that both report the same words."""

from __future__ import annotations


def converged(norm: float, tol: float, iterations: int) -> str:
    return f"|F| = {norm:.3g} <= {tol:g} after {iterations} iterations"


def max_iterations(norm: float, iterations: int) -> str:
    return f"|F| = {norm:.3g} after {iterations} iterations"


def stalled(norm: float, factor: float, window: int) -> str:
    return (
        f"|F| = {norm:.3g} did not fall below {factor:g} times the largest of the last "
        f"{window} iterations"
    )


def singular(cond: float, max_cond: float) -> str:
    return f"cond(DF) = {cond:.3g} > {max_cond:g}"


def diverged(x_norm: float, bound: float) -> str:
    return f"|x| = {x_norm:.3g} left the bound {bound:.3g}"


def non_finite(after_step: int) -> str:
    """F not finite at the starting point (``after_step`` 0) or after that step."""
    if not after_step:
        return "F is not finite at the starting point"
    return f"F is not finite after step {after_step}"
