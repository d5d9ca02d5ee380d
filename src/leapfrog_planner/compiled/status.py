"""The status codes that Python and the compiled kernels share, each declared once.

The kernels return integers: a :class:`FlowStatus` value from the integrator, an index in
:class:`RootStatus` from the Newton loop, a :class:`SweepCode` value from the warm sweep.
:func:`kernel_constants` writes them into each generated module, where numba folds them as
constants. Importing them loads neither numba nor SymPy.
"""

from __future__ import annotations

from enum import IntEnum, StrEnum


class FlowStatus(IntEnum):
    """How an integration ended."""

    OK = 0
    NON_FINITE = 1
    MAX_STEPS = 2
    STEP_TOO_SMALL = 3


class RootStatus(StrEnum):
    """How a root solve ended (the Python loop and the compiled one alike; the compiled loop
    returns the index of the status in this order)."""

    CONVERGED = "converged"
    MAX_ITERATIONS = "max-iterations"
    SINGULAR_JACOBIAN = "singular-jacobian"
    LINE_SEARCH_FAILED = "line-search-failed"
    NON_FINITE = "non-finite"
    DIVERGED = "diverged"
    STALLED = "stalled"


class SweepCode(IntEnum):
    """Why the compiled warm sweep stopped."""

    DONE = 0  # every junction up to q - 1 was solved from its warm guess
    WARM_FAILED = 1  # the warm attempt at the junction failed; its counts are included
    PYTHON = 2  # the junction needs the Python path; nothing of it is counted


#: RootStatus names that the kernels spell otherwise (NON_FINITE is also a flow status there).
_ROOT_NAMES = {"NON_FINITE": "NON_FINITE_F"}


def kernel_constants() -> list[str]:
    """The status codes as lines of the generated kernel module."""
    lines = ["# Status codes, written from the enums that declare them (compiled/status.py)."]
    lines += [f"{s.name} = {s.value}" for s in FlowStatus]
    lines += [f"{_ROOT_NAMES.get(s.name, s.name)} = {i}" for i, s in enumerate(RootStatus)]
    lines += [f"SWEEP_{c.name} = {c.value}" for c in SweepCode]
    return lines
