"""What the panels share: submitting a command with an error notification, and writing values back
only when the session's value changed (so a slider being dragged is not pulled back by a stale state)."""

from __future__ import annotations

from concurrent.futures import Future
from typing import Any

from app.live.commands import Command
from app.live.session import LiveSession


def notify_error(client: Any, title: str):  # noqa: ANN201 - a Future callback
    """A Future callback that shows the command's error (if any) to the browser that sent it."""

    def done(future: Future) -> None:
        exc = future.exception()
        if exc is not None and client is not None:
            client.add_notification(title, str(exc), color="red", auto_close_seconds=8.0)

    return done


def submit(session: LiveSession, command: Command, client: Any = None, title: str = "Command failed") -> Future:
    """Queue ``command`` without waiting; a failure is shown to ``client`` under ``title``."""
    future = session.submit(command)
    future.add_done_callback(notify_error(client, title))
    return future


class ChangeTracker:
    """Remembers the last value written back per key: `changed(key, value)` is True once per new value."""

    def __init__(self) -> None:
        self._seen: dict[str, object] = {}

    def changed(self, key: str, value: object) -> bool:
        if self._seen.get(key, object()) == value:
            return False
        self._seen[key] = value
        return True
