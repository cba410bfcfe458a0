"""The front page and the /api/visits routes: which visit a browser gets (`app.api.visits`), the page shown when
every session is taken, the running sessions and the read-only view of one (watch)."""

# No `from __future__ import annotations`: FastAPI reads the annotations of the route functions.
import html
from pathlib import Path
from typing import Annotated

from fastapi import FastAPI, HTTPException, Request
from fastapi import Path as PathParam
from fastapi.responses import FileResponse, HTMLResponse, Response

from app.api.errors import ErrorCodes, responses
from app.api.models import VisitEntry, VisitList, WatchInfo
from app.api.visits import VISIT_COOKIE, ServerFull, Visit
from app.live.view import status_line

WATCH_ID = r"^[0-9a-f]{12}$"
WatchId = Annotated[str, PathParam(pattern=WATCH_ID, description="a session's public watch id (GET /api/visits)")]


def _entry(visit: Visit, mine: Visit, now: float | None = None) -> VisitEntry:
    view = visit.session.view
    return VisitEntry(
        watch_id=visit.watch_id,
        yours=visit is mine,
        default=visit.default,
        terrain=view.status.terrain if view is not None else "",
        status=status_line(view) if view is not None else "starting",
        viewers=visit.viewers(),
        idle_s=round(visit.idle_s(now), 1),
        watch_url=f"/?watch={visit.watch_id}",
    )


def full_page(visits: list[Visit], max_sessions: int) -> str:
    """The page a browser gets when every live session is taken: what happened, what to do, watch links."""
    links = "".join(
        f'<li><a href="/?watch={html.escape(v.watch_id)}">watch session {html.escape(v.watch_id)}</a> '
        f"({html.escape(v.session.view.status.terrain if v.session.view else 'starting')})</li>"
        for v in visits
    )
    return (
        "<!doctype html><html lang=en><head><meta charset=utf-8><title>contactnet: server full</title>"
        '<meta name=viewport content="width=device-width,initial-scale=1">'
        '<link rel=icon href="/favicon.ico"><meta http-equiv=refresh content=30>'
        "<style>body{font:16px system-ui,sans-serif;max-width:40em;margin:3em auto;padding:0 1em}</style>"
        "</head><body><h1>Every robot is taken</h1>"
        f"<p>This server runs at most {max_sessions} live sessions at once and all of them have a visitor. "
        "A session is freed two minutes after its page is closed; this page tries again every 30 s.</p>"
        f"<p>Meanwhile, watch one (read-only):</p><ul>{links}</ul>"
        "<p>Running the server yourself? <code>contactnet serve --max-sessions N</code> allows more, "
        "<code>--shared</code> gives everyone one robot.</p></body></html>"
    )


def add_visit_routes(api: FastAPI, app, codes: ErrorCodes, index_html: Path) -> None:  # noqa: ANN001 - a ContactnetApp
    """The front page (``GET /``) and the /api/visits routes of `app` (a ContactnetApp: its `visits`)."""
    everywhere, changing = codes.everywhere, codes.changing

    def with_cookie(response: Response, visit: Visit) -> Response:
        if not app.visits.shared:
            response.set_cookie(VISIT_COOKIE, visit.visit_id, path="/", httponly=True, samesite="strict")
        return response

    @api.get("/", include_in_schema=False)
    def index(request: Request) -> Response:
        """The page. A watcher's page (``?watch=ID``) takes no session; any other gets the browser's visit (its
        cookie's, or a new one; the cookie is set here) or, when every session is taken, a page that says so."""
        if "watch" in request.query_params or app.visits.shared:
            return FileResponse(index_html, media_type="text/html")
        try:
            visit = app.visits.claim(request.cookies.get(VISIT_COOKIE))
        except ServerFull:
            return HTMLResponse(full_page(app.visits.visits(), app.visits.max_sessions), status_code=503,
                                headers={"Retry-After": "30"})
        return with_cookie(FileResponse(index_html, media_type="text/html"), visit)

    @api.post("/api/visits", response_model=VisitEntry, tags=["visits"], responses=responses(*changing, 503))
    def claim(request: Request, response: Response) -> VisitEntry:
        """A live session for this browser, as opening the page gives one: its cookie's if it still runs, else a new
        one (the cookie is set). The page asks for one when the API said 410 (its session was reclaimed, or the
        server restarted). 503 when every session is taken."""
        try:
            visit = app.visits.claim(request.cookies.get(VISIT_COOKIE))
        except ServerFull as exc:
            raise HTTPException(503, f"{exc}: try again in a minute, or watch one (GET /api/visits)") from None
        with_cookie(response, visit)
        return _entry(visit, visit)

    @api.get("/api/visits", response_model=VisitList, tags=["visits"], responses=responses(*everywhere))
    def list_visits() -> VisitList:
        """The running live sessions (one per visitor; yours is marked), with links to watch each read-only."""
        mine = app.visit()
        return VisitList(
            sessions=[_entry(v, mine) for v in app.visits.visits()],
            max_sessions=app.visits.max_sessions,
            shared=app.visits.shared,
            idle_timeout_s=app.visits.idle_s,
        )

    @api.get("/api/visits/{watch_id}/watch", response_model=WatchInfo, tags=["visits"],
             responses=responses(*everywhere, 404))
    def watch(watch_id: WatchId) -> WatchInfo:
        """The read-only 3D view of one session: a viser port showing its scene with no control panel."""
        visit = app.visits.by_watch_id(watch_id)
        if visit is None:
            raise HTTPException(404, f"no running session has the watch id {watch_id}")
        return WatchInfo(watch_id=watch_id, viser_port=visit.viewer.watch_port(), viewer_url="/viewer/")
