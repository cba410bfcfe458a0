"""The HTTP API: ``server`` (FastAPI routes, the front page, serving), ``models`` (request and answer
models), ``errors`` (how the API says no), ``recording_routes`` and ``recording_models``.
"""

from __future__ import annotations

from contactnet import lazy_exports

_EXPORTS = {
    "ContactnetApp": "app.api.server",
    "create_api": "app.api.server",
    "serve": "app.api.server",
    "BackgroundServer": "app.api.server",
}
__all__ = list(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
