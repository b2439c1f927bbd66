"""The HTTP planning service (FastAPI): tasks, planning problems, sessions, SPARQL.

Bodies are the project's file formats (the OpenAPI schema at /openapi.json is the task file, the
planning problem, the trajectory file). Every request that reasons or plans runs in a planning
worker process, every SPARQL query in a query worker (workers.py), so a query never takes a
planning worker. Sessions and stored tasks live here, in the server, as their state; each
request sends that state to whichever worker is free, which rebuilds (or updates) its planning
session from it, so a crashed or killed worker loses nothing.
"""

from __future__ import annotations

import asyncio
import html
import uuid
from collections.abc import Awaitable, Callable, Iterator
from contextlib import asynccontextmanager
from pathlib import Path
from typing import Any

from fastapi import FastAPI, Request, Response
from fastapi.exceptions import RequestValidationError
from fastapi.openapi.utils import get_openapi
from fastapi.responses import HTMLResponse
from pydantic import BaseModel, ValidationError
from starlette.exceptions import HTTPException
from starlette.middleware.cors import CORSMiddleware

from hriplan import HriplanError, __version__
from hriplan.planner.constraints.spec import ConstraintSet
from hriplan.planner.problem import PlanningProblem
from hriplan.robots.human import HumanSpec
from hriplan.robots.scene import Mesh, Obstacle, Scene
from hriplan.service.config import ServiceConfig
from hriplan.service.errors import RequestError, error_response
from hriplan.service.guard import Guard
from hriplan.service.schemas import (
    ErrorBody,
    ExplainResponse,
    FeasibleRequest,
    JobState,
    PlanResponse,
    SessionCreate,
    SessionPlanRequest,
    SessionState,
    StoredTask,
    TaskPlanResponse,
)
from hriplan.service.sparql_protocol import add_sparql_routes
from hriplan.service.workers import Busy, PoolError, WorkerPool
from hriplan.tasks.feasibility import Feasibility
from hriplan.tasks.model import TaskFile
from hriplan.tasks.pipeline import TaskOutcome, step_name

JSON_OR_YAML = {"requestBody": {"content": {"application/yaml": {"schema": {"$ref": "#/components/schemas/TaskFile"}}}}}
ERRORS: dict[int | str, dict[str, Any]] = {
    code: {"model": ErrorBody} for code in (400, 404, 409, 413, 422, 500, 503, 504)
}


def _walk(value: Any) -> Iterator[Any]:
    yield value
    if isinstance(value, BaseModel):
        for name in type(value).model_fields:
            yield from _walk(getattr(value, name))
    elif isinstance(value, (list, tuple)):
        for item in value:
            yield from _walk(item)
    elif isinstance(value, dict):
        for item in value.values():
            yield from _walk(item)


def refuse_server_files(model: BaseModel) -> None:
    """Nothing in a request may name a file on the server: mesh shapes do, so they are refused."""
    if any(isinstance(v, Mesh) for v in _walk(model)):
        raise HriplanError(
            "mesh shapes name a file on the server, which the service never reads; use a box, cylinder, sphere, capsule or cone"
        )


def _rules_dir(task: TaskFile, config: ServiceConfig) -> str | None:
    """A task's rule files may only be files in the configured rules folder."""
    if not task.rule_files:
        return None
    if config.rules_dir is None:
        raise HriplanError("this server reads no rule files (start it with --rules-dir DIR to allow files from DIR)")
    folder = config.rules_dir.resolve()
    for name in task.rule_files:
        path = (folder / name).resolve()
        if Path(name).is_absolute() or not path.is_relative_to(folder):
            raise HriplanError(f"rule file {name!r} is outside the server's rules folder; name a file in it")
        if not path.is_file():
            raise HriplanError(f"rule file {name!r} is not in the server's rules folder")
    return str(folder)


class BackgroundJob:
    """A plan running in the background: its state, its answer once done, its cancel switch."""

    def __init__(self, state: JobState) -> None:
        self.state = state
        self.result: Response | None = None
        self.cancel = asyncio.Event()
        self.task: asyncio.Task | None = None  # kept referenced while it runs

    async def cancelled(self) -> bool:
        return self.cancel.is_set()


def docs_page(schema: dict[str, Any]) -> str:
    """Every route with its summary, linking the full schema: plain HTML, no scripts."""
    rows = "".join(
        f"<tr><td>{method.upper()}</td><td><code>{html.escape(path)}</code></td>"
        f"<td>{html.escape(operation.get('description') or operation.get('summary', ''))}</td></tr>"
        for path, methods in schema["paths"].items()
        for method, operation in methods.items()
    )
    return (
        f"<!doctype html><html><head><meta charset='utf-8'><title>{schema['info']['title']} API</title></head><body>"
        f"<h1>{schema['info']['title']} {schema['info']['version']}</h1><p>{html.escape(schema['info']['description'])}"
        f" The request and response bodies: <a href='openapi.json'>openapi.json</a>; the reference: docs/service.md.</p>"
        f"<table><tr><th>method</th><th>path</th><th>what</th></tr>{rows}</table></body></html>"
    )


def create_app(config: ServiceConfig | None = None) -> FastAPI:
    config = config or ServiceConfig()
    pool = WorkerPool(config.workers, config.queue_limit, kernels=config.kernels)
    queries = WorkerPool(config.query_workers, config.queue_limit, config.query_memory << 20, "queries")
    sessions: dict[str, SessionState] = {}
    tasks: dict[str, dict[str, Any]] = {}
    background: dict[str, BackgroundJob] = {}

    @asynccontextmanager
    async def lifespan(_: FastAPI):
        await asyncio.gather(pool.start(), queries.start())
        yield
        await asyncio.gather(pool.close(), queries.close())

    app = FastAPI(
        title="hriplan",
        version=__version__,
        lifespan=lifespan,
        responses=ERRORS,
        description="Safe human-robot collaboration planning: derive constraints with the rules, plan, query.",
        docs_url=None,
        redoc_url=None,
    )

    def openapi() -> dict[str, Any]:
        """FastAPI's schema plus the bearer scheme (required by every route when a token is set)."""
        if app.openapi_schema is None:
            schema = get_openapi(title=app.title, version=app.version, description=app.description, routes=app.routes)
            schema.setdefault("components", {})["securitySchemes"] = {"bearer": {"type": "http", "scheme": "bearer"}}
            if config.token is not None:
                schema["security"] = [{"bearer": []}]
            app.openapi_schema = schema
        return app.openapi_schema

    app.openapi = openapi  # type: ignore[method-assign]

    @app.get("/docs", include_in_schema=False)
    async def docs() -> HTMLResponse:
        """The routes in a page that loads nothing from elsewhere (works offline)."""
        return HTMLResponse(docs_page(app.openapi()))

    @app.exception_handler(RequestValidationError)
    async def invalid(_: Request, exc: RequestValidationError) -> Response:
        first = exc.errors()[0]
        if first["type"] == "json_invalid":
            return error_response(400, f"body: not valid JSON ({first.get('ctx', {}).get('error', first['msg'])})")
        loc = [str(p) for p in first["loc"]]
        field = ".".join(loc[1:] if loc[:1] == ["body"] else loc) or "(top level)"
        return error_response(422, f"{field}: {first['msg']}", field)

    @app.exception_handler(RequestError)
    async def refused(_: Request, exc: RequestError) -> Response:
        return error_response(exc.status, str(exc))

    @app.exception_handler(HriplanError)
    async def bad_input(_: Request, exc: HriplanError) -> Response:
        return error_response(400, str(exc))

    @app.exception_handler(HTTPException)
    async def http_error(_: Request, exc: HTTPException) -> Response:
        return error_response(exc.status_code, str(exc.detail))

    @app.exception_handler(Exception)
    async def internal(_: Request, exc: Exception) -> Response:
        return error_response(500, f"internal error ({type(exc).__name__}); see the server log")

    async def run(request: Request, kind: str, payload: dict[str, Any]) -> Response:
        return await answer(kind, payload, request.is_disconnected)

    async def answer(kind: str, payload: dict[str, Any], gone: Callable[[], Awaitable[bool]]) -> Response:
        """Run a job in its lane (queries apart from planning) and make its reply a response."""
        lane = queries if kind == "sparql" else pool
        try:
            reply = await lane.run(kind, payload, config.request_time_limit, gone)
        except Busy as exc:
            return error_response(503, str(exc), headers={"Retry-After": "1"})
        except PoolError as exc:
            return error_response(exc.status, str(exc))
        if reply[0] == "ok":
            return Response(reply[1], media_type=reply[2])
        return error_response(reply[1], reply[2])

    def task_payload(task: TaskFile, **extra: Any) -> dict[str, Any]:
        refuse_server_files(task)
        return {"task": task.model_dump(mode="json", by_alias=True), "rules_dir": _rules_dir(task, config), **extra}

    # -- tasks and problems ----------------------------------------------------------------
    @app.get("/health", tags=["service"])
    async def health() -> dict[str, Any]:
        """Liveness, the planning and query workers (pid, ready, busy, compiled kernels on) and how
        many requests wait; "degraded" while a dead worker is being replaced."""
        lanes = pool.status()
        return {
            "status": "ok" if pool.healthy() and queries.healthy() else "degraded",
            "version": __version__,
            **lanes,
            "query_workers": queries.status()["workers"],
        }

    @app.post("/constraints", response_model=TaskOutcome, tags=["tasks"], openapi_extra=JSON_OR_YAML)
    async def constraints(request: Request, task: TaskFile) -> Response:
        """What each step would have to respect and why (`hriplan constraints`): no planning."""
        return await run(request, "constraints", task_payload(task))

    @app.post("/explain", response_model=ExplainResponse, tags=["tasks"], openapi_extra=JSON_OR_YAML)
    async def explain(request: Request, task: TaskFile) -> Response:
        """The rules and matched facts behind each constraint, in words (`hriplan explain`)."""
        return await run(request, "explain", task_payload(task))

    @app.post("/plan", response_model=TaskPlanResponse, tags=["tasks"], openapi_extra=JSON_OR_YAML)
    async def plan(request: Request, task: TaskFile, ros: bool = False) -> Response:
        """Derive and plan every step (`hriplan plan`); a step that fails ends the task with its status."""
        return await run(request, "plan", task_payload(task, ros=ros))

    @app.post("/solve", response_model=PlanResponse, tags=["tasks"])
    async def solve(request: Request, problem: PlanningProblem, ros: bool = False) -> Response:
        """Plan a planning problem (`hriplan solve`): constraints given, not derived."""
        refuse_server_files(problem)
        return await run(request, "solve", {"problem": problem.model_dump(mode="json", by_alias=True), "ros": ros})

    # -- background jobs: long plans submitted, polled, cancelled ------------------------------
    def submit(kind: str, payload: dict[str, Any]) -> Response:
        if len(background) >= config.max_jobs:
            finished = [i for i, j in background.items() if j.state.status == "done"]
            if not finished:
                raise RequestError(409, f"the server runs {config.max_jobs} jobs, its limit; cancel one first")
            del background[finished[0]]
        job = BackgroundJob(JobState(id=uuid.uuid4().hex[:12], kind=kind, status="running"))

        async def work() -> None:
            response = await answer(kind, payload, job.cancelled)
            job.result = response
            job.state = job.state.model_copy(update={"status": "done", "result_status": response.status_code})

        job.task = asyncio.get_running_loop().create_task(work())
        background[job.state.id] = job
        return Response(
            job.state.model_dump_json(),
            202,
            media_type="application/json",
            headers={"Location": f"/jobs/{job.state.id}"},
        )

    def background_job(job_id: str) -> BackgroundJob:
        if job_id not in background:
            raise RequestError(404, f"no job {job_id!r}")
        return background[job_id]

    @app.post("/jobs/plan", response_model=JobState, status_code=202, tags=["jobs"], openapi_extra=JSON_OR_YAML)
    async def plan_job(task: TaskFile, ros: bool = False) -> Response:
        """Start `POST /plan` in the background: poll /jobs/{id}, then fetch /jobs/{id}/result."""
        return submit("plan", task_payload(task, ros=ros))

    @app.post("/jobs/solve", response_model=JobState, status_code=202, tags=["jobs"])
    async def solve_job(problem: PlanningProblem, ros: bool = False) -> Response:
        """Start `POST /solve` in the background."""
        refuse_server_files(problem)
        return submit("solve", {"problem": problem.model_dump(mode="json", by_alias=True), "ros": ros})

    @app.get("/jobs/{job_id}", response_model=JobState, tags=["jobs"])
    async def get_job(job_id: str) -> JobState:
        """Whether the job is running or done (and the status its answer has)."""
        return background_job(job_id).state

    @app.get("/jobs/{job_id}/result", tags=["jobs"])
    async def job_result(job_id: str) -> Response:
        """The answer the synchronous route would have given; 409 while the job runs."""
        job = background_job(job_id)
        if job.result is None:
            raise RequestError(409, f"job {job_id!r} is still running; poll /jobs/{job_id}")
        return job.result

    @app.delete("/jobs/{job_id}", status_code=204, tags=["jobs"])
    async def cancel_job(job_id: str) -> Response:
        """Cancel a running job (its worker is stopped and replaced) or forget a finished one."""
        background_job(job_id).cancel.set()
        del background[job_id]
        return Response(status_code=204)

    # -- sessions ----------------------------------------------------------------------------
    def session(session_id: str) -> SessionState:
        if session_id not in sessions:
            raise RequestError(404, f"no session {session_id!r}")
        return sessions[session_id]

    def update(state: SessionState, **changes: Any) -> SessionState:
        try:
            scene = Scene.model_validate(changes.pop("scene")) if "scene" in changes else state.scene
        except ValidationError as exc:
            raise RequestError(
                409, f"the session's scene would conflict: {exc.errors()[0]['msg'].removeprefix('Value error, ')}"
            ) from None
        sessions[state.id] = state.model_copy(update={**changes, "scene": scene, "version": state.version + 1})
        return sessions[state.id]

    @app.post("/sessions", response_model=SessionState, status_code=201, tags=["sessions"])
    async def create_session(request: Request, body: SessionCreate) -> Response:
        """A running cell: the robot and hands are built once (per worker), the scene changes."""
        refuse_server_files(body)
        if body.id in sessions:
            raise RequestError(409, f"a session {body.id!r} exists already")
        if len(sessions) >= config.max_sessions:
            raise RequestError(409, f"the server holds {config.max_sessions} sessions, its limit; delete one first")
        state = SessionState(**body.model_dump(exclude={"id"}), id=body.id or uuid.uuid4().hex[:12])
        checked = await run(request, "session_check", {"state": state.model_dump(mode="json")})
        if checked.status_code != 200:
            return checked
        if state.id in sessions:
            raise RequestError(409, f"a session {state.id!r} exists already")
        sessions[state.id] = state
        return Response(state.model_dump_json(), status_code=201, media_type="application/json")

    @app.get("/sessions/{session_id}", response_model=SessionState, tags=["sessions"])
    async def get_session(session_id: str) -> SessionState:
        return session(session_id)

    @app.delete("/sessions/{session_id}", status_code=204, tags=["sessions"])
    async def delete_session(session_id: str) -> Response:
        session(session_id)
        del sessions[session_id]
        return Response(status_code=204)

    def put_in_scene(session_id: str, collection: str, name: str, item: HumanSpec | Obstacle) -> SessionState:
        state = session(session_id)
        refuse_server_files(item)
        if item.name != name:
            raise HriplanError(f"the body names {item.name!r}, the path {name!r}")
        items = [i.model_dump() for i in getattr(state.scene, collection) if i.name != name] + [item.model_dump()]
        return update(state, scene={**state.scene.model_dump(), collection: items})

    @app.put("/sessions/{session_id}/humans/{name}", response_model=SessionState, tags=["sessions"])
    async def put_human(session_id: str, name: str, human: HumanSpec) -> SessionState:
        """Add or move a person (as perception sees them)."""
        return put_in_scene(session_id, "humans", name, human)

    @app.put("/sessions/{session_id}/obstacles/{name}", response_model=SessionState, tags=["sessions"])
    async def put_obstacle(session_id: str, name: str, obstacle: Obstacle) -> SessionState:
        """Add or move an obstacle."""
        return put_in_scene(session_id, "obstacles", name, obstacle)

    @app.delete("/sessions/{session_id}/{collection}/{name}", response_model=SessionState, tags=["sessions"])
    async def remove_from_scene(session_id: str, collection: str, name: str) -> SessionState:
        """Remove a person (`humans`) or an obstacle (`obstacles`) from the session's scene."""
        state = session(session_id)
        if collection not in ("humans", "obstacles"):
            raise RequestError(404, f"a session has humans and obstacles, not {collection!r}")
        items = getattr(state.scene, collection)
        if not any(i.name == name for i in items):
            raise RequestError(404, f"the session has no {collection[:-1]} {name!r}")
        kept = [i.model_dump() for i in items if i.name != name]
        return update(state, scene={**state.scene.model_dump(), collection: kept})

    @app.put("/sessions/{session_id}/constraints", response_model=SessionState, tags=["sessions"])
    async def put_constraints(session_id: str, constraints: ConstraintSet) -> SessionState:
        """Replace the constraints every later plan of the session respects."""
        return update(session(session_id), constraints=constraints)

    @app.post("/sessions/{session_id}/plan", response_model=PlanResponse, tags=["sessions"])
    async def plan_in_session(
        request: Request, session_id: str, body: SessionPlanRequest, ros: bool = False
    ) -> Response:
        """Plan one motion against the session's scene and constraints as they are now."""
        state = session(session_id)
        payload = {"state": state.model_dump(mode="json"), "request": body.model_dump(mode="json"), "ros": ros}
        return await run(request, "session_plan", payload)

    @app.post("/sessions/{session_id}/feasible", response_model=Feasibility, tags=["sessions"])
    async def feasible_in_session(
        request: Request, session_id: str, body: FeasibleRequest, trajectories: bool = False
    ) -> Response:
        """Whether a task step can be done from a state in the session's world, at what cost (seconds
        of ISO/TS 15066-timed motion), under which derived constraints, else why not: a task
        planner's question, answered by planning and validating the step with a short budget.
        With ?trajectories=true the answer carries the validated motions too."""
        state = session(session_id)
        refuse_server_files(body)
        payload = {
            "state": state.model_dump(mode="json"),
            "request": body.model_dump(mode="json", by_alias=True),
            "rules_dir": _rules_dir(body.state, config),
            "trajectories": trajectories,
        }
        return await run(request, "session_feasible", payload)

    # -- stored tasks, for SPARQL --------------------------------------------------------------
    def stored(task_id: str) -> dict[str, Any]:
        if task_id not in tasks:
            raise RequestError(404, f"no stored task {task_id!r}")
        return {**tasks[task_id], "limits": config.query.model_dump()}

    @app.post("/tasks", response_model=StoredTask, status_code=201, tags=["sparql"], openapi_extra=JSON_OR_YAML)
    async def store_task(task: TaskFile) -> StoredTask:
        """Keep a task so its reasoned graph answers SPARQL at /tasks/{id}/sparql."""
        if len(tasks) >= config.max_tasks:
            raise RequestError(409, f"the server holds {config.max_tasks} tasks, its limit; delete one first")
        task_id = uuid.uuid4().hex[:12]
        tasks[task_id] = task_payload(task)
        return StoredTask(id=task_id, task=task.name, steps=[step_name(s, i) for i, s in enumerate(task.steps)])

    @app.delete("/tasks/{task_id}", status_code=204, tags=["sparql"])
    async def delete_task(task_id: str) -> Response:
        stored(task_id)
        del tasks[task_id]
        return Response(status_code=204)

    async def run_query(request: Request, payload: dict[str, Any]) -> Response:
        return await run(request, "sparql", {"limits": config.query.model_dump(), **payload})

    add_sparql_routes(app, run_query, stored)

    app.add_middleware(
        Guard,
        body_limit=config.body_limit,
        token=config.token,
        body_timeout=config.body_timeout,
        allowed_hosts=config.allowed_hosts,
        allowed_origins=config.cors_origins,
        robot_files=config.robot_files,
    )
    if config.cors_origins:
        app.add_middleware(
            CORSMiddleware,
            allow_origins=config.cors_origins,
            allow_methods=["GET", "POST", "PUT", "DELETE"],
            allow_headers=["Authorization", "Content-Type"],
        )
    return app
