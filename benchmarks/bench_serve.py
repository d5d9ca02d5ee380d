"""Load test of ``leapfrog serve``: concurrent clients editing the paper cases on a warm server.

    python benchmarks/bench_serve.py [--clients 20] [--seconds 60] [--workers N] [--think 1.0]
                                     [--seed 1]

Starts ``leapfrog serve`` on a free local port (``--workers`` solver processes, default the
command's own: the CPU cores, at most 4), warms it with each paper case, then runs ``--clients``
threads for ``--seconds``. Each client behaves like a person at the page: it picks a paper case
and drags one thing in it (an obstacle, its radius, the start or the goal, a heading) in small
random steps, ten requests a drag, waiting for each answer and then ``--think`` seconds on
average (uniform on [0, 2 think]) before the next edit. ``--think 0`` is a closed loop at full
load (the throughput figure).

Prints the request latency (p50, p95, p99, max, seen by the client: request to parsed
answer), the answers by HTTP status (errors = anything but 200; target 0), the throughput, and
the memory (RSS) of the server process and of its solver processes at the start and the end
(bounded: the end should not grow with the requests). Targets of the issue: p50 <= 150 ms,
p95 <= 400 ms. No assertions; the load average is printed since the machine is shared.
"""

from __future__ import annotations

import argparse
import copy
import http.client
import json
import math
import os
import random
import socket
import statistics
import subprocess
import sys
import threading
import time
import urllib.request
from collections import Counter

from leapfrog_planner.planning.scenario import builtin_scenarios, load_scenario

TARGET_P50_MS, TARGET_P95_MS = 150.0, 400.0
STEPS_PER_DRAG = 10


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def rss_mb(pid: int) -> float:
    try:
        with open(f"/proc/{pid}/status") as fh:
            for line in fh:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1]) / 1024
    except OSError:
        pass
    return float("nan")


def start_server(workers: int | None) -> tuple[subprocess.Popen, int]:
    port = free_port()
    argv = [sys.executable, "-m", "leapfrog_planner.cli", "serve", "--port", str(port)]
    if workers:
        argv += ["--workers", str(workers)]
    proc = subprocess.Popen(argv, stdout=subprocess.DEVNULL)
    end = time.monotonic() + 600
    while time.monotonic() < end:
        try:
            health = get(port, "/api/health")
            if health["ready"] >= health["workers"]:
                return proc, port
        except OSError:
            pass
        if proc.poll() is not None:
            raise SystemExit(f"leapfrog serve ended with exit code {proc.returncode}")
        time.sleep(0.2)
    proc.kill()
    raise SystemExit("leapfrog serve did not get ready within 600 s")


def get(port: int, path: str):
    with urllib.request.urlopen(f"http://127.0.0.1:{port}{path}", timeout=10) as r:
        return json.load(r)


def _outside(point, obstacles, gap=0.02) -> bool:
    return all(
        math.hypot(point[0] - o["center"][0], point[1] - o["center"][1]) >= o["radius"] + gap
        for o in obstacles
    )


class Drag:
    """One drag on a paper case: the thing dragged and its small random steps."""

    def __init__(self, rng: random.Random, cases: list[dict]):
        self.rng = rng
        self.scenario = copy.deepcopy(rng.choice(cases))
        obstacles = self.scenario["obstacles"]
        kinds = ["start", "goal", "heading"]
        if obstacles:
            kinds += ["obstacle", "obstacle", "radius"]
        self.kind = rng.choice(kinds)
        self.index = rng.randrange(len(obstacles)) if obstacles else 0
        self.key = rng.choice(["start", "goal"])
        self.step = (rng.gauss(0, 0.015), rng.gauss(0, 0.015))

    def next(self) -> dict:
        """The scenario after one more step (a step that would put the start or the goal
        inside an obstacle is skipped: the page's user sees the error and goes back)."""
        s, rng = self.scenario, self.rng
        trial = copy.deepcopy(s)
        dx, dy = self.step[0] + rng.gauss(0, 0.005), self.step[1] + rng.gauss(0, 0.005)
        if self.kind == "obstacle":
            c = trial["obstacles"][self.index]["center"]
            c[0], c[1] = c[0] + dx, c[1] + dy
        elif self.kind == "radius":
            ob = trial["obstacles"][self.index]
            ob["radius"] = max(0.02, ob["radius"] * (1 + rng.uniform(-0.05, 0.05)))
        elif self.kind == "heading":
            trial[self.key][2] += rng.uniform(-0.15, 0.15)
        else:
            trial[self.kind][0] += dx
            trial[self.kind][1] += dy
        if all(_outside(trial[k], trial["obstacles"]) for k in ("start", "goal")):
            self.scenario = trial
        return self.scenario


def client(port, seed, cases, deadline, think, out, lock):
    rng = random.Random(seed)
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=60)
    session, seq, drag, steps = f"bench-{seed}", 0, None, 0
    latencies, statuses = [], Counter()
    while time.monotonic() < deadline:
        if drag is None or steps >= STEPS_PER_DRAG:
            drag, steps = Drag(rng, cases), 0
        steps += 1
        seq += 1
        body = json.dumps({"scenario": drag.next(), "session": session, "seq": seq})
        t0 = time.perf_counter()
        try:
            conn.request("POST", "/api/plan", body, {"Content-Type": "application/json"})
            resp = conn.getresponse()
            payload = resp.read()
            if resp.status == 200:
                json.loads(payload)
            elif len(out["examples"]) < 5:
                out["examples"].append(f"{resp.status}: {payload[:300].decode()}")
            statuses[resp.status] += 1
        except (OSError, http.client.HTTPException) as e:
            statuses[type(e).__name__] += 1
            conn.close()
            conn = http.client.HTTPConnection("127.0.0.1", port, timeout=60)
        latencies.append(time.perf_counter() - t0)
        if think > 0:
            time.sleep(rng.uniform(0, 2 * think))
    with lock:
        out["latencies"] += latencies
        out["statuses"].update(statuses)


def memory(proc, port) -> tuple[float, float]:
    pids = get(port, "/api/health")["pids"]
    return rss_mb(proc.pid), sum(rss_mb(p) for p in pids)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--clients", type=int, default=20)
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--workers", type=int, default=None)
    ap.add_argument("--think", type=float, default=1.0, help="mean pause between edits, s")
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args(argv)

    cases = [load_scenario(n).to_dict() for n in builtin_scenarios() if n.startswith("paper")]
    proc, port = start_server(args.workers)
    try:
        for case in cases * 3:  # warm: every case through every code path once
            req = urllib.request.Request(
                f"http://127.0.0.1:{port}/api/plan",
                json.dumps({"scenario": case}).encode(),
                {"Content-Type": "application/json"},
            )
            urllib.request.urlopen(req, timeout=60).read()
        health = get(port, "/api/health")
        rss0 = memory(proc, port)
        out = {"latencies": [], "statuses": Counter(), "examples": []}
        lock = threading.Lock()
        deadline = time.monotonic() + args.seconds
        threads = [
            threading.Thread(
                target=client,
                args=(port, args.seed * 1000 + i, cases, deadline, args.think, out, lock),
            )
            for i in range(args.clients)
        ]
        t0 = time.perf_counter()
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        wall = time.perf_counter() - t0
        rss1 = memory(proc, port)
        load = os.getloadavg()
    finally:
        proc.terminate()
        proc.wait(20)

    lat = sorted(out["latencies"])
    q = statistics.quantiles(lat, n=100, method="inclusive")
    p50, p95, p99 = (q[49] * 1e3, q[94] * 1e3, q[98] * 1e3)
    errors = sum(n for s, n in out["statuses"].items() if s != 200)
    print(
        f"leapfrog serve: {health['workers']} solver processes, {args.clients} clients,"
        f" {args.seconds:g} s, think {args.think:g} s on average, seed {args.seed}"
    )
    print(f"requests: {len(lat)}  ({len(lat) / wall:.1f}/s)   by status: {dict(out['statuses'])}")
    print(f"errors: {errors}  (target 0)")
    for example in out["examples"]:
        print(f"  {example}")
    print(
        f"latency ms: p50 {p50:.0f} (target {TARGET_P50_MS:g}: "
        f"{'PASS' if p50 <= TARGET_P50_MS else 'MISS'})   p95 {p95:.0f} (target "
        f"{TARGET_P95_MS:g}: {'PASS' if p95 <= TARGET_P95_MS else 'MISS'})   p99 {p99:.0f}"
        f"   max {lat[-1] * 1e3:.0f}   mean {statistics.fmean(lat) * 1e3:.0f}"
    )
    print(
        f"RSS MB: server {rss0[0]:.0f} -> {rss1[0]:.0f}, solver processes {rss0[1]:.0f} ->"
        f" {rss1[1]:.0f}"
    )
    print(f"load average: {load[0]:.2f} {load[1]:.2f} {load[2]:.2f} on {os.cpu_count()} CPUs")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
