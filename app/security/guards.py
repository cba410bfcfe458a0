"""Who may talk to the tool: the Host and Origin checks, the access token, the CSRF rule and the body limits,
for the REST API (`RequestGuard`, an ASGI middleware) and for viser's websocket (`guard_viser`).

The tool binds 127.0.0.1 by default, so the threat is the user's own browser visiting another site:

- **DNS rebinding**: a site whose name resolves to 127.0.0.1 would be same-origin with the tool. Every request
  (API, pages, viser's HTTP and websocket) must carry a Host header naming the tool: 127.0.0.1, localhost,
  ::1, the bound host, `ServeSettings.allowed_hosts` (and, when bound to all interfaces, the machine's names
  and any IP literal). Anything else: 421.
- **Cross-site requests (CSRF)**: a state-changing request (POST, PUT, DELETE, PATCH) is refused (403) when its
  Origin is not the tool's page (host and port) or, without Origin, its Sec-Fetch-Site is not same-origin; a
  body that is not ``application/json`` is refused (415), so a ``text/plain`` form or fetch from any page
  (which needs no CORS preflight) never reaches a route. No CORS headers are sent, so a cross-origin
  ``application/json`` fetch is stopped by its preflight too.
- **viser's websocket** accepts only connections whose Origin is the tool's page or viser's own (a browser
  always sends Origin on websockets; clients without one are not browsers).
- **Beyond loopback** (``--host 0.0.0.0`` or an address): an access token (`AccessPolicy.token`, printed at
  start-up as ``http://HOST:PORT/?token=...``) is required by every HTTP request and every viser websocket:
  the ``X-Contactnet-Token`` header, ``Authorization: Bearer``, or the ``contactnet_token`` cookie that the page
  sets when opened with ``?token=`` (HttpOnly, SameSite=Strict; cookies are per host, so the browser sends it
  to viser's port too). Missing or wrong: 401.
- **Body limits**: `COMMAND_BODY_LIMIT_BYTES` for every JSON command, the terrain upload limit for a terrain
  PUT; refused by Content-Length before anything is read, or while streaming (413).

viser 1.1.1 has no hook on its websocket handshake: it builds its server with
``websockets.asyncio.server.serve(ws_handler, ..., process_request=viser_http_server)`` inside a private
thread. `guard_viser` replaces ``websockets.asyncio.server.serve`` (once, process-wide) by a subclass that,
only for viser's own handler (``viser.infra._infra``'s ``ws_handler``), runs the guard's check before viser's
``process_request``; every other caller gets websockets' ``serve`` unchanged. The check finds the guard of
the `WebsockServer` that owns the handler, so other viser servers (the recorders') stay unguarded. viser's
public "Share" link (a relay through viser's servers) is disabled: the button hidden, the request ignored.
"""

from __future__ import annotations

import hmac
import ipaddress
import logging
import secrets
import socket
import threading
import weakref
from collections.abc import Callable, Mapping
from http import HTTPStatus
from http.cookies import SimpleCookie
from typing import Any
from urllib.parse import parse_qs, urlsplit

from fastapi import HTTPException
from starlette.datastructures import Headers, MutableHeaders
from starlette.responses import JSONResponse
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from app.live.settings import LOOPBACK_HOSTS, ServeSettings

log = logging.getLogger("contactnet.app.security")

TOKEN_HEADER = "x-contactnet-token"
TOKEN_COOKIE = "contactnet_token"
SAFE_METHODS = frozenset({"GET", "HEAD", "OPTIONS", "TRACE"})
WILDCARD_HOSTS = frozenset({"0.0.0.0", "::", ""})


def is_json(content_type: str | None) -> bool:
    """application/json or application/*+json (parameters such as charset allowed)."""
    if not content_type:
        return False
    kind = content_type.split(";", 1)[0].strip().lower()
    return kind == "application/json" or (kind.startswith("application/") and kind.endswith("+json"))


def host_name(header: str | None) -> str | None:
    """The name in a Host header value (without port, brackets or trailing dot, lower case); None if malformed."""
    if not header or len(header) > 255 or any(c.isspace() or c in "/\\@?#" for c in header):
        return None
    header = header.lower()
    if header.startswith("["):
        name, bracket, rest = header[1:].partition("]")
        if not bracket or (rest and not (rest.startswith(":") and rest[1:].isdigit())):
            return None
        return name
    name, colon, port = header.partition(":")
    if colon and not port.isdigit():
        return None
    return name.rstrip(".") or None


def _is_ip(name: str) -> bool:
    try:
        ipaddress.ip_address(name)
    except ValueError:
        return False
    return True


class AccessPolicy:
    """The names the tool answers to, the ports of its pages, and its access token (None on loopback)."""

    def __init__(self, settings: ServeSettings):
        self.wildcard = settings.host in WILDCARD_HOSTS
        names = {*LOOPBACK_HOSTS, *settings.allowed_hosts}
        if not self.wildcard:
            names.add(settings.host)
        else:
            names |= {socket.gethostname(), socket.getfqdn()}
        self.names = frozenset(n.strip("[]").lower().rstrip(".") for n in names)
        self.token: str | None = None if settings.loopback else (settings.token or secrets.token_urlsafe(24))
        self.port = settings.port  #: the web page's and API's port
        self.ports: set[int] = {settings.port}  #: ports of the tool's pages (the API's, viser's): allowed Origins
        host = "127.0.0.1" if self.wildcard else settings.host.strip("[]")
        self.display_host = f"[{host}]" if ":" in host else host  #: the host as written in the tool's address

    @property
    def needs_token(self) -> bool:
        return self.token is not None

    def host_allowed(self, header: str | None) -> bool:
        name = host_name(header)
        return name is not None and (name in self.names or (self.wildcard and _is_ip(name)))

    def origin_allowed(self, origin: str) -> bool:
        """An Origin of one of the tool's pages: http(s), an allowed host name, one of `ports`."""
        try:
            parts = urlsplit(origin)
            port = parts.port or {"http": 80, "https": 443}.get(parts.scheme)
        except ValueError:
            return False
        if parts.scheme not in ("http", "https") or parts.path not in ("", "/") or not parts.hostname:
            return False
        return self.host_allowed(parts.netloc) and port in self.ports

    def token_given(self, headers: Mapping[str, str], query: str = "") -> str | None:
        """How a valid token came: 'header', 'cookie' or 'query'; None when it did not (or was wrong)."""
        if self.token is None:
            return None
        candidates = [("header", headers.get(TOKEN_HEADER))]
        authorization = headers.get("authorization", "")
        if authorization[:7].lower() == "bearer ":
            candidates.append(("header", authorization[7:].strip()))
        cookie = SimpleCookie()
        try:
            cookie.load(headers.get("cookie", ""))
        except Exception:  # noqa: BLE001 - a malformed cookie header counts as no cookie
            cookie = SimpleCookie()
        if TOKEN_COOKIE in cookie:
            candidates.append(("cookie", cookie[TOKEN_COOKIE].value))
        if query:
            candidates.extend(("query", value) for value in parse_qs(query).get("token", [])[:1])
        for how, value in candidates:
            if value and hmac.compare_digest(value.encode(), self.token.encode()):
                return how
        return None

    def refusal(self, method: str, headers: Mapping[str, str], query: str = "") -> tuple[int, str] | None:
        """(status, one line) when a request must be refused before it reaches a route; None to let it in."""
        if not self.host_allowed(headers.get("host")):
            return 421, (
                f"Host {headers.get('host', '')[:80]!r} is not a name of this tool: open it as "
                f"http://{self.display_host}:{self.port}/ (or add the name with --allow-host)"
            )
        if self.token is not None and self.token_given(headers, query) is None:
            return 401, (
                "this tool needs its access token: open the address printed at start-up (…/?token=…) "
                f"or send the {TOKEN_HEADER} header"
            )
        if method.upper() not in SAFE_METHODS:
            origin = headers.get("origin")
            if origin is not None and not self.origin_allowed(origin):
                return 403, f"cross-site request refused (Origin {origin[:80]!r} is not this tool's page)"
            site = headers.get("sec-fetch-site")
            if origin is None and site is not None and site not in ("same-origin", "none"):
                return 403, f"cross-site request refused (Sec-Fetch-Site: {site[:40]})"
        return None


# ---- the REST API ---------------------------------------------------------------------------------------------
class BodyTooLarge(HTTPException):
    def __init__(self, limit: int):
        super().__init__(413, f"request body exceeds the limit of {limit} bytes")


class RequestGuard:
    """ASGI middleware in front of the FastAPI app: `AccessPolicy.refusal`, the JSON-only rule for request
    bodies and the body limits (``body_limit(method, path)`` bytes), see the module doc."""

    def __init__(self, app: ASGIApp, policy: AccessPolicy, body_limit: Callable[[str, str], int]):
        self.app = app
        self.policy = policy
        self.body_limit = body_limit

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        headers = Headers(scope=scope)
        method = scope["method"].upper()
        query = scope.get("query_string", b"").decode("latin-1")
        refusal = self.policy.refusal(method, headers, query)
        if refusal is None and method not in SAFE_METHODS:
            refusal = self._body_refusal(method, scope["path"], headers)
        if refusal is not None:
            status, detail = refusal
            await JSONResponse({"detail": detail}, status_code=status)(scope, receive, send)
            return
        if method not in SAFE_METHODS:
            receive = self._limited(receive, self.body_limit(method, scope["path"]))
        if self.policy.token is not None and self.policy.token_given(headers, query) == "query":
            send = self._setting_cookie(send)
        await self.app(scope, receive, send)

    def _body_refusal(self, method: str, path: str, headers: Headers) -> tuple[int, str] | None:
        limit = self.body_limit(method, path)
        declared = headers.get("content-length")
        if declared is not None and not (declared.isascii() and declared.isdigit() and len(declared) <= 18):
            return 400, "Content-Length is not a number of bytes"
        if declared is not None and int(declared) > limit:
            return 413, f"request body of {int(declared)} bytes exceeds the limit of {limit} bytes"
        has_body = (declared is not None and int(declared) > 0) or "transfer-encoding" in headers
        if has_body and not is_json(headers.get("content-type")):
            kind = headers.get("content-type", "none")[:60]
            return 415, f"request bodies must be application/json (got {kind})"
        return None

    @staticmethod
    def _limited(receive: Receive, limit: int) -> Receive:
        received = 0

        async def limited() -> Message:
            nonlocal received
            message = await receive()
            if message["type"] == "http.request":
                received += len(message.get("body", b""))
                if received > limit:
                    raise BodyTooLarge(limit)
            return message

        return limited

    def _setting_cookie(self, send: Send) -> Send:
        async def with_cookie(message: Message) -> None:
            if message["type"] == "http.response.start":
                headers = MutableHeaders(scope=message)
                headers.append("set-cookie", f"{TOKEN_COOKIE}={self.policy.token}; Path=/; HttpOnly; SameSite=Strict")
            await send(message)

        return with_cookie


# ---- viser's websocket ---------------------------------------------------------------------------------------
_guards: weakref.WeakKeyDictionary[Any, AccessPolicy] = weakref.WeakKeyDictionary()
_install_lock = threading.Lock()
_installed = False
_pending: AccessPolicy | None = None  # the policy of the viser server being created (see prepare_viser_guard)


def viser_refusal(policy: AccessPolicy, headers: Mapping[str, str], path: str) -> tuple[int, str] | None:
    """Why a request to viser's port (its HTTP client files or its websocket) is refused, or None. ``headers``:
    websockets' `Headers` (a header may come more than once: then it counts as wrong) or a plain mapping."""

    def single(name: str) -> str | None:
        if hasattr(headers, "get_all"):
            values = headers.get_all(name)
        else:
            values = [headers[name]] if name in headers else []
        if len(values) > 1:
            return "\n"  # a repeated header: never a valid value
        return values[0] if values else None

    if not policy.host_allowed(single("Host")):
        return 421, "Host is not a name of this tool"
    if (single("Upgrade") or "").lower() == "websocket":
        origin = single("Origin")
        if origin is not None and not policy.origin_allowed(origin):
            return 403, "websocket from another site refused"
        lowered = {k.lower(): single(k) or "" for k in headers.keys()}
        if policy.token is not None and policy.token_given(lowered, urlsplit(path).query) is None:
            return 401, "access token missing"
    return None


def _viser_owner(handler: Any) -> Any:
    """The viser `WebsockServer` whose ``ws_handler`` this is (its closure's ``self``), else None."""
    code = getattr(handler, "__code__", None)
    if code is None or getattr(handler, "__module__", "") != "viser.infra._infra":
        return None
    for name, cell in zip(code.co_freevars, handler.__closure__ or (), strict=False):
        if name == "self":
            return cell.cell_contents
    return None


def _install_serve_hook() -> None:
    global _installed
    with _install_lock:
        if _installed:
            return
        import websockets.asyncio.server as ws_server

        original_serve = ws_server.serve

        class GuardedServe(original_serve):  # type: ignore[valid-type, misc]
            """websockets' ``serve``; for viser's handler, the owner's AccessPolicy checks each handshake."""

            def __init__(self, handler: Any, *args: Any, process_request: Any = None, **kwargs: Any):
                owner = _viser_owner(handler)
                if owner is not None:
                    if _pending is not None:  # guarded from its first connection on
                        _guards.setdefault(owner, _pending)
                    process_request = _guarded(owner, process_request)
                super().__init__(handler, *args, process_request=process_request, **kwargs)

        ws_server.serve = GuardedServe
        _installed = True


def _guarded(owner: Any, process_request: Any) -> Callable[..., Any]:
    def check(connection: Any, request: Any) -> Any:
        policy = _guards.get(owner)
        if policy is not None:
            refusal = viser_refusal(policy, request.headers, request.path)
            if refusal is not None:
                status, text = refusal
                log.warning("viser: refused %s (%s)", request.path[:80], text)
                return connection.respond(HTTPStatus(status), text + "\n")
        return process_request(connection, request) if process_request is not None else None

    return check


def prepare_viser_guard(policy: AccessPolicy) -> None:
    """Install the handshake hook and guard the next viser server created with ``policy`` from its first
    connection on; call just before creating it, and `guard_viser` just after."""
    global _pending
    _install_serve_hook()
    _pending = policy


def guard_viser(server: Any, policy: AccessPolicy) -> None:
    """Check every HTTP request and websocket handshake of ``server`` (a `viser.ViserServer`, created after
    `prepare_viser_guard`) against ``policy``, and disable its public share link."""
    global _pending
    websock_server = server._websock_server  # viser 1.1.1: the infra server owning the websocket handler
    _guards[websock_server] = policy
    if _pending is policy:
        _pending = None
    policy.ports.add(server.get_port())

    def no_share_url(*args: Any, **kwargs: Any) -> None:
        log.warning("viser: share link requested and refused (the tool is not published through a relay)")
        return None

    server.request_share_url = no_share_url  # the handler of the page's Share request calls this
