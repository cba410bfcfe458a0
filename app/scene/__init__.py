"""The 3D scene in viser: the robot, terrain, candidate disks, plans (``live_scene``), their marks
(``marks``), the robot's drawing (``robot_display``), cameras (``camera``) and click picking (``terrain_pick``).
"""

from __future__ import annotations

from contactnet import lazy_exports

_EXPORTS = {
    "LiveScene": "app.scene.live_scene",
}
__all__ = list(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
