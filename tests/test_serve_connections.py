"""The server's connections: one that does not send a whole request head in time is closed
(an idle connection, or headers dribbled a byte at a time), while prompt requests are answered
as before, also several on one kept-alive connection."""

from __future__ import annotations

import socket
import threading
import time

import pytest

pytest.importorskip("starlette")
uvicorn = pytest.importorskip("uvicorn")

from starlette.applications import Starlette  # noqa: E402
from starlette.responses import PlainTextResponse  # noqa: E402
from starlette.routing import Route  # noqa: E402
from tests.serving import free_port  # noqa: E402

from leapfrog_planner.web import connections  # noqa: E402

REQUEST = b"GET / HTTP/1.1\r\nHost: x\r\n\r\n"


@pytest.fixture
def server(monkeypatch):
    """A server with a short head deadline (0.5 s) in a thread: its port."""
    monkeypatch.setattr(connections, "HEAD_SECONDS", 0.5)
    app = Starlette(routes=[Route("/", lambda request: PlainTextResponse("ok"))])
    port = free_port()
    http = connections.HeadTimedH11Protocol
    config = uvicorn.Config(app, host="127.0.0.1", port=port, log_level="warning",
                            timeout_keep_alive=30, http=http)  # fmt: skip
    srv = uvicorn.Server(config)
    thread = threading.Thread(target=srv.run, daemon=True)
    thread.start()
    end = time.monotonic() + 20
    while not srv.started:
        assert time.monotonic() < end and thread.is_alive(), "the server did not start"
        time.sleep(0.01)
    yield port
    srv.should_exit = True
    thread.join(10)


def closed_by_server(s: socket.socket, within: float) -> bool:
    """Whether the server closes ``s`` within ``within`` s (reading what it still sends)."""
    s.settimeout(within)
    try:
        while s.recv(4096):
            pass
    except TimeoutError:
        return False
    except ConnectionResetError:
        pass
    return True


def answer(s: socket.socket) -> bytes:
    s.settimeout(5)
    data = b""
    while not data.endswith(b"ok"):
        data += s.recv(4096)
    return data


def test_an_idle_connection_is_closed_after_the_head_deadline(server):
    with socket.create_connection(("127.0.0.1", server)) as s:
        t = time.monotonic()
        assert closed_by_server(s, within=5)
        assert time.monotonic() - t >= 0.4


def test_a_head_dribbled_in_is_cut_off(server):
    with socket.create_connection(("127.0.0.1", server)) as s:
        end = time.monotonic() + 5
        for byte in REQUEST[:-4]:  # never the head's end
            try:
                s.send(bytes([byte]))
            except OSError:
                break
            time.sleep(0.1)
            if time.monotonic() > end:
                break
        assert closed_by_server(s, within=5)


def test_prompt_requests_are_answered_on_a_kept_alive_connection(server):
    with socket.create_connection(("127.0.0.1", server)) as s:
        for _ in range(3):
            s.sendall(REQUEST)
            assert answer(s).startswith(b"HTTP/1.1 200")
            time.sleep(0.3)  # less than the deadline between requests
        assert closed_by_server(s, within=5)  # then idle: closed
