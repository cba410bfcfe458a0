"""What the panels share: telling the user something through the session's notices (`tell`: the one notification
channel, the page's toasts and, in a 3D view opened on its own, viser's), submitting a command whose failure is
told that way, writing values back only
when the session's value changed (so a slider being dragged is not pulled back by a stale state), and
`SessionControls`: controls that show a session value and change it, kept in step with the session.

Why `SessionControls` (issue 26): viser runs a plain GUI callback in a thread pool, some time after its event
loop has set the handle's new value, and the viewer's refresh thread wrote the session's value into the same
handle. On a busy machine the two met: the browser unticks a box, the refresh (working from a view made before
that change reached the session) ticks it again, and the late callback then reads the box and submits the old
value: the user's change is lost for good. Two quick changes of one control could also reach the session out of
order (each callback reads the handle, then submits, on its own thread). And a change the session made and took
back between two refreshes (REST: on, then off) was never shown, the refresh comparing against the last session
value it saw rather than what the handle shows. Now a user's change is submitted by an async callback, which
viser runs on its event loop right after setting the value (in arrival order, with the value that message set),
and the session's value is written back on that same loop, only once every change of the control submitted so
far has been applied and is in the view being shown."""

from __future__ import annotations

import asyncio
import threading
from collections.abc import Callable
from concurrent.futures import Future
from dataclasses import dataclass
from typing import Any

from app.live.commands import Command, Notify
from app.live.session import LiveSession


def tell(session: LiveSession, title: str, body: str = "", level: str = "error") -> None:
    """Tell the session's users ``title: body`` once, as a notice (`Notify`): the front page shows it as a toast, a
    3D view opened on its own as viser's (`app.viewer.panels.notices`). One channel: the page hides viser's own
    toasts in the 3D view it embeds, so nothing is said twice in two wordings."""
    text = f"{title}: {body}" if body else title
    session.submit(Notify(text[:500], level))


def notify_error(session: LiveSession, title: str):  # noqa: ANN201 - a Future callback
    """A Future callback that tells the command's error (if any) to the session's users (`tell`)."""

    def done(future: Future) -> None:
        exc = future.exception()
        if exc is not None:
            tell(session, title, str(exc))

    return done


def submit(session: LiveSession, command: Command, client: Any = None, title: str = "Command failed") -> Future:
    """Queue ``command`` without waiting; a failure is told under ``title`` (`tell`). ``client``: the browser that
    sent it (kept for callers; the notice goes to the session's users)."""
    future = session.submit(command)
    future.add_done_callback(notify_error(session, title))
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


@dataclass
class _Control:
    handle: Any
    pending: int = 0  #: the user's changes submitted and not yet applied by the session
    settled_seq: int = -1  #: the first view seq that includes every applied one


class SessionControls:
    """GUI inputs that show a session value and change it (see the module doc): ``on_change`` submits the user's
    changes in the order they arrive; ``show`` writes the session's value back unless a change of the user's is
    still on its way."""

    def __init__(self, session: LiveSession, loop: asyncio.AbstractEventLoop):
        """``loop``: the viser server's event loop (`ViserServer.get_event_loop`), where viser sets the values
        the browsers send."""
        self.session = session
        self.loop = loop
        self._lock = threading.Lock()
        self._controls: dict[str, _Control] = {}

    def add(self, key: str, handle: Any) -> Any:  # noqa: ANN401 - a viser GUI handle
        self._controls[key] = _Control(handle)
        return handle

    def on_change(self, keys: tuple[str, ...], command: Callable[[], Command], title: str = "Command failed") -> None:
        """When a browser changes any of ``keys``' handles, submit ``command()`` (built from the handles' values
        at that moment, on viser's event loop, so changes are submitted in the order they arrived)."""

        async def changed(event) -> None:  # noqa: ANN001 - viser's GuiEvent; async: run on the event loop
            if event.client is not None:
                self.submit(keys, command(), event.client, title)

        for key in keys:
            self._controls[key].handle.on_update(changed)

    def submit(self, keys: tuple[str, ...], command: Command, client: Any = None,
               title: str = "Command failed") -> Future:
        """Submit ``command``, a user's change of ``keys``: their values are not written back until it applied."""
        with self._lock:
            for key in keys:
                self._controls[key].pending += 1
        future = submit(self.session, command, client, title)

        def settled(_: Future) -> None:  # the session published the view with the change before resolving
            view = self.session.view
            seq = view.seq if view is not None else -1
            with self._lock:
                for key in keys:
                    control = self._controls[key]
                    control.pending -= 1
                    control.settled_seq = max(control.settled_seq, seq)

        future.add_done_callback(settled)
        return future

    def show(self, key: str, value: Any, seq: int) -> None:  # noqa: ANN401
        """Write the session's ``value`` (from the view numbered ``seq``) into ``key``'s handle, on viser's event
        loop: skipped while a change of the user's is not in that view yet (its own view writes it later)."""
        self.loop.call_soon_threadsafe(self._show, key, value, seq)

    def _show(self, key: str, value: Any, seq: int) -> None:  # noqa: ANN401
        with self._lock:
            control = self._controls[key]
            if control.pending or seq < control.settled_seq:
                return
        if control.handle.value != value:
            control.handle.value = value

    def in_step(self) -> bool:
        """No change of the user's is on its way (tests)."""
        with self._lock:
            return not any(c.pending for c in self._controls.values())
