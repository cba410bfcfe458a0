"""The status of a recorded scene, drawn in the scene itself: a .viser recording holds only 3D scene messages
(no control panel, no plots), so `StatusOverlay` adds what a viewer of a recording needs to follow the run.

Above the robot, following it: a text label with the status line of the live page (`app.live.view.status_line`:
state, simulated time, x, steps, the rank of the chosen foothold) and, under it, the gait schedule as a
small strip (one row per leg with the robot's leg names; past stance dark, planned stance blue, swing
light; a red line at "now"), the picture of the live panel's gait plot. Per recorded frame: one label
text, 300 cell colours and one position, a few hundred bytes after compression and a fraction of a
millisecond (`StatusOverlay.update`).

The overlay is drawn only on the recorder's own viser server (`app.recordings.recorder.SceneRecorder`), never on the
live one, which has its status panel and plots.
"""

from __future__ import annotations

import math

import numpy as np
import trimesh
import viser

from app.live.view import LiveView, status_line

OVERLAY_ROOT = "/status"
HEIGHT_ABOVE_GROUND_M = 0.5  # the strip's centre above the ground under the robot
STRIP_WIDTH_M = 0.6
STRIP_HEIGHT_M = 0.15
#: The strip leans back by this angle (about x) to face a camera behind and above, as the recordings' first view
STRIP_TILT_RAD = math.atan2(0.55, 0.75)
CELL_FILL = 0.78  # of a leg's row height (the rest is the gap between legs)
CELL_DEPTH_M = 0.0005
PAST_NODES = 50  # 2 s of 40 ms nodes before now
FUTURE_NODES = 25  # 1 s after
NODES = PAST_NODES + FUTURE_NODES
PAST_STANCE = np.array([55, 65, 85], dtype=np.uint8)
PLANNED_STANCE = np.array([60, 130, 230], dtype=np.uint8)
SWING = np.array([225, 228, 234], dtype=np.uint8)
NOW_COLOR = (220, 30, 30)
MOVE_EPS_M = 1e-3


def gait_cells(view: LiveView) -> np.ndarray:
    """(4, NODES, 3) uint8 colours of the gait schedule around now: `PAST_NODES` recorded nodes (stance dark),
    then `FUTURE_NODES` planned ones (stance blue), swing light; one row per leg."""
    stance = np.zeros((NODES, 4), dtype=bool)
    planned = np.zeros((NODES, 4), dtype=bool)
    history = view.stance_history[-PAST_NODES:]
    stance[PAST_NODES - len(history) : PAST_NODES] = history
    now_node = view.stance_history_node0 + len(view.stance_history) - 1
    plan_node0 = int(round(view.plan_t0_s / view.gait.node_dt_s))
    future = view.planned_contact[max(0, now_node + 1 - plan_node0) :][:FUTURE_NODES]
    planned[PAST_NODES : PAST_NODES + len(future)] = future
    cells = np.empty((4, NODES, 3), dtype=np.uint8)
    cells[:] = SWING
    cells[stance.T] = PAST_STANCE
    cells[planned.T] = PLANNED_STANCE
    return cells


class StatusOverlay:
    """The status label and gait strip of a recorded scene on `server` (legs named `leg_names`, FL FR HL HR
    order); `update(view)` once per recorded frame. The strip is one batch of flat boxes (a cell per leg and
    node) in the vertical x-z plane: a frame changes only their colours (no image to encode)."""

    def __init__(self, server: viser.ViserServer, leg_names: tuple[str, ...]):
        scene = server.scene
        self.root = scene.add_frame(OVERLAY_ROOT, show_axes=False)
        self.label = scene.add_label(
            f"{OVERLAY_ROOT}/text",
            "",
            position=(0.0, 0.0, 0.5 * STRIP_HEIGHT_M + 0.02),
            anchor="bottom-center",
            font_size_mode="screen",
            font_screen_scale=0.9,
        )
        node_m, row_m = STRIP_WIDTH_M / NODES, STRIP_HEIGHT_M / 4
        cell = trimesh.creation.box((node_m, CELL_DEPTH_M, CELL_FILL * row_m))
        leg, node = np.divmod(np.arange(4 * NODES), NODES)
        positions = np.stack(
            [
                -0.5 * STRIP_WIDTH_M + (node + 0.5) * node_m,
                np.zeros(len(node)),
                0.5 * STRIP_HEIGHT_M - (leg + 0.5) * row_m,
            ],
            axis=1,
        )
        self._colors = np.tile(SWING, (4 * NODES, 1))
        tilt = (math.cos(-STRIP_TILT_RAD / 2), math.sin(-STRIP_TILT_RAD / 2), 0.0, 0.0)
        scene.add_frame(f"{OVERLAY_ROOT}/gait", show_axes=False, wxyz=tilt)
        self.strip = scene.add_batched_meshes_simple(
            f"{OVERLAY_ROOT}/gait/cells",
            cell.vertices,
            cell.faces,
            batched_wxyzs=np.tile([1.0, 0.0, 0.0, 0.0], (len(node), 1)),
            batched_positions=positions.astype(np.float32),
            batched_colors=self._colors,
            lod="off",
            material="toon3",  # flat tones, as the candidate disks
            cast_shadow=False,
            receive_shadow=False,
        )
        now = trimesh.creation.box((0.15 * node_m + 0.002, CELL_DEPTH_M, STRIP_HEIGHT_M + 0.01))
        scene.add_mesh_simple(
            f"{OVERLAY_ROOT}/gait/now",
            now.vertices,
            now.faces,
            color=NOW_COLOR,
            position=(-0.5 * STRIP_WIDTH_M + PAST_NODES * node_m, -CELL_DEPTH_M, 0.0),
            material="toon3",
            cast_shadow=False,
            receive_shadow=False,
        )
        for k, name in enumerate(leg_names[:4]):
            scene.add_label(
                f"{OVERLAY_ROOT}/gait/{name}",
                name,
                position=(-0.5 * STRIP_WIDTH_M - 0.005, 0.0, 0.5 * STRIP_HEIGHT_M - (k + 0.5) * row_m),
                anchor="center-right",
                font_size_mode="scene",
                font_scene_height=0.8 * row_m,
            )
        self._position: np.ndarray | None = None
        self._text = ""

    def update(self, view: LiveView) -> None:
        base = np.asarray(view.snapshot.q[:3], dtype=float)
        ground = float(view.terrain.ground_z(base[None, :2])[0])
        position = np.array([base[0], base[1], ground + HEIGHT_ABOVE_GROUND_M])
        if self._position is None or np.max(np.abs(position - self._position)) > MOVE_EPS_M:
            self._position = position
            self.root.position = tuple(position)
        text = status_line(view)  # the live header's and panel's line: one status source
        if text != self._text:
            self._text = text
            self.label.text = text
        colors = gait_cells(view).reshape(-1, 3)
        if not np.array_equal(colors, self._colors):
            self._colors = colors
            self.strip.batched_colors = colors
