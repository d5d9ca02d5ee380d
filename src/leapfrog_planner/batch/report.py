"""Statistics of a sweep's results file: per method and paired between methods.

``build_report(records)`` (records as :func:`.sweep_store.read_records` gives them) computes:

- per method: runs, successes and the success rate with its 95% Wilson interval (a success is a
  converged run whose path clears every obstacle: a record that says converged but has a
  negative ``min_clearance``, as other solvers' may, counts as a failure, ``collides``); the cost
  relative to the best cost any method found on the same scenario (converged runs only); the
  solver's wall time; Newton iterations;
- per pair of methods, on the scenarios both ran: who succeeds where the other fails, with the
  exact McNemar test (a binomial test on the discordant scenarios); on scenarios both solved,
  which is cheaper (relative difference over ``COST_TIE``) and which is faster, each with the
  Wilcoxon signed-rank test of the paired differences.

``Report.to_markdown()`` renders it; ``save_report(report, folder)`` writes ``report.md`` and the
figures ``success.png`` (rates with intervals), ``cost_ratio_ecdf.png`` and ``time_ecdf.png``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from .._atomic import write_atomic, write_text_atomic
from ..errors import LeapfrogError

__all__ = [
    "COST_TIE",
    "MethodStats",
    "PairStats",
    "Report",
    "ReportError",
    "build_report",
    "save_report",
    "wilson_interval",
]

#: Costs within this relative difference count as equal (the same extremal, found twice).
COST_TIE = 1e-6


class ReportError(LeapfrogError, ValueError):
    """No records, or records without the fields a report needs."""


def wilson_interval(k: int, n: int, confidence: float = 0.95) -> tuple[float, float]:
    """Wilson score interval of a binomial proportion (``(nan, nan)`` when ``n == 0``)."""
    if n == 0:
        return math.nan, math.nan
    from scipy.stats import binomtest

    ci = binomtest(k, n).proportion_ci(confidence_level=confidence, method="wilson")
    return float(ci.low), float(ci.high)


@dataclass(frozen=True)
class Quantiles:
    n: int
    median: float
    p90: float
    mean: float
    max: float

    @classmethod
    def of(cls, values) -> Quantiles:
        v = np.asarray([x for x in values if x is not None and math.isfinite(x)], dtype=float)
        if v.size == 0:
            return cls(0, math.nan, math.nan, math.nan, math.nan)
        return cls(
            int(v.size),
            float(np.median(v)),
            float(np.quantile(v, 0.9)),
            float(v.mean()),
            float(v.max()),
        )


@dataclass(frozen=True)
class MethodStats:
    method: str
    runs: int
    converged: int
    success_rate: float
    ci_low: float
    ci_high: float
    failures: dict[str, int]  # by reason
    best_found: int  # converged runs whose cost is the scenario's best (within COST_TIE)
    cheaper_seen: int  # converged runs that saw a cheaper collision-free motion (cheaper_motion)
    cost_ratio: Quantiles  # cost / best cost on the scenario, converged runs
    time_s: Quantiles  # solver wall time, all runs
    time_converged_s: Quantiles
    iterations: Quantiles  # Newton iterations, all runs that report them
    total_time_s: float


@dataclass(frozen=True)
class PairStats:
    a: str
    b: str
    scenarios: int  # run by both
    both_converged: int
    only_a: int
    only_b: int
    neither: int
    mcnemar_p: float  # exact two-sided, on only_a vs only_b
    a_cheaper: int  # among both converged
    b_cheaper: int
    cost_ties: int
    cost_wilcoxon_p: float
    a_faster: int  # among both converged
    b_faster: int
    median_time_ratio: float  # median over scenarios of time_a / time_b, both converged
    time_wilcoxon_p: float
    # The three p-values Holm-adjusted over every test of the report (all pairs): read these
    # when several pairs are compared, not the raw ones.
    holm: tuple[float, float, float] = (math.nan, math.nan, math.nan)


@dataclass(frozen=True)
class Report:
    runs: int
    scenarios: int
    methods: tuple[MethodStats, ...]
    pairs: tuple[PairStats, ...]
    cost_ratios: dict[str, tuple[float, ...]]  # per method, for the ECDF figure
    times: dict[str, tuple[float, ...]]

    def method(self, name: str) -> MethodStats:
        for m in self.methods:
            if m.method == name:
                return m
        raise KeyError(name)

    def pair(self, a: str, b: str) -> PairStats:
        for p in self.pairs:
            if (p.a, p.b) == (a, b):
                return p
        raise KeyError((a, b))

    def to_markdown(self) -> str:
        return _markdown(self)


def holm(pvalues) -> list[float]:
    """Holm's step-down adjustment of ``pvalues`` (NaN left out of the family and kept NaN):
    the k-th smallest of m is multiplied by m - k + 1, made non-decreasing, capped at 1."""
    p = [float(v) for v in pvalues]
    order = sorted((i for i, v in enumerate(p) if not math.isnan(v)), key=lambda i: p[i])
    m, out, running = len(order), [math.nan] * len(p), 0.0
    for k, i in enumerate(order):
        running = max(running, min(1.0, (m - k) * p[i]))
        out[i] = running
    return out


def summary_text(rep: Report) -> str:
    """A few lines for the terminal: per method, success with its interval, best optima found
    and median time; per pair, who solves more, is cheaper and faster, with Holm-adjusted p."""
    lines = [f"{rep.runs} runs on {rep.scenarios} scenarios"]
    for m in rep.methods:
        lines.append(
            f"  {m.method}: converged {m.converged}/{m.runs} ({100 * m.success_rate:.1f}%, 95% CI"
            f" {100 * m.ci_low:.1f}-{100 * m.ci_high:.1f}%), best optimum {m.best_found},"
            f" median time {_f(m.time_s.median)} s"
        )
    for p in rep.pairs:
        ps, pc, pt = (_p(v) for v in p.holm)
        lines.append(
            f"  {p.a} vs {p.b}: only {p.a} {p.only_a}, only {p.b} {p.only_b} (p {ps});"
            f" cheaper {p.a_cheaper}/{p.b_cheaper} (p {pc}); time ratio"
            f" {_f(p.median_time_ratio, '.3g')} (p {pt})"
        )
    if rep.pairs:
        lines.append("  (p: exact McNemar and Wilcoxon tests, Holm-adjusted over all of them)")
    return "\n".join(lines)


def _wilcoxon(d: np.ndarray) -> float:
    """Two-sided Wilcoxon signed-rank p-value; nan when there is nothing to test."""
    d = d[np.isfinite(d) & (d != 0)]
    if d.size == 0:
        return math.nan
    from scipy.stats import wilcoxon

    return float(wilcoxon(d).pvalue)


def build_report(records: list[dict]) -> Report:
    if not records:
        raise ReportError("no records")
    for i, r in enumerate(records):
        for k in ("scenario", "method", "status"):
            if k not in r:
                raise ReportError(f"record {i + 1} has no {k!r}")
    methods = list(dict.fromkeys(r["method"] for r in records))
    by = {(r["scenario"], r["method"]): r for r in records}
    scenarios = list(dict.fromkeys(r["scenario"] for r in records))

    def ok(r):
        return (
            r is not None
            and r["status"] == "converged"
            and r.get("cost") is not None
            and (r.get("min_clearance") is None or r["min_clearance"] >= 0.0)
        )

    best = {}
    for s in scenarios:
        costs = [by[(s, m)]["cost"] for m in methods if ok(by.get((s, m)))]
        if costs:
            best[s] = min(costs)

    def is_best(r):
        b = best[r["scenario"]]
        return r["cost"] - b <= COST_TIE * max(1.0, abs(b))

    stats, ratios, times = [], {}, {}
    for m in methods:
        rs = [r for r in records if r["method"] == m]
        conv = [r for r in rs if ok(r)]
        lo, hi = wilson_interval(len(conv), len(rs))
        failures: dict[str, int] = {}
        for r in rs:
            if not ok(r):
                collided = r["status"] == "converged"  # with a negative clearance
                reason = r.get("failure") or ("collides" if collided else "solver")
                failures[reason] = failures.get(reason, 0) + 1
        ratio = [r["cost"] / best[r["scenario"]] for r in conv if best[r["scenario"]] > 0]
        ratios[m] = tuple(ratio)
        t_all = [r.get("wall_time_s") for r in rs]
        times[m] = tuple(t for t in t_all if t is not None)
        stats.append(
            MethodStats(
                method=m,
                runs=len(rs),
                converged=len(conv),
                success_rate=len(conv) / len(rs),
                ci_low=lo,
                ci_high=hi,
                failures=dict(sorted(failures.items())),
                best_found=sum(1 for r in conv if is_best(r)),
                cheaper_seen=sum(1 for r in conv if r.get("cheaper_motion") is not None),
                cost_ratio=Quantiles.of(ratio),
                time_s=Quantiles.of(t_all),
                time_converged_s=Quantiles.of(r.get("wall_time_s") for r in conv),
                iterations=Quantiles.of(r.get("newton_iterations") for r in rs),
                total_time_s=float(sum(t for t in times[m])),
            )
        )

    pairs = []
    for i, a in enumerate(methods):
        for b in methods[i + 1 :]:
            pairs.append(_pair(a, b, scenarios, by, ok))
    raw = [v for p in pairs for v in (p.mcnemar_p, p.cost_wilcoxon_p, p.time_wilcoxon_p)]
    adjusted = holm(raw)
    pairs = [replace(p, holm=tuple(adjusted[3 * k : 3 * k + 3])) for k, p in enumerate(pairs)]
    return Report(
        runs=len(records),
        scenarios=len(scenarios),
        methods=tuple(stats),
        pairs=tuple(pairs),
        cost_ratios=ratios,
        times=times,
    )


def _pair(a, b, scenarios, by, ok) -> PairStats:
    from scipy.stats import binomtest

    common = [s for s in scenarios if (s, a) in by and (s, b) in by]
    both, only_a, only_b, neither = [], 0, 0, 0
    for s in common:
        ra, rb = by[(s, a)], by[(s, b)]
        if ok(ra) and ok(rb):
            both.append((ra, rb))
        elif ok(ra):
            only_a += 1
        elif ok(rb):
            only_b += 1
        else:
            neither += 1
    disc = only_a + only_b
    mcnemar = float(binomtest(only_a, disc, 0.5).pvalue) if disc else math.nan
    ca = np.array([ra["cost"] for ra, _ in both], dtype=float)
    cb = np.array([rb["cost"] for _, rb in both], dtype=float)
    scale = np.maximum(1.0, np.abs(np.minimum(ca, cb)))
    rel = (ca - cb) / scale
    a_cheaper = int(np.sum(rel < -COST_TIE))
    b_cheaper = int(np.sum(rel > COST_TIE))
    rel_test = np.where(np.abs(rel) <= COST_TIE, 0.0, ca - cb)
    ta = np.array([_t(ra) for ra, _ in both], dtype=float)
    tb = np.array([_t(rb) for _, rb in both], dtype=float)
    tvalid = np.isfinite(ta) & np.isfinite(tb) & (tb > 0)
    return PairStats(
        a=a,
        b=b,
        scenarios=len(common),
        both_converged=len(both),
        only_a=only_a,
        only_b=only_b,
        neither=neither,
        mcnemar_p=mcnemar,
        a_cheaper=a_cheaper,
        b_cheaper=b_cheaper,
        cost_ties=len(both) - a_cheaper - b_cheaper,
        cost_wilcoxon_p=_wilcoxon(rel_test),
        a_faster=int(np.sum(ta[tvalid] < tb[tvalid])),
        b_faster=int(np.sum(ta[tvalid] > tb[tvalid])),
        median_time_ratio=float(np.median(ta[tvalid] / tb[tvalid])) if tvalid.any() else math.nan,
        time_wilcoxon_p=_wilcoxon((ta - tb)[tvalid]),
    )


def _t(r) -> float:
    t = r.get("wall_time_s")
    return math.nan if t is None else float(t)


# --------------------------------------------------------------------------- rendering


def _f(v, fmt=".4g") -> str:
    return "n/a" if v is None or not math.isfinite(v) else format(v, fmt)


def _p(v) -> str:
    if v is None or not math.isfinite(v):
        return "n/a"
    return f"{v:.2e}" if v < 1e-3 else f"{v:.3f}"


def _markdown(rep: Report) -> str:
    out = [
        "# Sweep report",
        "",
        f"{rep.runs} runs, {rep.scenarios} scenarios, {len(rep.methods)} methods.",
        "",
        "## Success",
        "",
        "| method | runs | converged | rate | 95% CI (Wilson) | failures |",
        "|---|---:|---:|---:|---|---|",
    ]
    for m in rep.methods:
        fail = ", ".join(f"{k} {v}" for k, v in m.failures.items()) or "none"
        out.append(
            f"| {m.method} | {m.runs} | {m.converged} | {m.success_rate:.1%} | "
            f"[{_f(m.ci_low, '.1%')}, {_f(m.ci_high, '.1%')}] | {fail} |"
        )
    out += [
        "",
        "## Cost relative to the best method on each scenario (converged runs)",
        "",
        f"Ratio = cost / the lowest cost any method found on that scenario; costs within"
        f" {COST_TIE:g} relative count as the best.",
        "",
        "A cheaper motion seen: the planner converged, but another of its paths left a"
        " collision-free motion (not an extremal) that costs less: a cheaper optimum exists.",
        "",
        "| method | converged | best found | cheaper motion seen | median ratio | 90% ratio |"
        " max ratio |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    for m in rep.methods:
        q = m.cost_ratio
        out.append(
            f"| {m.method} | {m.converged} | {m.best_found} | {m.cheaper_seen} |"
            f" {_f(q.median, '.6g')} | {_f(q.p90, '.6g')} | {_f(q.max, '.6g')} |"
        )
    out += [
        "",
        "## Time and iterations",
        "",
        "| method | median time (s) | 90% time (s) | mean time (s) | median time, converged (s) |"
        " total (s) | median Newton iterations | mean Newton iterations |",
        "|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for m in rep.methods:
        out.append(
            f"| {m.method} | {_f(m.time_s.median)} | {_f(m.time_s.p90)} | {_f(m.time_s.mean)} | "
            f"{_f(m.time_converged_s.median)} | {_f(m.total_time_s, '.1f')} | "
            f"{_f(m.iterations.median, '.0f')} | {_f(m.iterations.mean, '.1f')} |"
        )
    if rep.pairs:
        out += [
            "",
            "## Paired comparisons (same scenarios)",
            "",
            "Success: scenarios only A (only B) solved; p from the exact McNemar test. Cost and"
            " time: among scenarios both solved; p from the Wilcoxon signed-rank test. Every p"
            " is Holm-adjusted over all the tests of this table.",
            "",
            "| A | B | scenarios | both | only A | only B | neither | p (success) |"
            " A cheaper | B cheaper | ties | p (cost) | A faster | B faster |"
            " median time A/B | p (time) |",
            "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
        ]
        for p in rep.pairs:
            out.append(
                f"| {p.a} | {p.b} | {p.scenarios} | {p.both_converged} | {p.only_a} | "
                f"{p.only_b} | {p.neither} | {_p(p.holm[0])} | {p.a_cheaper} | "
                f"{p.b_cheaper} | {p.cost_ties} | {_p(p.holm[1])} | {p.a_faster} | "
                f"{p.b_faster} | {_f(p.median_time_ratio, '.3g')} | {_p(p.holm[2])} |"
            )
    return "\n".join(out) + "\n"


# --------------------------------------------------------------------------- figures

_COLORS = tuple(
    f"tab:{c}" for c in "blue orange green red purple brown pink gray olive cyan".split()
)
_LINESTYLES = ("-", "--", "-.", ":", (0, (5, 1, 1, 1, 1, 1)), (0, (8, 2)), (0, (1, 1)))
_MARKERS = ("o", "s", "^", "D", "v", "P", "X", "*", "h")


def method_style(k: int) -> dict:
    """The k-th method's colour, line style, marker and width: (colour, line style) pairs differ
    for the first 70 methods, and each line is thinner than the one before it, so that curves on
    top of each other stay visible (the earlier ones show round the later ones)."""
    return {
        "color": _COLORS[k % len(_COLORS)],
        "ls": _LINESTYLES[k % len(_LINESTYLES)],
        "marker": _MARKERS[k % len(_MARKERS)],
        "lw": max(2.8 - 0.5 * k, 1.0),
    }


def _ecdf(ax, values, label, k: int = 0, log: bool = True):
    """The empirical distribution of ``values`` as a step line from 0 to 1, with hollow markers
    at (a staggered subset of) the runs."""
    v = np.sort(np.asarray(values, dtype=float))
    if not v.size:
        return None
    x = np.r_[v[0], v]
    y = np.r_[0.0, np.arange(1, v.size + 1) / v.size]
    step = max(1, v.size // 12)
    (line,) = ax.step(
        x, y, where="post", label=f"{label} (n = {v.size})", markevery=(1 + k % step, step),
        ms=5, mfc="none", mew=1.2, zorder=2 + 0.1 * k, **method_style(k),
    )  # fmt: skip
    return line


def _scale(ax, values) -> None:
    """Log x scale where the values span more than a factor of 10, else linear."""
    v = np.concatenate([np.asarray(x, dtype=float) for x in values] or [np.zeros(0)])
    v = v[np.isfinite(v) & (v > 0)]
    if v.size and v.max() > 10 * v.min():
        ax.set_xscale("log")


def _success_figure(rep: Report):
    from ..viz.style import new_figure

    names = [m.method for m in rep.methods]
    fig = new_figure(figsize=(max(5.4, 1.8 + 1.2 * len(names)), 3.8))  # room for the title
    ax = fig.add_subplot()
    rate = np.array([m.success_rate for m in rep.methods])
    err = np.array(
        [
            [m.success_rate - m.ci_low for m in rep.methods],
            [m.ci_high - m.success_rate for m in rep.methods],
        ]
    )
    colors = [method_style(k)["color"] for k in range(len(names))]
    ticks = [f"{m.method}\n{m.converged}/{m.runs}" for m in rep.methods]  # names are unique
    ax.bar(ticks, rate, yerr=err, capsize=4, color=colors, alpha=0.85, ecolor="0.2")
    pad = max(0.0, (3 - len(names)) / 2)  # one or two bars no wider than three would be
    ax.set_xlim(-0.6 - pad, len(names) - 0.4 + pad)
    ax.set_ylim(0, 1.05)
    ax.set_ylabel("success rate")
    ax.tick_params(axis="x", rotation=0 if max(map(len, names), default=0) <= 16 else 20)
    ax.set_title(f"Success per method, 95% Wilson intervals ({rep.scenarios} scenarios)")
    return fig


def _ecdf_figure(series: dict, title: str, xlabel: str, ylabel: str):
    from ..viz.style import new_figure

    fig = new_figure(figsize=(6.4, 4.0))
    ax = fig.add_subplot()
    for k, (m, values) in enumerate(series.items()):
        _ecdf(ax, values, m, k)
    _scale(ax, series.values())
    ax.set_ylim(-0.02, 1.02)
    ax.grid(True, alpha=0.3)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc="lower right", fontsize="small", framealpha=0.9)
    return fig


def report_figures(rep: Report) -> dict:
    """The report's figures by file name: ``success.png``, ``cost_ratio_ecdf.png`` and
    ``time_ecdf.png`` (matplotlib figures on the Agg canvas; nothing is shown or saved)."""
    names = [m.method for m in rep.methods]
    return {
        "success.png": _success_figure(rep),
        "cost_ratio_ecdf.png": _ecdf_figure(
            {m: rep.cost_ratios[m] for m in names},
            "Cost relative to the best found on each scenario",
            "cost / best cost on the scenario",
            "fraction of converged runs",
        ),
        "time_ecdf.png": _ecdf_figure(
            {m: [t for t in rep.times[m] if t > 0] for m in names},
            "Solver wall time per run",
            "solver wall time per run (s)",
            "fraction of runs",
        ),
    }


def save_report(rep: Report, folder) -> list[Path]:
    """Write ``report.md`` and the three figures into ``folder`` (created); each atomically."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    written = []
    md = rep.to_markdown()
    path = folder / "report.md"
    write_text_atomic(path, md)
    written.append(path)
    for name, fig in report_figures(rep).items():
        p = folder / name
        write_atomic(p, lambda tmp, fig=fig: fig.savefig(tmp, format="png", dpi=150))
        written.append(p)
    return written
