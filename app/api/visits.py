"""A robot per visitor: every browser gets a live session of its own (`Visit`), kept in a `VisitPool`.

A visit is what one visitor drives: a live session (robot, terrain, settings: a `SessionBackend`, simulated in
this process or in a Ray actor: ``serve --engine``), its 3D view (a `Viewer`: a viser server of its own, on a port
the OS picks), the terrain service in front of the session and a recorder. The terrain library and the recordings
folder are shared by all visits.

Who is who: the front page (``GET /``) gives the browser a cookie (`VISIT_COOKIE`, HttpOnly, SameSite=Strict)
naming its visit, created on the first visit. Every request that carries the cookie acts on that visit
(`VisitRouting` puts it in `CURRENT_VISIT` for the request, and `ContactnetApp.session` etc. read it); a request
without the cookie acts on the default visit, as before visits existed, so scripts keep working. The first
browser is given the default visit itself: a user alone with the tool and a script see the same robot. A cookie
whose visit has been reclaimed gets a 410 from the API (the page then asks for a reload).

Lifetime: a visit is reclaimed (its recording in progress saved, its threads and ports closed) once no browser
has had its 3D view open and none of its requests came for ``idle_s`` seconds; the default visit is never
closed, only released for the next browser (under a new id: the cookie of the browser that left no longer names
it). A visit whose simulation was lost (a Ray actor or its node died) is reclaimed at the reaper's next look,
and its cookie then gets a 410 that says so (the default visit is replaced by a new one). At most ``max_sessions``
visits run (the default one included);
a browser that comes when all are taken gets a page that says so, with links to watch the running ones.

Watching: each visit has a public ``watch_id`` (never its cookie, which would let the holder drive it). A
watcher's page (``/?watch=WATCH_ID``) opens a second viser server of that visit that shows the scene and has
no control panel (`Viewer.watch_port`): read-only by construction, not by hiding buttons.

`serve --shared` turns visits off: every browser is a visitor of the default session (no cookie is set).
"""

from __future__ import annotations

import logging
import secrets
import threading
import time
from collections.abc import Callable
from contextvars import ContextVar
from dataclasses import dataclass, field
from http.cookies import CookieError, SimpleCookie
from typing import TYPE_CHECKING

from starlette.responses import JSONResponse
from starlette.types import ASGIApp, Receive, Scope, Send

if TYPE_CHECKING:
    from app.live.backend import SessionBackend
    from app.live.editing import TerrainService
    from app.recordings.live_recorder import LiveRecorder
    from app.viewer.live_viewer import Viewer

log = logging.getLogger("contactnet.app.visits")

VISIT_COOKIE = "contactnet_visit"
#: CPU cores one live session takes at real time (walk, ContactNet, flat, scene at 30 Hz, no browser): 0.34 alone,
#: 0.31-0.36 each with 2 or 3 at once (`contactnet bench live --sessions 1,2,3,4`, docs/web-tool.md).
SESSION_CPU_CORES = 0.33
#: The sessions' simulations share one Python process (and its GIL): about one core in all, whatever the machine
#: (measured: 3 sessions kept real time on 0.92 cores; 4 took 1.05 cores and ran at 0.70-0.74 of real time).
PROCESS_CPU_CORES = 1.0
DEFAULT_IDLE_S = 120.0
LOST_KEPT = 256
REAP_PERIOD_S = 5.0


def default_max_sessions() -> int:
    """How many live sessions one server runs in real time by default: the cores one process can use (one, the
    GIL) over a session's cost (3, as measured)."""
    return max(1, int(PROCESS_CPU_CORES / SESSION_CPU_CORES))


def _new_id(nbytes: int) -> str:
    return secrets.token_hex(nbytes)


@dataclass(eq=False)
class Visit:
    """One visitor's live session, its 3D view, its terrain service and its recorder."""

    session: SessionBackend
    terrains: TerrainService
    recorder: LiveRecorder
    viewer: Viewer
    default: bool = False
    visit_id: str = field(default_factory=lambda: _new_id(16))  #: the secret the visitor's cookie holds
    watch_id: str = field(default_factory=lambda: _new_id(6))  #: public: names the visit in watch links
    claimed: bool = False  #: a browser holds its cookie
    created: float = field(default_factory=time.monotonic)
    last_seen: float = field(default_factory=time.monotonic)

    def touch(self) -> None:
        self.last_seen = time.monotonic()

    def viewers(self) -> int:
        """Browsers with this visit's 3D view open (watchers not counted)."""
        return self.viewer.clients()

    def idle_s(self, now: float | None = None) -> float:
        """Seconds since the visitor last showed up (0 while a 3D view is open)."""
        if self.viewers():
            self.touch()
            return 0.0
        return (time.monotonic() if now is None else now) - self.last_seen

    def close(self) -> str | None:
        """Stop it; a recording in progress is saved. One line about that recording, None when none was running."""
        self.viewer.close()  # no more frames fed to the recorder
        try:
            return self.recorder.save_in_progress()
        finally:
            self.recorder.close()
            self.session.stop()


class ServerFull(Exception):
    """Every live session is taken."""


class VisitPool:
    """The running visits (see the module docstring). ``build(default)`` makes a new `Visit`."""

    def __init__(self, build: Callable[[bool], Visit], max_sessions: int, idle_s: float = DEFAULT_IDLE_S,
                 shared: bool = False):
        if not (isinstance(max_sessions, int) and max_sessions >= 1):
            raise ValueError(f"max_sessions must be at least 1, got {max_sessions!r}")
        self._build = build
        self.max_sessions = max_sessions
        self.idle_s = idle_s
        self.shared = shared
        self._lock = threading.Lock()  # the dict of visits
        self._building = threading.Lock()  # one visit built at a time (viser's guard is armed per server)
        self.boot_id = _new_id(4)  #: starts every visit id this server gives: tells a restart from a reclaim
        self.default = build(True)
        self.default.visit_id = self.boot_id + self.default.visit_id
        self._visits: dict[str, Visit] = {self.default.visit_id: self.default}
        self.reclaimed = 0
        self._lost: dict[str, str] = {}  # visit id -> why its simulation was lost (the last LOST_KEPT)
        self._stop = threading.Event()
        self._reaper = threading.Thread(target=self._reap_loop, name="visit-reaper", daemon=True)
        self._reaper.start()

    # ---- lookup --------------------------------------------------------------------------------------
    def get(self, visit_id: str | None) -> Visit | None:
        if not visit_id:
            return None
        with self._lock:
            return self._visits.get(visit_id)

    def by_watch_id(self, watch_id: str) -> Visit | None:
        with self._lock:
            return next((v for v in self._visits.values() if v.watch_id == watch_id), None)

    def visits(self) -> list[Visit]:
        with self._lock:
            return list(self._visits.values())

    def __len__(self) -> int:
        with self._lock:
            return len(self._visits)

    # ---- the front page ----------------------------------------------------------------------------------
    def claim(self, visit_id: str | None) -> Visit:
        """The visit of a browser that opens the page with cookie ``visit_id`` (None: none): its own if it still
        runs, else the default one if no browser holds it, else a new one. `ServerFull` when none is left."""
        if self.shared:
            return self.default
        with self._building:
            with self._lock:
                visit = self._visits.get(visit_id) if visit_id else None
                if visit is None and not self.default.claimed:
                    visit = self.default
                if visit is not None:
                    visit.claimed = True
                    visit.touch()
                    return visit
                if len(self._visits) >= self.max_sessions:
                    raise ServerFull(f"all {self.max_sessions} live sessions are in use")
            visit = self._build(False)  # seconds: robot, models, simulator, viser server
            visit.visit_id = self.boot_id + visit.visit_id
            visit.claimed = True
            with self._lock:
                self._visits[visit.visit_id] = visit
            log.info("visit %s started (%d running)", visit.watch_id, len(self))
            return visit

    # ---- reclaiming --------------------------------------------------------------------------------------
    def reap(self, now: float | None = None) -> list[str]:
        """Close the visits idle for longer than ``idle_s`` (the default one is only released) and those whose
        simulation was lost (`reap_lost`); their watch ids."""
        gone = self.reap_lost()
        now = time.monotonic() if now is None else now
        closing = []
        with self._lock:
            for visit in list(self._visits.values()):
                if visit.idle_s(now) <= self.idle_s:
                    continue
                if visit.default:
                    if visit.claimed:  # released for the next browser: the last one's cookie no longer names it
                        del self._visits[visit.visit_id]
                        visit.visit_id = self.boot_id + _new_id(16)
                        self._visits[visit.visit_id] = visit
                    visit.claimed = False
                else:
                    del self._visits[visit.visit_id]
                    closing.append(visit)
        for visit in closing:
            try:
                note = visit.close()
            except Exception:  # noqa: BLE001 - one visit's failure must not stop the reaper
                log.exception("closing visit %s failed", visit.watch_id)
                continue
            self.reclaimed += 1
            log.info("visit %s reclaimed after %.0f s idle%s", visit.watch_id, self.idle_s, f"; {note}" if note else "")
        return gone + [v.watch_id for v in closing]

    def reap_lost(self) -> list[str]:
        """Reclaim the visits whose simulation was lost (``session.lost``: a Ray actor or its node died); a
        request with such a visit's cookie then gets a 410 saying so (`lost_reason`). The default visit is
        replaced by a new one. Their watch ids."""
        with self._lock:
            lost = [v for v in self._visits.values() if v.session.lost]
            for visit in lost:
                del self._visits[visit.visit_id]
                self._lost[visit.visit_id] = visit.session.lost
                while len(self._lost) > LOST_KEPT:
                    self._lost.pop(next(iter(self._lost)))
        for visit in lost:
            log.warning("visit %s reclaimed: %s", visit.watch_id, visit.session.lost)
            try:
                note = visit.close()
            except Exception:  # noqa: BLE001 - one visit's failure must not stop the reaper
                log.exception("closing visit %s failed", visit.watch_id)
                note = None
            if note:
                log.warning("visit %s: %s", visit.watch_id, note)
            self.reclaimed += 1
            if visit.default:  # the tool always has one: a new default session (its viewer on the same port)
                with self._building:
                    fresh = self._build(True)
                    fresh.visit_id = self.boot_id + fresh.visit_id
                    with self._lock:
                        self.default = fresh
                        self._visits[fresh.visit_id] = fresh
        return [v.watch_id for v in lost]

    def lost_reason(self, visit_id: str | None) -> str | None:
        """Why the visit ``visit_id`` was reclaimed when its simulation was lost (None: it was not)."""
        with self._lock:
            return self._lost.get(visit_id) if visit_id else None

    def _reap_loop(self) -> None:
        while not self._stop.wait(min(REAP_PERIOD_S, max(self.idle_s / 4, 0.05))):
            try:
                self.reap()
            except Exception:  # noqa: BLE001 - keep reaping
                log.exception("reaping visits failed")

    def close(self) -> list[str]:
        """Close every visit; one line per recording in progress (saved or dropped)."""
        self._stop.set()
        self._reaper.join(5.0)
        with self._lock:
            visits, self._visits = list(self._visits.values()), {}
        notes = []
        for visit in visits:
            try:
                note = visit.close()
            except Exception as exc:  # noqa: BLE001 - close the others, say what failed
                note = f"closing a session failed: {exc}"
            if note:
                notes.append(note)
        return notes


#: The visit the current request acts on (set by `VisitRouting`; None: the default visit).
CURRENT_VISIT: ContextVar[Visit | None] = ContextVar("contactnet_current_visit", default=None)


def visit_cookie(headers: list[tuple[bytes, bytes]]) -> str | None:
    """The value of `VISIT_COOKIE` among raw ASGI headers (the last one wins, as in browsers' order), or None."""
    value = None
    for name, raw in headers:
        if name.lower() != b"cookie":
            continue
        try:
            jar = SimpleCookie(raw.decode("latin-1"))
        except CookieError:
            continue
        if VISIT_COOKIE in jar:
            value = jar[VISIT_COOKIE].value
    return value


class VisitRouting:
    """ASGI middleware: a request with the visit cookie acts on that visit (`CURRENT_VISIT`); an API request
    whose visit was reclaimed gets a one-line 410."""

    def __init__(self, app: ASGIApp, pool: VisitPool):
        self.app = app
        self.pool = pool

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http" or self.pool.shared:
            await self.app(scope, receive, send)
            return
        visit_id = visit_cookie(scope.get("headers", []))
        visit = self.pool.get(visit_id)
        path = scope.get("path", "")
        if visit is None and visit_id and path.startswith("/api/") and not path.startswith("/api/visits"):
            lost = self.pool.lost_reason(visit_id)
            if lost:
                detail = f"your live session was closed: {lost}"
            elif visit_id.startswith(self.pool.boot_id):
                detail = f"your live session was closed after {self.pool.idle_s:g} s without a visit"
            else:
                detail = "the server restarted since your live session began"
            detail += ": POST /api/visits (or reload the page) for a new one"
            # no-store: browsers may cache a 410 (heuristically cacheable), and then keep answering /api/state with it
            # after the page has its new session
            await JSONResponse({"detail": detail}, status_code=410,
                               headers={"Cache-Control": "no-store"})(scope, receive, send)
            return
        if visit is not None:
            visit.touch()
        token = CURRENT_VISIT.set(visit)
        try:
            await self.app(scope, receive, send)
        finally:
            CURRENT_VISIT.reset(token)
