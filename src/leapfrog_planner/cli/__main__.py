"""``python -m leapfrog_planner.cli``: the ``leapfrog`` command."""

from .main import run

run()
