"""The composition service's HTTP endpoints (FastAPI): every body read with a size limit, every field checked before
any work, one message for a bad input.

    GET  /                           the page (page.html)
    GET  /health                     status, limits and each model's provenance (file, digest, run key, metrics)
    POST /compose/modular            JSON {"terrain_seed": S} or {"heightmap": 50 x 20 numbers}, with optional "k",
                                     "max", "samples", "seed", "distances", "model"; or a .npy height map as the body
                                     (Content-Type application/x-npy) with those as query parameters
    POST /compose/teams              a DroneDeploy label PNG as the body; query parameters budget, seed, measure,
                                     draw, name, model
    GET  /picture/modular            a design at its start pose on a terrain, as the report draws it (PNG)
    GET  /chips/synthetic/{seed}     a synthetic label chip (PNG), for the page's "pick a chip"

The queries are modular.compose.ModularComposer.query and teams.compose.TeamsComposer.query, the functions behind
`robocompose compose`. A bad input is a 4xx whose body is {"error": "<field>: <expected>, found <value>"}: 400 a
bad value, 404 an unknown model, 413 a body over its limit, 415 a body of another type. No file a request names is
read: bodies are parsed in memory and never written to disk; model files are loaded at start (weights only).
Work of seconds (a measured front, rollouts, pictures) runs in worker threads and never holds up the fast queries.
"""

from __future__ import annotations

import base64
import io
import json
import os
import re
import threading
import time
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np
from fastapi import FastAPI, Request
from fastapi.responses import HTMLResponse, JSONResponse, Response
from starlette.concurrency import run_in_threadpool

from robocompose.io.errors import InputError
from robocompose.modular.compose import ModularComposer, check_heightmap, load_npy, parse_caps
from robocompose.modular.terrain import TerrainConfig
from robocompose.teams.compose import TeamsComposer

MAX_BODY_BYTES = 8 * 1024 * 1024  # an upload: a label PNG or a height map (a 300 x 300 chip is ~10-60 kB)
MAX_CHIP_PIXELS = 2048 * 2048  # pixels of an uploaded label PNG decoded at most (the answer uses its first chip)
MAX_SEED = 2**63 - 1
MAX_K = 256  # designs a modular query answers at most
MAX_SAMPLES = 4096  # generator draws per modular query (doubled up to 16x while fewer than k designs are found)
NAME = re.compile(r"[A-Za-z0-9_.-]{1,64}")  # a chip's name: its chip id is "<name>-000000", as for a file <name>.png
PAGE = Path(__file__).with_name("page.html")


class ServiceError(InputError):
    """A bad request whose status is not 400: 404 unknown model, 413 too large, 415 wrong type."""

    def __init__(self, status: int, message: str):
        super().__init__(message)
        self.status = status


@dataclass
class Models:
    """The generators the service answers with, by name (the default one is "shipped"), loaded once."""

    modular: dict[str, ModularComposer]
    teams: dict[str, TeamsComposer]
    params_source: str  # where the modular params come from, as height-map errors name it
    spec: tuple = ((), (), None)  # (modular NAME=PATH flags, teams flags, params file): what a query process loads
    provenance: dict = field(default_factory=dict)  # world -> name -> provenance, filled by `create_app`


@dataclass(frozen=True)
class Query:
    """A checked request: which world's model answers it and the arguments of its `query`; `slow` (seconds: a
    measured front, rollouts) runs in a thread of the HTTP process, never in a query process."""

    world: str  # "modular" or "teams"
    model: str
    arguments: dict
    slow: bool = False
    draw: bool = False  # teams: add the chip's drawing (in the HTTP process)

    def composer(self, models: Models) -> Any:
        return (models.modular if self.world == "modular" else models.teams)[self.model]


_PROCESS_MODELS: Models | None = None  # a query process's own copy of the models, loaded by `start_query_process`


def start_query_process(modular: list[str], teams: list[str], params: str | None) -> None:
    """Initializer of a query process (`--workers N`): the HTTP process's models, loaded again here."""
    global _PROCESS_MODELS
    from robocompose.io.quiet import quiet_pybullet
    from robocompose.serve.cli import load_models

    quiet_pybullet()
    _PROCESS_MODELS = load_models(modular, teams, params and Path(params))


def answer_in_process(query: Query) -> dict:
    """`query` answered by a query process's models."""
    assert _PROCESS_MODELS is not None, "not a query process"
    return query.composer(_PROCESS_MODELS).query(**query.arguments)


def query_process_pid() -> int:
    """This process's pid, a quarter of a second later: tasks that last let every process of a pool take some."""
    time.sleep(0.25)
    return os.getpid()


def _shown(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else f"{text[:57]}..."


def _integer(value: Any, name: str, low: int, high: int) -> int:
    """An integer field of JSON or of the query string (decimal digits), within [low, high]."""
    if isinstance(value, str) and re.fullmatch(r"-?[0-9]{1,20}", value.strip()):
        value = int(value)
    if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
        raise InputError(f"{name}: expected an integer in {low}..{high}, found {_shown(value)}")
    return value


def _boolean(value: Any, name: str) -> bool:
    words = {"true": True, "1": True, "yes": True, "false": False, "0": False, "no": False}
    if isinstance(value, bool):
        return value
    if isinstance(value, str) and value.strip().lower() in words:
        return words[value.strip().lower()]
    raise InputError(f"{name}: expected true or false, found {_shown(value)}")


def _known(fields: dict, allowed: tuple[str, ...], where: str) -> None:
    unknown = sorted(set(fields) - set(allowed))
    if unknown:
        raise InputError(f"{unknown[0]}: unknown {where}, expected some of {list(allowed)}")


def _model(models: dict, name: Any) -> Any:
    if not isinstance(name, str) or name not in models:
        raise ServiceError(404, f"model: {_shown(name)} unknown, expected one of {sorted(models)}")
    return models[name]


async def _body(request: Request, limit: int = MAX_BODY_BYTES) -> bytes:
    """The request's body, refused (413) once it exceeds `limit` bytes, before more is read."""
    declared = request.headers.get("content-length", "")
    if declared.isdigit() and int(declared) > limit:
        raise ServiceError(413, f"body: {int(declared):,} bytes, expected at most {limit:,} bytes")
    chunks, size = [], 0
    async for chunk in request.stream():
        size += len(chunk)
        if size > limit:
            raise ServiceError(413, f"body: more than {limit:,} bytes, expected at most {limit:,} bytes")
        chunks.append(chunk)
    return b"".join(chunks)


# --- modular ---

MODULAR_FIELDS = ("terrain_seed", "heightmap", "k", "max", "samples", "seed", "distances", "model")
NPY_TYPES = ("application/x-npy", "application/octet-stream")


def _caps(value: Any) -> dict[str, int]:
    """`max` as {"leg": 2, "wheel": 0} or "leg=2,wheel=0" -> the port letters' caps."""
    if isinstance(value, dict):
        if not all(isinstance(v, int) and not isinstance(v, bool) for v in value.values()):
            raise InputError(f"max: expected integer caps per module type, found {_shown(value)}")
        value = ",".join(f"{k}={v}" for k, v in value.items())
    if not isinstance(value, str):
        raise InputError(f"max: expected caps such as {{\"leg\": 2}} or \"leg=2,wheel=0\", found {_shown(value)}")
    return parse_caps(value, "max")


def _heights(value: Any, composer: ModularComposer, where: str) -> np.ndarray:
    if isinstance(value, str):
        raise InputError(f"heightmap: expected a 50 x 20 array of numbers (metres), found a string {_shown(value)} "
                         "(the service reads no file a request names: send the heights themselves)")
    try:
        heights = np.asarray(value, dtype=np.float64)
    except (ValueError, TypeError):
        raise InputError("heightmap: expected a 50 x 20 array of numbers (metres), found a ragged or non-numeric "
                         "array") from None
    return check_heightmap(heights, composer.params.eval.terrain, where, "heightmap")


def modular_query(models: Models, fields: dict, heights: np.ndarray | None = None) -> Query:
    """The checked query of a request (its fields; a .npy body's heights). Every field is checked here, before any
    work."""
    _known(fields, MODULAR_FIELDS, "field")
    name = fields.get("model", "shipped")
    composer = _model(models.modular, name)
    seed_given = fields.get("terrain_seed") is not None
    if heights is None and fields.get("heightmap") is not None:
        heights = _heights(fields["heightmap"], composer, models.params_source)
    elif heights is not None:
        heights = check_heightmap(heights, composer.params.eval.terrain, models.params_source, "body")
    if seed_given == (heights is not None):
        raise InputError("terrain_seed: expected a terrain seed or a heightmap, exactly one")
    terrain_seed = _integer(fields["terrain_seed"], "terrain_seed", 0, MAX_SEED) if seed_given else None
    distances = fields.get("distances")
    if distances is not None and distances not in ("table", "rollout"):
        raise InputError(f"distances: expected \"table\", \"rollout\" or null, found {_shown(distances)}")
    if distances is not None and terrain_seed is None:
        raise InputError(f"distances: {distances!r} needs a terrain_seed (a height map alone does not define the "
                         "blocks)")
    arguments = dict(terrain_seed=terrain_seed, heights=heights, k=_integer(fields.get("k", 10), "k", 1, MAX_K),
                     caps=_caps(fields.get("max", {})),
                     samples=_integer(fields.get("samples", 64), "samples", 1, MAX_SAMPLES),
                     seed=_integer(fields.get("seed", 0), "seed", 0, MAX_SEED), distances=distances)
    return Query("modular", name, arguments, slow=distances == "rollout")


# --- teams ---

TEAMS_FIELDS = ("budget", "seed", "measure", "draw", "name", "model")


def teams_query(models: Models, fields: dict, body: bytes) -> Query:
    """The checked query of a teams request (query parameters, label PNG body). The chip is decoded here, in memory,
    before any work."""
    from robocompose.teams.chips import chips_in_file

    _known(fields, TEAMS_FIELDS, "query parameter")
    model = fields.get("model", "shipped")
    composer = _model(models.teams, model)
    budget = fields.get("budget")
    budget = None if budget in (None, "") else _integer(budget, "budget", 1, composer.bank)
    seed = _integer(fields.get("seed", 0), "seed", 0, MAX_SEED)
    measure, draw = _boolean(fields.get("measure", False), "measure"), _boolean(fields.get("draw", False), "draw")
    name = fields.get("name", "upload")
    if not NAME.fullmatch(name):
        raise InputError(f"name: expected 1 to 64 letters, digits, '_', '.' or '-', found {_shown(name)}")
    if not body:
        raise InputError("body: empty, expected a DroneDeploy label PNG")
    chip = next(chips_in_file(io.BytesIO(body), name="body", stem=name, max_pixels=MAX_CHIP_PIXELS), None)
    if chip is None:
        raise InputError("body: no 300 x 300 window without IGNORE pixels (expected a label PNG of at least "
                         "300 x 300 pixels)")
    return Query("teams", model, {"chip": chip, "budget": budget, "seed": seed, "measure": measure}, slow=measure,
                 draw=draw)


def chip_drawing(chip: Any, composer: TeamsComposer) -> str:
    """The chip in its label colours, lightened, with its regions' borders in black, as a PNG data URL."""
    from PIL import Image

    from robocompose.teams.chips import CLASS_COLOURS_RGB
    from robocompose.teams.decompose import decompose_chip

    raster = decompose_chip(chip, composer.decompose).raster(chip.terrain)  # (H, W) region of every pixel
    rgb = (0.45 * np.array(CLASS_COLOURS_RGB, dtype=np.float64)[chip.classes] + 0.55 * 255).astype(np.uint8)
    border = np.zeros(raster.shape, dtype=bool)
    border[:-1] |= raster[:-1] != raster[1:]
    border[:, :-1] |= raster[:, :-1] != raster[:, 1:]
    rgb[border] = 0
    buffer = io.BytesIO()
    Image.fromarray(rgb).save(buffer, format="PNG")
    return "data:image/png;base64," + base64.b64encode(buffer.getvalue()).decode()


# --- pictures ---

_PYBULLET = threading.Lock()  # one rendering at a time: pybullet's module-level state is not thread-safe


@lru_cache(maxsize=256)
def design_png(design: str, terrain_seed: int | None, config: TerrainConfig) -> bytes:
    """PNG of `design` at its start pose on the block terrain of `terrain_seed` (None: flat ground)."""
    from PIL import Image

    from robocompose.modular.experiments.pictures import design_picture
    from robocompose.modular.terrain import Terrain, generate_terrain

    terrain = (Terrain(-1, np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0), config) if terrain_seed is None
               else generate_terrain(terrain_seed, config))
    with _PYBULLET:
        image = design_picture(design, terrain)
    buffer = io.BytesIO()
    Image.fromarray(image).save(buffer, format="PNG")
    return buffer.getvalue()


def provenance(path: Path, info: dict) -> dict:
    """What a user checks of a loaded model: its file, size and digest, the code and run it came from, its metrics."""
    import hashlib

    return {"file": str(path), "bytes": path.stat().st_size, "sha256": hashlib.sha256(path.read_bytes()).hexdigest(),
            "problem": info.get("problem"), "model_code": info.get("model_code"), "run_key": info.get("run_key"),
            "shipped_from": info.get("shipped_from"), "metrics": info.get("metrics")}


def _json(payload: dict, started: float) -> Response:
    payload["latency_ms"] = round(1000 * (time.perf_counter() - started), 2)  # the server's part of the wait
    return Response(json.dumps(payload), media_type="application/json")


def create_app(models: Models, query_processes: int = 0) -> FastAPI:
    """The service over `models` (loaded by the caller: a model that does not load stops the start, not a request).

    `query_processes` > 0: the fast queries are answered by that many processes, each with its own copy of the
    models, taken request by request (a free process takes the next), so the cores share the load whichever
    connection a request comes on; the HTTP process parses, checks and answers the slow ones in its threads.
    0: the fast queries run on the event loop."""
    import asyncio
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor
    from contextlib import asynccontextmanager

    models.provenance = {"modular": {n: provenance(c.path, c.info) for n, c in models.modular.items()},
                         "teams": {n: provenance(c.path, c.info) for n, c in models.teams.items()}}
    page = PAGE.read_text()
    pool = None
    if query_processes:
        pool = ProcessPoolExecutor(query_processes, mp_context=multiprocessing.get_context("spawn"),
                                   initializer=start_query_process, initargs=models.spec)
        ready = [pool.submit(query_process_pid) for _ in range(4 * query_processes)]
        models.provenance["query_processes"] = sorted({f.result() for f in ready})  # every one up and loaded

    @asynccontextmanager
    async def lifespan(app: FastAPI):
        yield
        if pool is not None:
            pool.shutdown(cancel_futures=True)

    app = FastAPI(title="robocompose", description="Robot compositions in milliseconds from trained EG-GAN generators",
                  docs_url="/docs", redoc_url=None, lifespan=lifespan)
    app.state.models = models

    async def answer(query: Query, started: float) -> Response:
        if query.slow:
            out = await run_in_threadpool(query.composer(models).query, **query.arguments)
        elif pool is not None:
            out = await asyncio.get_running_loop().run_in_executor(pool, answer_in_process, query)
        else:
            out = query.composer(models).query(**query.arguments)  # a few ms: no thread hop
        if query.draw:
            out["drawing"] = await run_in_threadpool(chip_drawing, query.arguments["chip"], query.composer(models))
        return _json(out, started)

    @app.exception_handler(InputError)
    async def bad_input(request: Request, error: InputError) -> JSONResponse:
        message = " ".join(str(error).split())[:500]  # one line, of a readable length
        return JSONResponse({"error": message}, status_code=getattr(error, "status", 400))

    @app.get("/", response_class=HTMLResponse)
    async def index() -> HTMLResponse:
        return HTMLResponse(page)

    @app.get("/health")
    async def health() -> dict:
        return {"status": "ok", "worker": os.getpid(), "query_processes": models.provenance.get("query_processes", []),
                "models": {w: models.provenance[w] for w in ("modular", "teams")},
                "limits": {"body_bytes": MAX_BODY_BYTES, "chip_pixels": MAX_CHIP_PIXELS, "k": MAX_K,
                           "samples": MAX_SAMPLES}}

    @app.post("/compose/modular")
    async def compose_modular(request: Request) -> Response:
        started = time.perf_counter()
        body = await _body(request)
        kind = request.headers.get("content-type", "").split(";")[0].strip().lower()
        if kind == "application/json":
            try:
                fields = json.loads(body)
            except (ValueError, RecursionError):
                raise InputError("body: not valid JSON, expected an object such as {\"terrain_seed\": 1000}") from None
            if not isinstance(fields, dict):
                raise InputError(f"body: expected a JSON object, found {type(fields).__name__}")
            query = modular_query(models, fields)
        elif kind in NPY_TYPES:
            query = modular_query(models, dict(request.query_params), load_npy(body, "body"))
        else:
            raise ServiceError(415, f"body: content type {kind or 'none'!r}, expected application/json or "
                                    "application/x-npy (a .npy height map)")
        return await answer(query, started)

    @app.post("/compose/teams")
    async def compose_teams(request: Request) -> Response:
        started = time.perf_counter()
        body = await _body(request)
        return await answer(teams_query(models, dict(request.query_params), body), started)

    @app.get("/picture/modular")
    async def picture(request: Request) -> Response:
        from robocompose.modular.robot import parse_design

        fields = dict(request.query_params)
        _known(fields, ("design", "terrain_seed", "model"), "query parameter")
        composer = _model(models.modular, fields.get("model", "shipped"))
        design = parse_design(fields.get("design", ""))
        seed = fields.get("terrain_seed")
        seed = None if seed in (None, "") else _integer(seed, "terrain_seed", 0, MAX_SEED)
        png = await run_in_threadpool(design_png, design, seed, composer.params.eval.terrain)  # frozen: a cache key
        return Response(png, media_type="image/png")

    @app.get("/chips/synthetic/{seed}")
    async def synthetic(seed: str) -> Response:
        from robocompose.teams.chips import label_png_bytes, synthetic_chip

        chip = synthetic_chip(_integer(seed, "seed", 0, 2**32 - 1))
        return Response(label_png_bytes(chip.classes), media_type="image/png")

    return app
