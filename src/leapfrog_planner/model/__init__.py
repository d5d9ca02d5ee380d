"""Built-in vehicle models, by name. SymPy is imported only when a model is built."""

from __future__ import annotations

import importlib
from pathlib import Path
from typing import TYPE_CHECKING

from ..errors import ModelError

if TYPE_CHECKING:
    from .base import VehicleModel

# name -> module in this package defining a function of the same name (with _ for -)
_BUILTIN = {"unicycle": "unicycle", "diff-drive": "diff_drive", "car": "car"}
MODELS: tuple[str, ...] = tuple(_BUILTIN)


def _check(name: str) -> str:
    if name not in _BUILTIN:
        raise ModelError(f"unknown model {name!r} (known: {', '.join(MODELS)})")
    return _BUILTIN[name]


def get_model(name) -> VehicleModel:
    """The built-in model called ``name``, as SymPy expressions (a model is returned as it is)."""
    if not isinstance(name, str):
        return name
    module = _check(name)
    return getattr(importlib.import_module(f".{module}", __name__), module)()


def builtin_source(name: str) -> str:
    """Source text that defines the built-in model ``name`` (its cache key)."""
    return (Path(__file__).parent / f"{_check(name)}.py").read_text()


def __getattr__(attr):  # lazy, so that importing the package does not import SymPy
    if attr in ("VehicleModel", "unicycle", "diff_drive", "car"):
        module = "base" if attr == "VehicleModel" else attr
        return getattr(importlib.import_module(f".{module}", __name__), attr)
    raise AttributeError(attr)


__all__ = ["MODELS", "VehicleModel", "builtin_source", "get_model"]
