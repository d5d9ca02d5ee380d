"""Built-in vehicle models, by name."""

from collections.abc import Callable

from ..errors import ModelError
from .base import VehicleModel
from .diff_drive import diff_drive
from .unicycle import unicycle

MODELS: dict[str, Callable[[], VehicleModel]] = {"unicycle": unicycle, "diff-drive": diff_drive}


def get_model(name: str | VehicleModel) -> VehicleModel:
    """The built-in model called ``name`` (a :class:`VehicleModel` is returned as it is)."""
    if isinstance(name, VehicleModel):
        return name
    try:
        return MODELS[name]()
    except KeyError:
        raise ModelError(f"unknown model {name!r} (known: {', '.join(MODELS)})") from None


__all__ = ["MODELS", "VehicleModel", "diff_drive", "get_model", "unicycle"]
