"""The "Record" folder: start and stop a recording of the scene (listed on the front page)."""

from __future__ import annotations

import logging

import viser

from app.live.view import LiveView
from app.recordings.live_recorder import LiveRecorder
from app.recordings.recorder import RecordingConflict
from app.viewer.panels.common import ChangeTracker, tell

log = logging.getLogger("contactnet.app.panels.recording")

IDLE_TEXT = "Recordings are listed on the front page."


class RecordingPanel:
    """One start/stop button and a line saying what is being (or was last) recorded."""

    def __init__(self, gui: viser.GuiApi, recorder: LiveRecorder, order: float = 60.0, session=None):  # noqa: ANN001
        """``session``: whose users are told what a click did (`tell`); None: the browser that clicked (tests)."""
        self.recorder = recorder
        self.session = session
        self._seen = ChangeTracker()
        with gui.add_folder("Record", order=order, expand_by_default=False):
            self.record_button = gui.add_button("Start recording", icon=viser.Icon.PLAYER_RECORD, color="red")
            self.record_info = gui.add_markdown(IDLE_TEXT)

        @self.record_button.on_click
        def _(event) -> None:
            try:
                if self.recorder.recording:
                    info = self.recorder.stop()
                    self._tell(event.client, "Recording saved",
                               f"{info.name} ({info.size_bytes / 1e6:.1f} MB): see Recordings on the front page", "info")
                else:
                    self.recorder.start()
            except Exception as exc:  # noqa: BLE001 - shown to the user
                if isinstance(exc, OSError | RecordingConflict):  # a refusal (a folder that cannot be written): one line
                    log.warning("recording: %s", exc)
                else:
                    log.exception("recording failed")
                self._tell(event.client, "Recording", str(exc), "error")
            self._refresh_button()

    def _tell(self, client, title: str, body: str, level: str) -> None:  # noqa: ANN001 - viser's ClientHandle
        if self.session is not None:
            tell(self.session, title, body, level)
        elif client is not None:
            client.add_notification(title, body, color="red" if level == "error" else "green", auto_close_seconds=8)

    def _refresh_button(self) -> None:
        recording = self.recorder.recording
        self.record_button.label = "Stop recording" if recording else "Start recording"
        self.record_button.icon = viser.Icon.PLAYER_STOP if recording else viser.Icon.PLAYER_RECORD

    def refresh(self, view: LiveView) -> None:
        self._refresh_button()
        status = self.recorder.status()
        text = (
            f"**not saved** {status['name']}: {status['save_error']}. Stop recording again to save it."
            if status["recording"] and status.get("save_error") and self.recorder.stopped
            else f"**recording** {status['name']}: {status['duration_s']:.1f} s, {status['frames']} frames"
            if status["recording"]
            else (f"last saved: {status['last_saved']}" if status["last_saved"] else IDLE_TEXT)
        )
        if self._seen.changed("record_info", text):
            self.record_info.content = text
