#!/usr/bin/env python
"""Benchmarks of the numerical core of leapfrog-planner.

Run from the repository root::

    python benchmarks/bench_core.py            # full run (about 1 to 2 minutes)
    python benchmarks/bench_core.py --quick    # fewer repetitions and subprocesses
    python benchmarks/bench_core.py --out DIR  # where the plot and results.json go

Every measurement follows a warm-up call that triggers numba compilation (or loads the compiled
kernels from the disk cache). The script never asserts on timings: it prints figures, the ratio
of each to its target and PASS or MISS, then a summary table, and exits 0.

Sections:

1. One flow evaluation with costate sensitivities (paper case 1, RK4, 200 fixed steps).
2. Accuracy against time of RK4, DP5 and DOP853 on extremals of paper cases 1 and 4.
3. One simple-shooting solve of paper case 1 from the affine guess, per root method.
4. The same solve with ``scipy.optimize.root`` (hybr) over ``solve_ivp`` (DOP853) in NumPy.
5. A fresh Python process with a warm disk cache: import and one solve.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import os
import platform
import statistics
import subprocess
import sys
import textwrap
import time
import timeit
from pathlib import Path

T_SCRIPT = time.perf_counter()
BLAS_VARS = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def _early_blas_threads(argv) -> None:
    """``--blas-threads N`` must act before numpy loads its BLAS, so it is read here."""
    for i, a in enumerate(argv):
        if a.startswith("--blas-threads"):
            n = a.split("=", 1)[1] if "=" in a else (argv[i + 1] if i + 1 < len(argv) else "")
            if n.isdigit():
                for var in BLAS_VARS:
                    os.environ[var] = n


_early_blas_threads(sys.argv[1:])

import numpy as np  # noqa: E402
import scipy  # noqa: E402
from scipy.integrate import solve_ivp  # noqa: E402
from scipy.optimize import root as scipy_root  # noqa: E402

T_IMPORT0 = time.perf_counter()
import leapfrog_planner  # noqa: E402
from leapfrog_planner import Flow, IntegratorSettings, OptimalControlProblem  # noqa: E402
from leapfrog_planner.bvp.shooting import (  # noqa: E402
    ShootingSettings,
    affine_costate_guess,
    solve_shooting,
)
from leapfrog_planner.planning.scenario import load_scenario  # noqa: E402

T_IMPORT = time.perf_counter() - T_IMPORT0

PI = math.pi
METHODS = ("newton", "modified-newton", "nleq-err")

# Paper case 1 (spec section 5): no obstacles, several extremals close together.
CASE1 = dict(start=[-1.0, 2.0, PI / 2], goal=[1.0, 2.0, PI / 2], obstacles=np.zeros((0, 3)))
CASE1_COSTATE = [-4.676, 3.213, 3.213]  # near the optimal extremal (J = 10.32320)
CASE1_REF_COST = 10.32320

# Paper case 4 (spec section 5): seven obstacles.
_CASE4 = load_scenario("paper-case-4")
CASE4 = dict(start=_CASE4.start, goal=_CASE4.goal, obstacles=np.asarray(_CASE4.obstacles))
# A costate guess read off the direct method's solution from the straight line (CasADi + IPOPT,
# 400 intervals, cost 5.6662): lambda1, lambda2 by least squares on v = -(l1 cos th + l2 sin th)
# over the first 30 intervals (where the penalty vanishes), lambda3 = -omega(0). Shooting from it
# converges to the spec's reference extremal (J = 5.663875, clearance 0.008).
CASE4_GUESS = [1.018, 11.69, 1.598]
CASE4_REF_COST = 5.663875

RESULTS: dict = {}
SUMMARY: list[tuple] = []  # (metric, measured, unit, target text, ratio, verdict)


# --------------------------------------------------------------------------- helpers


def heading(title: str) -> None:
    print()
    print("=" * 100)
    print(title)
    print("=" * 100)


def status_text(status) -> str:
    return str(getattr(status, "value", status))


def per_call(fn, *, number: int | None = None, repeat: int = 7, budget: float = 0.05):
    """Seconds per call of ``fn``, one value per repetition (``number`` calls each).

    Without ``number``, it is chosen so that one repetition lasts about ``budget`` seconds.
    """
    if number is None:
        t = time.perf_counter()
        fn()
        once = max(time.perf_counter() - t, 1e-7)
        number = max(1, int(budget / once))
    times = timeit.repeat(fn, number=number, repeat=repeat)
    return [t / number for t in times]


def verdict(measured: float, target: float, at_most: bool) -> tuple[float, str]:
    ratio = measured / target
    ok = measured <= target if at_most else measured >= target
    return ratio, "PASS" if ok else "MISS"


def add_target(metric, measured, unit, target, at_most=True):
    ratio, v = verdict(measured, target, at_most)
    sign = "<=" if at_most else ">="
    SUMMARY.append((metric, measured, unit, f"{sign} {target:g} {unit}", ratio, v))
    return v


def add_info(metric, measured, unit):
    SUMMARY.append((metric, measured, unit, "-", None, "info"))


def fmt(x: float, digits: int = 4) -> str:
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return str(x)
    return f"{x:.{digits}g}"


def make_problem(case: dict, **kw) -> OptimalControlProblem:
    return OptimalControlProblem.create("unicycle", case["obstacles"], **kw)


def z_start(case: dict, costate) -> np.ndarray:
    return np.concatenate([np.asarray(case["start"], float), np.asarray(costate, float)])


def no_samples(settings: ShootingSettings) -> ShootingSettings:
    return dataclasses.replace(settings, samples=0)


# --------------------------------------------------------------------------- 1. flow


def bench_flow(args) -> None:
    heading("1. Flow with costate sensitivities: paper case 1, RK4, 200 fixed steps, t in [0, 1]")
    problem = make_problem(CASE1)
    flow = Flow(problem, IntegratorSettings(method="rk4", steps=200))
    z0 = z_start(CASE1, CASE1_COSTATE)

    t = time.perf_counter()
    r = flow(0.0, z0, 1.0, sensitivity="costate")
    warm = time.perf_counter() - t
    print(f"warm-up (first call: compile or load from the disk cache): {warm * 1e3:.1f} ms")
    print(
        f"z(1) = {np.array2string(r.z, precision=6)}, cost = {r.cost:.6f}, status = {r.status.name}"
    )

    number, rounds = (300, 9) if args.quick else (1000, 21)
    seed = np.eye(6)[:, 3:]
    cands = {
        "Flow.__call__(sensitivity='costate')": lambda: flow(0.0, z0, 1.0, sensitivity="costate"),
        "Flow.__call__(sensitivity=None)": lambda: flow(0.0, z0, 1.0),
    }
    # The compiled part alone, to separate the Python overhead of Flow.__call__.
    if hasattr(flow, "_run"):
        cands["Flow._run (array setup + kernel)"] = lambda: flow._run(
            0.0, z0, 1.0, seed, flow.dynamics.no_samples
        )
    try:  # through its entry point, as Flow calls it: numba's dispatch is Python overhead too
        from leapfrog_planner.compiled.kernels import entry_point

        Y0 = np.concatenate([z0, [0.0], seed.ravel()])
        kargs = (Y0, 0.0, 1.0, seed.shape[1], flow.dynamics, 200, flow.dynamics.no_samples)
        erk_fixed = entry_point(flow.kernels.erk_fixed, kargs)
        cands["kernels.erk_fixed (compiled only)"] = lambda: erk_fixed(*kargs)
    except (AttributeError, ImportError) as exc:
        print(f"kernels.erk_fixed: not measurable ({exc})")
    for name in list(cands):
        try:
            cands[name]()
        except Exception as exc:  # the private API may have changed under us
            print(f"{name}: not measurable ({type(exc).__name__}: {exc})")
            del cands[name]
    # Interleaved rounds, so that load from other processes hits every variant alike.
    per = {name: [] for name in cands}
    for _ in range(rounds):
        for name, fn in cands.items():
            per[name].append(timeit.timeit(fn, number=number) / number * 1e6)
    print(f"per call, {rounds} interleaved rounds of {number} calls each:")
    for name, vals in per.items():
        print(f"  {name:<40} median {statistics.median(vals):8.2f} us   min {min(vals):8.2f} us")
    calls = per["Flow.__call__(sensitivity='costate')"]
    med, best = statistics.median(calls), min(calls)
    v = add_target("flow rk4/200 + costate sens. (median)", med, "us", 100.0)
    add_info("  same, min over rounds", best, "us")
    print(f"Flow.__call__ with costate sensitivities: median {med:.2f} us, target <= 100 us: {v}")
    RESULTS["flow_us"] = {k: dict(median=statistics.median(x), min=min(x)) for k, x in per.items()}
    kname = "kernels.erk_fixed (compiled only)"
    if kname in per:
        kmed, kmin = statistics.median(per[kname]), min(per[kname])
        print(
            f"compiled kernel: {kmin * 1e3 / 800:.0f} ns per right-hand side evaluation (min;"
            f" 800 stages of 25 components: z, cost, 6x3 sensitivities)"
        )
        print(
            f"Python overhead of Flow.__call__ over the kernel: median {med - kmed:.2f} us,"
            f" min {best - kmin:.2f} us"
        )
        add_info("  compiled kernel alone (erk_fixed, median)", kmed, "us")


# --------------------------------------------------------------------------- 2. accuracy


def find_extremals(args):
    """Extremals of cases 1 and 4 by simple shooting from good guesses (default integrator)."""
    out = {}
    for name, case, guess, ref in (
        ("case 1", CASE1, CASE1_COSTATE, CASE1_REF_COST),
        ("case 4", CASE4, CASE4_GUESS, CASE4_REF_COST),
    ):
        problem = make_problem(case)
        r = solve_shooting(
            problem, 0.0, case["start"], 1.0, case["goal"], method="nleq-err", guess=guess
        )
        clear = ""
        if case["obstacles"].shape[0] and r.trajectory is not None:
            c = problem.penalty.clearance(r.trajectory.x[:, :2]).min()
            clear = f", min clearance {c:.4f}"
        print(
            f"{name}: shooting from {guess}: {status_text(r.status)} in {r.root.iterations} it.,"
            f" J = {r.cost:.7f} (spec reference {ref}){clear}"
        )
        print(f"        costate lambda(0) = {np.array2string(r.costate0, precision=10)}")
        if not r.success:
            print(f"        (not converged: the curve below uses the guess {guess} as it is)")
        out[name] = (problem, case, r.costate0 if r.success else np.asarray(guess, float), r)
    return out


def bench_accuracy(args, extremals) -> None:
    heading("2. Accuracy against time: end state z(1) of an extremal, with costate sensitivities")
    rk4_steps = [25 * 2**i for i in range(8)]  # 25 .. 3200
    rtols = [10.0**-e for e in range(4, 14)]  # 1e-4 .. 1e-13
    repeat, budget = (3, 0.01) if args.quick else (5, 0.04)
    curves = {}
    for name, (problem, case, s, _) in extremals.items():
        z0 = z_start(case, s)
        ref = Flow(problem, IntegratorSettings(method="dop853", rtol=1e-13, atol=1e-13))(
            0.0, z0, 1.0
        )
        n_rk4 = 12800 if args.quick else 25600
        ref2 = Flow(problem, IntegratorSettings(method="rk4", steps=n_rk4))(0.0, z0, 1.0)
        half = Flow(problem, IntegratorSettings(method="rk4", steps=n_rk4 // 2))(0.0, z0, 1.0)
        agree = float(np.abs(ref.z - ref2.z).max())
        print(
            f"\n{name}: reference = dop853, rtol = atol = 1e-13 ({ref.steps} steps,"
            f" {ref.rejected} rejected); check against rk4 with N steps:"
        )
        for n, r2 in ((n_rk4 // 2, half), (n_rk4, ref2)):
            print(
                f"        rk4 N = {n:>5}: |dx(1)| = {np.linalg.norm(r2.x - ref.x):.2e},"
                f" |dlam(1)| = {np.linalg.norm(r2.lam - ref.lam):.2e},"
                f" |dJ| = {abs(r2.cost - ref.cost):.2e}"
            )
        print(
            "        (the difference should fall 16x per doubling of N while rk4's own error"
            " dominates it)"
        )
        print(f"        x(1) = {np.array2string(ref.x, precision=12)}, J = {ref.cost:.10f}")
        RESULTS.setdefault("reference_agreement", {})[name] = agree
        rows = []
        settings = [("rk4", IntegratorSettings(method="rk4", steps=n), f"N={n}") for n in rk4_steps]
        for m in ("dp5", "dop853"):
            settings += [
                (m, IntegratorSettings(method=m, rtol=rt, atol=rt), f"rtol={rt:.0e}")
                for rt in rtols
            ]
        for method, st, label in settings:
            flow = Flow(problem, st)
            r = flow(0.0, z0, 1.0, sensitivity="costate")
            calls = per_call(
                lambda flow=flow, z0=z0: flow(0.0, z0, 1.0, sensitivity="costate"),
                repeat=repeat,
                budget=budget,
            )
            # The minimum over repetitions: the curve is about the method, not the machine's load.
            t, tmed = min(calls) * 1e6, statistics.median(calls) * 1e6
            ex = float(np.linalg.norm(r.x - ref.x))
            el = float(np.linalg.norm(r.lam - ref.lam))
            ej = abs(r.cost - ref.cost)
            is_ref = method == "dop853" and st.rtol == 1e-13
            status = r.status.name + (" (the reference)" if is_ref else "")
            rows.append((method, label, r.steps, r.rejected, t, ex, el, ej, status, tmed))
        print(
            f"{'method':<7}{'setting':<13}{'steps':>6}{'rej':>5}{'min [us]':>10}{'median':>9}"
            f"{'|dx(1)|':>11}{'|dlam(1)|':>11}{'|dJ|':>11}  status"
        )
        for method, label, n, rej, t, ex, el, ej, st, tmed in rows:
            print(
                f"{method:<7}{label:<13}{n:>6}{rej:>5}{t:>10.1f}{tmed:>9.1f}"
                f"{ex:>11.2e}{el:>11.2e}{ej:>11.2e}  {st}"
            )
        curves[name] = rows
        # Cheapest setting of each method that reaches a given end-state accuracy.
        for tol in (1e-6, 1e-10):
            best = []
            for method in ("rk4", "dp5", "dop853"):
                ok = [r for r in rows if r[0] == method and r[5] <= tol and "ref" not in r[8]]
                if ok:
                    b = min(ok, key=lambda r: r[4])
                    best.append(f"{method} {b[4]:.0f} us ({b[1]})")
                else:
                    best.append(f"{method} not reached")
            print(f"fastest to |dx(1)| <= {tol:g}: " + ", ".join(best))
    RESULTS["accuracy"] = {
        k: [
            dict(
                zip(
                    (
                        "method",
                        "setting",
                        "steps",
                        "rejected",
                        "time_us_min",
                        "err_x",
                        "err_lam",
                        "err_cost",
                        "status",
                        "time_us_median",
                    ),
                    r,
                    strict=True,
                )
            )
            for r in v
        ]
        for k, v in curves.items()
    }
    plot_accuracy(args, curves)


def plot_accuracy(args, curves) -> None:
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib not available: no plot")
        return
    fig, axes = plt.subplots(1, len(curves), figsize=(6 * len(curves), 4.8), squeeze=False)
    styles = {
        "rk4": ("o-", "RK4, N = 25..3200"),
        "dp5": ("s-", "DP5, rtol 1e-4..1e-13"),
        "dop853": ("^-", "DOP853, rtol 1e-4..1e-13"),
    }
    for ax, (name, rows) in zip(axes[0], curves.items(), strict=True):
        for method, (style, label) in styles.items():
            pts = [(r[4], r[5]) for r in rows if r[0] == method and "ref" not in r[8]]
            ax.loglog(*zip(*pts, strict=True), style, label=label, ms=4)
        ax.set_xlabel("wall time per flow call with costate sensitivities [us] (min)")
        ax.set_ylabel("|x(1) - x_ref(1)|")
        ax.set_title(f"paper {name}: end-state error against time")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend()
    fig.tight_layout()
    path = Path(args.out) / "accuracy_vs_time.png"
    fig.savefig(path, dpi=120)
    plt.close(fig)
    print(f"\nplot saved: {path}")


# --------------------------------------------------------------------------- 3. shooting


def bench_shooting(args) -> dict:
    heading("3. Simple shooting, paper case 1, from the affine guess (default integrator)")
    problem = make_problem(CASE1)
    base = ShootingSettings()
    flow = Flow(problem, base.integrator)
    x0, x1 = CASE1["start"], CASE1["goal"]
    s0 = affine_costate_guess(problem, 0.0, x0, 1.0, x1, flow=flow)
    print(f"integrator: {base.integrator}")
    extra = {
        f.name: getattr(base, f.name)
        for f in dataclasses.fields(base)
        if f.name not in ("method", "root", "integrator")
    }
    print(f"shooting settings: {extra}, root: {base.root}")
    print(f"affine guess lambda(0) = {np.array2string(s0, precision=6)}")
    # Cost of one evaluation of F and DF at the guess with the default integrator.
    z0 = z_start(CASE1, s0)
    fr = flow(0.0, z0, 1.0, sensitivity="costate")
    calls = per_call(lambda: flow(0.0, z0, 1.0, sensitivity="costate"), repeat=5, budget=0.05)
    t_eval = statistics.median(calls) * 1e6
    print(
        f"one F + DF evaluation at the guess: {t_eval:.0f} us"
        f" ({fr.steps} steps, {fr.rejected} rejected)"
    )
    RESULTS["shooting_eval_us"] = t_eval
    n = base.samples
    if n:
        calls = per_call(lambda: flow(0.0, z0, 1.0, samples=n), repeat=5, budget=0.05)
        t_dense = statistics.median(calls) * 1e6
        print(f"one F evaluation with a dense trajectory (samples={n}): {t_dense:.0f} us")
        RESULTS["dense_eval_us"] = t_dense

    runs = 30 if args.quick else 50
    out = {}
    print(
        f"\n{'method':<17}{'trajectory':<12}{'median [ms]':>12}{'min [ms]':>10}{'status':>11}"
        f"{'cost J':>12}{'it':>4}{'F ev':>6}{'DF ev':>6}{'|F|':>10}   target <= 2 ms"
    )
    for method in METHODS:
        for dense, st in (("samples=" + str(base.samples), base), ("samples=0", no_samples(base))):

            def solve(method=method, st=st):
                return solve_shooting(
                    problem, 0.0, x0, 1.0, x1, method=method, settings=st, flow=flow
                )

            r = solve()  # warm-up
            calls = per_call(solve, number=1, repeat=runs)
            med, best = statistics.median(calls) * 1e3, min(calls) * 1e3
            v = add_target(f"shooting {method}, {dense} (median)", med, "ms", 2.0)
            print(
                f"{method:<17}{dense:<12}{med:>12.3f}{best:>10.3f}{status_text(r.status):>11}"
                f"{r.cost:>12.6f}{r.root.iterations:>4}{r.root.f_evals:>6}{r.root.jac_evals:>6}"
                f"{r.root.residual_norm:>10.1e}   {v}"
            )
            out[(method, dense == "samples=0")] = (med, r)
    shooting_breakdown(problem, flow, x0, x1, base)
    shooting_one_blas_thread(args, out)
    print("\nextremals reached (the affine guess is not in the basin of the optimum J = 10.32320):")
    for method in METHODS:
        r = out[(method, False)][1]
        print(
            f"  {method:<17} J = {r.cost:.8f},"
            f" lambda(0) = {np.array2string(r.costate0, precision=8)}"
        )
    RESULTS["shooting"] = {
        f"{m}{' no-traj' if nt else ''}": dict(
            median_ms=v[0],
            cost=v[1].cost,
            iterations=v[1].root.iterations,
            status=status_text(v[1].status),
            costate0=v[1].costate0.tolist(),
        )
        for (m, nt), v in out.items()
    }
    return dict(problem=problem, flow=flow, s0=s0, results=out)


class TimedFlow:
    """A stand-in for a Flow that counts its calls, their time and their integration steps."""

    def __init__(self, flow):
        self._flow = flow
        self.calls = self.sens_calls = self.steps = 0
        self.seconds = 0.0

    def __getattr__(self, name):
        return getattr(self._flow, name)

    def __call__(self, *a, **kw):
        t = time.perf_counter()
        r = self._flow(*a, **kw)
        self.seconds += time.perf_counter() - t
        self.calls += 1
        self.sens_calls += kw.get("sensitivity") is not None
        self.steps += r.steps + r.rejected
        return r


def shooting_breakdown(problem, flow, x0, x1, base, runs=7) -> None:
    """Where the time of one solve goes: the affine guess, the integrations, everything else.

    The guess is computed first and passed as ``guess=``, so the two parts are timed apart.
    """
    print(
        "\nbreakdown, median of 7 solves each: guess = affine_costate_guess; flow = inside"
        " Flow.__call__; rest = root loop (LU, SVD, line search) and result packaging"
    )
    print(
        f"{'method':<17}{'trajectory':<12}{'guess [ms]':>11}{'flow [ms]':>10}{'rest [ms]':>10}"
        f"{'flow calls':>11}{'with DF':>8}{'steps':>7}{'us/step':>8}"
    )
    for method in METHODS:
        for dense, st in (("samples=" + str(base.samples), base), ("samples=0", no_samples(base))):
            rows = []
            for _ in range(runs):
                t = time.perf_counter()
                s0 = affine_costate_guess(problem, 0.0, x0, 1.0, x1, flow=flow)
                guess = time.perf_counter() - t
                tf = TimedFlow(flow)
                t = time.perf_counter()
                try:
                    solve_shooting(
                        problem, 0.0, x0, 1.0, x1, method=method, guess=s0, settings=st, flow=tf
                    )
                except Exception as exc:  # a stand-in flow may not be accepted any more
                    print(f"  breakdown not measurable: {type(exc).__name__}: {exc}")
                    return
                total = time.perf_counter() - t
                rows.append(
                    (guess, tf.seconds, total - tf.seconds, tf.calls, tf.sens_calls, tf.steps)
                )
            gu, fl, rest = (statistics.median(r[i] for r in rows) * 1e3 for i in range(3))
            calls, sens, steps = rows[-1][3:]
            print(
                f"{method:<17}{dense:<12}{gu:>11.3f}{fl:>10.3f}{rest:>10.3f}"
                f"{calls:>11}{sens:>8}{steps:>7}{fl * 1e3 / max(steps, 1):>8.1f}"
            )


def blas_env(env=None) -> str:
    env = os.environ if env is None else env
    vals = {v: env[v] for v in BLAS_VARS if v in env}
    return ", ".join(f"{k}={v}" for k, v in vals.items()) or "not set (library default)"


CHILD_SHOOT = textwrap.dedent(
    """
    import json, math, statistics, sys, timeit
    from dataclasses import replace
    from leapfrog_planner import Flow, OptimalControlProblem
    from leapfrog_planner.bvp.shooting import ShootingSettings, affine_costate_guess, solve_shooting
    runs = int(sys.argv[1])
    p = OptimalControlProblem.create("unicycle")
    base = ShootingSettings()
    flow = Flow(p, base.integrator)
    x0, x1 = [-1.0, 2.0, math.pi / 2], [1.0, 2.0, math.pi / 2]
    out = {}
    g = lambda: affine_costate_guess(p, 0.0, x0, 1.0, x1, flow=flow)
    g()
    out["guess"] = statistics.median(timeit.repeat(g, number=1, repeat=runs)) * 1e3
    for m in ("newton", "modified-newton", "nleq-err"):
        for nt, st in ((False, base), (True, replace(base, samples=0))):
            f = lambda: solve_shooting(p, 0.0, x0, 1.0, x1, method=m, settings=st, flow=flow)
            f()
            t = timeit.repeat(f, number=1, repeat=runs)
            out[m + (" no-traj" if nt else "")] = (statistics.median(t) * 1e3, min(t) * 1e3)
    print(json.dumps(out))
    """
)


def shooting_one_blas_thread(args, out) -> None:
    """The same solves in a process whose BLAS runs on one thread (tiny matrices everywhere)."""
    if all(os.environ.get(v) == "1" for v in BLAS_VARS):
        print("\n(BLAS already limited to one thread in this run: no separate measurement)")
        return
    env = dict(os.environ, **{v: "1" for v in BLAS_VARS})
    runs = 30 if args.quick else 50
    p = subprocess.run(
        [sys.executable, "-c", CHILD_SHOOT, str(runs)],
        capture_output=True,
        text=True,
        env=env,
        check=False,
    )
    try:
        res = json.loads(p.stdout.strip().splitlines()[-1])
    except (ValueError, IndexError):
        print(f"\none-BLAS-thread run failed: {p.stderr.strip()[-500:]}")
        return
    print(
        f"\nthe same solves in a new process with {blas_env(env)} ({runs} runs each;"
        f" BLAS here: {blas_env()}):"
    )
    print(f"  affine guess alone: median {res['guess']:.3f} ms (1 thread)")
    print(f"{'method':<17}{'trajectory':<12}{'this run':>10}{'1 thread':>10}{'min':>8}   <= 2 ms")
    for method in METHODS:
        for no_traj in (False, True):
            med1, min1 = res[method + (" no-traj" if no_traj else "")]
            dense = "samples=0" if no_traj else "default"
            v = add_target(f"shooting {method}, {dense}, 1 BLAS thread", med1, "ms", 2.0)
            print(
                f"{method:<17}{dense:<12}{out[(method, no_traj)][0]:>10.3f}{med1:>10.3f}"
                f"{min1:>8.3f}   {v}"
            )
    RESULTS["shooting_one_blas_thread"] = res


# --------------------------------------------------------------------------- 4. scipy


def penalty_numpy(x, y, obstacles, weight=100.0, n=2):
    """P and its gradient, written directly from spec section 1."""
    if obstacles.shape[0] == 0:
        return 0.0, 0.0, 0.0
    dx = x - obstacles[:, 0]
    dy = y - obstacles[:, 1]
    r2 = obstacles[:, 2] ** 2
    s = (dx * dx + dy * dy) / r2
    e = weight * np.exp(-(s**n))
    dP_ds = -n * s ** (n - 1) * e
    return float(e.sum()), float((dP_ds * 2 * dx / r2).sum()), float((dP_ds * 2 * dy / r2).sum())


def canonical_rhs(obstacles):
    """Canonical system of the unicycle (spec section 1), plus the running cost as state 7.

    H = (v^2 + w^2)/2 + P + l1 v cos th + l2 v sin th + l3 w, so dH/du = 0 gives
    v = -(l1 cos th + l2 sin th), w = -l3, and lambda' = -dH/dx with u held at u*:
    l1' = -dP/dx, l2' = -dP/dy, l3' = -v (-l1 sin th + l2 cos th).
    """

    def rhs(t, y):
        th, l1, l2, l3 = y[2], y[3], y[4], y[5]
        c, s = math.cos(th), math.sin(th)
        v = -(l1 * c + l2 * s)
        w = -l3
        P, Px, Py = penalty_numpy(y[0], y[1], obstacles)
        out = [v * c, v * s, w, -Px, -Py, -v * (-l1 * s + l2 * c)]
        if y.size > 6:
            out.append(0.5 * (v * v + w * w) + P)
        return np.array(out)

    return rhs


def scipy_end(rhs, x0, s, with_cost=False):
    y0 = np.concatenate([x0, s, [0.0]] if with_cost else [x0, s])
    return solve_ivp(rhs, (0.0, 1.0), y0, method="DOP853", rtol=1e-12, atol=1e-12)


def same_extremal(r, J, s) -> bool:
    return bool(
        r.success
        and abs(r.cost - J) <= 1e-6 * abs(J)
        and np.linalg.norm(r.costate0 - s) <= 1e-6 * (1 + np.linalg.norm(s))
    )


def bench_scipy(args, extremals, shoot) -> None:
    heading("4. scipy.optimize.root(hybr) over solve_ivp(DOP853, rtol = atol = 1e-12), plain NumPy")
    # Check the hand-written canonical system against the library's derived flow first.
    for name, (problem, case, s, _) in extremals.items():
        z0 = z_start(case, s)
        ref = Flow(problem, IntegratorSettings(method="dop853", rtol=1e-13, atol=1e-13))(
            0.0, z0, 1.0
        )
        sol = scipy_end(canonical_rhs(case["obstacles"]), np.asarray(case["start"]), s, True)
        dz = float(np.abs(sol.y[:6, -1] - ref.z).max())
        dj = abs(sol.y[6, -1] - ref.cost)
        ok = "agrees" if dz < 1e-7 and dj < 1e-7 else "DISAGREES"
        print(f"check on the {name} extremal: max |dz(1)| = {dz:.1e}, |dJ| = {dj:.1e}: {ok}")
    x0 = np.asarray(CASE1["start"])
    x1 = np.asarray(CASE1["goal"])
    rhs = canonical_rhs(CASE1["obstacles"])

    def fun(s):
        return scipy_end(rhs, x0, s).y[:3, -1] - x1

    s0 = shoot["s0"]
    calls = per_call(lambda: fun(s0), number=1, repeat=3 if args.quick else 5)
    t_fun = statistics.median(calls) * 1e3
    ratio_eval = t_fun * 1e3 / RESULTS["shooting_eval_us"]
    print(
        f"one F evaluation at the affine guess: scipy {t_fun * 1e3:.0f} us (F only; hybr builds"
        f" DF by finite differences) vs ours {RESULTS['shooting_eval_us']:.0f} us (F and DF):"
        f" {ratio_eval:.1f}x"
    )
    add_info("  scipy F eval / ours F+DF eval", ratio_eval, "x")
    runs = 2 if args.quick else 4
    problem, flow = shoot["problem"], shoot["flow"]
    base = ShootingSettings()

    def scipy_solve(guess, label):
        sol = scipy_root(fun, guess, method="hybr")  # also a warm-up
        calls = per_call(lambda: scipy_root(fun, guess, method="hybr"), number=1, repeat=runs)
        t = statistics.median(calls) * 1e3
        J = float(scipy_end(rhs, x0, sol.x, True).y[6, -1])
        print(
            f"scipy hybr from {label}: success={sol.success}, nfev={sol.nfev},"
            f" |F| = {np.linalg.norm(sol.fun):.1e}, J = {J:.8f},"
            f" lambda(0) = {np.array2string(sol.x, precision=8)}"
        )
        print(f"  median {t:.1f} ms per solve ({runs} runs); scipy says: {sol.message.strip()}")
        return sol, J, t

    def compare(sol, J, t_scipy, ours, metric):
        print(f"{'ours':<32}{'median [ms]':>12}{'scipy/ours':>12}  same extremal as scipy?")
        same = []
        for (method, no_traj), (med, r) in ours.items():
            match = same_extremal(r, J, sol.x)
            if match:
                same.append((med, method, no_traj))
            label = f"{method}{', samples=0' if no_traj else ''}"
            print(
                f"  {label:<30}{med:>12.3f}{t_scipy / med:>12.1f}  {'yes' if match else 'no'}"
                f" (J = {r.cost:.6f})"
            )
        # The ratio that counts: against the slowest of our runs that reach scipy's extremal;
        # if none does, against the library default (modified-newton with its trajectory).
        if same:
            med, method, no_traj = max(same)
            basis = f"{method}{', samples=0' if no_traj else ''}, same extremal"
        else:
            med = ours[("modified-newton", False)][0]
            basis = "modified-newton default, NOT the same extremal"
        ratio = t_scipy / med
        v = add_target(metric, ratio, "x", 20.0, at_most=False)
        print(f"scipy / ours ({basis}): {ratio:.1f}x   target >= 20x: {v}")
        return ratio, basis

    print("\n(a) from the affine guess, as in section 3")
    sol, J, t_a = scipy_solve(s0, "the affine guess")
    ratio_a, basis_a = compare(sol, J, t_a, shoot["results"], "scipy/ours, affine guess")
    RESULTS["scipy_affine"] = dict(
        median_ms=t_a,
        nfev=int(sol.nfev),
        cost=J,
        costate0=sol.x.tolist(),
        fun_ms=t_fun,
        ratio=ratio_a,
        basis=basis_a,
    )

    print(f"\n(b) from the guess {CASE1_COSTATE} near the optimal extremal (J = 10.32320)")
    guess = np.asarray(CASE1_COSTATE)
    sol, J, t_b = scipy_solve(guess, f"{CASE1_COSTATE}")
    ours = {}
    n = 30 if args.quick else 50
    for method in METHODS:
        for no_traj, st in ((False, base), (True, no_samples(base))):

            def solve(method=method, st=st):
                return solve_shooting(
                    problem, 0.0, x0, 1.0, x1, method=method, guess=guess, settings=st, flow=flow
                )

            r = solve()
            ours[(method, no_traj)] = (
                statistics.median(per_call(solve, number=1, repeat=n)) * 1e3,
                r,
            )
    ratio_b, basis_b = compare(sol, J, t_b, ours, "scipy/ours, near-optimal guess")
    RESULTS["scipy_near_optimal"] = dict(
        median_ms=t_b,
        nfev=int(sol.nfev),
        cost=J,
        costate0=sol.x.tolist(),
        ratio=ratio_b,
        basis=basis_b,
        ours={
            f"{m}{' no-traj' if nt else ''}": dict(
                median_ms=v[0], cost=v[1].cost, iterations=v[1].root.iterations
            )
            for (m, nt), v in ours.items()
        },
    )


# --------------------------------------------------------------------------- 5. process start

CHILD = textwrap.dedent(
    """
    import time
    t0 = time.perf_counter()
    import json, math
    from leapfrog_planner import OptimalControlProblem
    from leapfrog_planner.compiled.kernels import load_kernels
    from leapfrog_planner.bvp.shooting import solve_shooting
    t1 = time.perf_counter()
    load_kernels("unicycle")
    t2 = time.perf_counter()
    p = OptimalControlProblem.create("unicycle")
    r = solve_shooting(p, 0.0, [-1.0, 2.0, math.pi / 2], 1.0, [1.0, 2.0, math.pi / 2])
    t3 = time.perf_counter()
    print(json.dumps(dict(imp=t1 - t0, load=t2 - t1, solve=t3 - t2, cost=r.cost,
                          status=str(r.status))))
    """
)


def run_process(code: str) -> tuple[float, str]:
    t = time.perf_counter()
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=False)
    wall = time.perf_counter() - t
    if p.returncode != 0:
        print(f"  subprocess failed ({p.returncode}): {p.stderr.strip()[-500:]}")
    return wall, p.stdout


def bench_process(args) -> None:
    heading("5. A new Python process with a warm disk cache (numba kernels cached on disk)")
    runs = 3 if args.quick else 5
    walls, phases = [], []
    for i in range(runs):
        wall, outp = run_process(CHILD)
        try:
            ph = json.loads(outp.strip().splitlines()[-1])
        except (ValueError, IndexError):
            ph = {}
        walls.append(wall)
        phases.append(ph)
        print(
            f"run {i + 1}: wall {wall:.3f} s   (in-process: import {ph.get('imp', math.nan):.3f} s,"
            f" load kernels {ph.get('load', math.nan):.3f} s, first solve"
            f" {ph.get('solve', math.nan):.3f} s; J = {ph.get('cost', math.nan):.6f}"
            f" {ph.get('status', '')}){'  <- may compile' if i == 0 else ''}"
        )
    warm = walls[1:]
    med = statistics.median(warm)
    v = add_target("new process: import + solve case 1 (warm)", med, "s", 1.5)
    print(f"warm runs: median {med:.3f} s, max {max(warm):.3f} s   target < 1.5 s: {v}")
    ph = [p for p in phases[1:] if p]
    if ph:
        for key, label in (("imp", "import"), ("load", "load kernels"), ("solve", "first solve")):
            print(f"  median {label:<13}{statistics.median(p[key] for p in ph):.3f} s")

    print("\nimport split (separate processes, median wall time):")
    split = {}
    n = 2 if args.quick else 3
    for label, code in (
        ("python -c pass", "pass"),
        ("import numpy", "import numpy"),
        ("import scipy.interpolate", "import scipy.interpolate"),
        ("import sympy", "import sympy"),
        ("import numba", "import numba"),
        ("import leapfrog_planner", "import leapfrog_planner"),
    ):
        w = statistics.median(run_process(code)[0] for _ in range(n))
        split[label] = w
        print(f"  {label:<26}{w:.3f} s")
    import_tree()
    add_info("new process: import leapfrog_planner", split["import leapfrog_planner"], "s")
    add_info("new process: python -c pass", split["python -c pass"], "s")
    RESULTS["process"] = dict(walls=walls, phases=phases, warm_median=med, split=split)


def import_tree(min_ms: float = 40.0, max_depth: int = 2) -> None:
    """The heavy part of ``python -X importtime -c 'import leapfrog_planner'`` as a tree."""
    p = subprocess.run(
        [sys.executable, "-X", "importtime", "-c", "import leapfrog_planner"],
        capture_output=True,
        text=True,
        check=False,
    )
    lines = []
    for line in p.stderr.splitlines():
        parts = line.split("|")
        if not line.startswith("import time:") or len(parts) != 3:
            continue
        try:
            cum = int(parts[1]) / 1e3
        except ValueError:
            continue  # the header
        depth = (len(parts[2]) - len(parts[2].lstrip()) - 1) // 2
        if cum >= min_ms and depth <= max_depth:
            lines.append((depth, parts[2].strip(), cum))
    # importtime prints children before their parent: reverse to read top-down.
    print(f"\npython -X importtime -c 'import leapfrog_planner' (cumulative >= {min_ms:g} ms):")
    for depth, name, cum in reversed(lines):
        print(f"  {'  ' * depth}{name:<{50 - 2 * depth}}{cum:8.0f} ms")


def load() -> str:
    try:
        return "load average {:.2f} {:.2f} {:.2f}".format(*os.getloadavg())
    except OSError:
        return "load average unknown"


# --------------------------------------------------------------------------- main


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="fewer repetitions (about half the time)")
    ap.add_argument(
        "--blas-threads",
        type=int,
        default=None,
        help="set OPENBLAS/OMP/MKL_NUM_THREADS for this run and its subprocesses"
        " (default: leave the environment alone)",
    )
    ap.add_argument(
        "--out",
        default=str(Path(__file__).parent / "out"),
        help="directory for the plot and results.json (default: benchmarks/out)",
    )
    args = ap.parse_args(argv)
    Path(args.out).mkdir(parents=True, exist_ok=True)

    heading("leapfrog-planner core benchmarks" + (" (--quick)" if args.quick else ""))
    print(
        f"machine: {platform.machine()}, {platform.processor() or '?'};"
        f" os.cpu_count() = {os.cpu_count()}"
    )
    print(
        f"python {platform.python_version()}, numpy {np.__version__}, scipy {scipy.__version__},"
        f" numba {__import__('numba').__version__}, leapfrog_planner {leapfrog_planner.__version__}"
    )
    print(
        f"import leapfrog_planner in this process: {T_IMPORT:.3f} s (numpy, scipy already loaded)"
    )
    print(f"{load()} (other processes on this machine make timings noisy)")
    print("BLAS threads: " + blas_env())

    bench_flow(args)
    heading("Extremals used by sections 2 and 4")
    extremals = find_extremals(args)
    bench_accuracy(args, extremals)
    shoot = bench_shooting(args)
    bench_scipy(args, extremals, shoot)
    bench_process(args)

    heading("Summary")
    print(f"os.cpu_count() = {os.cpu_count()}, {load()}; ratio = measured / target")
    print(f"{'metric':<54}{'measured':>10} {'unit':<4}{'target':>12}{'ratio':>8}  verdict")
    for metric, measured, unit, target, ratio, v in SUMMARY:
        r = "-" if ratio is None else f"{ratio:.2f}"
        print(f"{metric:<54}{fmt(measured):>10} {unit:<4}{target:>12}{r:>8}  {v}")
    total = time.perf_counter() - T_SCRIPT
    print(f"\ntotal runtime of the script: {total:.1f} s")
    RESULTS["summary"] = [
        dict(metric=m, measured=x, unit=u, target=t, ratio=r, verdict=v)
        for m, x, u, t, r, v in SUMMARY
    ]
    RESULTS["cpu_count"] = os.cpu_count()
    RESULTS["total_runtime_s"] = total
    path = Path(args.out) / "results.json"
    path.write_text(json.dumps(RESULTS, indent=1, default=float))
    print(f"results saved: {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
