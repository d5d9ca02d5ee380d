"""leapfrog-planner: optimal mobile-robot trajectories by Pontryagin's principle and Leapfrog."""

import importlib

from .errors import LeapfrogError, ModelError, ScenarioError, SettingsError
from .integrate.flow import Flow, FlowResult, FlowStatus, IntegratorSettings, Trajectory
from .kernels import ModelInfo, model_info
from .models import MODELS, get_model
from .problem import ObstaclePenalty, OptimalControlProblem, obstacle_penalty
from .scenario import Scenario, builtin_scenarios, load_scenario
from .shooting import ShootingResult, ShootingSettings, affine_costate_guess, solve_shooting

# SymPy-backed names load on first use, so that `import leapfrog_planner` stays fast.
# The planner too: it loads the initial-path kernels.
_LAZY = {
    "VehicleModel": ".models.base",
    "CanonicalSystem": ".pmp",
    "derive": ".pmp",
    "plan": ".planner",
    "Planner": ".planner",
    "PlannerSettings": ".planner",
    "LeapfrogResult": ".results",
    "PlanStatus": ".results",
}


def __getattr__(name):
    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name], __name__), name)
    raise AttributeError(f"module 'leapfrog_planner' has no attribute {name!r}")


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
    "solve_shooting",
]
