"""Recordings: ``recorder`` (the scene over time as .viser files), ``live_recorder`` (recording the live session), ``store`` (the folder of
recordings), ``meta`` (their metadata), ``track`` (their data track: events, plans and velocities in simulated time,
for the player's timeline and plots), ``overlay`` (the status drawn on them), ``journal`` (a live recording on
disk as it goes, recovered after a crash), ``viser_files`` (the .viser format: read, write, HTML export),
``player`` (the one-file HTML player with the timeline and plots).
"""

from __future__ import annotations

from contactnet import lazy_exports

_EXPORTS = {
    "SceneRecorder": "app.recordings.recorder",
    "LiveRecorder": "app.recordings.live_recorder",
    "RecordingStore": "app.recordings.store",
}
__all__ = list(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
