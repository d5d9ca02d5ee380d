"""leapfrog-planner: optimal mobile-robot trajectories by Pontryagin's principle and Leapfrog."""

import importlib

# First, and light: where numba keeps its compiled code (before any compiled function is defined).
from . import _cache, _compat

_cache.use_writable_numba_cache()

# Every public name loads on first use, so that `import leapfrog_planner` takes milliseconds
# (numba, SciPy and SymPy load with the first name that needs them) and the `leapfrog` command
# can report a Ctrl-C during its start as one line.
_LAZY = {
    "ShootingResult": ".bvp.shooting",
    "ShootingSettings": ".bvp.shooting",
    "affine_costate_guess": ".bvp.shooting",
    "solve_shooting": ".bvp.shooting",
    "LeapfrogError": ".errors",
    "ModelError": ".errors",
    "ScenarioError": ".errors",
    "SettingsError": ".errors",
    "Flow": ".integrate.flow",
    "FlowResult": ".integrate.flow",
    "FlowStatus": ".integrate.flow",
    "IntegratorSettings": ".integrate.flow",
    "Trajectory": ".integrate.flow",
    "MODELS": ".model",
    "get_model": ".model",
    "ModelInfo": ".compiled.kernels",
    "model_info": ".compiled.kernels",
    "ObstaclePenalty": ".integrate.problem",
    "OptimalControlProblem": ".integrate.problem",
    "obstacle_penalty": ".integrate.problem",
    "Scenario": ".planning.scenario",
    "builtin_scenarios": ".planning.scenario",
    "load_scenario": ".planning.scenario",
    "scenario_from_dict": ".planning.scenario",
    "VehicleModel": ".model.base",
    "CanonicalSystem": ".model.pmp",
    "derive": ".model.pmp",
    "plan": ".planning.planner",
    "Planner": ".planning.planner",
    "replan": ".planning.replan",
    "PlannerSettings": ".planning.planner",
    "PlanResult": ".planning.results",
    "LeapfrogResult": ".planning.results",
    "PlanStatus": ".planning.results",
}


def __getattr__(name):
    if name in _LAZY:
        value = getattr(importlib.import_module(_LAZY[name], __name__), name)
        globals()[name] = value  # the next access is a plain attribute
        return value
    raise AttributeError(f"module 'leapfrog_planner' has no attribute {name!r}")


def __dir__():
    return sorted({*globals(), *_LAZY})


_compat.install(__name__)  # the flat layout's module paths, for one release

__version__ = "0.1.0"

__all__ = [
    "MODELS",
    "CanonicalSystem",
    "Flow",
    "FlowResult",
    "FlowStatus",
    "IntegratorSettings",
    "LeapfrogError",
    "LeapfrogResult",
    "PlanResult",
    "ModelInfo",
    "ModelError",
    "ObstaclePenalty",
    "OptimalControlProblem",
    "PlanStatus",
    "Planner",
    "PlannerSettings",
    "ScenarioError",
    "Scenario",
    "SettingsError",
    "ShootingResult",
    "ShootingSettings",
    "Trajectory",
    "VehicleModel",
    "affine_costate_guess",
    "builtin_scenarios",
    "derive",
    "get_model",
    "load_scenario",
    "model_info",
    "obstacle_penalty",
    "plan",
    "replan",
    "scenario_from_dict",
    "solve_shooting",
]
