"""leapfrog-planner: optimal mobile-robot trajectories by Pontryagin's principle and Leapfrog."""

from .errors import LeapfrogError, ModelError, ScenarioError, SettingsError
from .integrate.flow import Flow, FlowResult, FlowStatus, IntegratorSettings, Trajectory
from .models import MODELS, VehicleModel, get_model
from .pmp import CanonicalSystem, derive
from .problem import ObstaclePenalty, OptimalControlProblem, obstacle_penalty

__version__ = "0.1.0"

__all__ = [
    "MODELS",
    "CanonicalSystem",
    "Flow",
    "FlowResult",
    "FlowStatus",
    "IntegratorSettings",
    "LeapfrogError",
    "ModelError",
    "ObstaclePenalty",
    "OptimalControlProblem",
    "ScenarioError",
    "SettingsError",
    "Trajectory",
    "VehicleModel",
    "derive",
    "get_model",
    "obstacle_penalty",
]
