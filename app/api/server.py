"""The web server: a FastAPI app (front page, REST API with OpenAPI docs, recordings) next to a
viser server (the 3D view and its control panel), around the live sessions (one per visitor: `app/api/visits.py`).

viser cannot be mounted inside FastAPI (it is its own websocket server), so it runs on its own
port; the front page embeds viser's client (served here at /viewer/) with `?websocket=` pointing
at that port. `contactnet serve` calls `serve(settings)` (`app.live.settings.ServeSettings`); tests build
a `ContactnetApp` directly. `create_api` sets the API up and adds its route groups: `app/api/session_routes.py`,
`app/api/terrain_routes.py`, `app/api/recording_routes.py`; the request and response models are in `app/api/models.py`.
"""

import contextlib
import functools
import gc
import logging
import os
import signal
import sys
import threading
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import uvicorn
from fastapi import FastAPI, HTTPException
from fastapi.responses import FileResponse
from fastapi.staticfiles import StaticFiles
from fastapi_offline import FastAPIOffline

from app.api.errors import ErrorCodes, StrictJsonRoute, install_error_handlers
from app.api.models import (
    State,
    state_of,
)
from app.api.recording_routes import add_recording_routes
from app.api.session_routes import add_session_routes
from app.api.terrain_routes import add_terrain_routes
from app.api.visit_routes import add_visit_routes
from app.api.visits import (
    CURRENT_VISIT,
    SESSION_CPU_CORES,
    Visit,
    VisitPool,
    VisitRouting,
    default_max_sessions,
)
from app.live.backend import SessionBackend
from app.live.editing import TerrainService
from app.live.editor import MAX_UPLOAD_BYTES
from app.live.planners import default_planner_factory
from app.live.session import LiveSession
from app.live.settings import (
    COMMAND_BODY_LIMIT_BYTES,
    ServeSettings,
)
from app.live.terrain_files import TerrainLibrary
from app.recordings.live_recorder import LiveRecorder
from app.recordings.recorder import RecordingStore
from app.security.guards import AccessPolicy, RequestGuard
from app.viewer.live_viewer import Viewer
from contactnet import registry
from contactnet.robots import Robot, load_robot
from contactnet.terrain import Terrain

log = logging.getLogger("contactnet.app.server")

STATIC_DIR = Path(__file__).resolve().parents[2] / "static"
VISER_CLIENT = Path(__import__("viser").__file__).parent / "client" / "build" / "index.html"


# ---- the application ----------------------------------------------------------------------------
class ContactnetApp:
    """The whole tool: the visits (a live session, viser viewer, terrain service and recorder per visitor:
    `app.api.visits`), the shared recordings store and the FastAPI app.

    `session`, `terrains`, `recorder`, `viewer` and `state()` are those of the visit the current request acts on
    (its cookie's, else the default visit's); outside a request, the default visit's."""

    def __init__(self, settings: ServeSettings):
        self.settings = settings
        self.policy = AccessPolicy(settings)
        self.robot = load_robot(settings.robot)  # for drawing (each session thread has its own)
        self.recordings = RecordingStore(settings.recordings_folder())
        self._library = TerrainLibrary(settings.user_terrains_dir())
        max_sessions = settings.max_sessions if settings.max_sessions is not None else default_max_sessions()
        self._engine = contextlib.ExitStack()  # Ray, for --engine ray (stopped at close if started here)
        if settings.engine == "ray":
            from contactnet.jobs.ray_engine import session as ray_session

            self._engine.enter_context(ray_session(settings.address))
        try:
            self.visits = VisitPool(self._new_visit, max_sessions, settings.session_idle_s, shared=settings.shared)
        except BaseException:
            self._engine.close()
            raise
        # Terrain uploads are validated here, never on the event loop (two at a time; more wait their turn).
        self.validation_pool = ThreadPoolExecutor(max_workers=2, thread_name_prefix="terrain-upload")
        self.api = create_api(self)
        # What start-up built (robot, models, viser, the simulated world) lives as long as the tool: keep the
        # cyclic garbage collector from walking it again. A full collection over it held the GIL for ~0.2 s in
        # the middle of a terrain upload (every thread, /api/state included, waited); now ~0.05 s.
        gc.freeze()

    def _new_visit(self, default: bool) -> Visit:
        """A live session with its viewer, terrain service and recorder; the default one on ``serve --viser-port``,
        the others on ports the OS picks."""
        settings = self.settings
        terrain, label = self._initial_terrain(settings.terrain, self.robot)
        planners = functools.partial(default_planner_factory, model_dir=settings.models_dir)
        session: SessionBackend
        if settings.engine == "ray":  # the simulation in a Ray actor; this process streams its snapshots
            from app.live.ray_session import RaySession

            session = RaySession(settings, terrain, label, planner_factory=planners, num_cpus=SESSION_CPU_CORES)
        else:
            session = LiveSession(settings, terrain, label, planner_factory=planners)
        session.start()
        try:
            terrains = TerrainService(session, self._library, scale=self.robot.description.size_scale)
            recorder = LiveRecorder(self.recordings, self.robot, rate_hz=settings.record_hz)
            viewer = Viewer(
                session,
                terrains,
                recorder,
                self.robot,
                host=settings.host,
                port=settings.viser_port if default else 0,
                scene_hz=settings.scene_hz,
                policy=self.policy,
            )
        except BaseException:
            session.stop()
            raise
        return Visit(session, terrains, recorder, viewer, default=default)

    @staticmethod
    def _initial_terrain(spec: str, robot: Robot) -> tuple[Terrain, str]:
        """``serve --terrain``: a file as it is, a scene at the robot's size (`registry.terrain_for`)."""
        terrain = registry.terrain_for(spec, robot)
        label = Path(spec).stem if spec.endswith(".json") else spec
        return terrain, label

    # ---- the visit of the current request ---------------------------------------------------------------
    def visit(self) -> Visit:
        return CURRENT_VISIT.get() or self.visits.default

    @property
    def session(self) -> SessionBackend:
        return self.visit().session

    @property
    def terrains(self) -> TerrainService:
        return self.visit().terrains

    @property
    def recorder(self) -> LiveRecorder:
        return self.visit().recorder

    @property
    def viewer(self) -> Viewer:
        return self.visit().viewer

    @property
    def viser_port(self) -> int:
        return self.viewer.port

    def state(self) -> State:
        visit = self.visit()
        view = visit.session.view
        if view is None:
            raise HTTPException(503, "the live session is starting")
        return state_of(view, visit.viewer.port, visit.recorder.recording)

    def close(self) -> str | None:
        """Stop everything; recordings in progress are saved. One line about those recordings (saved where, or
        dropped and why), None when nothing was recording."""
        try:
            notes = self.visits.close()
        finally:
            self.validation_pool.shutdown(wait=False, cancel_futures=True)
            self._engine.close()
        return "; ".join(notes) or None


#: s a stopping server waits for open responses (the page's state streams, GET /api/state/stream) before it ends them.
STREAM_SHUTDOWN_S = 3.0


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
    api.add_middleware(VisitRouting, pool=app.visits)  # inside the guard: refused requests never reach a visit
    api.add_middleware(RequestGuard, policy=app.policy, body_limit=body_limit)
    codes = ErrorCodes.of(app.policy)

    # ---- pages ------------------------------------------------------------------------------------
    add_visit_routes(api, app, codes, STATIC_DIR / "index.html")

    @api.get("/favicon.ico", include_in_schema=False)
    def favicon() -> FileResponse:  # what browsers ask for before they read the page's <link rel="icon">
        return FileResponse(STATIC_DIR / "favicon.svg", media_type="image/svg+xml")

    @api.get("/viewer/", include_in_schema=False)
    def viewer_page() -> FileResponse:
        """viser's client (one self-contained HTML file): give it ?websocket=ws://host:port for the
        live view, or ?playbackPath=URL to play a recording."""
        return FileResponse(VISER_CLIENT, media_type="text/html")

    if STATIC_DIR.is_dir():
        api.mount("/static", StaticFiles(directory=STATIC_DIR), name="static")

    add_session_routes(api, app, codes)
    add_terrain_routes(api, app, codes)
    # ---- recordings ---------------------------------------------------------------------------------
    add_recording_routes(api, app, codes)

    return api


# ---- process start-up ------------------------------------------------------------------------------
class BackgroundServer:
    """uvicorn in a thread (tests and benchmarks)."""

    def __init__(self, api: FastAPI, host: str, port: int):
        policy = getattr(api.state, "access_policy", None)
        if policy is not None:
            policy.ports.add(port)  # the page served from this port may call the API and open the 3D view
        self.server = uvicorn.Server(
            uvicorn.Config(api, host=host, port=port, log_level="warning", lifespan="off",
                          timeout_graceful_shutdown=STREAM_SHUTDOWN_S)
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
    server = uvicorn.Server(uvicorn.Config(app.api, host=settings.host, port=settings.port, log_level="warning",
                                          timeout_graceful_shutdown=STREAM_SHUTDOWN_S))

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
        where = ""
        if settings.engine == "ray":
            where = (f"\n  simulations: a Ray actor per visitor's session, on "
                     f"{settings.address or os.environ.get('RAY_ADDRESS') or 'a local Ray of this machine'}")
        print(
            f"{opening}\n  3D view: viser on port {app.viser_port}; API docs: {base}docs; your terrains: "
            f"{app.terrains.store.directory}; recordings: {app.recordings.directory}{where}",
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
