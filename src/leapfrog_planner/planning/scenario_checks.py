"""The validators of a scenario file: each raises a one-line :class:`ScenarioError` that names
the file and the key, ``<source>: <key>: <problem>``."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, NoReturn

import numpy as np

from .. import checks
from ..errors import ScenarioError, describe, did_you_mean, require_integer, short
from .scenario_toml import BARE_KEY


def key_path(prefix: str, key: Any) -> str:
    key = str(key)
    name = key if BARE_KEY.fullmatch(key) else short(key)
    return f"{prefix}.{name}" if prefix else name


class ScenarioCheck:
    """Validators that raise one-line :class:`ScenarioError` messages naming ``source``."""

    def __init__(self, source: str):
        self.source = source

    def fail(self, key: str, message: str) -> NoReturn:
        text = f"{self.source}: {key}: {message}" if key else f"{self.source}: {message}"
        # Often raised while handling the error it words (a check's, the TOML parser's): the
        # message says it all, so the traceback shows this error alone.
        raise ScenarioError(" ".join(text.splitlines())) from None

    def _named(self, check, *args, **kw):
        """``check`` (of :mod:`..checks`) with this file's name in front of its message."""
        try:
            return check(*args, **kw)
        except ScenarioError as e:
            self.fail("", str(e))

    def number(self, value: Any, key: str, *, gt: float | None = None, ge: float | None = None):
        return self._named(checks.real, value, key, gt=gt, ge=ge)

    def integer(self, value: Any, key: str, *, minimum: int | None = None, maximum=None) -> int:
        return self._named(require_integer, key, value, minimum, maximum, error=ScenarioError)

    def in_range(self, x: float, key: str, bounds: tuple[float, float]) -> float:
        return self._named(checks.in_range, x, key, *bounds)

    def magnitude(self, values, key: str, limit: float) -> None:
        self._named(checks.magnitude, values, key, limit)

    def pose(self, value: Any, key: str, names=("x", "y", "heading")) -> np.ndarray:
        """A state ``[x, y, heading, ...]`` of the model (``names``) within the bounds."""
        p = self.vector(value, len(names), key, f" [{', '.join(names)}]")
        self.magnitude(p[:2], key, checks.COORDINATE_MAX)
        if not abs(p[2]) <= checks.HEADING_MAX:
            self.fail(f"{key}[2]", f"must be at most {checks.HEADING_MAX:g} in size, got {p[2]!r}")
        for i in range(3, p.size):
            if not abs(p[i]) <= checks.COORDINATE_MAX:
                self.fail(f"{key}[{i}]", f"must be at most 1e+06 in size, got {p[i]!r}")
        return p

    def string(self, value: Any, key: str) -> str:
        if not isinstance(value, str):
            self.fail(key, f"expected a string, got {describe(value)}")
        try:
            value.encode("utf-8")
        except UnicodeEncodeError:
            self.fail(key, f"not valid Unicode text: {short(value)}")
        return str(value)

    def table(self, value: Any, key: str) -> Mapping:
        if not isinstance(value, Mapping):
            self.fail(key, f"expected a table, got {describe(value)}")
        for k in value:
            if not isinstance(k, str):
                self.fail(key, f"keys must be strings, got {describe(k)}")
        return value

    def known_keys(self, table: Mapping, allowed, prefix: str, what: str = "") -> None:
        for k in table:
            if k not in allowed:
                did = did_you_mean(k, allowed)
                self.fail(
                    key_path(prefix, k),
                    f"unknown key{what} ({did}allowed: {', '.join(allowed) or 'none'})",
                )

    def vector(self, value: Any, n: int, key: str, what: str = "") -> np.ndarray:
        return self._named(checks.vector, value, n, key, what)

    def rows(self, value: Any, n: int, key: str, what: str = "") -> np.ndarray:
        """An array of ``n``-vectors as a ``(k, n)`` float array (``k`` may be 0)."""
        return self._named(checks.rows, value, n, key, what)

    def obstacles(self, value) -> np.ndarray:
        return self._named(checks.obstacles, value)

    def outside(self, point, key: str, obstacles: np.ndarray, robot_radius: float = 0.0) -> None:
        self._named(checks.outside, point, key, obstacles, robot_radius=robot_radius)
