"""Exceptions (each subclasses the built-in it refines, so callers may catch either), the words
their messages describe a wrong value with, and the one integer check."""

import numbers
from collections.abc import Mapping
from typing import Any

import numpy as np


class LeapfrogError(Exception):
    """Base class of every error the planner raises on purpose."""


class ModelError(LeapfrogError, ValueError):
    """A vehicle model that Pontryagin's principle cannot be applied to as required."""


class ScenarioError(LeapfrogError, ValueError):
    """A scenario (file or object) with a missing, malformed or inconsistent value."""


class SettingsError(LeapfrogError, ValueError):
    """An unknown option, or an option with a value outside its range."""


#: Words that name no setting but that a user may reach for, and the settings they may mean.
MEANT = {
    "tolerance": (
        ("reduce_tol", "the relative cost decrease that ends a sweep level"),
        ("final_shooting", "whose root.tol is the final solve's |F| tolerance"),
    ),
}


def did_you_mean(word: str, allowed) -> str:
    """``"did you mean 'x'? "`` for the nearest of ``allowed`` to ``word``, or the settings of
    ``allowed`` that :data:`MEANT` lists for it (``""`` if none)."""
    import difflib

    allowed = [str(a) for a in allowed]
    meant = [f"{name!r}, {what}," for name, what in MEANT.get(str(word), ()) if name in allowed]
    if meant:
        return f"did you mean {' or '.join(meant)[:-1]}? "
    hint = difflib.get_close_matches(str(word), allowed, n=1)
    return f"did you mean {hint[0]!r}? " if hint else ""


def short(text: str, limit: int = 40) -> str:
    """``repr(text)``, cut to ``limit`` characters."""
    r = repr(text)
    return r if len(r) <= limit else r[: limit - 4] + "...'"


def describe(value: Any) -> str:
    """A short, one-line description of a (wrong) value for error messages, in the words of
    TOML and JSON (``boolean true``, ``number 3.0``, ``string '3'``)."""
    if isinstance(value, bool | np.bool_):
        return f"boolean {str(bool(value)).lower()}"
    if isinstance(value, str):
        return f"string {short(value)}"
    if isinstance(value, numbers.Integral):
        digits = str(int(value))
        return f"integer {digits if len(digits) <= 30 else digits[:27] + '...'}"
    if isinstance(value, numbers.Real):
        return f"number {float(value)!r}"
    if isinstance(value, Mapping):
        return "a table"
    if isinstance(value, list | tuple):
        return f"an array of {len(value)}"
    if isinstance(value, np.ndarray):
        return f"an array of shape {value.shape}"
    if value is None:
        return "nothing (None)"
    return f"{type(value).__name__} {short(str(value))}"


def require_integer(
    key: str,
    value: Any,
    minimum: int | None = 1,
    maximum: int | None = None,
    *,
    error: type[Exception] = SettingsError,
) -> int:
    """``value`` as an ``int``; else raise ``error`` with a one-line message naming ``key``.

    The package's one check of a count or an index. An integer is an ``int`` or a NumPy integer
    (a TOML or JSON integer is an ``int``); a boolean, a float (even ``3.0``) or a string is
    refused, and so is a value below ``minimum`` or above ``maximum`` (either may be None).
    ``error`` is the exception class (default :class:`SettingsError`)."""
    bound = "" if minimum is None else f" >= {minimum}"
    if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Integral):
        raise error(f"{key}: expected an integer{bound}, got {describe(value)}")
    n = int(value)
    digits = describe(n).removeprefix("integer ")  # a huge one cut short
    if minimum is not None and n < minimum:
        raise error(f"{key}: must be an integer{bound}, got {digits}")
    if maximum is not None and n > maximum:
        raise error(f"{key}: must be at most {maximum}, got {digits}")
    return n
