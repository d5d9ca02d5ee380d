"""Leapfrog results: validated against Pontryagin's conditions, saved as JSON and NPZ.

JSON schema (``schema`` = 1). These top-level keys are a stable contract for other tools:

- ``status``: ``"converged"`` on success, ``"failed"`` otherwise; ``message`` says why.
- numbers: ``cost`` (= ``energy`` + ``penalty``), ``min_clearance`` (smallest distance from the
  path to an obstacle edge; ``null`` without obstacles), ``end_state_error`` (|x(T) - goal| after
  re-integrating the returned initial state and costate with DOP853 at rtol 1e-12),
  ``max_costate_jump`` (at the junctions after the last sweep, relative), ``wall_time_s``.
- ``method`` (local Newton method), ``sweeps``, ``newton_iterations``.
- ``trajectory``: equal-length arrays ``t``, the states (``x``, ``y``, ``theta``), the controls
  (``v``, ``omega`` for the unicycle; the model's names otherwise) and ``lambda_1`` ...

Further keys: ``schema``, ``scenario``, ``model``, ``final_solver`` (``"shooting"`` or
``"multiple-shooting"``), ``initial_path``, ``costate0``, ``clearance`` (per obstacle),
``max_dH_du``, ``hamiltonian_variation``, ``f_evals``, ``timing`` (``initial_path_s``,
``sweeps_s``, ``final_s``, ``validation_s``), ``history`` (one object per sweep: ``q``, ``cost``,
``max_costate_jump``, ``newton_iterations``, ``f_evals``, ``failures``, ``rejected``, ``time_s``)
and ``alternatives`` (the other initial paths: ``label``, ``status``, ``cost``).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from enum import StrEnum
from pathlib import Path

import numpy as np

from ._atomic import write_atomic
from .integrate.flow import Flow, FlowStatus, IntegratorSettings, Trajectory
from .leapfrog import SweepRecord
from .problem import OptimalControlProblem

SCHEMA = 1
VALIDATION = IntegratorSettings(method="dop853", rtol=1e-12, atol=1e-12)


class PlanStatus(StrEnum):
    CONVERGED = "converged"
    FAILED = "failed"


@dataclass(frozen=True)
class PathOutcome:
    """Summary of Leapfrog from one initial path."""

    label: str
    status: PlanStatus
    cost: float
    initial_cost: float
    sweeps: int
    message: str


@dataclass(frozen=True)
class Validation:
    """A returned extremal, re-integrated from its initial state and costate."""

    trajectory: Trajectory | None
    cost: float
    energy: float
    penalty: float
    clearance: np.ndarray  # per obstacle
    end_state_error: float
    max_dH_du: float
    hamiltonian_variation: float


def validate(
    problem: OptimalControlProblem, t0, x0, t1, x1, costate0, samples: int = 1001
) -> Validation:
    """Re-integrate at rtol 1e-12 and check the end state and Pontryagin's conditions."""
    flow = Flow(problem, VALIDATION)
    r = flow(t0, np.concatenate([x0, costate0]), t1, samples=samples)
    if r.status != FlowStatus.OK or r.trajectory is None:
        nan = float("nan")
        return Validation(
            None, nan, nan, nan, np.full(problem.obstacles.shape[0], nan), float("inf"), nan, nan
        )
    tr = r.trajectory
    xy = tr.x[:, :2]
    penalty = _penalty_integral(problem, tr, samples) if problem.obstacles.shape[0] else 0.0
    H = tr.hamiltonian[tr.at_step]
    return Validation(
        trajectory=tr,
        cost=r.cost,
        energy=r.cost - penalty,
        penalty=penalty,
        clearance=problem.penalty.clearance(xy),
        end_state_error=float(np.linalg.norm(r.x - np.asarray(x1))),
        max_dH_du=float(np.abs(tr.dH_du).max()),
        hamiltonian_variation=float(np.abs(H - H[0]).max() / max(1.0, abs(H[0]))),
    )


def _penalty_integral(problem: OptimalControlProblem, tr: Trajectory, samples: int) -> float:
    """Simpson's rule on the uniform rows of the trajectory (the others are integrator steps).

    Written out rather than imported: ``scipy.integrate`` takes longer to import (0.3 s) than the
    rest of a warm start's solve.
    """
    t = tr.t
    uniform = np.isin(t, np.linspace(t[0], t[-1], samples))
    if uniform.sum() != samples or samples % 2 == 0:  # not the expected grid: trapezoid
        P = problem.penalty(tr.x[:, :2])
        return float(np.sum(0.5 * (P[1:] + P[:-1]) * np.diff(t)))
    tu, P = t[uniform], problem.penalty(tr.x[uniform, :2])
    h = (tu[-1] - tu[0]) / (samples - 1)
    return float(h / 3.0 * (P[0] + P[-1] + 4.0 * P[1:-1:2].sum() + 2.0 * P[2:-1:2].sum()))


@dataclass(frozen=True)
class LeapfrogResult:
    status: PlanStatus
    message: str
    scenario: str
    model: str
    state_names: tuple[str, ...]
    control_names: tuple[str, ...]
    method: str
    final_solver: str | None
    initial_path: str
    costate0: np.ndarray | None
    trajectory: Trajectory | None
    cost: float
    energy: float
    penalty: float
    clearance: np.ndarray
    end_state_error: float
    max_costate_jump: float
    max_dH_du: float
    hamiltonian_variation: float
    initial_cost: float
    history: tuple[SweepRecord, ...]
    initial_junctions: tuple[np.ndarray, np.ndarray]  # (t, X) of the initial path
    newton_iterations: int
    f_evals: int
    cost_increases: int
    time_initial_path_s: float
    time_sweeps_s: float
    time_final_s: float
    time_validation_s: float
    wall_time_s: float
    alternatives: tuple[PathOutcome, ...] = ()

    @property
    def success(self) -> bool:
        return self.status is PlanStatus.CONVERGED

    @property
    def sweeps(self) -> int:
        return len(self.history)

    @property
    def min_clearance(self) -> float | None:
        return float(self.clearance.min()) if self.clearance.size else None

    def trajectory_columns(self) -> dict[str, np.ndarray]:
        """The dense trajectory as named columns of equal length."""
        tr = self.trajectory
        if tr is None:
            return {}
        cols = {"t": tr.t}
        cols.update({n: tr.x[:, i] for i, n in enumerate(self.state_names)})
        cols.update({n: tr.u[:, i] for i, n in enumerate(self.control_names)})
        cols.update({f"lambda_{i + 1}": tr.lam[:, i] for i in range(tr.lam.shape[1])})
        return cols

    def to_dict(self) -> dict:
        def num(v):
            return None if v is None or not np.isfinite(v) else float(v)

        return {
            "schema": SCHEMA,
            "status": str(self.status),
            "message": self.message,
            "scenario": self.scenario,
            "model": self.model,
            "method": self.method,
            "final_solver": self.final_solver,
            "initial_path": self.initial_path,
            "cost": num(self.cost),
            "energy": num(self.energy),
            "penalty": num(self.penalty),
            "min_clearance": num(self.min_clearance),
            "clearance": [num(c) for c in self.clearance],
            "end_state_error": num(self.end_state_error),
            "max_costate_jump": num(self.max_costate_jump),
            "max_dH_du": num(self.max_dH_du),
            "hamiltonian_variation": num(self.hamiltonian_variation),
            "costate0": None if self.costate0 is None else self.costate0.tolist(),
            "wall_time_s": self.wall_time_s,
            "sweeps": self.sweeps,
            "newton_iterations": self.newton_iterations,
            "f_evals": self.f_evals,
            "timing": {
                "initial_path_s": self.time_initial_path_s,
                "sweeps_s": self.time_sweeps_s,
                "final_s": self.time_final_s,
                "validation_s": self.time_validation_s,
            },
            "history": [
                {
                    "sweep": h.sweep,
                    "q": h.q,
                    "cost": h.cost,
                    "max_costate_jump": h.max_costate_jump,
                    "newton_iterations": h.newton_iterations,
                    "f_evals": h.f_evals,
                    "failures": h.failures,
                    "rejected": h.rejected,
                    "time_s": h.time_s,
                }
                for h in self.history
            ],
            "alternatives": [
                {"label": a.label, "status": str(a.status), "cost": num(a.cost), "sweeps": a.sweeps}
                for a in self.alternatives
            ],
            "trajectory": {k: v.tolist() for k, v in self.trajectory_columns().items()},
        }

    def save_json(self, path) -> None:
        text = json.dumps(self.to_dict(), indent=1, allow_nan=False)
        write_atomic(path, lambda tmp: Path(tmp).write_text(text))

    def save_npz(self, path) -> None:
        arrays = {k: np.asarray(v) for k, v in self.trajectory_columns().items()}
        arrays["history_cost"] = np.array([h.cost for h in self.history])
        arrays["history_jump"] = np.array([h.max_costate_jump for h in self.history])
        arrays["clearance"] = self.clearance

        def write(tmp):
            with open(tmp, "wb") as fh:  # a handle: np.savez would append .npz to a file name
                np.savez(fh, **arrays)

        write_atomic(path, write)
