"""Exceptions. Each subclasses the built-in it refines, so callers may catch either."""


class LeapfrogError(Exception):
    """Base class of every error the planner raises on purpose."""


class ModelError(LeapfrogError, ValueError):
    """A vehicle model that Pontryagin's principle cannot be applied to as required."""


class ScenarioError(LeapfrogError, ValueError):
    """A scenario (file or object) with a missing, malformed or inconsistent value."""


class SettingsError(LeapfrogError, ValueError):
    """An unknown option, or an option with a value outside its range."""


def require_integer(name: str, value, minimum: int = 1, maximum: int | None = None) -> None:
    """Raise :class:`SettingsError`, naming ``name``, unless ``value`` is an integer in
    ``[minimum, maximum]`` (booleans and floats with a fraction are refused)."""
    what = "a positive integer" if minimum == 1 else f"an integer >= {minimum}"
    try:
        ok = not isinstance(value, bool) and int(value) == value and value >= minimum
    except (TypeError, ValueError, OverflowError):
        ok = False
    if not ok:
        raise SettingsError(f"{name} must be {what}, got {value!r}")
    if maximum is not None and value > maximum:
        raise SettingsError(f"{name} must be at most {maximum}, got {value!r}")
