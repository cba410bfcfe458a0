"""The viser side: ``live_viewer`` (one ViserServer, its update loop), ``gui`` (the control panel)
and ``panels/`` (one class per folder of the panel).
"""

from __future__ import annotations

from contactnet import lazy_exports

_EXPORTS = {
    "Viewer": "app.viewer.live_viewer",
}
__all__ = list(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
