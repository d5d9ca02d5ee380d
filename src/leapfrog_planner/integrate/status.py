"""The integrator's status codes (also written into the compiled kernels: see bvp/abi.py)."""

from enum import IntEnum


class FlowStatus(IntEnum):
    OK = 0
    NON_FINITE = 1
    MAX_STEPS = 2
    STEP_TOO_SMALL = 3
