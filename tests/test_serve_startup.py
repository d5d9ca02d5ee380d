"""``leapfrog serve`` answers from its start, also while its solver processes are being prepared
(a fresh machine compiles the kernels, about 20 s a model): ``/api/health`` says each model's
state and where the warm-up is; a plan of a model not warm yet is refused at once with that
progress (503, ``Retry-After``), and a plan of a model already warm is answered while the others
are still being prepared. A fresh machine is stood in for by solver processes that wait at each
model until the test opens its gate (:mod:`tests.gated_worker`)."""

from __future__ import annotations

import json
import os
import socket
import subprocess
import time
import urllib.error
import urllib.request
from pathlib import Path

import pytest

pytest.importorskip("starlette")
pytest.importorskip("httpx2")

from starlette.testclient import TestClient  # noqa: E402
from tests.gated_worker import GATE, serve_command  # noqa: E402
from tests.serving import free_port  # noqa: E402
from tests.test_serve_connections import closed_by_server  # noqa: E402

from leapfrog_planner.planning.scenario import load_scenario  # noqa: E402
from leapfrog_planner.web import connections  # noqa: E402
from leapfrog_planner.web import pool as pool_module  # noqa: E402
from leapfrog_planner.web.app import create_app  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
CASE1 = load_scenario("paper-case-1").to_dict()
DIFF_DRIVE = {**CASE1, "robot": {"model": "diff-drive"}}


@pytest.fixture
def gate(tmp_path, monkeypatch):
    """The folder of the gates; solver processes run the gated stand-in."""
    monkeypatch.setenv(GATE, str(tmp_path))
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join([str(ROOT / "src"), str(ROOT)]))
    monkeypatch.setattr(pool_module, "WORKER", "tests.gated_worker")
    return tmp_path


def _until(check, timeout=60.0):
    end = time.monotonic() + timeout
    while not check():
        assert time.monotonic() < end, "never happened"
        time.sleep(0.02)


def test_health_and_plans_while_the_solver_is_prepared(gate):
    app = create_app(workers=1, queue=4, time_limit=30.0, models=("unicycle", "diff-drive"))
    with TestClient(app) as client:
        h = client.get("/api/health").json()
        assert h["ready"] == 0 and len(h["pids"]) == 1
        assert h["preparing"]["model"] == "unicycle"
        assert (h["preparing"]["models_done"], h["preparing"]["models"]) == (0, 2)
        assert h["models"]["unicycle"] in ("waiting", "compiling")  # the process is starting
        assert h["models"]["diff-drive"] == "waiting"

        r = client.post("/api/plan", json={"scenario": CASE1})
        assert r.status_code == 503 and r.headers["retry-after"] == "2"
        message = r.json()["error"]
        assert message.startswith("the solver is being prepared (the unicycle kernels, model 1")
        assert message.endswith("try again when /api/health says the unicycle is ready")
        assert client.get("/").status_code == 200  # the page and the scenarios meanwhile
        assert client.get("/api/scenarios").status_code == 200

        (gate / "unicycle").touch()
        _until(lambda: client.get("/api/health").json()["models"]["unicycle"] == "ready")
        # the diff-drive is compiled by a process of its own, starting meanwhile
        _until(lambda: client.get("/api/health").json()["models"]["diff-drive"] == "compiling")
        h = client.get("/api/health").json()
        assert h["models"] == {"unicycle": "ready", "diff-drive": "compiling"}
        assert h["ready"] == 0 and h["preparing"]["model"] == "diff-drive"
        assert h["preparing"]["models_done"] == 1
        # the unicycle is planned while the diff-drive is still being prepared (its gate shut)
        r = client.post("/api/plan", json={"scenario": CASE1})
        assert r.status_code == 200 and r.json()["status"] == "converged"
        r = client.post("/api/plan", json={"scenario": DIFF_DRIVE})
        assert r.status_code == 503
        assert r.json()["error"].startswith(
            "the solver is being prepared (the diff-drive kernels, model 2 of 2, "
        )
        assert " s on them, " in r.json()["error"]  # that model's seconds, then all of them
        assert client.get("/api/health").json()["models"]["diff-drive"] == "compiling"

        (gate / "diff-drive").touch()
        assert app.state.pool.wait_ready()
        h = client.get("/api/health").json()
        assert h["ready"] == 1 and h["preparing"] is None and h["not_ready"] == 2
        assert h["models"] == {"unicycle": "ready", "diff-drive": "ready"}
        r = client.post("/api/plan", json={"scenario": DIFF_DRIVE})
        assert r.status_code == 200 and r.json()["status"] == "converged"


def test_a_plan_of_a_model_further_on_waits_for_its_turn(gate):
    """The models are warmed up in their order: one not reached yet is said to be waiting,
    and a plan of it says which model comes first."""
    app = create_app(workers=1, queue=4, time_limit=30.0, models=("unicycle", "car"))
    with TestClient(app) as client:
        _until(lambda: client.get("/api/health").json()["models"]["unicycle"] == "compiling")
        assert client.get("/api/health").json()["models"]["car"] == "waiting"
        car = {**CASE1, "start": [*CASE1["start"], 0.0], "goal": [*CASE1["goal"], 0.0]}
        r = client.post("/api/plan", json={"scenario": {**car, "robot": {"model": "car"}}})
        assert r.status_code == 503
        assert r.json()["error"].startswith(
            "the solver is being prepared (the car kernels after the unicycle kernels, model 1 of"
        )


def test_a_model_whose_warm_up_fails_is_said_and_the_others_are_served(gate, monkeypatch):
    monkeypatch.setenv("LEAPFROG_TEST_FAIL", "diff-drive")
    app = create_app(workers=1, queue=4, time_limit=30.0, models=("unicycle", "diff-drive"))
    with TestClient(app) as client:
        (gate / "unicycle").touch()
        (gate / "diff-drive").touch()
        assert not app.state.pool.wait_ready()  # not every model: it does not wait for ever
        h = client.get("/api/health").json()
        assert h["preparing"] is None
        assert h["models"] == {"unicycle": "ready", "diff-drive": "failed"} and h["ready"] == 0
        r = client.post("/api/plan", json={"scenario": DIFF_DRIVE})
        assert r.status_code == 500
        assert r.json()["error"] == (
            "the solver could not prepare the diff-drive kernels: RuntimeError: a test's failure"
        )
        r = client.post("/api/plan", json={"scenario": CASE1})
        assert r.status_code == 200 and r.json()["status"] == "converged"


def test_the_other_processes_start_once_the_first_has_compiled(gate):
    """The first process alone compiles the kernels into the disk cache; the others start
    when it is ready, and load them from there."""
    app = create_app(workers=2, queue=4, time_limit=30.0, models=("unicycle",))
    with TestClient(app) as client:
        time.sleep(0.5)
        h = client.get("/api/health").json()
        assert len(h["pids"]) == 1 and h["ready"] == 0
        (gate / "unicycle").touch()
        _until(lambda: client.get("/api/health").json()["ready"] == 2)
        assert len(client.get("/api/health").json()["pids"]) == 2


def test_a_solver_that_fails_to_start_is_said_and_not_waited_for(gate, monkeypatch):
    monkeypatch.setattr(pool_module, "WORKER", "tests.no_such_module")
    app = create_app(workers=1, queue=4, time_limit=30.0, models=("unicycle",))
    with TestClient(app) as client:
        assert not app.state.pool.wait_ready()
        h = client.get("/api/health").json()
        assert h["ready"] == 0 and h["preparing"] is None and h["pids"] == []
        r = client.post("/api/plan", json={"scenario": CASE1})
        assert r.status_code == 500
        assert r.json()["error"] == "no solver process is running (see the server's log)"


def _get(url: str):
    try:
        with urllib.request.urlopen(url, timeout=5) as r:
            return r.status, json.load(r)
    except urllib.error.HTTPError as e:
        return e.code, json.load(e)


def test_the_command_answers_before_its_solver_is_ready(gate):
    """``leapfrog serve`` itself: its health answers while the solver waits at its gate; a
    connection that never sends a request is closed after the head deadline."""
    port = free_port()
    argv = serve_command(port)
    proc = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    url = f"http://127.0.0.1:{port}"
    try:
        end = time.monotonic() + 60
        while True:
            try:
                status, h = _get(url + "/api/health")
                break
            except OSError:
                assert proc.poll() is None, proc.stderr.read().decode()
                assert time.monotonic() < end, "leapfrog serve never answered"
                time.sleep(0.05)
        assert status == 200 and h["ready"] == 0 and h["preparing"]["model"] == "unicycle"
        idle = socket.create_connection(("127.0.0.1", port))
        for model in ("unicycle", "diff-drive", "car"):
            (gate / model).touch()
        _until(lambda: _get(url + "/api/health")[1]["ready"] == 1)
        with idle:
            assert closed_by_server(idle, within=connections.HEAD_SECONDS + 10)
    finally:
        proc.terminate()
        proc.wait(10)


def _serve_in_a_thread(monkeypatch, cached: set[str]):
    """``worker.serve`` of the three models in a thread of this process, with stand-ins for the
    warm-up (it notes the model), the look into the disk cache (true for ``cached``), the
    process compiling apart (it says each model it is given compiled, then ends) and the plan.
    Returns the end jobs go in at, the end messages come out of, what was warmed up and what
    was handed to a process apart."""
    import threading
    from multiprocessing import Pipe

    from leapfrog_planner.planning import warmup
    from leapfrog_planner.web import worker

    warmed, apart = [], []

    def warm_apart(models):
        apart.append(list(models))
        said, says = Pipe(duplex=False)
        for model in models:
            says.send((worker.WARMING, model))
            says.send((worker.WARM, model))
        says.close()
        return type("Ended", (), {"wait": lambda self: 0})(), said

    monkeypatch.setattr(worker, "_as_a_child", lambda: None)
    monkeypatch.setattr(worker, "warm_apart", warm_apart)
    monkeypatch.setattr(worker, "answer", lambda job, threads: ("ok", job))
    monkeypatch.setattr(warmup, "warm_up", warmed.append)
    monkeypatch.setattr(warmup, "in_disk_cache", lambda model: model in cached)
    receive, jobs = Pipe(duplex=False)
    answers, send = Pipe(duplex=False)
    models = ["unicycle", "diff-drive", "car"]
    thread = threading.Thread(target=worker.serve, args=(receive, send, models, 1), daemon=True)
    thread.start()
    return jobs, answers, warmed, apart, thread


@pytest.mark.parametrize("cached", [{"diff-drive"}, {"diff-drive", "car"}, set()])
def test_models_in_the_disk_cache_are_loaded_by_the_solver_itself(monkeypatch, cached):
    """A model already in the disk cache is loaded by the solver process itself, between plans,
    under a second (a process apart would start, load it and say so first: 2.4 s more, measured
    with every model warm); only the models missing from the cache are compiled apart."""
    jobs, answers, warmed, apart, thread = _serve_in_a_thread(monkeypatch, cached)
    jobs.send("a plan")
    said = []
    while not (("ok", "a plan") in said and sum(m[0] == "warm" for m in said) == 3):
        assert answers.poll(30), said
        said.append(answers.recv())
    jobs.close()
    thread.join(30)
    assert not thread.is_alive()
    assert said[:2] == [("warming", "unicycle"), ("warm", "unicycle")]
    assert sorted(warmed) == ["car", "diff-drive", "unicycle"]
    missing = [m for m in ("diff-drive", "car") if m not in cached]
    assert apart == ([missing] if missing else [])
    for model in ("diff-drive", "car"):  # each said warming, then warm
        assert said.index(("warming", model)) < said.index(("warm", model))
