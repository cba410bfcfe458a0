"""The web server: a FastAPI app (front page, REST API with OpenAPI docs, recordings) next to a
viser server (the 3D view and its control panel), around one live session.

viser cannot be mounted inside FastAPI (it is its own websocket server), so it runs on its own
port; the front page embeds viser's client (served here at /viewer/) with `?websocket=` pointing
at that port. `contactnet serve` calls `serve(settings)` (`app.live.settings.ServeSettings`); tests build
a `ContactnetApp` directly. The request and response models are in `app/api/models.py`.
"""

# No `from __future__ import annotations` here: the settings endpoint's body model is built at run time
# (from the registry) and FastAPI must see the class itself, not its name.
import asyncio
import functools
import gc
import logging
import os
import signal
import sys
import threading
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Annotated, Any

import uvicorn
from fastapi import FastAPI, HTTPException, Query, Request
from fastapi import Path as PathParam
from fastapi.responses import FileResponse
from fastapi.staticfiles import StaticFiles
from fastapi_offline import FastAPIOffline

from app.api.errors import StrictJsonRoute, as_http_errors, install_error_handlers, responses
from app.api.models import (
    Info,
    PauseCommand,
    PushCommand,
    Saved,
    State,
    TerrainEntry,
    TerrainList,
    TerrainSelect,
    VelocityCommand,
    compare_command_model,
    settings_command_model,
    state_of,
)
from app.api.recording_routes import add_recording_routes
from app.live.commands import (
    ApplyPush,
    Reset,
    SetCompare,
    SetGait,
    SetLoop,
    SetNoise,
    SetObserver,
    SetPaused,
    SetPlanner,
    SetRetarget,
    SetSpeed,
    SetVelocity,
)
from app.live.editing import TerrainService
from app.live.editor import MAX_UPLOAD_BYTES
from app.live.planners import default_planner_factory
from app.live.session import LiveSession
from app.live.settings import (
    COMMAND_BODY_LIMIT_BYTES,
    PUSH_DURATION_LIMIT_S,
    PUSH_FORCE_LIMIT_N,
    VELOCITY_LIMIT_M_S,
    ServeSettings,
)
from app.live.terrain_files import TerrainLibrary
from app.recordings.recorder import LiveRecorder, RecordingStore
from app.security.guards import AccessPolicy, RequestGuard
from app.viewer.live_viewer import Viewer
from contactnet.robots import load_robot
from contactnet.terrain import Terrain, resolve

log = logging.getLogger("contactnet.app.server")

STATIC_DIR = Path(__file__).resolve().parents[2] / "static"
VISER_CLIENT = Path(__import__("viser").__file__).parent / "client" / "build" / "index.html"
TERRAIN_NAME = r"^[A-Za-z0-9][A-Za-z0-9_-]{0,63}$"
COMMAND_TIMEOUT_S = 60.0
TerrainName = Annotated[str, PathParam(pattern=TERRAIN_NAME, description="a terrain file's stem")]


# ---- the application ----------------------------------------------------------------------------
class ContactnetApp:
    """The whole tool: live session, viser viewer, terrain service, recorder and the FastAPI app."""

    def __init__(self, settings: ServeSettings):
        self.settings = settings
        self.policy = AccessPolicy(settings)
        terrain, label = self._initial_terrain(settings.terrain)
        self.session = LiveSession(
            settings,
            terrain,
            label,
            planner_factory=functools.partial(default_planner_factory, model_dir=settings.models_dir),
        ).start()
        try:
            self.robot = load_robot(settings.robot)  # for drawing (the session thread has its own)
            self.terrains = TerrainService(self.session, TerrainLibrary(settings.user_terrains_dir()))
            self.recordings = RecordingStore(settings.recordings_folder())
            self.recorder = LiveRecorder(self.recordings, self.robot, rate_hz=settings.record_hz)
            self.viewer = Viewer(
                self.session,
                self.terrains,
                self.recorder,
                self.robot,
                host=settings.host,
                port=settings.viser_port,
                scene_hz=settings.scene_hz,
                policy=self.policy,
            )
        except BaseException:
            self.session.stop()
            raise
        # Terrain uploads are validated here, never on the event loop (two at a time; more wait their turn).
        self.validation_pool = ThreadPoolExecutor(max_workers=2, thread_name_prefix="terrain-upload")
        self.api = create_api(self)
        # What start-up built (robot, models, viser, the simulated world) lives as long as the tool: keep the
        # cyclic garbage collector from walking it again. A full collection over it held the GIL for ~0.2 s in
        # the middle of a terrain upload (every thread, /api/state included, waited); now ~0.05 s.
        gc.freeze()

    @staticmethod
    def _initial_terrain(spec: str) -> tuple[Terrain, str]:
        terrain = resolve(spec)
        label = Path(spec).stem if spec.endswith(".json") else spec
        return terrain, label

    @property
    def viser_port(self) -> int:
        return self.viewer.port

    def state(self) -> State:
        view = self.session.view
        if view is None:
            raise HTTPException(503, "the live session is starting")
        return state_of(view, self.viser_port, self.recorder.recording)

    def close(self) -> str | None:
        """Stop everything; a recording in progress is saved. Returns one line about that recording (saved
        where, or dropped and why), None when nothing was recording."""
        self.viewer.close()  # no more frames fed to the recorder
        try:
            note = self.recorder.save_in_progress()
        finally:
            self.recorder.close()
            self.validation_pool.shutdown(wait=False, cancel_futures=True)
            self.session.stop()
        return note


def body_limit(method: str, path: str) -> int:
    """Largest request body: a terrain upload's limit for PUT /api/terrains/..., 64 KiB for everything else."""
    return MAX_UPLOAD_BYTES if method == "PUT" and path.startswith("/api/terrains/") else COMMAND_BODY_LIMIT_BYTES


def create_api(app: ContactnetApp) -> FastAPI:
    # /docs and /redoc serve Swagger UI and ReDoc from the installed fastapi-offline package: no CDN, so
    # the API docs work on a machine without internet.
    api = FastAPIOffline(
        title="contactnet",
        description=f"Drive, push and inspect the live {app.settings.robot} session; manage terrains and "
        "recordings. The 3D view is at / (viser, port given by GET /api/info). Requests must name the tool "
        "in their Host header; state-changing ones must come from its page (or no page) and carry JSON.",
        version="0.1.0",
    )
    api.router.route_class = StrictJsonRoute  # every JSON body read by contactnet.strict_json.loads_strict
    api.state.access_policy = app.policy
    install_error_handlers(api)
    api.add_middleware(RequestGuard, policy=app.policy, body_limit=body_limit)
    SettingsCommand = settings_command_model()  # noqa: N806 - a model class
    CompareCommand = compare_command_model()  # noqa: N806 - a model class

    # The error codes every route can answer (Host, token) and those of every state-changing one.
    everywhere = (421, 401) if app.policy.needs_token else (421,)
    changing = (*everywhere, 400, 403, 413, 415)
    session_command = (*changing, 422, 503, 504)

    def run(command, timeout: float = COMMAND_TIMEOUT_S) -> State:
        with as_http_errors():
            app.session.call(command, timeout=timeout)
        return app.state()

    # ---- pages ------------------------------------------------------------------------------------
    @api.get("/", include_in_schema=False)
    def index() -> FileResponse:
        return FileResponse(STATIC_DIR / "index.html", media_type="text/html")

    @api.get("/viewer/", include_in_schema=False)
    def viewer_page() -> FileResponse:
        """viser's client (one self-contained HTML file): give it ?websocket=ws://host:port for the
        live view, or ?playbackPath=URL to play a recording."""
        return FileResponse(VISER_CLIENT, media_type="text/html")

    if STATIC_DIR.is_dir():
        api.mount("/static", StaticFiles(directory=STATIC_DIR), name="static")

    # ---- session ------------------------------------------------------------------------------------
    @api.get("/api/info", response_model=Info, tags=["session"], responses=responses(*everywhere))
    def info() -> Info:
        return Info(
            session_id=app.session.session_id,
            viser_port=app.viser_port,
            viewer_url="/viewer/",
            version="0.1.0",
            robot=app.settings.robot,
        )

    @api.get("/api/state", response_model=State, tags=["session"], responses=responses(*everywhere, 503))
    def get_state() -> State:
        return app.state()

    @api.post(
        "/api/command",
        response_model=State,
        tags=["session"],
        description=f"Set the commanded velocity (|vx|, |vy| <= {VELOCITY_LIMIT_M_S:g} m/s).",
        responses=responses(*session_command),
    )
    def command(body: VelocityCommand) -> State:
        return run(SetVelocity(body.vx, body.vy))

    @api.post(
        "/api/push",
        response_model=State,
        tags=["session"],
        description=f"Push the base now (0 < |f| <= {PUSH_FORCE_LIMIT_N:g} N, "
        f"0 < duration <= {PUSH_DURATION_LIMIT_S:g} s). Only while the robot walks: 409 when it is paused, "
        "has fallen or reached the goal.",
        responses=responses(*session_command, 409),
    )
    def push(body: PushCommand) -> State:
        return run(ApplyPush(body.fx, body.fy, body.duration))

    @api.post("/api/reset", response_model=State, tags=["session"], responses=responses(*session_command))
    def reset() -> State:
        """Back to the start of the terrain, running."""
        return run(Reset())

    @api.post("/api/pause", response_model=State, tags=["session"], responses=responses(*session_command))
    def pause(body: PauseCommand) -> State:
        """Stop or run the clock; running also ends the wait for the first browser."""
        return run(SetPaused(body.paused))

    @api.post("/api/compare", response_model=State, tags=["session"], responses=responses(*session_command))
    def compare(body: CompareCommand) -> State:
        """Compare mode: ``{"planners": ["contactnet", "fixed"]}`` runs two robots on the same terrain with the
        same command (the main robot with the first planner, the other drawn as a ghost), both from the start;
        ``{"planners": []}`` turns it off. `State.compare` reports the other robot."""
        return run(SetCompare(tuple(body.planners)))

    @api.post("/api/settings", response_model=State, tags=["session"], responses=responses(*session_command))
    def settings(body: SettingsCommand) -> State:
        """Change gait, planner, noise (each restarts the robot), simulation speed, loop, swing retargeting and the
        disturbance observer."""
        if body.speed is not None:
            run(SetSpeed(body.speed))
        if body.loop is not None:
            run(SetLoop(body.loop))
        if body.gait is not None:
            run(SetGait(body.gait))
        if body.planner is not None:
            run(SetPlanner(body.planner))
        if body.noise is not None:
            run(SetNoise(body.noise))
        if body.retarget is not None:
            run(SetRetarget(body.retarget))
        if body.observer is not None:
            run(SetObserver(body.observer))
        return app.state()

    @api.post(
        "/api/session/terrain",
        response_model=State,
        tags=["session"],
        responses=responses(*session_command, 404, 409),
    )
    def session_terrain(body: TerrainSelect) -> State:
        """Put the robot on another terrain (a file, a shipped generator, or the random field); 409 when that
        file is not a valid terrain."""
        with as_http_errors():
            app.terrains.load(body.name, removed=body.removed, seed=body.seed, timeout=COMMAND_TIMEOUT_S)
        return app.state()

    # ---- terrains ---------------------------------------------------------------------------------
    @api.get("/api/terrains", response_model=TerrainList, tags=["terrains"], responses=responses(*everywhere))
    def list_terrains() -> TerrainList:
        store = app.terrains.store
        return TerrainList(
            terrains=[
                TerrainEntry(name=n, shipped=store.is_shipped(n), url=f"/api/terrains/{n}") for n in store.names()
            ],
            current=app.terrains.label,
        )

    @api.get("/api/terrains/{name}", tags=["terrains"], responses=responses(*everywhere, 404, 409, 422))
    def get_terrain(name: TerrainName) -> dict[str, Any]:
        """The terrain file (the "Terrain file" format of docs/architecture.md): the user's own file of that
        name, else the shipped one. 409 when that file is not a valid terrain (fix or replace it)."""
        with as_http_errors():
            return app.terrains.store.load(name).to_dict()

    @api.put(
        "/api/terrains/{name}",
        response_model=Saved,
        tags=["terrains"],
        responses=responses(*changing, 409, 422),
        openapi_extra={
            "requestBody": {
                "required": True,
                "content": {
                    "application/json": {
                        "schema": {
                            "type": "object",
                            "description": "a terrain (docs/architecture.md 'Terrain file'); at most "
                            f"{MAX_UPLOAD_BYTES} bytes",
                            "required": ["name", "start", "goal_x", "regions"],
                        }
                    }
                },
            }
        },
    )
    async def put_terrain(
        name: TerrainName,
        request: Request,
        overwrite: Annotated[
            bool, Query(description="confirm saving your own copy under the name of a shipped terrain")
        ] = False,
    ) -> Saved:
        """Save a terrain as the user's file `name` (validated once, off the event loop; nothing is written if
        it is invalid). The shipped terrains are never changed: under a shipped name (confirmed with
        ``overwrite``) the user's own copy is saved, and shadows the shipped file."""
        body = await request.body()  # at most MAX_UPLOAD_BYTES: RequestGuard refuses more while streaming
        job = app.validation_pool.submit(app.terrains.save_upload, body, name, overwrite)
        with as_http_errors():
            path = await asyncio.wrap_future(job)
        return Saved(name=name, path=str(path))

    # ---- recordings ---------------------------------------------------------------------------------
    add_recording_routes(api, app, everywhere, changing)

    return api


# ---- process start-up ------------------------------------------------------------------------------
class BackgroundServer:
    """uvicorn in a thread (tests and benchmarks)."""

    def __init__(self, api: FastAPI, host: str, port: int):
        policy = getattr(api.state, "access_policy", None)
        if policy is not None:
            policy.ports.add(port)  # the page served from this port may call the API and open the 3D view
        self.server = uvicorn.Server(
            uvicorn.Config(api, host=host, port=port, log_level="warning", lifespan="off")
        )
        self.thread = threading.Thread(target=self.server.run, name="uvicorn", daemon=True)
        self.thread.start()
        while not self.server.started:
            if not self.thread.is_alive():
                raise RuntimeError(f"uvicorn could not start on {host}:{port}")
            threading.Event().wait(0.02)

    def stop(self) -> None:
        self.server.should_exit = True
        self.thread.join(10)


def url_host(host: str) -> str:
    """``host`` as it goes in a URL (IPv6 in brackets; the wildcard addresses as 127.0.0.1)."""
    if host in ("0.0.0.0", "::", ""):
        return "127.0.0.1"
    return f"[{host}]" if ":" in host else host


def serve(settings: ServeSettings) -> int:
    """Run the tool until interrupted (Ctrl-C or SIGTERM); a recording in progress is then saved (or stderr
    says that it was dropped, naming it)."""
    logging.basicConfig(
        level=os.environ.get("CONTACTNET_LOG", "INFO"),
        stream=sys.stderr,
        format="%(asctime)s %(name)s %(levelname)s: %(message)s",
    )
    logging.getLogger("websockets").setLevel(logging.WARNING)
    app = ContactnetApp(settings)
    server = uvicorn.Server(uvicorn.Config(app.api, host=settings.host, port=settings.port, log_level="warning"))

    def stop(signum: int, frame: Any) -> None:
        # uvicorn handles the signals while it runs and calls this afterwards; before, this stops it.
        server.should_exit = True

    previous = {sig: signal.signal(sig, stop) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        base = f"http://{url_host(settings.host)}:{settings.port}/"
        if app.policy.needs_token:
            opening = (
                f"contactnet: open {base}?token={app.policy.token}  (listening on {settings.host}: this "
                "address, with its token, lets anyone who has it drive the robot)"
            )
        else:
            opening = f"contactnet: open {base}"
        print(
            f"{opening}\n  3D view: viser on port {app.viser_port}; API docs: {base}docs; your terrains: "
            f"{app.terrains.store.directory}; recordings: {app.recordings.directory}",
            file=sys.stderr,
            flush=True,
        )
        server.run()
    finally:
        try:
            note = app.close()
        except Exception as exc:  # noqa: BLE001 - say it, do not hide the shut-down's cause
            note = f"shut-down failed: {exc}"
        if note:
            print(f"contactnet: {note}", file=sys.stderr, flush=True)
        for sig, handler in previous.items():
            signal.signal(sig, handler)
    return 0
