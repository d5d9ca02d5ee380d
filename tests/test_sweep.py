"""Sweeps: the JSONL store, resume after SIGKILL, determinism, a real Dask cluster, faulty pairs.

The sweeps run as real ``leapfrog sweep`` subprocesses on a few small random scenarios (three
obstacles, one initial path), so the tests stay in seconds.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

import pytest

from leapfrog_planner.batch.generate import GeneratorSpec, generate
from leapfrog_planner.batch.store import ResultStore, StoreError, read_records, strip_timings
from leapfrog_planner.batch.sweep import SweepMethod, SweepSettings, run_sweep
from leapfrog_planner.errors import SettingsError

SPEC = ["--n", "6", "--obstacles", "3", "--seed", "5"]
METHODS = ["--methods", "newton,modified-newton"]
PAIRS = 12


def _sweep_cmd(out, *extra):
    return [sys.executable, "-m", "leapfrog_planner.cli", "sweep", *SPEC, *METHODS, "--quiet",
            "--out", str(out), *extra]  # fmt: skip


def _run(out, *extra, check=True):
    r = subprocess.run(_sweep_cmd(out, *extra), capture_output=True, text=True, timeout=300)
    if check:
        assert r.returncode == 0, r.stderr
    return r


def _stripped(path):
    return [strip_timings(r) for r in read_records(path)]


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """One uninterrupted local sweep with 2 workers: what every other run must reproduce."""
    out = tmp_path_factory.mktemp("ref") / "ref.jsonl"
    _run(out, "--workers", "2")
    return out


# --------------------------------------------------------------------------- the store


def test_store_cuts_a_torn_line_and_refuses_duplicates_and_a_second_writer(tmp_path):
    path = tmp_path / "r.jsonl"
    good = {"scenario": "a", "method": "m", "status": "converged"}
    path.write_text(json.dumps(good) + "\n" + '{"scenario": "b", "met')
    assert read_records(path) == [good]
    with ResultStore.open(path) as store:
        assert store.done == {("a", "m")}
        with pytest.raises(StoreError, match="another sweep"):
            ResultStore.open(path)
        store.append({"scenario": "b", "method": "m", "status": "failed"})
        with pytest.raises(StoreError, match="already recorded"):
            store.append({"scenario": "b", "method": "m", "status": "failed"})
    lines = path.read_text().splitlines()
    assert len(lines) == 2 and all(json.loads(x) for x in lines)
    path.write_text(path.read_text() + "garbage\n" + json.dumps(good) + "\n")
    with pytest.raises(StoreError, match="line 3 is not JSON"):
        read_records(path)


# --------------------------------------------------------------------------- end to end


def test_reference_sweep_is_complete_and_sorted(reference):
    recs = read_records(reference)
    names = [sc.name for sc in generate(GeneratorSpec(n=6, obstacles=(3, 3), seed=5))]
    assert [(r["scenario"], r["method"]) for r in recs] == [
        (n, m) for n in names for m in ("newton", "modified-newton")
    ]
    assert all(r["status"] in ("converged", "failed") for r in recs)
    assert sum(r["status"] == "converged" for r in recs) >= PAIRS // 2
    ok = [r for r in recs if r["status"] == "converged"]
    assert all(r["cost"] > 0 and r["end_state_error"] < 1e-8 for r in ok)
    assert all(r["obstacles"] == 3 and r["task_time_s"] > 0 for r in recs)


def test_sigkill_then_resume_gives_each_pair_once_and_the_same_results(tmp_path, reference):
    out = tmp_path / "r.jsonl"
    proc = subprocess.Popen(
        _sweep_cmd(out, "--workers", "1", "--no-sort"),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,  # its own process group: the kill takes the workers too
    )
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and proc.poll() is None:
        if out.exists() and out.read_bytes().count(b"\n") >= 3:
            break
        time.sleep(0.01)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    partial = read_records(out)
    assert 3 <= len(partial) < PAIRS, "the kill should land mid-sweep"
    assert out.read_bytes().endswith(b"\n")  # whole lines only
    r = _run(out, "--workers", "2")
    keys = [(x["scenario"], x["method"]) for x in read_records(out)]
    assert len(keys) == PAIRS and len(set(keys)) == PAIRS
    # The pairs finished before the kill are kept as they were, not re-run.
    after = {(x["scenario"], x["method"]): x for x in read_records(out)}
    for x in partial:
        assert after[(x["scenario"], x["method"])] == x
    assert _stripped(out) == _stripped(reference)  # deterministic apart from timings
    again = _run(out)  # nothing left to do: the file is unchanged
    assert _stripped(out) == _stripped(reference) and again.returncode == 0
    assert r.stderr == ""


def test_dask_cluster_gives_the_local_results(tmp_path, reference):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(
        n_workers=2,
        threads_per_worker=1,
        processes=True,
        host="127.0.0.1",
        dashboard_address=None,
    ) as cluster:
        out = tmp_path / "dask.jsonl"
        _run(out, "--scheduler", cluster.scheduler_address, "--chunk-size", "3")
    recs = read_records(out)
    assert _stripped(out) == _stripped(reference)
    assert len({r["worker"] for r in recs}) == 2  # both workers took part
    # Each worker process warmed up (loaded the kernels) once, on its first pair only.
    assert sum(r["warmup_s"] > 0 for r in recs) == 2


def test_resume_with_other_settings_is_refused(tmp_path, reference):
    out = tmp_path / "r.jsonl"
    out.write_bytes(reference.read_bytes())
    r = _run(out, "--option", "partitions=4", check=False)
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "other settings" in r.stderr
    assert out.read_bytes() == reference.read_bytes()


@pytest.mark.parametrize(
    "args, message",
    [
        (["--methods", "newton,bogus"], "unknown method"),
        (["--option", "nope=1"], "unknown option"),
        (["--time-limit", "0"], "time-limit"),
        (["--workers", "0"], "workers"),
    ],
)
def test_bad_input_is_one_line_and_writes_nothing(tmp_path, args, message):
    out = tmp_path / "r.jsonl"
    cmd = [sys.executable, "-m", "leapfrog_planner.cli", "sweep", *SPEC, "--out", str(out), *args]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=60)
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and message in r.stderr
    assert not out.exists()


def test_the_random_scenarios_options_without_n_are_refused_not_ignored(tmp_path):
    """``--horizon free --cruise-speed`` with files only would sweep the files' fixed horizons,
    the options silently ignored: refused in one line, naming them, nothing written."""
    out = tmp_path / "r.jsonl"
    args = ["builtin:paper-case-1", "--horizon", "free", "--cruise-speed", "0.5"]
    cmd = [sys.executable, "-m", "leapfrog_planner.cli", "sweep", *args, "--out", str(out)]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=60)
    assert r.returncode == 2 and r.stderr.count("\n") == 1, r.stderr
    assert "--horizon, --cruise-speed: options of the random scenarios" in r.stderr
    assert 'horizon = "free"' in r.stderr and not out.exists()


# --------------------------------------------------------------------------- faulty pairs


def outcomes(path):
    """The records of a faulty sweep by scenario index ("00003"), and their (status, failure)."""
    recs = {r["scenario"].rsplit("-", 1)[1]: r for r in read_records(path)}
    return recs, {k: (r["status"], r["failure"]) for k, r in recs.items()}


def faulty(sc, options):
    """A user method that misbehaves in a different way on each scenario (by its index)."""
    i = int(sc.name.rsplit("-", 1)[1])
    if i == 1:
        os.kill(os.getpid(), signal.SIGKILL)  # the worker dies
    elif i == 2:
        signal.signal(signal.SIGALRM, signal.SIG_IGN)  # deaf to the time limit: a hard hang
        time.sleep(60)
    elif i == 3:
        while True:  # slow but interruptible
            time.sleep(0.01)
    elif i == 4:
        raise ValueError("bad luck")
    return {"status": "converged", "cost": float(i), "message": "fine"}


def test_crash_hang_timeout_and_errors_are_recorded_and_the_sweep_goes_on(tmp_path):
    scenarios = list(generate(GeneratorSpec(n=6, obstacles=(1, 1), seed=1)))
    settings = SweepSettings(
        methods=(SweepMethod("faulty", faulty),), time_limit=1.0, kill_grace=1.0, workers=2
    )
    out = tmp_path / "r.jsonl"
    summary = run_sweep(scenarios, out, settings)
    recs, got = outcomes(out)
    assert len(recs) == 6 and summary.ran == 6 and summary.complete
    assert got == {
        "00000": ("converged", None),
        "00001": ("failed", "crash"),
        "00002": ("failed", "timeout"),
        "00003": ("failed", "timeout"),
        "00004": ("failed", "error"),
        "00005": ("converged", None),
    }
    assert "worker killed" in recs["00002"]["message"]
    assert "time limit" in recs["00003"]["message"]
    assert "ValueError: bad luck" in recs["00004"]["message"]
    assert recs["00005"]["cost"] == 5.0
    assert summary.failures == {"crash": 1, "timeout": 2, "error": 1}


def test_settings_are_validated():
    with pytest.raises(SettingsError, match="listed twice"):
        SweepSettings(methods=("newton", "newton"))
    with pytest.raises(SettingsError, match="give the method in methods"):
        SweepSettings(planner={"method": "newton"})
    with pytest.raises(SettingsError, match="unknown option"):
        SweepSettings(planner={"partitionz": 3})
    s = SweepSettings(planner={"partitions": 4})
    assert s.options() == {"initial_paths": 1, "threads": 1, "partitions": 4}
    assert SweepSettings(planner={"initial_paths": 3}).options()["initial_paths"] == 3


def faulty_in_threads(sc, options):
    """Like :func:`faulty` for Dask, whose tasks run in threads (no signals there)."""
    i = int(sc.name.rsplit("-", 1)[1])
    if i == 1:
        os.kill(os.getpid(), signal.SIGKILL)
    elif i == 2:
        time.sleep(120)  # a hang nothing inside the worker interrupts
    elif i == 3:
        raise ValueError("bad luck")
    return {"status": "converged", "cost": float(i), "message": "fine"}


def test_dask_crash_and_hang_are_recorded_and_the_sweep_goes_on(tmp_path):
    distributed = pytest.importorskip("distributed")
    import dask

    scenarios = list(generate(GeneratorSpec(n=5, obstacles=(1, 1), seed=1)))
    # One worker death is enough to give up on a task (the default, 3, means 4 restarts).
    with (
        dask.config.set({"distributed.scheduler.allowed-failures": 0}),
        distributed.LocalCluster(
            n_workers=2,
            threads_per_worker=1,
            processes=True,
            host="127.0.0.1",
            dashboard_address=None,
        ) as cluster,
    ):
        settings = SweepSettings(
            methods=(SweepMethod("faulty", faulty_in_threads),),
            time_limit=2.0,
            kill_grace=3.0,
            scheduler=cluster.scheduler_address,
            chunk_size=1,
        )
        summary = run_sweep(scenarios, tmp_path / "r.jsonl", settings)
    recs, got = outcomes(tmp_path / "r.jsonl")
    assert got == {
        "00000": ("converged", None),
        "00001": ("failed", "crash"),
        "00002": ("failed", "timeout"),
        "00003": ("failed", "error"),
        "00004": ("converged", None),
    }
    assert "restarted" in recs["00002"]["message"]
    assert summary.complete and summary.engine == "dask"


def test_direct_method_is_an_independent_multistart(tmp_path):
    """IPOPT from lines and the planner's paths: its cost, collision-free, near Leapfrog's."""
    pytest.importorskip("casadi")
    sc = [s for s in generate(GeneratorSpec(n=2, obstacles=(2, 2), seed=3))]
    out = tmp_path / "d.jsonl"
    summary = run_sweep(sc, out, SweepSettings(methods=("modified-newton", "direct"), workers=1))
    assert summary.converged == 4
    recs = {(r["scenario"], r["method"]): r for r in read_records(out)}
    for s in sc:
        lf, d = recs[(s.name, "modified-newton")], recs[(s.name, "direct")]
        assert d["final_solver"] == "ipopt-N100" and d["min_clearance"] > 0
        assert d["end_state_error"] < 1e-6  # the controls, driven exactly, reach the goal
        # The mesh's error lies above the true optimum, within about 1e-3.
        assert lf["cost"] <= d["cost"] <= lf["cost"] * (1 + 2e-3)
        # No cheaper motion was seen (a number where one was: see test_time_units).
        assert "cheaper_motion" in lf and lf["cheaper_motion"] is None
        assert d["cheaper_motion"] is None


def test_direct_method_without_casadi_is_refused(monkeypatch):
    import importlib.util

    real = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util, "find_spec", lambda name, *a: None if name == "casadi" else real(name, *a)
    )
    with pytest.raises(SettingsError, match="needs CasADi"):
        SweepSettings(methods=("direct",))
