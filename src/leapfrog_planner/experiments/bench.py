"""The peer benchmark: Leapfrog against plain shooting, ``solve_bvp`` and a direct method.

:func:`run_bench` runs every solver of :mod:`.peers` on the paper cases and a seeded set of random
scenarios in one process, measures the floor (one simple shooting from Leapfrog-MNM's converged
costates) and profiles one Leapfrog solve (:mod:`.profiling`). :func:`write_bench` writes
``bench.md``, ``bench.csv``, ``bench.json`` and ``bench.png`` (time and cost per solver).
:func:`target_ratios` gives the issue's two performance ratios per paper case.
"""

from __future__ import annotations

import csv
import io
import json
import math
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from .._atomic import write_text_atomic
from ..errors import SettingsError, require_integer
from ..planning.scenario import Scenario, load_scenario
from . import peers
from .paper import ExperimentEvent, machine_info, paper_cases, warm_up
from .peers import PeerOutcome
from .profiling import PARTS, ProfileSplit, profile_split

__all__ = ["SOLVERS", "BenchResult", "BenchSettings", "run_bench", "target_ratios", "write_bench"]

SOLVERS = (
    "leapfrog-mnm",
    "leapfrog-mnm-1path",
    "leapfrog-nm",
    "leapfrog-nleq-err",
    "shooting",
    "bvp",
    "direct",
)
LEAPFROG = {  # solver -> (method, planner options)
    "leapfrog-mnm": ("modified-newton", {}),
    "leapfrog-mnm-1path": ("modified-newton", {"initial_paths": 1}),
    "leapfrog-nm": ("newton", {}),
    "leapfrog-nleq-err": ("nleq-err", {}),
}
CASADI_MISSING = (
    "CasADi is not installed, so the direct-method rows are skipped: "
    "pip install 'leapfrog-planner[bench]'"
)
# Performance targets of the issue, as ratios.
TARGET_DIRECT_SPEEDUP, GOAL_DIRECT_SPEEDUP, TARGET_FLOOR_RATIO = 1.0, 10.0, 5.0
FLOOR_SOLVES = 10  # timed floor solves per scenario, at least


@dataclass(frozen=True)
class BenchSettings:
    cases: tuple[int, ...] = (1, 2, 3, 4)  # paper cases
    random: int = 5  # seeded random scenarios
    seed: int = 0
    repeat: int = 3  # timed repetitions after a warm-up; the median is reported
    solvers: tuple[str, ...] = SOLVERS
    meshes: tuple[int, ...] = (100, 200)  # direct-method intervals
    profile: bool = True

    def __post_init__(self):
        cases = paper_cases(self.cases, allow_none=True)
        object.__setattr__(self, "cases", cases)
        object.__setattr__(self, "random", require_integer("random", self.random, 0))
        object.__setattr__(self, "seed", require_integer("seed", self.seed, 0))
        object.__setattr__(self, "repeat", require_integer("repeat", self.repeat, 1))
        unknown = sorted(set(self.solvers) - set(SOLVERS))
        if unknown or not self.solvers:
            raise SettingsError(
                f"unknown solver {unknown[0] if unknown else None!r} (known: {', '.join(SOLVERS)})"
            )
        object.__setattr__(self, "solvers", tuple(s for s in SOLVERS if s in self.solvers))
        meshes = tuple(require_integer("meshes", m, 2) for m in self.meshes)
        if not meshes:
            raise SettingsError("meshes: at least one mesh size is needed")
        object.__setattr__(self, "meshes", meshes)
        if not cases and not self.random:
            raise SettingsError("nothing to run: no paper case and no random scenario")


@dataclass(frozen=True)
class BenchResult:
    settings: BenchSettings
    scenarios: tuple[str, ...]
    outcomes: tuple[PeerOutcome, ...]
    floors: tuple[PeerOutcome, ...]  # shooting from Leapfrog-MNM's converged costates
    profile: ProfileSplit | None
    notes: tuple[str, ...]
    machine: dict
    wall_time_s: float

    def outcome(self, scenario: str, solver: str) -> PeerOutcome | None:
        for o in self.outcomes:
            if o.scenario == scenario and o.solver == solver:
                return o
        return None


def _units(settings: BenchSettings, have_casadi: bool) -> list[str]:
    units = [s for s in settings.solvers if s in LEAPFROG]
    if "shooting" in settings.solvers:
        units.append("shooting")
    if "bvp" in settings.solvers:
        units += ["bvp-line", "bvp-path"]
    if "direct" in settings.solvers and have_casadi:
        units += [f"direct-N{n}-{g}" for n in settings.meshes for g in ("line", "path", "paths")]
    return units


def _peer(unit: str, sc: Scenario) -> peers.Peer:
    if unit in LEAPFROG:
        method, options = LEAPFROG[unit]
        return peers.leapfrog_peer(sc, method, solver=unit, **options)
    if unit == "shooting":
        return peers.shooting_peer(sc)
    if unit.startswith("bvp-"):
        return peers.bvp_peer(sc, unit[4:])
    n, start_from = unit[len("direct-N") :].split("-")
    return peers.direct_peer(sc, int(n), start_from)


def _measured(sc: Scenario, units: list[str], repeat: int, step) -> tuple[list, list]:
    """Every unit on ``sc``, timed in interleaved rounds (:func:`peers.measure`), and the floor
    from Leapfrog-MNM's answer: (outcomes, [floor outcome] or [])."""

    def floor(values):
        # From the warm-up's answer: the timed solves give the same, the planner is deterministic.
        res = values[units.index("leapfrog-mnm")] if "leapfrog-mnm" in units else None
        if res is None or not res.success:
            return []
        # Timed about ten times per scenario: it takes well under a millisecond.
        per_round = math.ceil(FLOOR_SOLVES / repeat)
        return [peers.shooting_peer(sc, res.costate0, "floor", per_round=per_round)]

    measured = peers.measure([_peer(u, sc) for u in units], repeat, more=floor, progress=step)
    return [o for o, _ in measured[: len(units)]], [o for o, _ in measured[len(units) :]]


def run_bench(
    settings: BenchSettings | None = None,
    *,
    progress: Callable[[ExperimentEvent], None] | None = None,
) -> BenchResult:
    settings = settings or BenchSettings()
    t0 = time.perf_counter()
    have_casadi = peers.casadi_available()
    notes = []
    if "direct" in settings.solvers and not have_casadi:
        notes.append(CASADI_MISSING)
    scenarios = [load_scenario(f"paper-case-{k}") for k in settings.cases]
    scenarios += peers.random_scenarios(settings.random, settings.seed)
    units = _units(settings, have_casadi)
    # Per scenario: each unit's warm-up, the floor's warm-up (when Leapfrog-MNM runs), rounds.
    steps = len(units) + ("leapfrog-mnm" in units) + settings.repeat
    total = len(scenarios) * steps + settings.profile
    done = 0

    def emit(label):
        if progress is not None:
            progress(ExperimentEvent(done, total, label))

    emit("warm-up (loading compiled kernels)")
    warm_up()
    outcomes, floors = [], []

    def step_of(name: str):
        def step(label: str):
            nonlocal done
            emit(f"{name}: {label}")
            done += 1

        return step

    for k, sc in enumerate(scenarios):
        outs, floor = _measured(sc, units, settings.repeat, step_of(sc.name))
        outcomes += outs
        floors += floor
        done = (k + 1) * steps  # a skipped floor still counts its step
    split = None
    if settings.profile:
        case = f"paper-case-{settings.cases[-1]}" if settings.cases else scenarios[-1]
        emit(f"profiling one Leapfrog solve ({getattr(case, 'name', case)})")
        split = profile_split(case)
        done += 1
    emit("done")
    return BenchResult(
        settings=settings,
        scenarios=tuple(sc.name for sc in scenarios),
        outcomes=tuple(outcomes),
        floors=tuple(floors),
        profile=split,
        notes=tuple(notes),
        machine=machine_info(),
        wall_time_s=time.perf_counter() - t0,
    )


# --------------------------------------------------------------------------- ratios


@dataclass(frozen=True)
class RatioLine:
    scenario: str
    kind: str  # "direct" or "floor"
    leapfrog: str  # the Leapfrog solver measured
    against: str  # the solver compared with
    ratio: float  # direct: direct time / Leapfrog time (speed-up); floor: Leapfrog / floor time
    leapfrog_cost: float
    other_cost: float
    passed: bool
    text: str


_SAME_START = {("leapfrog-mnm", "paths"), ("leapfrog-mnm-1path", "path")}


def _direct_line(name: str, lf: PeerOutcome, o: PeerOutcome) -> RatioLine:
    speed = o.time_s / lf.time_s
    cost_ok = lf.success and (not o.success or lf.cost <= o.cost * (1 + 1e-6) + 1e-12)
    passed = lf.success and speed >= TARGET_DIRECT_SPEEDUP and cost_ok
    other = f"{o.cost:.6f}" if o.success else f"{o.solver} failed"
    same = (lf.solver, o.solver.rsplit("-", 1)[-1]) in _SAME_START
    text = (
        f"{name}{' (same initial paths)' if same else ''}: {o.solver} time / {lf.solver} time = "
        f"{o.time_s * 1e3:.1f} / "
        f"{lf.time_s * 1e3:.1f} ms = {speed:.2f}x (target >= {TARGET_DIRECT_SPEEDUP:g}x, goal "
        f"{GOAL_DIRECT_SPEEDUP:g}x); cost {lf.cost:.6f} vs {other} -> "
        f"{'PASS' if passed else 'MISS'}"
    )
    return RatioLine(name, "direct", lf.solver, o.solver, speed, lf.cost, o.cost, passed, text)


def target_ratios(result: BenchResult) -> list[RatioLine]:
    """The issue's ratios per paper case, from this run's figures: Leapfrog-MNM against each
    direct-method row, MNM from one initial path (when run) against the rows from the line and
    from that path, and MNM against the floor. The like-for-like pairs start from the same
    paths: ``leapfrog-mnm`` and ``direct-*-paths``, ``leapfrog-mnm-1path`` and ``direct-*-path``.
    """
    lines = []
    floors = {f.scenario: f for f in result.floors}
    for name in result.scenarios:
        if not name.startswith("paper-case-"):
            continue
        for solver in ("leapfrog-mnm", "leapfrog-mnm-1path"):
            lf = result.outcome(name, solver)
            if lf is None:
                continue
            for o in result.outcomes:
                # One path against IPOPT from three would say nothing.
                one_vs_all = solver.endswith("-1path") and o.solver.endswith("-paths")
                if o.scenario == name and o.solver.startswith("direct-") and not one_vs_all:
                    lines.append(_direct_line(name, lf, o))
        mnm, f = result.outcome(name, "leapfrog-mnm"), floors.get(name)
        if mnm is not None and f is not None:
            ratio = mnm.time_s / f.time_s
            passed = ratio <= TARGET_FLOOR_RATIO
            text = (
                f"{name}: leapfrog-mnm time / floor (one simple shooting from the converged "
                f"costates) = {mnm.time_s * 1e3:.1f} / {f.time_s * 1e3:.2f} ms = {ratio:.0f}x "
                f"(target <= {TARGET_FLOOR_RATIO:g}x) -> {'PASS' if passed else 'MISS'}"
            )
            lines.append(
                RatioLine(name, "floor", "leapfrog-mnm", "floor", ratio, mnm.cost, f.cost,
                          passed, text)
            )  # fmt: skip
    return lines


def summary_rows(result: BenchResult) -> list[tuple]:
    """Per solver: successes, scenarios where it found the best optimum (within 1e-3, the
    direct method's mesh error), and the median of its median times."""
    best = _best_costs(result)
    rows = []
    for solver in dict.fromkeys(o.solver for o in result.outcomes):
        outs = [o for o in result.outcomes if o.solver == solver]
        ok = [o for o in outs if o.success]
        at_best = sum(o.scenario in best and o.cost <= best[o.scenario] * (1 + 1e-3) for o in ok)
        times = [o.time_s for o in outs]
        rows.append((solver, len(ok), at_best, len(outs), float(np.median(times))))
    return rows


# --------------------------------------------------------------------------- outputs


def _best_costs(result: BenchResult) -> dict[str, float]:
    best = {}
    for o in result.outcomes:
        if o.success and math.isfinite(o.cost):
            best[o.scenario] = min(best.get(o.scenario, math.inf), o.cost)
    return best


def _fmt(v: float, spec: str) -> str:
    return "-" if v is None or not math.isfinite(v) else format(v, spec)


def _machine_text(result: BenchResult) -> str:
    m = result.machine
    return (
        f"Machine: {m['cores']} cores, load average {m['load_average']} at the end, "
        f"Python {m['python']}, {m['platform']}. Times: median of {result.settings.repeat} "
        f"solves after a warm-up (a failed warm-up is timed once), the solvers of a scenario "
        f"timed in turn, round after round. Whole run {result.wall_time_s:.0f} s."
    )


def bench_markdown(result: BenchResult) -> str:
    best = _best_costs(result)
    lines = ["# Peer benchmark", ""]
    lines += [f"**Note:** {n}" for n in result.notes] + ([""] if result.notes else [])
    lines += [
        "Every solver on the same problem (the minimum-energy problem of the README) in one "
        "process. Cost relative to the best successful cost of the scenario; end-state error "
        "re-integrated (see `leapfrog_planner.experiments.peers`). Direct-method costs carry the "
        "mesh's O(h^2) error.",
        "",
        "## Summary",
        "",
        "| solver | succeeded | found the best optimum (1e-3) | median time (ms) |",
        "|---|---|---|---|",
    ]
    for solver, ok, at_best, n, t in summary_rows(result):
        lines.append(f"| {solver} | {ok}/{n} | {at_best}/{n} | {t * 1e3:.1f} |")
    lines.append("")
    for name in result.scenarios:
        lines += [
            f"## {name}",
            "",
            "| solver | success | cost | cost / best - 1 | end-state error | median time (ms) "
            "| message |",
            "|---|---|---|---|---|---|---|",
        ]
        for o in result.outcomes:
            if o.scenario != name:
                continue
            rel = (o.cost - best[name]) / abs(best[name]) if name in best else math.nan
            msg = o.message.replace("|", "\\|")
            lines.append(
                f"| {o.solver} | {'yes' if o.success else '**no**'} | {_fmt(o.cost, '.6f')} "
                f"| {_fmt(rel, '.1e')} | {_fmt(o.end_state_error, '.1e')} "
                f"| {o.time_s * 1e3:.1f} | {msg} |"
            )
        lines.append("")
    ratios = target_ratios(result)
    if ratios:
        lines += [
            "## Performance targets (ratios measured in this run)",
            "",
            "IPOPT starts from the straight line (`-line`), from the planner's first initial path "
            "(`-path`, the start of `leapfrog-mnm-1path`), or from each of the planner's initial "
            "paths in one thread per path, the cheapest kept (`-paths`, the search of "
            "`leapfrog-mnm`). The pairs that start from the same paths are marked.",
            "",
        ]
        lines += [f"- {r.text}" for r in ratios] + [""]
    if result.profile is not None:
        lines += profile_markdown(result.profile)
    lines += [_machine_text(result), ""]
    return "\n".join(lines)


def profile_markdown(p: ProfileSplit) -> list[str]:
    lines = [
        f"## Where the time goes: one Leapfrog solve of {p.scenario} ({p.method})",
        "",
        f"Wall time {p.wall_s * 1e3:.0f} ms with the initial paths run one after the other "
        "(`threads=1`), split by timers around the functions of each part (exclusive; see "
        "`leapfrog_planner.experiments.profiling`).",
        "",
        "| part | time (ms) | share | calls |",
        "|---|---|---|---|",
    ]
    for part in PARTS:
        calls = p.calls.get(part, "")
        lines.append(
            f"| {part.replace('_', ' ')} | {p.parts_s[part] * 1e3:.1f} "
            f"| {100 * p.fraction(part):.1f}% | {calls} |"
        )
    n = p.integrations
    t_int = p.parts_s["integration"]
    lines += [
        "",
        f"Integrations: {n} ({p.jacobian_calls} with the variational equations), {p.steps} "
        f"accepted steps, {p.steps / max(n, 1):.1f} steps and "
        f"{1e6 * t_int / max(p.steps, 1):.2f} us per step on average.",
    ]
    lines += ["", "cProfile, most expensive functions (cumulative):", "", "```"]
    lines += [p.top_functions.strip(), "```", ""]
    return lines


CSV_COLUMNS = ("scenario", "solver", "success", "cost", "cost_rel_best", "end_state_error",
               "median_time_s", "times_s", "message")  # fmt: skip


def bench_csv(result: BenchResult) -> str:
    best = _best_costs(result)
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(CSV_COLUMNS)
    for o in result.outcomes + result.floors:
        rel = (o.cost - best[o.scenario]) / abs(best[o.scenario]) if o.scenario in best else ""
        w.writerow([o.scenario, o.solver, o.success, repr(o.cost), repr(rel),
                    repr(o.end_state_error), repr(o.time_s),
                    " ".join(repr(t) for t in o.times_s), o.message])  # fmt: skip
    return buf.getvalue()


def bench_json(result: BenchResult) -> str:
    def clean(v):
        if isinstance(v, float) and not math.isfinite(v):
            return None
        if isinstance(v, dict):
            return {k: clean(x) for k, x in v.items()}
        if isinstance(v, list | tuple):
            return [clean(x) for x in v]
        return v

    data = {
        "settings": asdict(result.settings),
        "machine": result.machine,
        "notes": list(result.notes),
        "outcomes": [asdict(o) for o in result.outcomes],
        "floors": [asdict(o) for o in result.floors],
        "ratios": [asdict(r) for r in target_ratios(result)],
        "profile": None if result.profile is None else asdict(result.profile),
        "wall_time_s": result.wall_time_s,
    }
    return json.dumps(clean(data), indent=1, allow_nan=False)


FLOOR_REL = 1e-10  # relative cost differences below this are shown at this height
FAILED_HATCH = "//"


def solver_colors(n: int) -> list:
    """``n`` pairwise distinct colours: the report figures' ten (``batch.report.method_style``,
    Matplotlib's tab10) first, then the light tab20 shades and tab20b/tab20c (60 in all, then
    again). The benchmark has up to 13 solver rows with two meshes."""
    from matplotlib import colormaps
    from matplotlib.colors import to_hex

    from ..batch.report import method_style

    palette = [to_hex(method_style(k)["color"]) for k in range(10)]
    palette += [to_hex(colormaps["tab20"](2 * j + 1)) for j in range(10)]
    for name in ("tab20b", "tab20c"):
        palette += [to_hex(c) for c in colormaps[name].colors]
    palette = list(dict.fromkeys(palette))
    return [palette[k % len(palette)] for k in range(n)]


def bench_figure(result: BenchResult):
    """Median time (log scale) and cost relative to the best, per scenario and solver: a bar per
    solver in its own colour; a failed solve's time bar hatched and unfilled, its cost an x. The
    legend below the axes names the solvers (plain swatches) and, when a solve failed, the
    hatching."""
    from matplotlib.patches import Patch

    from ..viz.style import legend_below, new_figure

    solvers = list(dict.fromkeys(o.solver for o in result.outcomes))
    colors = solver_colors(len(solvers))
    names = list(result.scenarios)
    best = _best_costs(result)
    fig = new_figure(figsize=(max(8.0, 1.3 * len(names) + 2), 7.0))
    ax_t, ax_c = fig.subplots(2, 1, sharex=True)
    width = 0.8 / max(1, len(solvers))
    x = np.arange(len(names))
    any_failed = False
    for k, (s, color) in enumerate(zip(solvers, colors, strict=True)):
        t, rel, fail = [], [], []
        for name in names:
            o = result.outcome(name, s)
            ok = o is not None and o.success
            t.append(o.time_s if o is not None else np.nan)
            r = (o.cost - best[name]) / abs(best[name]) if ok and name in best else np.nan
            rel.append(max(r, FLOOR_REL) if ok else np.nan)
            fail.append(o is not None and not o.success)
        pos = x + (k - (len(solvers) - 1) / 2) * width
        bars = ax_t.bar(pos, t, width, color=color, gid=f"time:{s}")
        for b, f in zip(bars, fail, strict=True):
            if f:  # unfilled, hatched in the solver's colour
                b.set(facecolor="white", edgecolor=color, hatch=FAILED_HATCH, lw=0.8)
        ax_c.bar(pos, rel, width, color=color, gid=f"cost:{s}")
        if any(fail):
            any_failed = True
            ax_c.plot(pos[np.array(fail)], np.full(sum(fail), FLOOR_REL), ls="none", marker="x",
                      color=color, ms=7, mew=1.5, gid=f"failed:{s}")  # fmt: skip
    ax_t.set_yscale("log")
    ax_t.set_ylabel("median time (s)")
    ax_c.set_yscale("log")
    ax_c.set_ylim(FLOOR_REL / 3, None)
    ax_c.set_ylabel(f"cost / best cost - 1\n(floored at {FLOOR_REL:g})")
    ax_c.set_xticks(
        x, names, rotation=30 if len(names) > 1 else 0, ha="right" if len(names) > 1 else "center"
    )
    handles = [
        Patch(facecolor=c, edgecolor="none", label=s) for s, c in zip(solvers, colors, strict=True)
    ]
    if any_failed:
        handles.append(Patch(facecolor="white", edgecolor="0.3", hatch=FAILED_HATCH,
                             label="failed (hatched time bar, x for the cost)"))  # fmt: skip
    w, h = fig.get_size_inches()
    legend_below(fig, handles, lambda lh: (w, h + lh), max_cols=5)
    fig.suptitle("Peer benchmark: time and cost per scenario")
    return fig


def write_bench(result: BenchResult, out: Path | str) -> list[Path]:
    from ..viz.plots import save_figure

    out = Path(out)
    written = []
    for name, text in (
        ("bench.md", bench_markdown(result)),
        ("bench.csv", bench_csv(result)),
        ("bench.json", bench_json(result)),
    ):
        write_text_atomic(out / name, text)
        written.append(out / name)
    written.append(save_figure(bench_figure(result), out / "bench.png"))
    return written
