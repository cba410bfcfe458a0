"""The REST API's recordings routes: list, start, stop, download, data track, HTML export (a one-file player
with the timeline and plots), rename or retitle (PATCH), delete (`add_recording_routes`)."""

# No `from __future__ import annotations`: FastAPI reads the annotations of the route functions.
from pathlib import Path
from typing import Annotated

from fastapi import FastAPI, HTTPException, Response
from fastapi import Path as PathParam
from fastapi.responses import FileResponse, HTMLResponse, JSONResponse
from starlette.convertors import Convertor, register_url_convertor

from app.api.errors import STORAGE_CODES, ErrorCodes, as_http_errors, responses
from app.api.recording_models import (
    RecordingChange,
    RecordingEntry,
    RecordingStart,
    RecordingStatus,
    entry_of,
)
from app.recordings.player import player_html
from app.recordings.recorder import RECORDING_NAME
from app.recordings.track import TrackError, read_track

RecordingName = Annotated[str, PathParam(pattern=RECORDING_NAME.pattern, description="a recording's file name")]


class RecordingFileConvertor(Convertor[str]):
    """``{name:recording_file}``: only names of .viser files match, so ``GET /api/recordings/start`` finds
    no GET route and answers 405 (the route exists for POST), instead of a 422 about a bad file name."""

    regex = RECORDING_NAME.pattern.strip("^$")

    def convert(self, value: str) -> str:
        return value

    def to_string(self, value: str) -> str:
        return value


register_url_convertor("recording_file", RecordingFileConvertor())


def add_recording_routes(
    api: FastAPI,
    app,  # noqa: ANN001 - a ContactnetApp (app.api.server imports this module)
    codes: ErrorCodes,
) -> None:
    """Add the /api/recordings routes of `app` (a ContactnetApp: its `recordings` store and live `recorder`)
    to `api`."""
    everywhere, changing = codes.everywhere, codes.changing

    @api.get(
        "/api/recordings",
        response_model=list[RecordingEntry],
        tags=["recordings"],
        responses=responses(*everywhere),
    )
    def list_recordings() -> list[RecordingEntry]:
        """The recordings of the recordings folder with what they show, newest first."""
        return [entry_of(r) for r in app.recordings.list()]

    @api.get(
        "/api/recordings/status",
        response_model=RecordingStatus,
        tags=["recordings"],
        responses=responses(*everywhere),
    )
    def recording_status() -> RecordingStatus:
        return RecordingStatus(**app.recorder.status())

    @api.post(
        "/api/recordings/start",
        response_model=RecordingStatus,
        tags=["recordings"],
        responses=responses(*changing, 409, 422),
    )
    def start_recording(body: RecordingStart | None = None) -> RecordingStatus:
        """Record the scene (12 Hz) until stopped (at most 10 simulated minutes)."""
        body = body or RecordingStart()
        with as_http_errors():
            app.recorder.start(body.label.replace(" ", "-"), title=body.title)
        return RecordingStatus(**app.recorder.status())

    @api.post(
        "/api/recordings/stop",
        response_model=RecordingEntry,
        tags=["recordings"],
        responses=responses(*changing, 409, *STORAGE_CODES),
    )
    def stop_recording() -> RecordingEntry:
        """Stop and save the recording. When it cannot be written (500, or 507: the disk is full; the detail
        says why) it is kept, stopped: stop again to save it once the folder can be written."""
        with as_http_errors():
            info = app.recorder.stop()
        return entry_of(info)

    def recording_path(name: str) -> Path:
        path = app.recordings.path(name)
        if not path.is_file():
            raise HTTPException(404, f"no recording named {name!r}")
        return path

    @api.get(
        "/api/recordings/{name:recording_file}",
        tags=["recordings"],
        response_class=FileResponse,
        responses={
            **responses(*everywhere, 404, 422, json_route=False),
            200: {
                "content": {"application/octet-stream": {"schema": {"type": "string", "format": "binary"}}}
            },
        },
    )
    def download_recording(name: RecordingName) -> FileResponse:
        """The .viser file (play it with /viewer/?playbackPath=<this URL>)."""
        return FileResponse(recording_path(name), media_type="application/octet-stream", filename=name)

    @api.patch(
        "/api/recordings/{name:recording_file}",
        response_model=RecordingEntry,
        tags=["recordings"],
        responses=responses(*changing, 404, 409, 422, *STORAGE_CODES),
    )
    def change_recording(name: RecordingName, body: RecordingChange) -> RecordingEntry:
        """Rename the recording's file (``name``; 409 when that name is taken) and/or set its title. 409 for
        the recording in progress."""
        if body.name is None and body.title is None:
            raise HTTPException(422, "nothing to change: give a new 'name' or 'title'")
        new_name = body.name
        if new_name is not None and not new_name.endswith(".viser"):
            new_name += ".viser"
        with as_http_errors():
            return entry_of(app.recorder.change(name, new_name, body.title))

    @api.delete(
        "/api/recordings/{name:recording_file}",
        status_code=204,
        response_class=Response,
        tags=["recordings"],
        responses=responses(*changing, 404, 409, *STORAGE_CODES),
    )
    def delete_recording(name: RecordingName) -> Response:
        """Delete the recording and its metadata. 409 for the recording in progress."""
        with as_http_errors():
            app.recorder.delete(name)
        return Response(status_code=204)

    @api.get(
        "/api/recordings/{name:recording_file}/html",
        tags=["recordings"],
        response_class=HTMLResponse,
        responses=responses(*everywhere, 404, 422, json_route=False),
    )
    def recording_html(name: RecordingName, download: bool = True) -> Response:
        """One self-contained HTML file that plays the recording in any browser, offline: the 3D view with the
        timeline in simulated seconds, its markers and the plots of the data track (when it has one)."""
        path = recording_path(name)
        info = app.recordings.info(name)
        try:
            track = read_track(path)
        except (FileNotFoundError, TrackError):
            track = None
        title = (info.meta.title if info.meta is not None else "") or name
        html = player_html(path.read_bytes(), track, title=title, meta=info.meta, name=name)
        headers = {"Content-Disposition": f'attachment; filename="{name[:-6]}.html"'} if download else {}
        return HTMLResponse(html, headers=headers)

    @api.get(
        "/api/recordings/{name:recording_file}/track",
        tags=["recordings"],
        responses={
            **responses(*everywhere, 404, 422, 500),
            200: {"content": {"application/json": {"schema": {"type": "object"}}}},
        },
    )
    def recording_track(name: RecordingName) -> Response:
        """The recording's data track (`app.recordings.track`): per frame the recording time and the simulated
        time, x, progress, commanded and measured velocity, steps, rank, run and state; per plan the planner's and
        optimizer's milliseconds, the rank chosen and stands; events (push, stand, fall, goal, end, restart). 404
        for a recording made before tracks were kept (it plays without one)."""
        path = recording_path(name)
        try:
            track = read_track(path)
        except FileNotFoundError as exc:
            raise HTTPException(404, str(exc)) from None
        except TrackError as exc:
            raise HTTPException(500, f"the data track of {name} cannot be read: {exc}") from None
        return JSONResponse(track)
