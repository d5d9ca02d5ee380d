"""``python -m leapfrog_planner.cli``: the ``leapfrog`` command."""

from . import run

run()
