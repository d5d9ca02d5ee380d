"""The server's HTTP/1.1 connections: uvicorn's, with a deadline for each request's head.

uvicorn closes a connection left idle after a response (``timeout_keep_alive``), but not one
that never sends a whole request line and headers: a client may open a connection and send
nothing, or a byte of headers every few seconds, and hold it for ever. The server takes at most
100 connections at once (``limit_concurrency``), so a hundred such clients would turn every
other visitor away. Here a connection that has not sent a request's whole head within
:data:`HEAD_SECONDS` of opening, or of its last response, is closed. A request's body has its
own deadline in the application (``app.BODY_SECONDS``).
"""

from __future__ import annotations

import asyncio

import h11
from uvicorn.protocols.http.h11_impl import H11Protocol

#: Seconds a connection may take to send a request's line and headers.
HEAD_SECONDS = 10.0


class HeadTimedH11Protocol(H11Protocol):
    """uvicorn's h11 protocol that closes a connection whose request head is late."""

    _head_timer: asyncio.TimerHandle | None = None

    def connection_made(self, transport) -> None:  # type: ignore[override]
        super().connection_made(transport)
        self._await_head()

    def connection_lost(self, exc: Exception | None) -> None:
        self._stop_waiting()
        super().connection_lost(exc)

    def on_response_complete(self) -> None:
        super().on_response_complete()
        self._await_head()

    def _await_head(self) -> None:
        self._stop_waiting()
        self._head_timer = self.loop.call_later(HEAD_SECONDS, self._head_late)

    def _stop_waiting(self) -> None:
        if self._head_timer is not None:
            self._head_timer.cancel()
            self._head_timer = None

    def _head_late(self) -> None:
        """Close the connection if it still waits for a request's head (h11 leaves the
        client's state ``IDLE`` until the whole head has arrived)."""
        self._head_timer = None
        if self.conn.their_state is h11.IDLE and not self.transport.is_closing():
            self.transport.close()
