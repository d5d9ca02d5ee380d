"""A solver process of ``leapfrog serve`` standing in for one on a fresh machine: before it
warms each model up it waits until the file of that model's name appears in the folder
``$LEAPFROG_TEST_GATE`` (a real first start compiles for about a minute a model), so that a
test sees the server while its solver is being prepared and decides when that ends."""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

from leapfrog_planner.planning import warmup
from leapfrog_planner.web import worker

GATE = "LEAPFROG_TEST_GATE"


#: A model whose warm-up fails once its gate opens (a test of a failed warm-up sets it).
FAIL = "LEAPFROG_TEST_FAIL"


def gated(warm_up):
    """``warm_up``, waiting first until the gate of its model is open."""

    def wait_then_warm_up(model, *args, **kwargs):
        gate = Path(os.environ[GATE]) / model
        while not gate.exists():
            time.sleep(0.02)
        if os.environ.get(FAIL) == model:
            raise RuntimeError("a test's failure")
        return warm_up(model, *args, **kwargs)

    return wait_then_warm_up


def serve_command(port: int) -> list[str]:
    """``leapfrog serve`` on ``port`` with one solver process, the gated stand-in (the gate
    folder and the path to these tests come from the environment)."""
    code = (
        "import sys\n"
        "from leapfrog_planner.web import pool\n"
        "pool.WORKER = 'tests.gated_worker'\n"
        "from leapfrog_planner.cli import run\n"
        "sys.argv[0] = 'leapfrog'\n"
        "run()\n"
    )
    return [sys.executable, "-c", code, "serve", "--port", str(port), "--workers", "1"]


if __name__ == "__main__":
    warmup.warm_up = gated(warmup.warm_up)
    warmup.in_disk_cache = lambda model: False  # as on a fresh machine: compiled apart
    worker.main(sys.argv[1:])
