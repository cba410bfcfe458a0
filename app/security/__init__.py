"""What the server lets in: Host, origin, access token, body limits and the viser websocket guard
(``guards``).
"""

from __future__ import annotations

from contactnet import lazy_exports

_EXPORTS = {
    "AccessPolicy": "app.security.guards",
    "RequestGuard": "app.security.guards",
}
__all__ = list(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
