"""The web application of ``leapfrog serve``: the page and its JSON API.

- ``GET /``: the page; ``GET /static/...``: its script and style (shipped in the package).
- ``GET /api/scenarios``: the built-in scenarios, in the layout of a scenario file.
- ``GET /api/models``: the vehicle models a scenario's ``[robot] model`` names: their states,
  their controls (each can be bounded) and their parameters with the defaults.
- ``POST /api/open`` ``{"toml", "name"}``: a scenario file opened on the page, checked (its
  ``[map]`` table is given back apart: the page opens the map's files itself).
- ``POST /api/maps`` ``{"yaml", "image"}``: a ROS map opened on the page (:mod:`.maps`): its id,
  place and suggested ends; ``GET /api/maps/<id>.png``: the map drawn as ROS shows it.
- ``POST /api/plan`` ``{"scenario", "options", "session", "seq"}``: plan it; what the page draws
  (a scenario's ``map`` is ``{"id", "unknown", "length"}``, the id of a map opened on the page).
- ``POST /api/toml``, ``/api/result.json``, ``/api/result.csv``: the downloads (the scenario file
  with the page's options in its ``[solver]`` table; the result as ``leapfrog solve --json`` and
  ``leapfrog export --csv`` write it).
- ``GET /api/health``: the pool's state and counts: ``models``, each model's state
  (``"ready"``: plans of it are answered; ``"compiling"``, ``"waiting"`` for its turn,
  ``"failed"``), ``ready``, the solver processes that have warmed every model up, and while one
  warms up (a first start on a machine compiles the kernels, about 20 s a model)
  ``preparing``: its model, how many of the models are done, the seconds so far. The server
  answers from its start on, and plans of a model as soon as a solver process has warmed it up.

Every error is JSON, ``{"error": "<one line>"}``: 400 for bad input (the command line's message),
404/405 for a wrong address or method, 409 for a request superseded by a newer one of the same
session, 413 for a body too large, 503 when the pool is full or no solver process has warmed the
plan's model up yet (with ``Retry-After``), 504 past the time limit (a plan is given 0.8 of it
as its own limit and ends with the best answer found by then: see :data:`.pool.PLAN_SHARE`).
"""

from __future__ import annotations

import json
import logging
from collections import OrderedDict
from contextlib import asynccontextmanager
from importlib import resources

import anyio
from starlette.applications import Starlette
from starlette.exceptions import HTTPException
from starlette.requests import Request
from starlette.responses import FileResponse, JSONResponse, Response
from starlette.routing import Mount, Route
from starlette.staticfiles import StaticFiles

from .._atomic import json_text
from ..planning.scenario import builtin_scenarios, load_scenario
from .maps import MAX_MAP_BYTES, MAX_UPLOAD_BYTES, MapStore, parse_upload
from .pool import PoolError, SolvePool
from .schema import (
    MAX_BODY_BYTES,
    PlanRequest,
    RequestError,
    file_name,
    parse_json,
    parse_plan,
    parse_toml,
)

log = logging.getLogger(__name__)

#: Sessions whose latest request number is remembered (the oldest forgotten first).
MAX_SESSIONS = 4096

STATIC = resources.files("leapfrog_planner.web").joinpath("static")


def error(message: str, status: int, headers: dict | None = None) -> JSONResponse:
    body = {"error": " ".join(str(message).splitlines())}
    return JSONResponse(body, status_code=status, headers=headers)


class _Latest:
    """The newest request number of each session."""

    def __init__(self):
        self._seen: OrderedDict[str, int] = OrderedDict()

    def note(self, session: str | None, seq: int) -> None:
        if session is None:
            return
        self._seen[session] = max(seq, self._seen.get(session, seq))
        self._seen.move_to_end(session)
        while len(self._seen) > MAX_SESSIONS:
            self._seen.popitem(last=False)

    def stale(self, session: str | None, seq: int):
        if session is None:
            return None
        return lambda: self._seen.get(session, seq) > seq


#: Seconds a request's body may take to arrive (a client that dribbles it is cut off).
BODY_SECONDS = 30.0


async def _body(request: Request):
    """The JSON of a request, read up to :data:`MAX_BODY_BYTES` (see :func:`_read`)."""
    too_large = RequestError(f"request: larger than {MAX_BODY_BYTES // 2**20} MB", 413)
    return parse_json(await _read(request, MAX_BODY_BYTES, too_large), MAX_BODY_BYTES)


async def _upload(request: Request):
    """The JSON of a map's upload, read up to :data:`MAX_UPLOAD_BYTES` (see :func:`_read`)."""
    too_large = RequestError(
        f"map: the YAML file and its image are larger than {MAX_MAP_BYTES // 2**20} MB", 413
    )
    return parse_json(await _read(request, MAX_UPLOAD_BYTES, too_large), MAX_UPLOAD_BYTES)


async def _read(request: Request, limit: int, too_large: RequestError) -> bytes:
    """A request's body, refused at once when it says it is larger than ``limit`` bytes and
    as soon as more arrives (never held whole first), and cut off (408) when it takes longer
    than :data:`BODY_SECONDS` to arrive."""
    declared = request.headers.get("content-length", "")
    if declared.isdigit() and int(declared) > limit:
        raise too_large
    chunks, size = [], 0
    try:
        with anyio.fail_after(BODY_SECONDS):
            async for chunk in request.stream():
                size += len(chunk)
                if size > limit:
                    raise too_large
                chunks.append(chunk)
    except TimeoutError:
        raise RequestError(f"request: the body took longer than {BODY_SECONDS:g} s", 408) from None
    return b"".join(chunks)


def create_app(pool: SolvePool | None = None, **pool_options) -> Starlette:
    """The application; it starts ``pool`` (or a new ``SolvePool(**pool_options)``) when it
    starts and closes it when it stops."""
    pool = pool if pool is not None else SolvePool(**pool_options)
    maps = MapStore()
    latest = _Latest()
    limiter = anyio.CapacityLimiter(pool.capacity)

    async def solve(req: PlanRequest, kind: str) -> bytes:
        with pool.admitted():
            latest.note(req.session, req.seq)
            stale = latest.stale(req.session, req.seq)
            status, value = await anyio.to_thread.run_sync(
                pool.run, req.job(kind, pool.plan_limit), stale, req.scenario.model, limiter=limiter
            )
        if status == "bad":
            raise RequestError(value)
        if status != "ok":
            raise PoolError(value)
        return value

    async def open_file(request):
        sc, world = parse_toml(await _body(request))
        return JSONResponse({"scenario": sc.to_dict(), "map": world})

    async def open_map(request):
        files = parse_upload(await _upload(request))
        m = await anyio.to_thread.run_sync(maps.add, *files)
        return JSONResponse(await anyio.to_thread.run_sync(m.info))

    async def map_image(request):
        m = maps.find(request.path_params["id"])
        if m is None:
            raise HTTPException(404, "no such map on the server: open it again")
        return Response(m.png, media_type="image/png", headers={"Cache-Control": "no-store"})

    async def planned(request) -> PlanRequest:
        data = await _body(request)
        return await anyio.to_thread.run_sync(parse_plan, data, maps)

    async def plan(request):
        body = await solve(await planned(request), "view")
        return Response(body, media_type="application/json")

    async def toml(request):
        req = await planned(request)
        text = req.toml()
        return _download(text.encode(), "application/toml", file_name(req.scenario.name, ".toml"))

    async def result_json(request):
        req = await planned(request)
        body = _named_map(await solve(req, "json"), req)
        return _download(body, "application/json", file_name(req.scenario.name, ".json"))

    async def result_csv(request):
        req = await planned(request)
        body = await solve(req, "csv")
        return _download(body, "text/csv", file_name(req.scenario.name, ".csv"))

    async def health(request):
        return JSONResponse(pool.stats())

    @asynccontextmanager
    async def lifespan(app):
        await anyio.to_thread.run_sync(pool.start)
        try:
            yield
        finally:
            pool.close()
            maps.close()

    routes = [
        Route("/", _page),
        Route("/api/scenarios", _scenarios),
        Route("/api/models", _models),
        Route("/api/open", open_file, methods=["POST"]),
        Route("/api/maps", open_map, methods=["POST"]),
        Route("/api/maps/{id}.png", map_image),
        Route("/api/plan", plan, methods=["POST"]),
        Route("/api/toml", toml, methods=["POST"]),
        Route("/api/result.json", result_json, methods=["POST"]),
        Route("/api/result.csv", result_csv, methods=["POST"]),
        Route("/api/health", health),
        Mount("/static", app=StaticFiles(directory=str(STATIC)), name="static"),
    ]
    app = Starlette(routes=routes, exception_handlers=HANDLERS, lifespan=lifespan)
    app.state.pool = pool
    app.state.maps = maps
    return app


async def _page(request):
    return FileResponse(str(STATIC.joinpath("index.html")), media_type="text/html")


async def _scenarios(request):
    out = [{"name": n, "scenario": load_scenario(n).to_dict()} for n in builtin_scenarios()]
    return JSONResponse({"scenarios": out})


def model_table() -> list[dict]:
    """Each built-in model as the page's robot panel shows it: what the start and goal hold
    (its states), what can be bounded (its controls) and its parameters by name, each with its
    default and whether it must be positive (the planner's bound parameters left out)."""
    from ..compiled.kernels import model_info
    from ..model import MODELS

    out = []
    for name in MODELS:
        info = model_info(name)
        facts = zip(info.defaults, info.positive, strict=True)
        table = dict(zip(info.parameters, facts, strict=True))
        out.append(
            {
                "name": name,
                "description": info.description,
                "states": list(info.states),
                "controls": list(info.controls),
                "parameters": [
                    {"name": p, "default": table[p][0], "positive": bool(table[p][1])}
                    for p in info.robot_parameters
                ],
            }
        )
    return out


async def _models(request):
    return JSONResponse({"models": await anyio.to_thread.run_sync(model_table)})


def _internal(request, exc) -> JSONResponse:
    log.exception("internal error", exc_info=exc)
    return error(f"internal error: {type(exc).__name__}", 500)


def _named_map(body: bytes, req: PlanRequest) -> bytes:
    """A result file of a plan on an uploaded map names the map by its YAML file's name (the
    file beside it, as the TOML download does), never by the server's temporary folder."""
    if req.map is None:
        return body
    data = json.loads(body)
    table = (data.get("scenario_file") or {}).get("map")
    if isinstance(table, dict) and "file" in table:
        table["file"] = req.map.name
    return json_text(data).encode()


def _download(body: bytes, media_type: str, name: str) -> Response:
    headers = {"Content-Disposition": f'attachment; filename="{name}"'}
    return Response(body, media_type=media_type, headers=headers)


#: Errors as JSON ``{"error": "<one line>"}`` with their status.
HANDLERS = {
    RequestError: lambda r, e: error(str(e), e.status),
    PoolError: lambda r, e: error(str(e), e.status, getattr(e, "headers", None)),
    HTTPException: lambda r, e: error(e.detail, e.status_code),
    Exception: _internal,
}
