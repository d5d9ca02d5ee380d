"""``leapfrog serve``: plan interactively in the browser (the page and its API: :mod:`..web`)."""

from __future__ import annotations

import os

import click

from .common import EXIT_OK, console


def _default_workers() -> int:
    return max(1, min(4, os.cpu_count() or 1))


@click.command()
@click.option("--host", default="127.0.0.1", show_default=True, help="address to listen on")
@click.option("--port", type=click.IntRange(0, 65535), default=8000, show_default=True)
@click.option(
    "--workers",
    type=click.IntRange(1, 64),
    default=None,
    help="solver processes (solves at once)  [default: CPU cores, at most 4]",
)
@click.option(
    "--queue",
    type=click.IntRange(0, 1024),
    default=32,
    show_default=True,
    help="requests waiting for a solver process; more are refused (503)",
)
@click.option(
    "--time-limit",
    type=click.FloatRange(min=0, min_open=True, max=3600),
    default=20.0,
    show_default=True,
    help="seconds a solve may take: a plan ends with its best answer after 0.8 of them, and a"
    " solve still running at the limit is stopped (504)",
)
def serve(host, port, workers, queue, time_limit):
    """Plan interactively in the browser: a local web page to edit a scenario (drag the start,
    the goal and the obstacles) and see the optimal path, its controls and the sweeps."""
    try:
        import uvicorn

        from ..web.app import create_app
        from ..web.connections import HeadTimedH11Protocol
    except ImportError as e:
        raise click.ClickException(
            f"leapfrog serve needs starlette and uvicorn ({e.name} is missing): "
            "pip install 'leapfrog-planner[serve]'"
        ) from None
    workers = workers or _default_workers()
    app = create_app(workers=workers, queue=queue, time_limit=time_limit)
    where = f"[{host}]" if ":" in host else host
    console.print(
        f"leapfrog serve: http://{where}:{port}/  ({workers} solver processes, time limit"
        f" {time_limit:g} s; the first start compiles the kernels); Ctrl-C stops",
        highlight=False,
        markup=False,
        soft_wrap=True,
    )
    # At most 100 connections at once (more are answered 503 at once, not held), idle ones
    # closed after 5 s, one whose request head is late after 10 s; a body that dribbles in is
    # cut off by the application (408).
    uvicorn.run(app, host=host, port=port, log_level="warning", access_log=False,
                limit_concurrency=100, timeout_keep_alive=5,
                http=HeadTimedH11Protocol)  # fmt: skip
    return EXIT_OK
