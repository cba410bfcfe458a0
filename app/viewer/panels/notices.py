"""Toasts in the 3D view: every new notice of the session (the one notification channel: the front page shows the
same notices as its own toasts and hides these in the 3D view it embeds) (`LiveView.notices`: "Gait set to trot: the
robot restarted from the start", ...) shown once to every connected browser, and viser's own
"Software WebGL rendering detected" toast closed on its own after a few seconds (it has no
auto-close and would cover part of the scene on machines without a GPU)."""

from __future__ import annotations

import threading

import viser
from viser import _messages

from app.live.view import LiveView

NOTICE_SECONDS = 6.0
#: viser 1.1's client shows this toast (id "webgl-software-rendering") without auto-close; a notification
#: update with the same id gives it one (a no-op in a browser that did not show it).
SOFTWARE_WEBGL_TOAST = "webgl-software-rendering"
SOFTWARE_WEBGL_SECONDS = 4.0


def close_software_webgl_toast(client: viser.ClientHandle) -> None:
    """Give viser's software-rendering toast an auto-close (and a shorter text) in this browser."""
    props = _messages.NotificationProps(
        title="Software WebGL rendering",
        body="No GPU in use: the 3D view may be slow (turning Shadows off helps).",
        loading=False,
        with_close_button=True,
        auto_close_seconds=SOFTWARE_WEBGL_SECONDS,
        color="orange",
    )
    client._websock_connection.queue_message(_messages.NotificationUpdateMessage(SOFTWARE_WEBGL_TOAST, props))


class NoticeToasts:
    """Shows each new notice (by `seq`) once to every connected browser. A browser that connects later
    is not shown what happened before it came."""

    def __init__(self, server: viser.ViserServer):
        self.server = server
        self._lock = threading.Lock()
        self.shown_seq: int | None = None  # the newest notice shown (None: none seen yet)

    def refresh(self, view: LiveView) -> None:
        notices = view.notices
        with self._lock:
            if self.shown_seq is None:  # the first view: what is there already is old news
                self.shown_seq = max((n.seq for n in notices), default=0)
                return
            new = [n for n in notices if n.seq > self.shown_seq]
            if not new:
                return
            self.shown_seq = max(n.seq for n in new)
        clients = list(self.server.get_clients().values())
        for notice in sorted(new, key=lambda n: n.seq):
            title, body = toast_text(notice.text)
            color = {"info": "blue", "warning": "orange"}.get(notice.level, "red")
            for client in clients:
                client.add_notification(title, body, color=color, auto_close_seconds=NOTICE_SECONDS)


def toast_text(text: str) -> tuple[str, str]:
    """(title, body) of a notice: "Gait set to trot: the robot restarted" -> ("Gait set to trot", "the robot
    restarted"); a notice without a colon is all title."""
    title, sep, body = text.partition(": ")
    return (title, body) if sep and body else (text, "")
