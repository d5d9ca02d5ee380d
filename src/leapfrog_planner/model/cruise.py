"""The effort of driving straight ahead, which turns a cruise speed into a price of time.

With the final time free and a price ``k`` on each second, the cost of a straight run of
length ``D`` at speed ``v`` in free space is ``(k + c v^2) D / v``, where ``c v^2`` is the least
running cost of the controls that drive the model straight ahead at ``v``. It is least at
``v = sqrt(k / c)``: a price of time ``k = c v^2`` makes the optimum cruise at ``v`` where no
obstacle is near. ``c`` is 1/2 for the unicycle and the car, ``1 / r^2`` for the differential
drive with wheel radius ``r`` (both wheels at ``v / r``).
"""

from __future__ import annotations

import functools
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import sympy as sp

from ..errors import ModelError
from .base import VehicleModel


@dataclass(frozen=True)
class Cruise:
    """How ``model`` drives straight ahead in free space: the least running cost ``effort``
    (``c`` above) of the controls that drive it at unit speed, and those ``controls`` (by the
    model's control order)."""

    effort: float
    controls: tuple[float, ...]

    def top_speed(self, control_names, bounds: dict[str, tuple[float, float]]) -> float | None:
        """The top speed at which these controls, scaled, drive straight ahead (or back) inside
        ``bounds`` (by control name); None where no bound limits them."""
        limits = [
            (lo, hi, u)
            for name, u in zip(control_names, self.controls, strict=True)
            if name in bounds and abs(u) > 1e-12
            for lo, hi in [bounds[name]]
        ]
        if not limits:
            return None
        ahead = min(max((hi if u > 0 else lo) / u, 0.0) for lo, hi, u in limits)
        back = min(max((lo if u > 0 else hi) / -u, 0.0) for lo, hi, u in limits)
        return max(ahead, back)


def cruise(model: VehicleModel, parameters: Mapping[str, float]) -> Cruise:
    """The :class:`Cruise` of ``model`` from the origin with every other state at zero, for the
    parameter values ``parameters`` (by name; defaults for the others). The running cost must be
    a quadratic form of the controls and the dynamics there linear in them. Derived with SymPy
    once per model and parameter values (milliseconds), then remembered."""
    return _cruise(model, tuple(sorted(dict(parameters).items())))


def straight_effort(model: VehicleModel, parameters: Mapping[str, float]) -> float:
    """``c``: the least running cost of driving ``model`` straight ahead at unit speed
    (:func:`cruise`)."""
    return cruise(model, parameters).effort


def top_straight_speed(
    model: VehicleModel, parameters: Mapping[str, float], bounds: dict[str, tuple[float, float]]
) -> float | None:
    """The top speed at which ``model`` can drive straight ahead (or back) with the controls of
    least effort (those of a cruise) inside ``bounds`` (by control name); None where no bound
    limits them: the differential drive's is set by its wheels' bounds."""
    return cruise(model, parameters).top_speed(model.control_names, bounds)


@functools.lru_cache(maxsize=64)
def _cruise(model: VehicleModel, parameters: tuple[tuple[str, float], ...]) -> Cruise:
    """:func:`cruise`, of parameter values given as sorted pairs."""
    values = dict(zip(model.parameter_names, model.defaults, strict=True)) | dict(parameters)
    at = {s: 0 for s in model.states}
    at.update({p: values[n] for p, n in zip(model.parameters, model.parameter_names, strict=True)})
    u = model.controls
    f = [sp.sympify(e).subs(at) for e in model.dynamics]
    L = sp.sympify(model.running_cost).subs(at)
    try:
        A = np.array(sp.Matrix(f).jacobian(u).subs({c: 0 for c in u}), dtype=float)
        Q = np.array(sp.hessian(L, u).subs({c: 0 for c in u}), dtype=float)
        offset = np.array([e.subs({c: 0 for c in u}) for e in f], dtype=float)
    except TypeError as exc:  # symbols left: the cost or dynamics depend on more than u
        raise ModelError(f"model {model.name!r}: no cruise speed: {exc}") from None
    if np.any(offset) or not np.allclose(L.subs({c: 0 for c in u}), 0.0):
        raise ModelError(f"model {model.name!r}: at rest it moves or costs: give a time weight")
    # least 1/2 u'Qu with A u = e_1 (unit speed along x, every other rate zero)
    rows = np.any(A != 0.0, axis=1)
    b = np.zeros(A.shape[0])
    b[0] = 1.0
    A, b = A[rows], b[rows]
    try:
        Qi = np.linalg.inv(Q)
        uc = Qi @ A.T @ np.linalg.solve(A @ Qi @ A.T, b)
    except np.linalg.LinAlgError:
        raise ModelError(
            f"model {model.name!r}: its effort is no positive quadratic form of the controls: "
            "give a time weight instead of a cruise speed"
        ) from None
    c = 0.5 * float(uc @ Q @ uc)
    if not np.allclose(A @ uc, b) or not c > 0.0:
        raise ModelError(f"model {model.name!r} cannot drive straight ahead: give a time weight")
    return Cruise(c, tuple(float(x) for x in uc))
