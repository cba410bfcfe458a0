"""How the REST API says no: the error models its OpenAPI schema declares, the handlers that produce exactly
those shapes, and the route class that reads every JSON body with `contactnet.strict_json.loads_strict`.

Every refusal is ``{"detail": "one line"}`` (`Problem`), except 422, whose ``detail`` is either FastAPI's
list of field errors (a body or parameter that does not fit its model: `FieldError`, with at most a short
excerpt of the bad input, never the input itself) or one line (a request that fits the model but not the
session: a terrain that is not valid, a bad command). `responses(...)` declares the codes a route returns
with these models, so the schema tells the truth (schemathesis checks it).

A file the tool cannot write, rename or delete (a read-only or full data folder: an OSError of the file
system, `contactnet.atomic.StorageError`) is 507 when the disk is full, else 500, with one line naming the file
and the system's reason, and one warning line in the log: no traceback. A client that hangs up before its body
is read gets nothing more and logs nothing (at debug level: one line). A path with a control character (a
newline, ...) matches no route: 404.

Messages never show absolute paths of the machine: `one_line` keeps only a path's last component.
"""

from __future__ import annotations

import logging
import math
import re
import reprlib
from collections.abc import Callable, Coroutine, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from fastapi import FastAPI, HTTPException, Request, Response
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from fastapi.routing import APIRoute
from pydantic import BaseModel, Field
from starlette.exceptions import HTTPException as StarletteHTTPException
from starlette.requests import ClientDisconnect
from starlette.routing import Match

from app.live.commands import CommandConflict
from app.live.editor import EditError, ShippedTerrainError
from app.live.settings import COMMAND_BODY_LIMIT_BYTES
from app.live.terrain_files import StoredTerrainError
from app.recordings.recorder import RecordingConflict
from app.security.guards import is_json
from contactnet.atomic import NO_SPACE
from contactnet.strict_json import JsonInputError, JsonLimits, loads_strict

log = logging.getLogger("contactnet.app.api")

#: JSON limits of a command body (the terrain upload has its own, `app.live.terrain_files.UPLOAD_JSON_LIMITS`).
COMMAND_JSON_LIMITS = JsonLimits(max_bytes=COMMAND_BODY_LIMIT_BYTES, max_depth=16, max_values=10_000)
MAX_DETAIL_CHARS = 300
MAX_FIELD_ERRORS = 20


class Problem(BaseModel):
    """A refused request: one line saying why."""

    detail: str


class FieldError(BaseModel):
    """One field of the request that does not fit its model (FastAPI's validation error, bounded)."""

    loc: list[str | int] = Field(description="where: 'body', 'query' or 'path', then the field")
    msg: str
    type: str
    input: Any = Field(None, description="the bad value, or a short excerpt of it")


class ValidationProblem(BaseModel):
    """422: field errors (the request does not fit its model) or one line (it fits, but is refused)."""

    detail: list[FieldError] | str


DESCRIPTIONS = {
    400: "Malformed request (a bad Content-Length, ...)",
    401: "Access token missing or wrong (only when the tool listens beyond loopback)",
    403: "Cross-site request refused (Origin or Sec-Fetch-Site of another site)",
    404: "No such terrain or recording",
    409: "Not possible in the session's current state",
    413: "Request body over the limit",
    415: "A request body that is not application/json",
    421: "Host header not one of the tool's names (DNS rebinding protection)",
    422: "Invalid request",
    500: "A file could not be written (the data folder is read-only, ...): one line naming it and why",
    503: "The live session is not running",
    504: "The live session did not answer in time",
    507: "No space left to write the file (the disk is full)",
}
#: The codes of a route that writes a user file (a terrain, a recording): `storage_status`.
STORAGE_CODES = (500, 507)


#: What each library error means to an HTTP client, most specific first: the one mapping every route uses
#: (`as_http_errors`). Anything else is a bug of ours and stays a 500.
ERROR_STATUS: tuple[tuple[type[Exception], int], ...] = (
    (FileNotFoundError, 404),  # no such terrain or recording
    (CommandConflict, 409),  # not possible in the session's state (a push while paused, ...)
    (StoredTerrainError, 409),  # a stored terrain file that is not valid
    (ShippedTerrainError, 409),  # a shipped terrain's name, not confirmed
    (RecordingConflict, 409),  # already recording, not recording, the recording in progress
    (FileExistsError, 409),  # a name that is taken
    (EditError, 422),  # an edit or a terrain that is refused
    (ValueError, 422),  # a value the library refuses
    (TimeoutError, 504),  # the session thread did not answer in time
    (RuntimeError, 503),  # the live session is not running
)
_TIMEOUT_DETAIL = "the live session did not answer in time"


def storage_status(exc: BaseException) -> int | None:
    """507 (the disk is full) or 500 for an error of the file system (an OSError with an errno, other than a
    missing file or a time-out); None for any other error."""
    if not isinstance(exc, OSError) or exc.errno is None or isinstance(exc, FileNotFoundError | TimeoutError):
        return None
    return 507 if exc.errno in NO_SPACE else 500


def storage_detail(exc: OSError) -> str:
    """One line: the file system's reason, naming the file (a `StorageError` says it already)."""
    if type(exc).__str__ is not OSError.__str__:  # a StorageError: its own line
        return str(exc)
    name = Path(str(exc.filename)).name if exc.filename else None
    return f"{exc.strerror or type(exc).__name__}{f' ({name})' if name else ''}"


def status_of(exc: BaseException) -> int | None:
    """The HTTP status of this error: `storage_status`, else `ERROR_STATUS`; None when it is none of them."""
    storage = storage_status(exc)
    if storage is not None:
        return storage
    return next((status for kind, status in ERROR_STATUS if isinstance(exc, kind)), None)


@contextmanager
def as_http_errors() -> Iterator[None]:
    """Inside the block, a library error becomes the HTTPException of its status (`ERROR_STATUS`), its one
    line as the detail."""
    try:
        yield
    except HTTPException:
        raise
    except Exception as exc:
        status = status_of(exc)
        if status is None:
            raise
        if status in STORAGE_CODES:
            detail = one_line(storage_detail(exc))  # type: ignore[arg-type] - an OSError
            log.warning("refused (%d): %s", status, detail)
            raise HTTPException(status, detail) from None
        raise HTTPException(status, _TIMEOUT_DETAIL if status == 504 else str(exc)) from None


@dataclass(frozen=True)
class ErrorCodes:
    """The error codes routes declare: those every route can answer (Host, and the token when one is needed), those
    of every state-changing route, and those of a route that sends the live session a command."""

    everywhere: tuple[int, ...]
    changing: tuple[int, ...]
    session_command: tuple[int, ...]

    @classmethod
    def of(cls, policy: Any) -> ErrorCodes:  # an AccessPolicy
        everywhere = (421, 401) if policy.needs_token else (421,)
        changing = (*everywhere, 400, 403, 413, 415)
        return cls(everywhere, changing, (*changing, 422, 503, 504))


def responses(*codes: int, json_route: bool = True) -> dict[int | str, dict[str, Any]]:
    """The OpenAPI ``responses`` of a route that can answer with these error codes. ``json_route=False`` for a
    route whose own answer is not JSON (HTML, a file): its errors are still JSON, which FastAPI would not say
    (its models' schemas must then come from other routes, as they do here)."""
    result: dict[int | str, dict[str, Any]] = {}
    for code in sorted(set(codes)):
        model = ValidationProblem if code == 422 else Problem
        if json_route:
            result[code] = {"model": model, "description": DESCRIPTIONS[code]}
        else:
            schema = {"$ref": f"#/components/schemas/{model.__name__}"}
            result[code] = {"description": DESCRIPTIONS[code], "content": {"application/json": {"schema": schema}}}
    return result


# ---- messages ---------------------------------------------------------------------------------------------
_ABSOLUTE_PATH = re.compile(r"(?<![\w:/.~\-])/(?:[^\s'\"()<>,;:/]+/)+([^\s'\"()<>,;:/]*)")
_EXCERPT = reprlib.Repr()
_EXCERPT.maxlevel, _EXCERPT.maxstring, _EXCERPT.maxother, _EXCERPT.maxlong = 2, 40, 40, 40
_EXCERPT.maxlist = _EXCERPT.maxtuple = _EXCERPT.maxdict = _EXCERPT.maxset = 4


def one_line(text: object, limit: int = MAX_DETAIL_CHARS) -> str:
    """``text`` on one line, absolute paths cut to their last component, at most ``limit`` characters."""
    line = " ".join(str(text).split())
    line = _ABSOLUTE_PATH.sub(lambda m: m.group(1) or "<folder>", line)
    return line if len(line) <= limit else line[: limit - 3] + "..."


def excerpt(value: Any) -> Any:
    """A JSON value small enough to send back: small scalars as they are, anything else a short repr."""
    if value is None or isinstance(value, bool):
        return value
    if isinstance(value, int) and abs(value) < 10**15:
        return value
    if isinstance(value, float):
        return value if math.isfinite(value) else str(value)
    if isinstance(value, str) and len(value) <= 40:
        return value
    try:
        return _EXCERPT.repr(value)[:80]
    except Exception:  # noqa: BLE001 - a value whose repr fails is still refused, without excerpt
        return f"<{type(value).__name__}>"


def field_errors(errors: Any) -> list[dict[str, Any]]:
    """FastAPI's validation errors as `FieldError` dicts (bounded: excerpts, one-line messages, at most 20)."""
    result = []
    for error in list(errors)[:MAX_FIELD_ERRORS]:
        loc = [part if isinstance(part, int) else one_line(part, 64) for part in error.get("loc", ())]
        result.append(
            {
                "loc": loc,
                "msg": one_line(error.get("msg", "")),
                "type": str(error.get("type", "value_error"))[:64],
                "input": excerpt(error.get("input")),
            }
        )
    return result


def install_error_handlers(api: FastAPI) -> None:
    """422s as bounded `FieldError` lists; every other refusal (and a one-line 422) as `Problem`."""

    @api.exception_handler(RequestValidationError)
    async def validation_error(request: Request, exc: RequestValidationError) -> JSONResponse:
        return JSONResponse(status_code=422, content={"detail": field_errors(exc.errors())})

    @api.exception_handler(StarletteHTTPException)
    async def http_error(request: Request, exc: StarletteHTTPException) -> Response:
        headers = dict(exc.headers or {})
        if exc.status_code == 405:  # Starlette names the methods of one route of the path; give them all
            headers["Allow"] = ", ".join(allowed_methods(request))
        if exc.status_code in (204, 304):
            return Response(status_code=exc.status_code, headers=headers)
        return JSONResponse(status_code=exc.status_code, content={"detail": one_line(exc.detail)}, headers=headers)

    @api.exception_handler(ClientDisconnect)
    async def client_gone(request: Request, exc: ClientDisconnect) -> Response:
        # The client hung up while sending its body: nobody reads an answer; Starlette's default is a 58-line
        # traceback per request (1 MB of log a second from a client that does it in a loop).
        log.debug("%s %s: the client hung up before its body was read", request.method, request.url.path[:80])
        return Response(status_code=400)


def allowed_methods(request: Request) -> list[str]:
    """The methods of every route whose path matches the request's."""
    methods: set[str] = set()
    for route in request.app.router.routes:
        match, _ = route.matches(request.scope)
        if match != Match.NONE:
            methods |= set(getattr(route, "methods", None) or ())
    return sorted(methods)


# ---- strict JSON bodies -------------------------------------------------------------------------------------
_CONTROL_CHARACTER = re.compile(r"[\x00-\x1f\x7f]")


class StrictJsonRoute(APIRoute):
    """A route whose JSON body is read by `loads_strict` (size, depth, number length, duplicate keys) before
    FastAPI validates it against the model: a refusal is a 422 field error at ``["body"]`` with one line.
    A path with a control character matches no route (Starlette's ``$`` matches before a final newline:
    ``/api/recordings/x.viser%0A`` would be ``x.viser``)."""

    def matches(self, scope: Any) -> tuple[Match, dict[str, Any]]:
        if _CONTROL_CHARACTER.search(scope.get("path", "")):
            return Match.NONE, {}
        return super().matches(scope)

    def get_route_handler(self) -> Callable[[Request], Coroutine[Any, Any, Response]]:
        handler = super().get_route_handler()

        async def strict_handler(request: Request) -> Response:
            if self.body_field is not None and is_json(request.headers.get("content-type")):
                body = await request.body()
                if body:
                    try:
                        request._json = loads_strict(body, source="request body", limits=COMMAND_JSON_LIMITS)
                    except JsonInputError as exc:
                        raise RequestValidationError(
                            [{"type": "json_invalid", "loc": ("body",), "msg": str(exc), "input": None}]
                        ) from None
            return await handler(request)

        return strict_handler
