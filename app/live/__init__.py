"""The live session: one robot walking, driven by commands, read through immutable views.

- ``session``: `LiveSession`, the one thread that owns a simulation; ``commands``: what it can be told;
- ``view``: the snapshot every reader gets (`LiveView`); ``step_events``: stands, useless steps, retargets;
- ``settings``: `ServeSettings`; ``pacing``, ``runs``, ``compare``, ``planners``, ``terrain_change``;
- ``editor``, ``editing``, ``terrain_files``: terrain edits and the user's terrain files.
"""

from __future__ import annotations

from contactnet import lazy_exports

_EXPORTS = {
    "LiveSession": "app.live.session",
    "ServeSettings": "app.live.settings",
}
__all__ = list(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
