"""leapfrog-planner: optimal mobile-robot trajectories by Pontryagin's principle and Leapfrog."""

import importlib

# first: importing _cache sets numba's cache up before any compiled function is defined
from . import _cache, _compat  # noqa: F401
from .bvp.shooting import ShootingResult, ShootingSettings, affine_costate_guess, solve_shooting
from .errors import LeapfrogError, ModelError, ScenarioError, SettingsError
from .integrate.flow import Flow, FlowResult, FlowStatus, IntegratorSettings, Trajectory
from .model import MODELS, get_model
from .model.kernels import ModelInfo, model_info
from .model.problem import ObstaclePenalty, OptimalControlProblem, obstacle_penalty
from .planning.scenario import Scenario, builtin_scenarios, load_scenario

# SymPy-backed names load on first use, so that `import leapfrog_planner` stays fast.
# The planner too: it loads the initial-path kernels.
_LAZY = {
    "VehicleModel": ".model.base",
    "CanonicalSystem": ".model.pmp",
    "derive": ".model.pmp",
    "plan": ".planning.planner",
    "Planner": ".planning.planner",
    "PlannerSettings": ".planning.planner",
    "PlanResult": ".planning.results",
    "LeapfrogResult": ".planning.results",
    "PlanStatus": ".planning.results",
}


def __getattr__(name):
    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name], __name__), name)
    raise AttributeError(f"module 'leapfrog_planner' has no attribute {name!r}")


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
    "solve_shooting",
]
