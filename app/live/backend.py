"""What the web side uses of a live session (`SessionBackend`), whichever process runs its simulation.

Two implementations: `app.live.session.LiveSession` (the simulation thread in this process: ``serve --engine
local``, the default) and `app.live.ray_session.RaySession` (the same LiveSession inside a Ray actor, on this
machine or a cluster: ``serve --engine ray [--address A]``; this process only forwards commands and receives the
session's `LiveView` snapshots). Visits (`app.api.visits`), the viewer, the panels, the terrain service and the
routes use nothing else of a session (docs/sessions-on-ray.md).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from concurrent.futures import Future
from typing import TYPE_CHECKING, Any, Protocol, runtime_checkable

if TYPE_CHECKING:
    from app.live.commands import Command
    from app.live.pacing import PacingStats
    from app.live.settings import ServeSettings
    from app.live.view import LiveView

@runtime_checkable
class SessionBackend(Protocol):
    """A started live session as the web side sees it: commands in (`submit`, `call`), snapshots out (`view`)."""

    settings: ServeSettings  #: what the session started with (the panels read their initial values here)
    session_id: str  #: new for every session (clients reconnect when it changes)
    stats: PacingStats  #: the simulation's pacing (real-time factor: `contactnet bench live`)

    def start(self, timeout: float = 60.0) -> SessionBackend:
        """Start the simulation; returns the session, or raises (one line) when it cannot start."""

    def stop(self, timeout: float = 10.0) -> None:
        """Stop the simulation and free what it holds (idempotent)."""

    def submit(self, command: Command) -> Future:
        """Queue a command; the Future resolves to its result once applied (`view` then shows its effect), or
        carries the error that refused it (ValueError, `app.live.commands.CommandConflict`, RuntimeError when the
        session is not running)."""

    def call(self, command: Command, timeout: float = 30.0) -> Any:
        """`submit` and wait."""

    @property
    def view(self) -> LiveView | None:
        """The latest snapshot (None before the first); never blocks."""

    @property
    def alive(self) -> bool:
        """The simulation runs (False once stopped or lost)."""

    @property
    def lost(self) -> str | None:
        """One line when the simulation was lost without being stopped (its process or machine died), else None."""

    def wait_view(self, predicate: Callable[[LiveView], bool], timeout: float = 10.0) -> LiveView:
        """Block until the latest view satisfies ``predicate`` (tests, benchmarks)."""


def wait_view(session: SessionBackend, predicate: Callable[[LiveView], bool], timeout: float = 10.0) -> LiveView:
    """Poll ``session.view`` until it satisfies ``predicate`` (every backend's `wait_view`); TimeoutError after
    ``timeout`` seconds."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        view = session.view
        if view is not None and predicate(view):
            return view
        time.sleep(0.005)
    raise TimeoutError("condition on the live view not met in time")
