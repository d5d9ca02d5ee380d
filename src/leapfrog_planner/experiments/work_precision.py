"""Work against precision: for an answer this accurate, what does each method cost?

Per scenario (the paper cases and a few of the general preset), time against the relative cost
error, for

- Leapfrog (the default planner, and from its first initial path only) over a range of final
  tolerances: the final solve's ``|F|`` tolerance ``tol``, its integrator and the answer's check
  at ``rtol = tol / 100``;
- IPOPT (the direct method: RK4 multiple shooting), warm, started from the same initial paths
  (each in its thread, the cheapest kept; and from the first path only), over meshes of 25 to
  3,200 intervals, larger meshes dropped once a solve takes longer than ``max_solve_s``;
- ``scipy.integrate.solve_bvp`` from the first initial path over tolerances 1e-3 to 1e-8.

Each error is measured against a reference computed apart from the method measured: Leapfrog's
against the direct method's optimum extrapolated in the mesh (Richardson, 800 and 1,600
intervals, from the Leapfrog path so that it is the same extremal), the others' against the
Leapfrog answer re-checked at rtol 1e-13. A result more than 1% off its reference is another
extremal and is marked, not dropped; failures too. Times are medians of interleaved rounds
(:func:`.peers.measure`): the machine's drift falls on every method alike.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from ..errors import SettingsError, require_integer
from ..integrate.flow import IntegratorSettings
from ..planning.direct import cached_transcription, clear_transcriptions, richardson
from ..planning.leapfrog import LeapfrogSettings
from ..planning.planner import Planner
from ..planning.results import validate
from ..planning.scenario import Scenario, load_scenario
from . import peers
from .paper import ExperimentEvent, machine_info, paper_cases, warm_up

MESHES = (25, 50, 100, 200, 400, 800, 1600, 3200)
LEAPFROG_TOLS = (1e-4, 1e-6, 1e-8, 1e-10)
BVP_TOLS = (1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8)
OTHER_EXTREMAL = 1e-2  # relative cost difference beyond which a result is another extremal
TARGET_ERROR = 1e-6  # the accuracy of the first ratio
REFERENCE_MESHES = (800, 1600)  # of the extrapolated direct optimum
METHODS = ("leapfrog", "leapfrog-1path", "ipopt", "ipopt-1path", "solve_bvp")


@dataclass(frozen=True)
class WorkPrecisionSettings:
    cases: tuple[int, ...] = (1, 2, 3, 4)
    general: int = 3  # scenarios of the general preset
    seed: int = 1
    repeat: int = 3  # timed rounds after the warm-ups; the median is reported
    meshes: tuple[int, ...] = MESHES
    leapfrog_tols: tuple[float, ...] = LEAPFROG_TOLS
    bvp_tols: tuple[float, ...] = BVP_TOLS
    max_solve_s: float = 10.0

    def __post_init__(self):
        object.__setattr__(self, "cases", paper_cases(self.cases, allow_none=True))
        for name in ("general", "seed", "repeat"):
            v = require_integer(name, getattr(self, name), 1 if name == "repeat" else 0)
            object.__setattr__(self, name, v)
        meshes = tuple(require_integer("meshes", m, 2) for m in self.meshes)
        if not meshes:
            raise SettingsError("meshes: at least one mesh size is needed")
        object.__setattr__(self, "meshes", meshes)
        if not self.max_solve_s > 0:
            raise SettingsError(f"max_solve_s must be > 0, got {self.max_solve_s!r}")


@dataclass(frozen=True)
class Point:
    scenario: str
    method: str  # one of METHODS
    knob: float  # the tolerance, or the number of intervals
    time_s: float
    cost: float
    error: float  # relative, against the reference independent of the method
    status: str  # "ok", "failed" or "other extremal"


@dataclass(frozen=True)
class Reference:
    scenario: str
    leapfrog: float  # the default planner's answer re-checked at rtol 1e-13
    direct: float  # IPOPT extrapolated in the mesh (REFERENCE_MESHES)

    @property
    def agreement(self) -> float:
        return abs(self.leapfrog - self.direct) / abs(self.direct)


@dataclass(frozen=True)
class WorkPrecisionResult:
    settings: WorkPrecisionSettings
    points: tuple[Point, ...]
    references: tuple[Reference, ...]
    machine: dict
    notes: tuple[str, ...]

    def curve(self, scenario: str, method: str) -> list[Point]:
        return [p for p in self.points if p.scenario == scenario and p.method == method]


def scenarios(settings: WorkPrecisionSettings) -> list[Scenario]:
    from ..batch.generate import GeneratorSpec, generate

    out = [load_scenario(f"paper-case-{c}") for c in settings.cases]
    return out + list(
        generate(GeneratorSpec.preset("general", n=settings.general, seed=settings.seed))
    )


def _final_shooting(tol: float):
    """The final solve's settings for ``|F| <= tol`` (integrator at ``tol / 100``)."""
    fs = LeapfrogSettings().final_shooting
    return replace(
        fs,
        root=replace(fs.root, tol=tol),
        integrator=replace(fs.integrator, rtol=tol / 100, atol=tol / 100),
    )


def reference(sc: Scenario) -> tuple[Reference, object]:
    """The two references of ``sc`` and the default planner's result."""
    res = Planner(sc).plan()
    if not res.success:
        return Reference(sc.name, math.nan, math.nan), res
    check = IntegratorSettings("dop853", rtol=1e-13, atol=1e-13)
    v = validate(sc.problem(), 0.0, sc.start, sc.horizon, sc.goal, res.costate0, 2, check)
    lf = v.cost if v.end_state_error <= 1e-7 else res.cost  # a long shot: the planner's own
    tr = res.trajectory
    costs = []
    for n in REFERENCE_MESHES:
        t = np.linspace(0.0, sc.horizon, n + 1)
        guess = np.column_stack([np.interp(t, tr.t, tr.x[:, i]) for i in range(3)])
        r = cached_transcription(sc.obstacles.shape[0], n).solve(
            sc.start, sc.goal, sc.horizon, sc.footprint_obstacles,
            weight=sc.weight, exponent=sc.exponent,
            guess_states=guess,
        )  # fmt: skip
        costs.append(r.cost if r.success else math.nan)
    return Reference(sc.name, lf, richardson(*costs)), res


def _peers_of(sc: Scenario, s: WorkPrecisionSettings, meshes: list[int]) -> list[tuple]:
    """(method, knob, peer) for every point of ``sc``."""
    out = []
    mnm = "modified-newton"
    for tol in s.leapfrog_tols:
        final = _final_shooting(tol)
        out.append(("leapfrog", tol, peers.leapfrog_peer(sc, mnm, final_shooting=final)))
        one = peers.leapfrog_peer(sc, mnm, final_shooting=final, initial_paths=1)
        out.append(("leapfrog-1path", tol, one))
    for n in meshes:
        out.append(("ipopt", n, peers.direct_peer(sc, n, "paths")))
        out.append(("ipopt-1path", n, peers.direct_peer(sc, n, "path")))
    for tol in s.bvp_tols:
        out.append(("solve_bvp", tol, peers.bvp_peer(sc, "path", tol=tol)))
    return out


def _usable_meshes(sc: Scenario, s: WorkPrecisionSettings, progress) -> list[int]:
    """The meshes, ascending, up to the first whose solve (from the paths) takes too long."""
    kept = []
    for n in sorted(s.meshes):
        progress(f"{sc.name}: IPOPT on {n} intervals (building)")
        peer = peers.direct_peer(sc, n, "paths")
        peer.solve()  # builds the transcriptions, untimed
        t0 = time.perf_counter()
        peer.solve()
        kept.append(n)
        if time.perf_counter() - t0 > s.max_solve_s:
            break
    return kept


def _point(sc, method, knob, outcome, ref: Reference) -> Point:
    against = ref.direct if method.startswith("leapfrog") else ref.leapfrog
    if not outcome.success or not math.isfinite(outcome.cost):
        return Point(sc.name, method, knob, outcome.time_s, math.nan, math.nan, "failed")
    error = abs(outcome.cost - against) / abs(against)
    status = "other extremal" if error > OTHER_EXTREMAL else "ok"
    return Point(sc.name, method, knob, outcome.time_s, outcome.cost, error, status)


def run_work_precision(
    settings: WorkPrecisionSettings | None = None,
    *,
    progress: Callable[[ExperimentEvent], None] | None = None,
) -> WorkPrecisionResult:
    s = settings or WorkPrecisionSettings()
    if not peers.casadi_available():
        raise SettingsError("the work-precision benchmark needs CasADi: pip install '.[bench]'")
    warm_up()
    todo = scenarios(s)
    points, refs, notes = [], [], []
    for k, sc in enumerate(todo):

        def say(label, k=k):
            if progress is not None:
                progress(ExperimentEvent(k, len(todo), label))

        say(f"{sc.name}: references")
        ref, res = reference(sc)
        refs.append(ref)
        if not res.success:
            notes.append(f"{sc.name}: the planner did not converge ({res.status}); skipped")
            continue
        meshes = _usable_meshes(sc, s, say)
        if len(meshes) < len(s.meshes):
            notes.append(f"{sc.name}: meshes above {meshes[-1]} dropped (a solve took > "
                         f"{s.max_solve_s:g} s)")  # fmt: skip
        todo_peers = _peers_of(sc, s, meshes)
        measured = peers.measure([p for _, _, p in todo_peers], s.repeat, progress=say)
        for (method, knob, _), (outcome, _) in zip(todo_peers, measured, strict=True):
            points.append(_point(sc, method, knob, outcome, ref))
        del todo_peers, measured
        clear_transcriptions()  # a scenario's large meshes hold gigabytes
    return WorkPrecisionResult(s, tuple(points), tuple(refs), machine_info(), tuple(notes))


# --------------------------------------------------------------------------- ratios


def _time_at(curve: list[Point], error: float) -> float | None:
    """The time to reach ``error`` on a curve, interpolated log-log between the two points that
    bracket it (the cheapest point at or below it if none brackets it); None if never reached."""
    ok = sorted((p for p in curve if p.status == "ok" and p.error > 0), key=lambda p: p.time_s)
    reached = [p for p in ok if p.error <= error]
    if not reached:
        return None
    first = reached[0]
    before = [p for p in ok if p.time_s < first.time_s and p.error > error]
    if not before:
        return first.time_s
    a = before[-1]
    la, lb = math.log(a.error), math.log(first.error)
    f = (math.log(error) - la) / (lb - la)
    return math.exp(math.log(a.time_s) + f * (math.log(first.time_s) - math.log(a.time_s)))


def _cheapest_within(curve: list[Point], error: float) -> float | None:
    ok = [p.time_s for p in curve if p.status == "ok" and p.error <= error]
    return min(ok) if ok else None


@dataclass(frozen=True)
class Ratio:
    scenario: str
    pair: str  # "full planner vs IPOPT from its paths", "one path vs IPOPT from that path"
    at: str  # "at relative cost error 1e-06", "at IPOPT's accuracy on 100 intervals (...)"
    ratio: float | None  # IPOPT time / Leapfrog time; None: IPOPT never gets there

    @property
    def text(self) -> str:
        value = "unreachable for IPOPT" if self.ratio is None else f"IPOPT {self.ratio:.1f}x slower"
        return f"{self.scenario}, {self.pair}, {self.at}: {value}"


def ratios(result: WorkPrecisionResult) -> list[Ratio]:
    """Per scenario and pair: IPOPT's time over Leapfrog's at relative cost error 1e-6 (on
    IPOPT's curve, interpolated) and at IPOPT's own accuracy on 100 intervals."""
    out = []
    pairs = (
        ("leapfrog", "ipopt", "full planner vs IPOPT from its paths"),
        ("leapfrog-1path", "ipopt-1path", "one path vs IPOPT from that path"),
    )
    for ref in result.references:
        for lf_name, ip_name, label in pairs:
            lf, ip = result.curve(ref.scenario, lf_name), result.curve(ref.scenario, ip_name)
            if not lf or not ip:
                continue
            t_lf = _cheapest_within(lf, TARGET_ERROR)
            t_ip = _time_at(ip, TARGET_ERROR)
            r = None if t_ip is None or t_lf is None else t_ip / t_lf
            out.append(Ratio(ref.scenario, label, f"at relative cost error {TARGET_ERROR:g}", r))
            at100 = [p for p in ip if p.knob == 100 and p.status == "ok"]
            if at100:
                e = at100[0].error
                t_lf = _cheapest_within(lf, e)
                r = None if t_lf is None else at100[0].time_s / t_lf
                at = f"at IPOPT's accuracy on 100 intervals ({e:.1e})"
                out.append(Ratio(ref.scenario, label, at, r))
    return out


# --------------------------------------------------------------------------- files

STYLE = {  # method -> (colour, marker, line style): one colour and one marker per method,
    # a family in one hue (Leapfrog blue/cyan, IPOPT red/orange), one path dotted
    "leapfrog": ("tab:blue", "o", "-"),
    "leapfrog-1path": ("tab:cyan", "D", ":"),
    "ipopt": ("tab:red", "s", "-"),
    "ipopt-1path": ("tab:orange", "v", ":"),
    "solve_bvp": ("tab:green", "^", "-"),
}
LABELS = {
    "leapfrog": "Leapfrog, default planner (over final tol)",
    "leapfrog-1path": "Leapfrog from one path (over final tol)",
    "ipopt": "IPOPT from the same paths (over mesh size)",
    "ipopt-1path": "IPOPT from one path (over mesh size)",
    "solve_bvp": "solve_bvp from one path (over tol)",
}
GID_TARGET = "target-error"


def work_precision_csv(result: WorkPrecisionResult) -> str:
    lines = ["scenario,method,knob,time_s,cost,relative_error,status"]
    for p in result.points:
        lines.append(
            f"{p.scenario},{p.method},{p.knob:g},{p.time_s:.6g},{p.cost!r},{p.error!r},{p.status}"
        )
    return "\n".join(lines) + "\n"


def work_precision_markdown(result: WorkPrecisionResult) -> str:
    m = result.machine
    out = [
        "# Work against precision",
        "",
        f"Machine: {m.get('cores')} cores, load {m.get('load_average')}, Python {m.get('python')}."
        f" Medians of {result.settings.repeat} interleaved rounds.",
        "",
        "Errors are relative to a reference computed apart from the method measured: Leapfrog's "
        "against the direct method's optimum extrapolated in the mesh, the others' against the "
        "Leapfrog answer re-checked at rtol 1e-13.",
        "",
        "## References",
        "",
        "| scenario | Leapfrog at rtol 1e-13 | IPOPT extrapolated (800, 1600) | agreement |",
        "|---|---:|---:|---:|",
    ]
    for r in result.references:
        out.append(f"| {r.scenario} | {r.leapfrog:.10g} | {r.direct:.10g} | {r.agreement:.1e} |")
    out += ["", "## Ratios (IPOPT time / Leapfrog time at the same accuracy)", ""]
    out += [f"- {r.text}" for r in ratios(result)]
    out += [
        "",
        "## Points",
        "",
        "| scenario | method | knob | time (ms) | relative error | status |",
    ]
    out.append("|---|---|---:|---:|---:|---|")
    for p in result.points:
        err = "" if not math.isfinite(p.error) else f"{p.error:.2e}"
        out.append(
            f"| {p.scenario} | {p.method} | {p.knob:g} | {1e3 * p.time_s:.3g} | {err} |"
            f" {p.status} |"
        )
    if result.notes:
        out += ["", "## Notes", ""] + [f"- {n}" for n in result.notes]
    return "\n".join(out) + "\n"


def _wp_legend_handles(result: WorkPrecisionResult) -> list:
    """A line per method drawn in any panel, the target error's line, and grey markers for
    'another extremal' and 'failed' when a panel shows one."""
    from matplotlib.lines import Line2D

    drawn = {p.method for p in result.points}
    handles = [
        Line2D([], [], color=STYLE[m][0], marker=STYLE[m][1], ls=STYLE[m][2], ms=5, lw=1.4,
               label=LABELS[m])
        for m in METHODS
        if m in drawn
    ]  # fmt: skip
    target = f"{TARGET_ERROR:.0e}".replace("e-0", "e-")
    handles.append(Line2D([], [], color="0.5", lw=0.8, ls="--",
                          label=f"relative error {target}, the ratios' target"))  # fmt: skip
    status = {p.status for p in result.points}
    if "other extremal" in status:
        handles.append(Line2D([], [], ls="none", marker="o", mfc="none", color="0.3", ms=6,
                              label="open marker: another extremal (> 1% off)"))  # fmt: skip
    if "failed" in status:
        handles.append(Line2D([], [], ls="none", marker="x", color="0.3", ms=6,
                              label="x at error 1: failed"))  # fmt: skip
    return handles


def work_precision_figure(result: WorkPrecisionResult):
    """Time against relative cost error, log-log, one panel per scenario; failures as crosses
    at error 1, other extremals as open markers. One legend below the panels for them all."""
    from ..viz.style import legend_below, new_figure

    names = [r.scenario for r in result.references]
    cols = min(4, max(1, len(names)))
    rows = math.ceil(len(names) / cols)
    fig = new_figure(figsize=(max(4.2 * cols, 6.4), 3.6 * rows + 0.5))  # room for the title
    axes = fig.subplots(rows, cols, squeeze=False).ravel()
    for ax, name in zip(axes, names, strict=False):
        for method in METHODS:
            curve = sorted(result.curve(name, method), key=lambda p: p.knob)
            color, marker, ls = STYLE[method]
            ok = [p for p in curve if p.status == "ok" and p.error > 0]
            if ok:
                ax.plot([p.error for p in ok], [p.time_s for p in ok], color=color,
                        marker=marker, ls=ls, ms=4, lw=1.2, label=LABELS[method],
                        gid=method)  # fmt: skip
            other = [p for p in curve if p.status == "other extremal"]
            if other:
                ax.plot([p.error for p in other], [p.time_s for p in other], ls="none",
                        marker=marker, mfc="none", color=color, ms=6,
                        gid=f"{method}:other")  # fmt: skip
            failed = [p for p in curve if p.status == "failed"]
            if failed:
                ax.plot([1.0] * len(failed), [p.time_s for p in failed], ls="none", marker="x",
                        color=color, ms=6, gid=f"{method}:failed")  # fmt: skip
        ax.axvline(TARGET_ERROR, color="0.5", lw=0.8, ls="--", gid=GID_TARGET)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_title(name, fontsize="medium")
        ax.set_xlabel("relative cost error |J / J_ref - 1|")
        ax.set_ylabel("time (s)")
        ax.grid(True, which="major", alpha=0.3)
    for ax in axes[len(names) :]:
        ax.set_visible(False)
    w, h = fig.get_size_inches()
    legend_below(fig, _wp_legend_handles(result), lambda lh: (w, h + lh), max_cols=3)
    fig.suptitle("Work against precision: time against relative cost error")
    return fig


def write_work_precision(result: WorkPrecisionResult, folder) -> list:
    """``work_precision.png``, ``.csv`` and ``.md`` in ``folder`` (created), each atomically."""
    from pathlib import Path

    from .._atomic import write_atomic, write_text_atomic

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    out = []
    for name, text in (
        ("work_precision.csv", work_precision_csv(result)),
        ("work_precision.md", work_precision_markdown(result)),
    ):
        path = folder / name
        write_text_atomic(path, text)
        out.append(path)
    fig = work_precision_figure(result)
    path = folder / "work_precision.png"
    write_atomic(path, lambda tmp: fig.savefig(tmp, format="png", dpi=120))
    return out + [path]
