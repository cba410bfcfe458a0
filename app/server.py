"""The web server: a FastAPI app (front page, REST API with OpenAPI docs, recordings) next to a
viser server (the 3D view and its control panel), around one live session.

viser cannot be mounted inside FastAPI (it is its own websocket server), so it runs on its own
port; the front page embeds viser's client (served here at /viewer/) with `?websocket=` pointing
at that port. `contactnet serve` calls `serve(settings)` (`app.settings.ServeSettings`); tests build
a `ContactnetApp` directly. The request and response models are in `app/api_models.py`.
"""

# No `from __future__ import annotations` here: the settings endpoint's body model is built at run time
# (from the registry) and FastAPI must see the class itself, not its name.
import functools
import logging
import os
import sys
import threading
from pathlib import Path
from typing import Annotated, Any

import uvicorn
from fastapi import FastAPI, HTTPException, Query, Request
from fastapi import Path as PathParam
from fastapi.encoders import jsonable_encoder
from fastapi.exceptions import RequestValidationError
from fastapi.responses import FileResponse, HTMLResponse, JSONResponse, Response
from fastapi.staticfiles import StaticFiles

from app.api_models import (
    Info,
    PauseCommand,
    PushCommand,
    RecordingEntry,
    RecordingStart,
    RecordingStatus,
    Saved,
    State,
    TerrainEntry,
    TerrainList,
    TerrainSelect,
    VelocityCommand,
    json_safe,
    settings_command_model,
    state_of,
)
from app.commands import ApplyPush, Reset, SetGait, SetNoise, SetPaused, SetPlanner, SetSpeed, SetVelocity
from app.editing import TerrainService
from app.editor import (
    MAX_UPLOAD_BYTES,
    EditError,
    ShippedTerrainError,
    TerrainStore,
    is_shipped,
    parse_upload,
)
from app.live import LiveSession
from app.planners import default_planner_factory
from app.recordings import LiveRecorder, RecordingStore, viser_html
from app.settings import PUSH_DURATION_LIMIT_S, PUSH_FORCE_LIMIT_N, VELOCITY_LIMIT_M_S, ServeSettings
from app.viewer import Viewer
from contactnet.robots import load_robot
from contactnet.terrain import Terrain, resolve, terrains_dir

log = logging.getLogger("contactnet.app.server")

STATIC_DIR = Path(__file__).resolve().parent.parent / "static"
VISER_CLIENT = Path(__import__("viser").__file__).parent / "client" / "build" / "index.html"
TERRAIN_NAME = r"^[A-Za-z0-9][A-Za-z0-9_-]{0,63}$"
COMMAND_TIMEOUT_S = 60.0
TerrainName = Annotated[str, PathParam(pattern=TERRAIN_NAME, description="file stem in terrains/")]
RecordingName = Annotated[str, PathParam(pattern=r"^[A-Za-z0-9][A-Za-z0-9_-]{0,99}\.viser$")]


# ---- the application ----------------------------------------------------------------------------
class ContactnetApp:
    """The whole tool: live session, viser viewer, terrain service, recorder and the FastAPI app."""

    def __init__(self, settings: ServeSettings):
        self.settings = settings
        terrain, label = self._initial_terrain(settings.terrain)
        self.session = LiveSession(
            settings,
            terrain,
            label,
            planner_factory=functools.partial(default_planner_factory, model_dir=settings.models_dir),
        ).start()
        try:
            self.robot = load_robot(settings.robot)  # for drawing (the session thread has its own)
            self.terrains = TerrainService(self.session, TerrainStore(settings.terrains_dir or terrains_dir()))
            self.recordings = RecordingStore(settings.recordings_dir)
            self.recorder = LiveRecorder(self.recordings, self.robot, rate_hz=settings.record_hz)
            self.viewer = Viewer(
                self.session,
                self.terrains,
                self.recorder,
                self.robot,
                host=settings.host,
                port=settings.viser_port,
                scene_hz=settings.scene_hz,
            )
        except BaseException:
            self.session.stop()
            raise
        self.api = create_api(self)

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

    def close(self) -> None:
        self.recorder.close()
        self.viewer.close()
        self.session.stop()


def create_api(app: ContactnetApp) -> FastAPI:
    api = FastAPI(
        title="contactnet",
        description=f"Drive, push and inspect the live {app.settings.robot} session; manage terrains and "
        "recordings. The 3D view is at / (viser, port given by GET /api/info).",
        version="0.1.0",
    )
    SettingsCommand = settings_command_model()  # noqa: N806 - a model class

    @api.exception_handler(RequestValidationError)
    async def validation_error(request: Request, exc: RequestValidationError) -> JSONResponse:
        """FastAPI's 422, but JSON-safe when the bad input was NaN or infinite (JSON allows neither)."""
        return JSONResponse(status_code=422, content={"detail": json_safe(jsonable_encoder(exc.errors()))})

    def run(command, timeout: float = COMMAND_TIMEOUT_S) -> State:
        try:
            app.session.call(command, timeout=timeout)
        except (ValueError, EditError) as exc:
            raise HTTPException(422, str(exc)) from None
        except TimeoutError:
            raise HTTPException(504, "the live session did not answer in time") from None
        except RuntimeError as exc:
            raise HTTPException(503, str(exc)) from None
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
    @api.get("/api/info", response_model=Info, tags=["session"])
    def info() -> Info:
        return Info(viser_port=app.viser_port, viewer_url="/viewer/", version="0.1.0", robot=app.settings.robot)

    @api.get("/api/state", response_model=State, tags=["session"])
    def get_state() -> State:
        return app.state()

    @api.post(
        "/api/command",
        response_model=State,
        tags=["session"],
        description=f"Set the commanded velocity (|vx|, |vy| <= {VELOCITY_LIMIT_M_S:g} m/s).",
    )
    def command(body: VelocityCommand) -> State:
        return run(SetVelocity(body.vx, body.vy))

    @api.post(
        "/api/push",
        response_model=State,
        tags=["session"],
        description=f"Push the base now (|f| <= {PUSH_FORCE_LIMIT_N:g} N, "
        f"0 < duration <= {PUSH_DURATION_LIMIT_S:g} s).",
    )
    def push(body: PushCommand) -> State:
        return run(ApplyPush(body.fx, body.fy, body.duration))

    @api.post("/api/reset", response_model=State, tags=["session"])
    def reset() -> State:
        """Back to the start of the terrain, running."""
        return run(Reset())

    @api.post("/api/pause", response_model=State, tags=["session"])
    def pause(body: PauseCommand) -> State:
        return run(SetPaused(body.paused))

    @api.post("/api/settings", response_model=State, tags=["session"])
    def settings(body: SettingsCommand) -> State:
        """Change gait, planner, noise (each restarts the robot) and simulation speed."""
        if body.speed is not None:
            run(SetSpeed(body.speed))
        if body.gait is not None:
            run(SetGait(body.gait))
        if body.planner is not None:
            run(SetPlanner(body.planner))
        if body.noise is not None:
            run(SetNoise(body.noise))
        return app.state()

    @api.post("/api/session/terrain", response_model=State, tags=["session"])
    def session_terrain(body: TerrainSelect) -> State:
        """Put the robot on another terrain (a file, a shipped generator, or the random field)."""
        try:
            app.terrains.load(body.name, removed=body.removed, seed=body.seed, timeout=COMMAND_TIMEOUT_S)
        except FileNotFoundError as exc:
            raise HTTPException(404, str(exc)) from None
        except (EditError, ValueError) as exc:
            raise HTTPException(422, str(exc)) from None
        return app.state()

    # ---- terrains ---------------------------------------------------------------------------------
    @api.get("/api/terrains", response_model=TerrainList, tags=["terrains"])
    def list_terrains() -> TerrainList:
        names = app.terrains.store.names()
        return TerrainList(
            terrains=[TerrainEntry(name=n, shipped=is_shipped(n), url=f"/api/terrains/{n}") for n in names],
            current=app.terrains.label,
        )

    @api.get("/api/terrains/{name}", tags=["terrains"])
    def get_terrain(name: TerrainName) -> dict[str, Any]:
        """The terrain file (the "Terrain file" format of docs/architecture.md)."""
        try:
            return app.terrains.store.load(name).to_dict()
        except FileNotFoundError as exc:
            raise HTTPException(404, str(exc)) from None
        except EditError as exc:
            raise HTTPException(422, str(exc)) from None

    @api.put(
        "/api/terrains/{name}",
        response_model=Saved,
        tags=["terrains"],
        openapi_extra={
            "requestBody": {
                "required": True,
                "content": {
                    "application/json": {
                        "schema": {
                            "type": "object",
                            "description": "a terrain (docs/architecture.md 'Terrain file'); at most 1 MB",
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
        overwrite: Annotated[bool, Query(description="confirm replacing a shipped terrain")] = False,
    ) -> Saved:
        """Save a terrain under `name` in terrains/ (validated; nothing is written if it is invalid)."""
        declared = request.headers.get("content-length")
        if declared is not None and declared.isdigit() and int(declared) > MAX_UPLOAD_BYTES:
            raise HTTPException(
                413, f"terrain file is {declared} bytes; the limit is {MAX_UPLOAD_BYTES} bytes"
            )
        body = bytearray()
        async for chunk in request.stream():
            body += chunk
            if len(body) > MAX_UPLOAD_BYTES:
                raise HTTPException(413, f"terrain file exceeds the limit of {MAX_UPLOAD_BYTES} bytes")
        try:
            data = parse_upload(bytes(body), source=f"{name}.json")
            path = app.terrains.store.save(data, name, overwrite=overwrite)
        except ShippedTerrainError as exc:
            raise HTTPException(409, str(exc)) from None
        except EditError as exc:
            raise HTTPException(422, str(exc)) from None
        return Saved(name=name, path=str(path))

    # ---- recordings ---------------------------------------------------------------------------------
    def entry(name: str, size: int, modified: float) -> RecordingEntry:
        url = f"/api/recordings/{name}"
        return RecordingEntry(
            name=name,
            size_bytes=size,
            modified=modified,
            download_url=url,
            html_url=f"{url}/html",
            play_url=f"/viewer/?playbackPath={url}",
        )

    @api.get("/api/recordings", response_model=list[RecordingEntry], tags=["recordings"])
    def list_recordings() -> list[RecordingEntry]:
        return [entry(r.name, r.size_bytes, r.modified) for r in app.recordings.list()]

    @api.get("/api/recordings/status", response_model=RecordingStatus, tags=["recordings"])
    def recording_status() -> RecordingStatus:
        return RecordingStatus(**app.recorder.status())

    @api.post("/api/recordings/start", response_model=RecordingStatus, tags=["recordings"])
    def start_recording(body: RecordingStart | None = None) -> RecordingStatus:
        """Record the scene (12 Hz) until stopped (at most 10 simulated minutes)."""
        try:
            app.recorder.start((body.label if body else "").replace(" ", "-"))
        except RuntimeError as exc:
            raise HTTPException(409, str(exc)) from None
        return RecordingStatus(**app.recorder.status())

    @api.post("/api/recordings/stop", response_model=RecordingEntry, tags=["recordings"])
    def stop_recording() -> RecordingEntry:
        try:
            info = app.recorder.stop()
        except RuntimeError as exc:
            raise HTTPException(409, str(exc)) from None
        return entry(info.name, info.size_bytes, info.modified)

    def recording_path(name: str) -> Path:
        path = app.recordings.path(name)
        if not path.is_file():
            raise HTTPException(404, f"no recording named {name!r}")
        return path

    @api.get("/api/recordings/{name}", tags=["recordings"], response_class=FileResponse)
    def download_recording(name: RecordingName) -> FileResponse:
        """The .viser file (play it with /viewer/?playbackPath=<this URL>)."""
        return FileResponse(recording_path(name), media_type="application/octet-stream", filename=name)

    @api.get("/api/recordings/{name}/html", tags=["recordings"], response_class=HTMLResponse)
    def recording_html(name: RecordingName, download: bool = True) -> Response:
        """One self-contained HTML file that plays the recording in any browser."""
        html = viser_html(recording_path(name).read_bytes())
        headers = {"Content-Disposition": f'attachment; filename="{name[:-6]}.html"'} if download else {}
        return HTMLResponse(html, headers=headers)

    return api


# ---- process start-up ------------------------------------------------------------------------------
class BackgroundServer:
    """uvicorn in a thread (tests and benchmarks)."""

    def __init__(self, api: FastAPI, host: str, port: int):
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


def serve(settings: ServeSettings) -> int:
    """Run the tool until interrupted (Ctrl-C)."""
    logging.basicConfig(
        level=os.environ.get("CONTACTNET_LOG", "INFO"),
        stream=sys.stderr,
        format="%(asctime)s %(name)s %(levelname)s: %(message)s",
    )
    logging.getLogger("websockets").setLevel(logging.WARNING)
    app = ContactnetApp(settings)
    try:
        print(
            f"contactnet: open http://{settings.host}:{settings.port}/  "
            f"(3D view: viser on port {app.viser_port}; API docs: http://{settings.host}:{settings.port}/docs)",
            file=sys.stderr,
            flush=True,
        )
        uvicorn.Server(uvicorn.Config(app.api, host=settings.host, port=settings.port, log_level="warning")).run()
    finally:
        app.close()
    return 0
