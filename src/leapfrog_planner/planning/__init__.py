"""From a scenario to a validated trajectory: initial paths, Leapfrog, the planner."""
