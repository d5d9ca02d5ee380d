"""Start-up: how long a new process takes before and around the plan, and how soon
``leapfrog serve`` answers.

    python benchmarks/bench_startup.py [--runs 10] [--cold] [--serve] [--first]

1. ``leapfrog solve paper-case-4`` as a new process with a warm kernel cache (median of
   ``--runs``, target 0.5 s), beside what it is made of: ``python -c pass``, ``import numba``,
   a process that imports the planner and loads the kernels the plan needs but does not plan,
   and the same that plans (its in-process plan time printed too).
2. ``leapfrog --help`` and ``leapfrog solve --help``.
3. ``leapfrog serve``: seconds from its start to its first ``/api/health`` answer (target 2 s),
   to a first plan (a unicycle's, asked as soon as ``/api/health`` says the unicycle is ready)
   and to a solver process that has warmed every model up. ``--cold``: in a fresh, empty
   kernel cache (the solver compiles every model: minutes, and the machine is loaded
   meanwhile); ``--serve``: this section alone.

4. ``--first`` (this section alone): a fresh machine, as the README's first command meets it:
   ``leapfrog solve paper-case-4`` in a fresh, empty kernel cache (numba's cache of the
   package's own functions too): seconds to the answer (target 20 s), what it said on stderr,
   then seconds until the Newton loops compiled in the background are in the cache, and a
   second solve's seconds.

No assertions: it prints figures (wall seconds, each a whole process) and PASS or MISS against
the targets of the issue, and the load average, since the machine may be shared.
"""

from __future__ import annotations

import argparse
import json
import os
import socket
import statistics
import subprocess
import sys
import tempfile
import time
import urllib.request

TARGET_SOLVE_S = 0.5
TARGET_HEALTH_S = 2.0
TARGET_FIRST_S = 20.0
CLI = [sys.executable, "-m", "leapfrog_planner.cli"]

#: Imports and loads the kernels of a plan of paper case 4 as ``leapfrog solve`` does; plans it
#: when PLAN is true. Ends as the command does (no interpreter teardown).
PARTS = """
import os, sys
from leapfrog_planner.cli.warmup import ensure_compiled
from leapfrog_planner.planning.planner import Planner
from leapfrog_planner.planning.scenario import load_scenario
sc = load_scenario("paper-case-4")
planner = Planner(sc)
ensure_compiled([sc.model], show=False, methods=[planner.settings.leapfrog.method])
if {plan}:
    print(planner.plan().wall_time_s, flush=True)
os._exit(0)
"""


def wall(argv: list[str], env=None) -> tuple[float, str]:
    t = time.perf_counter()
    p = subprocess.run(argv, capture_output=True, text=True, env=env, check=False)
    return time.perf_counter() - t, p.stdout


def median_wall(argv: list[str], runs: int) -> tuple[float, list[str]]:
    wall(argv)  # a warm-up run (it compiles, the first time on a machine)
    times, outs = [], []
    for _ in range(runs):
        t, out = wall(argv)
        times.append(t)
        outs.append(out)
    return statistics.median(times), outs


def verdict(value: float, target: float) -> str:
    return f"(target {target:g} s) {'PASS' if value <= target else 'MISS'}"


def bench_solve(runs: int) -> None:
    print(f"1. a new process, warm kernel cache (median of {runs} runs, wall s)")
    for label, argv in (
        ("python -c pass", [sys.executable, "-c", "pass"]),
        ("python -c 'import numba'", [sys.executable, "-c", "import numba"]),
        ("imports + the plan's kernels", [sys.executable, "-c", PARTS.format(plan=False)]),
    ):
        print(f"   {label:<36}{median_wall(argv, runs)[0]:7.3f}")
    t, outs = median_wall([sys.executable, "-c", PARTS.format(plan=True)], runs)
    plan = statistics.median(float(o.split()[-1]) for o in outs if o.strip())
    print(f"   {'the same, and the plan':<36}{t:7.3f}   (the plan itself {plan:.3f})")
    t, _ = median_wall([*CLI, "solve", "paper-case-4"], runs)
    print(f"   {'leapfrog solve paper-case-4':<36}{t:7.3f}   {verdict(t, TARGET_SOLVE_S)}")
    print("2. help")
    for args in (["--help"], ["solve", "--help"]):
        t, _ = median_wall([*CLI, *args], runs)
        print(f"   {'leapfrog ' + ' '.join(args):<36}{t:7.3f}")


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def plan(port: int) -> None:
    body = json.dumps({"scenario": {"name": "line", "horizon": 1.0, "start": [0, 0, 0],
                                    "goal": [1, 0, 0]}}).encode()  # fmt: skip
    req = urllib.request.Request(f"http://127.0.0.1:{port}/api/plan", body,
                                 {"Content-Type": "application/json"})  # fmt: skip
    urllib.request.urlopen(req, timeout=60).read()


def bench_serve(cold: bool) -> None:
    print(f"3. leapfrog serve, {'cold (an empty kernel cache)' if cold else 'warm'} cache")
    env = dict(os.environ)
    # ignore_cleanup_errors: the Newton loops' background compiles may still write into it
    folder = tempfile.TemporaryDirectory(prefix="leapfrog-cold-", ignore_cleanup_errors=True)
    if cold:
        env = fresh_cache_env(folder.name)
    port = free_port()
    argv = [*CLI, "serve", "--port", str(port), "--workers", "1"]
    t0 = time.perf_counter()
    proc = subprocess.Popen(argv, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        watch_serve(proc, port, t0)
    finally:
        proc.terminate()
        proc.wait(10)
        folder.cleanup()


def watch_serve(proc: subprocess.Popen, port: int, t0: float) -> None:
    """Poll the health of the server started at ``t0``: its first answer, each change of its
    models' states, a first plan (a unicycle's, asked as soon as the unicycle is ready) and
    when a solver process has warmed every model up."""
    first, said, planned, during = None, None, False, []
    while proc.poll() is None and time.perf_counter() - t0 < 900:
        try:
            with urllib.request.urlopen(f"http://127.0.0.1:{port}/api/health", timeout=5) as r:
                h = json.load(r)
        except OSError:
            time.sleep(0.02)
            continue
        now = time.perf_counter() - t0
        models = h.get("models") or {}  # older servers: no states by model
        if first is None:
            first = now
            print(f"   first /api/health answer {first:7.2f} s {verdict(first, TARGET_HEALTH_S)}")
            print(f"     it said: ready {h['ready']}, preparing {h.get('preparing')}")
        line = " ".join(f"{m} {s}" for m, s in models.items())
        if models and line != said:
            print(f"     {now:7.2f} s: {line}")
            said = line
        if models.get("unicycle") == "ready" or h["ready"] >= 1:
            asked = time.perf_counter()
            plan(port)
            took = time.perf_counter() - asked
            if not planned:
                print(f"   a first plan answered    {asked - t0 + took:7.2f} s ({took:.2f} s)")
                planned = True
            else:
                during.append(took)
        if h["ready"] >= 1:
            print(f"   every model ready        {time.perf_counter() - t0:7.2f} s")
            if during:  # a unicycle's plans while the other models were warmed up
                print(f"     {len(during)} more plans meanwhile, the slowest {max(during):.2f} s")
            return
        time.sleep(0.5)


def fresh_cache_env(folder: str) -> dict:
    """The environment of a fresh machine: empty kernel caches in ``folder``."""
    env = dict(os.environ)
    env["LEAPFROG_CACHE_DIR"] = folder
    env["NUMBA_CACHE_DIR"] = os.path.join(folder, "numba")  # the package's own functions
    env.pop("LEAPFROG_COMPILE_IN_BACKGROUND", None)  # the default: the loops compile apart
    return env


def bench_first() -> None:
    print("4. the first solve on a fresh machine (empty kernel caches), wall s")
    with tempfile.TemporaryDirectory(prefix="leapfrog-first-") as folder:
        env = fresh_cache_env(folder)
        argv = [*CLI, "solve", "paper-case-4"]
        t0 = time.perf_counter()
        p = subprocess.run(argv, capture_output=True, text=True, env=env, check=False)
        first = time.perf_counter() - t0
        print(f"   leapfrog solve paper-case-4 {first:7.2f}   {verdict(first, TARGET_FIRST_S)}")
        for line in p.stderr.splitlines():
            print(f"     it said: {line}")
        models = os.path.join(folder, "models")
        while any(f.endswith(".compiling") for f in os.listdir(models)):
            if time.perf_counter() - t0 > 900:
                print("   the background compile has not finished after 900 s")
                return
            time.sleep(0.5)
        print(f"   the Newton loops in the cache  {time.perf_counter() - t0:7.2f}")
        second, _ = wall(argv, env)
        print(f"   a second solve              {second:7.2f}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=10)
    ap.add_argument("--cold", action="store_true", help="serve with an empty kernel cache")
    ap.add_argument("--serve", action="store_true", help="only section 3")
    ap.add_argument("--first", action="store_true", help="only section 4: a fresh machine")
    args = ap.parse_args(argv)
    print("load average {:.2f} {:.2f} {:.2f}".format(*os.getloadavg()), f"cpus {os.cpu_count()}")
    if args.first:
        bench_first()
        return 0
    if not args.serve:
        bench_solve(args.runs)
    bench_serve(args.cold)
    return 0


if __name__ == "__main__":
    sys.exit(main())
