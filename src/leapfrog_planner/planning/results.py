"""Leapfrog results: validated against Pontryagin's conditions, saved as JSON and NPZ.

JSON schema (``schema`` = 3; ``leapfrog schema`` prints it as a JSON Schema). A file stands
alone: it holds the scenario planned (``scenario_file``, the keys of a scenario file, whose
``solver`` table is written from the settings used), the planner's settings (``settings``) and
how it was made (``provenance``: ``versions`` of the package, numba, numpy and scipy,
``python``, ``platform``, ``date`` in UTC, ``call``: the command line or the API call).
``PlanResult.load(path)`` reads it back, and files of schemas 1 and 2 too (see
:mod:`.result_files`); ``plan(result)`` re-plans it (:mod:`.rerun`). These top-level keys are a
stable contract for other tools:

- ``status``: ``"converged"`` on success (a collision-free extremal that meets Pontryagin's
  conditions), ``"collides"`` when every extremal found passes through an obstacle, ``"failed"``
  when none was found; ``message`` says why, and what was returned.
- ``optimal`` (the trajectory is a validated extremal: always when converged),
  ``trajectory_source`` (``"extremal"``, or for the best collision-free motion of a failure
  ``"Leapfrog iterate (q = 4), not optimal"`` or ``"initial path, not optimal"``) and
  ``weight`` (the obstacle weight of the problem the trajectory solves: the scenario's, unless
  it was raised to clear the obstacles), ``cheaper_motion`` (converged only: the cost of a
  collision-free motion cheaper than the extremal, another path's Leapfrog iterate: a cheaper
  optimum exists that no run converged to; ``null`` when none was found).
- numbers (of the returned trajectory): ``cost`` (= ``energy`` + ``penalty``, + the price of
  time ``free_time.time_cost`` = k T with a free final time; the trajectory's ``running_cost``,
  ``initial_cost`` and the costs in ``history`` are without it),
  ``min_clearance`` (smallest distance from the path to an obstacle edge, on a map to its
  blocked cells, exact to :data:`CLEARANCE_TOLERANCE` for an extremal; ``null`` without
  obstacles), ``end_state_error`` (|x(T) - goal| after re-integrating the extremal arc by arc
  from its solver's junctions with DOP853 at rtol 1e-12, and the largest jump where its arcs
  meet),
  ``max_costate_jump`` (at the junctions after the last sweep, relative), ``wall_time_s``.
- ``method`` (local Newton method), ``sweeps``, ``newton_iterations``.
- ``trajectory``: equal-length arrays ``t``, the states (``x``, ``y``, ``theta``), the controls
  (``v``, ``omega`` for the unicycle; the model's names otherwise, listed in ``state_names`` and
  ``control_names``), ``lambda_1`` ..., ``running_cost`` and ``hamiltonian``. Rows are the
  integrator's steps and a uniform grid merged (not uniform): ``leapfrog export`` resamples.

Further keys: ``schema``, ``scenario``, ``model``, ``final_solver`` (``"shooting"`` or
``"multiple-shooting"``), ``initial_path``, ``costate0``, ``clearance`` (per obstacle),
``max_dH_du``, ``hamiltonian_variation``, ``f_evals``, ``timing`` (``initial_path_s``,
``sweeps_s``, ``final_s``, ``validation_s``), ``history`` (one object per sweep: ``q``, ``cost``,
``max_costate_jump``, ``newton_iterations``, ``f_evals``, ``failures``, ``rejected``, ``time_s``,
and the junctions ``junction_t``, ``junction_X``), ``initial_junctions`` (``t``, ``X``) and
``alternatives`` (the other initial paths: ``label``, ``status``, ``cost``, ``sweeps``,
``weight``, ``message`` and their extremal's ``trajectory``, empty when they found none) and
``search`` (every Leapfrog run in the order made: ``stage``, ``reason``, ``label``,
``partitions``, ``weight``, ``aid`` (the value of the model's planning aid, null without one),
``status``, ``cost``, ``sweeps``, ``time_s``, ``message``) and ``replan`` (how ``replan`` made
it: ``"warm"`` from the previous answer, ``"full"`` by a full plan; null for a plan, and in a
file written before the key existed).
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace

import numpy as np

from ..integrate.flow import Flow, FlowStatus, IntegratorSettings, Trajectory
from ..integrate.problem import OptimalControlProblem
from ..world.obstacle_map import polyline_bound, segment_bounds
from .export import interpolate_columns, resample_columns, result_html
from .leapfrog import Arcs, SweepRecord
from .result_files import load_result, result_to_dict, save_json, save_npz, trajectory_columns
from .scenario import Scenario
from .status import FreeTimeReport, PathOutcome, PlanStatus, RunRecord

VALIDATION = IntegratorSettings(method="dop853", rtol=1e-12, atol=1e-12)

#: On a map, the clearance between two rows of a motion is known only as a bound (the distance
#: to the blocked cells is 1-Lipschitz: ``(a + b - L) / 2`` on a stretch of length ``L`` whose
#: ends clear by ``a`` and ``b``), which reads up to half the spacing low: 3.5 cm on a 70 m
#: route at 1001 samples. A stretch whose bound lies more than ``CLEARANCE_TOLERANCE`` (metres)
#: below the least clearance at the rows is integrated again with ``REFINE_SAMPLES`` samples,
#: at most ``REFINE_LEVELS`` times (4096 times finer): the extremal's clearance is then exact to
#: that tolerance, and still a proven lower bound.
CLEARANCE_TOLERANCE = 1e-4
REFINE_SAMPLES = 16
REFINE_LEVELS = 3


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
    problem: OptimalControlProblem,
    t0,
    x0,
    t1,
    x1,
    costate0,
    samples: int = 1001,
    integrator: IntegratorSettings = VALIDATION,
) -> Validation:
    """Re-integrate (at rtol 1e-12 by default) and check the end state and Pontryagin's
    conditions."""
    one = Arcs(np.array([t0, t1], dtype=float), np.array([x0, x1], dtype=float), costate0[None])
    return validate_arcs(problem, one, samples, integrator)


def validate_arcs(
    problem: OptimalControlProblem,
    arcs: Arcs,
    samples: int = 1001,
    integrator: IntegratorSettings = VALIDATION,
) -> Validation:
    """Re-integrate an extremal arc by arc from its junctions (at rtol 1e-12 by default) and
    check it.

    ``end_state_error`` is the largest jump of the state or the costate where one arc meets the
    next, or of the state from the goal ``arcs.X[-1]`` at the end: with one arc, the end-state
    error of simple shooting. The cost and the conditions are those of the joined arcs."""
    nan = float("nan")
    flow = Flow(problem, integrator)
    q = arcs.t.size - 1
    T = arcs.t[-1] - arcs.t[0]
    parts, cost, penalty, error = [], 0.0, 0.0, 0.0
    for j in range(q):
        n = (
            samples
            if q == 1
            else max(3, 2 * round(samples * (arcs.t[j + 1] - arcs.t[j]) / T / 2) + 1)
        )
        z0 = np.concatenate([arcs.X[j], arcs.lam0[j]])
        r = flow(arcs.t[j], z0, arcs.t[j + 1], samples=n)
        if r.status != FlowStatus.OK or r.trajectory is None:
            return Validation(
                None,
                nan,
                nan,
                nan,
                np.full(problem.penalty.clearance(np.zeros((0, 2))).size, nan),
                np.inf,
                nan,
                nan,
            )
        target = arcs.X[j + 1] if j == q - 1 else np.concatenate([arcs.X[j + 1], arcs.lam0[j + 1]])
        end = r.x if j == q - 1 else r.z
        error = max(error, float(np.linalg.norm(end - target)))
        tr = r.trajectory
        if problem.penalty.any:
            penalty += penalty_integral(problem, tr)
        parts.append(replace(tr, cost=tr.cost + cost))
        cost += r.cost
    tr = _joined(parts)
    H = tr.hamiltonian[tr.at_step]
    world = problem.penalty.map
    on_map = None if world is None else map_clearance(world, flow, tr)
    clearance = problem.penalty.clearance(tr.x[:, :2], map_entry=on_map)
    return Validation(
        trajectory=tr,
        cost=cost,
        energy=max(cost - penalty, 0.0),  # (the penalty by quadrature can exceed a cost of 0)
        penalty=penalty,
        clearance=clearance,
        end_state_error=error,
        max_dH_du=float(np.abs(tr.dH_du).max()),
        hamiltonian_variation=float(np.abs(H - H[0]).max() / max(1.0, abs(H[0]))),
    )


def map_clearance(world, flow: Flow, tr: Trajectory) -> float:
    """The clearance of the extremal ``tr`` (integrated by ``flow``) against the map ``world``
    (an :class:`~leapfrog_planner.world.ObstacleMap`): exact at its rows, and between rows
    whose bound hides a lower value, from that stretch integrated again more finely (see
    :data:`CLEARANCE_TOLERANCE`); a lower bound of the clearance along the motion, and never
    below the bound of the rows alone (``ObstacleMap.path_clearance``: both are lower bounds)."""
    keep = np.append(np.diff(tr.t) > 0, True)  # (a junction's time once)
    pieces = [(tr.t[keep], np.hstack([tr.x[keep], tr.lam[keep]]))]
    clear = [world.clearance_at(pieces[0][1][:, :2])]
    rows_bound = polyline_bound(pieces[0][1][:, :2], clear[0])
    low, bound = float(clear[0].min()), np.inf
    for level in range(REFINE_LEVELS + 1):
        finer = []
        for (t, z), c in zip(pieces, clear, strict=True):
            b = segment_bounds(z[:, :2], c)
            hides = b < low - CLEARANCE_TOLERANCE
            bound = min(bound, float(b[~hides].min(initial=np.inf)))
            for i0, i1 in _stretches(hides):  # rows i0 .. i1, each segment hiding
                n = REFINE_SAMPLES * (i1 - i0) + 1
                r = None if level == REFINE_LEVELS else flow(t[i0], z[i0], t[i1], samples=n)
                if r is None or r.status != FlowStatus.OK or r.trajectory is None:
                    bound = min(bound, float(b[i0:i1].min()))
                else:
                    finer.append((r.trajectory.t, np.hstack([r.trajectory.x, r.trajectory.lam])))
        if not finer:
            break
        pieces = finer
        points = world.clearance_at(np.vstack([z[:, :2] for _, z in pieces]))
        clear = np.split(points, np.cumsum([len(t) for t, _ in pieces])[:-1])
        low = min(low, float(points.min()))
    return max(rows_bound, min(low, bound))


def _stretches(mask: np.ndarray) -> list[tuple[int, int]]:
    """The runs of consecutive true entries of ``mask`` as ``(first, last + 1)``."""
    edges = np.diff(np.concatenate(([0], mask.astype(np.int8), [0])))
    return list(zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1), strict=True))


def _joined(parts: list[Trajectory]) -> Trajectory:
    """Trajectories of consecutive arcs as one (each junction once: the later arc's row)."""
    if len(parts) == 1:
        return parts[0]
    cols = {}
    for f in fields(Trajectory):
        pieces = [getattr(p, f.name)[:-1] for p in parts[:-1]] + [getattr(parts[-1], f.name)]
        cols[f.name] = np.concatenate(pieces)
    return Trajectory(**cols)


def piecewise_trajectory(flow: Flow, arcs: Arcs, samples: int = 1001) -> Trajectory:
    """The arcs of a piecewise extremal integrated one after the other and joined: a feasible
    motion from start to goal (each arc meets the next junction up to the local problems'
    tolerance), about ``samples`` rows in all; the running cost accumulates across arcs."""
    T = arcs.t[-1] - arcs.t[0]
    parts: list[Trajectory] = []
    offset = 0.0
    for j in range(arcs.t.size - 1):
        n = max(3, round(samples * (arcs.t[j + 1] - arcs.t[j]) / T))
        r = flow(arcs.t[j], np.concatenate([arcs.X[j], arcs.lam0[j]]), arcs.t[j + 1], samples=n)
        if r.trajectory is None:
            raise ValueError(f"arc {j} could not be integrated ({r.status})")
        parts.append(replace(r.trajectory, cost=r.trajectory.cost + offset))
        offset += float(r.cost)
    return _joined(parts)


def penalty_integral(problem: OptimalControlProblem, tr: Trajectory) -> float:
    """The trapezoidal rule over every row of the trajectory: the uniform samples and the
    integrator's own steps, which crowd where the motion changes fast.

    Simpson's rule on the uniform samples alone missed a quick dash at a long horizon: at
    T = 100 (seed 2, layout 4: a 0.1 s dash away from an obstacle) it gave a penalty of 0.1765
    where 200,001 samples give 0.0562, and a negative energy; over every row, 0.0565. On paper
    case 2 the two rules agree to 2e-7.
    """
    P = problem.penalty(tr.x[:, :2])
    return float(np.sum(0.5 * (P[1:] + P[:-1]) * np.diff(tr.t)))


@dataclass(frozen=True)
class PlanResult:
    """What :func:`.planner.plan` returns: the status, the trajectory (an extremal, or the best
    collision-free motion computed), its cost, its checks, the sweeps and the timings."""

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
    alternatives: tuple[PathOutcome, ...]
    weight: float  # the obstacle weight of the problem the trajectory solves
    optimal: bool  # the trajectory is a validated extremal (always when converged)
    trajectory_source: str  # "extremal", "Leapfrog iterate (q = 4), not optimal", ...
    task: Scenario | None = None  # the scenario planned (end states, obstacles, robot, penalty)
    settings: dict | None = None  # the planner's settings, as JSON values
    # Converged only: the cost of a collision-free motion cheaper than the extremal (another
    # path's last Leapfrog iterate, not an extremal): a cheaper optimum exists that no run
    # converged to. NaN when none was found.
    cheaper_motion: float = float("nan")
    # Every Leapfrog run of the search, in the order made: which stage asked for it, why, and
    # what it gave (see :mod:`.search`).
    search: tuple[RunRecord, ...] = ()
    # With a free final time: the price of time, the T chosen and how (then ``cost`` includes
    # the price of time, ``energy + penalty + time_weight T``); None for a fixed horizon.
    free_time: FreeTimeReport | None = None
    # How the result was made (versions, platform, date, the call: see :mod:`.rerun`):
    # metadata, which comparisons of answers leave out. None in a file of schema 2 or older.
    provenance: dict | None = None
    # How :func:`.replan.replan` made it: ``"warm"`` (from the previous answer's extremal) or
    # ``"full"`` (a full plan, the message says why); None for a plan.
    replan: str | None = None

    @classmethod
    def load(cls, path) -> PlanResult:
        """A result saved with :meth:`save_json` or :meth:`save_npz`: it needs nothing else to
        be drawn or exported (its ``task`` is the scenario planned)."""
        return cls(**load_result(path))

    def __repr__(self) -> str:
        cost = "nan" if not np.isfinite(self.cost) else f"{self.cost:.8g}"
        return (
            f"PlanResult(status={str(self.status)!r}, cost={cost}, scenario={self.scenario!r}, "
            f"method={self.method!r}, sweeps={self.sweeps}, wall_time={self.wall_time_s:.3g} s)"
        )

    def _repr_html_(self) -> str:
        return result_html(self)

    def at(self, t) -> dict[str, np.ndarray]:
        """The trajectory's columns at times ``t`` (scalar or array), within the horizon: a cubic
        spline through the rows of an extremal, PCHIP through those of a non-optimal motion."""
        return interpolate_columns(self.trajectory_columns(), t, self.optimal)

    def resample(self, dt: float) -> dict[str, np.ndarray]:
        """The trajectory's columns on a uniform grid of step ``dt`` (the end time included)."""
        return resample_columns(self.trajectory_columns(), dt, self.optimal)

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
        """The dense trajectory as named columns of equal length (``t``, states, controls,
        costates ``lambda_1``..., ``running_cost``, ``hamiltonian``)."""
        return trajectory_columns(self.trajectory, self.state_names, self.control_names)

    def to_dict(self) -> dict:
        return result_to_dict(self)

    def save_json(self, path) -> None:
        save_json(self, path)

    def save_npz(self, path) -> None:
        save_npz(self, path)


#: The old name of :class:`PlanResult`, kept for one release.
LeapfrogResult = PlanResult
