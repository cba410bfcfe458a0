"""The 3D view's marks of what the planner does besides stepping (issue 14), drawn by `LiveScene`:

- while the planner *stands* by choice (the current step horizon swings no leg), a slate outline joins the four
  feet on the ground, once per stand horizon; a label above the robot says "standing (planner's choice)"
  (`app.live.view.STANDING`) only while that is the robot's state (told to stay: `status_kind`), never on the
  single horizons a walking robot stands (it would blink every 0.4-0.8 s on terrains where the planner stands
  every other horizon; the status sentence counts them: "stood N");
- a swing *retargeted* during its swing (`contactnet.planning.retarget`) flashes at its new landing for `FLASH_S` of
  simulated time: a cyan ring that pulses `PULSES` times (growing and blinking white), with a line from the old
  landing (still marked by the gold disk of the planner's first choice), which gets a small cross; both float
  just over that disk.

Cheap like the rest of the scene: nothing is sent while nothing shows or changes; a flash sends one batched
mesh's positions, scales and colours and one line node per scene update while it lasts.
"""

from __future__ import annotations

import math

import numpy as np
import trimesh
import viser

from app.live.step_events import FLASH_S, RetargetFlash
from app.live.view import STANDING, LiveView, is_stand, status_kind

HIDDEN_POS = np.array([0.0, 0.0, -100.0], dtype=np.float32)  # where pooled instances wait, out of sight


def hidden_mesh_pool(scene, name: str, mesh: trimesh.Trimesh, pool: int,  # noqa: ANN001 - viser scene API
                     color: np.ndarray):
    """``pool`` instances of ``mesh`` (one batched node), all out of sight, in flat toon tones (the standard
    material washes the colours out toward white) and without shadows (a toon disk in the robot's shadow
    turns black); the caller moves, scales and colours the ones it shows."""
    return scene.add_batched_meshes_simple(
        name,
        mesh.vertices,
        mesh.faces,
        batched_wxyzs=np.tile([1.0, 0.0, 0.0, 0.0], (pool, 1)),
        batched_positions=np.tile(HIDDEN_POS, (pool, 1)),
        batched_scales=np.ones((pool, 3), dtype=np.float32),
        batched_colors=np.tile(color, (pool, 1)),
        lod="off",
        material="toon3",
        cast_shadow=False,
        receive_shadow=False,
    )
RING_POOL = 8  # flashes shown at once (a trot retargets two legs at a time)
RING_RADII_M = (0.024, 0.036)  # inner, outer: around a foot ball (2 cm) and the gold chosen disk
RING_HEIGHT_M = 0.004
PULSES = 3  # over FLASH_S
PULSE_GROWTH = 0.8  # a ring grows to 1 + this at the height of a pulse
RETARGET_COLOR = np.array([0, 150, 230], dtype=np.float64)  # cyan (toon-lit lighter): no other mark uses it
FLASH_WHITE = np.array([255, 255, 255], dtype=np.float64)
OLD_CROSS_M = 0.012  # half the size of the cross at the old landing
STAND_COLOR = (73, 80, 87)  # slate, like the gait plot's stand band (app/viewer/panels/plots.py STAND_COLOR)
ABOVE_GROUND_M = 0.003
FLASH_ABOVE_GROUND_M = 0.014  # over the gold disk of the old choice (app.scene.live_scene: 4 mm x CHOSEN_SCALE 3 tall)
WHITE_BLEND = 0.45  # how far toward white a ring blinks at a pulse's height
STAND_LABEL_ABOVE_BASE_M = 0.2
MOVE_EPS_M = 1e-3


def flash_style(age_s: float) -> tuple[float, np.ndarray]:
    """(scale, RGB colour 0-255) of a retarget ring ``age_s`` after the retarget: `PULSES` pulses over
    `FLASH_S`, each growing the ring by up to `PULSE_GROWTH` and blinking it toward white."""
    phase = min(max(age_s / FLASH_S, 0.0), 1.0)
    pulse = 0.5 - 0.5 * math.cos(2.0 * math.pi * PULSES * phase)  # 0 at the retarget, 1 at each pulse's height
    return 1.0 + PULSE_GROWTH * pulse, np.rint(RETARGET_COLOR + WHITE_BLEND * pulse * (FLASH_WHITE - RETARGET_COLOR))


def retarget_segments(flashes: tuple[RetargetFlash, ...], lift_m: float) -> np.ndarray:
    """(3 N, 2, 3) line segments: for each flash the line from its old landing to its new one and a cross at
    the old one, ``lift_m`` above the landings' foot-ball centres (on the ground: minus the radius plus a little)."""
    segments = np.empty((3 * len(flashes), 2, 3), dtype=np.float32)
    dx, dy = np.array([OLD_CROSS_M, OLD_CROSS_M, 0.0]), np.array([OLD_CROSS_M, -OLD_CROSS_M, 0.0])
    for k, flash in enumerate(flashes):
        old = np.asarray(flash.old_world, dtype=float) + [0.0, 0.0, lift_m]
        new = np.asarray(flash.new_world, dtype=float) + [0.0, 0.0, lift_m]
        segments[3 * k : 3 * k + 3] = ((old, new), (old - dx, old + dx), (old - dy, old + dy))
    return segments


class StepMarks:
    """The stand outline and label (the label only while standing is the robot's state) and the retarget flashes of one scene; `update(view)` draws a `LiveView`.
    `standing` and `flashes` say what is drawn now (tests)."""

    def __init__(self, server: viser.ViserServer, foot_radius_m: float):
        scene = server.scene
        self.lift_m = ABOVE_GROUND_M - foot_radius_m  # from a foot-ball centre to just above the ground
        self.flash_lift_m = FLASH_ABOVE_GROUND_M - foot_radius_m
        ring = trimesh.creation.annulus(*RING_RADII_M, height=RING_HEIGHT_M, sections=32)
        self.rings = hidden_mesh_pool(scene, "/events/retarget/rings", ring, RING_POOL, RETARGET_COLOR.astype(np.uint8))
        self.lines = scene.add_line_segments(
            "/events/retarget/lines", np.tile(HIDDEN_POS, (3, 2, 1)), tuple(RETARGET_COLOR.astype(int)),
            thickness=0.006, visible=False,
        )
        self.stand_outline = scene.add_line_segments(
            "/events/stand/support", np.tile(HIDDEN_POS, (4, 2, 1)), STAND_COLOR, thickness=0.008, visible=False
        )
        self.stand_label = scene.add_label(
            "/events/stand/label", STANDING, position=tuple(HIDDEN_POS), anchor="bottom-center", visible=False
        )
        self.standing = False
        self.flashes: tuple[RetargetFlash, ...] = ()
        self._feet: np.ndarray | None = None
        self._label_at: np.ndarray | None = None

    def update(self, view: LiveView) -> None:
        self._draw_stand(view)
        self._draw_flashes(view)

    def _draw_stand(self, view: LiveView) -> None:
        standing = is_stand(view.snapshot) and not view.snapshot.fell
        if standing:
            feet = np.asarray(view.foot_pos_world, dtype=float)[[0, 1, 3, 2]] + [0.0, 0.0, self.lift_m]  # FL FR HR HL
            if self._feet is None or np.max(np.abs(feet - self._feet)) > MOVE_EPS_M:
                self._feet = feet
                self.stand_outline.points = np.stack([feet, np.roll(feet, -1, axis=0)], axis=1).astype(np.float32)
            label_at = np.asarray(view.snapshot.q[:3], dtype=float) + [0.0, 0.0, STAND_LABEL_ABOVE_BASE_M]
            if self._label_at is None or np.max(np.abs(label_at - self._label_at)) > MOVE_EPS_M:
                self._label_at = label_at
                self.stand_label.position = tuple(label_at)
        if standing != self.standing:
            self.standing = standing
            self.stand_outline.visible = standing
        labelled = standing and status_kind(view) == "standing"  # the robot's state, not one horizon's choice
        if labelled != self.stand_label.visible:
            self.stand_label.visible = labelled

    def _draw_flashes(self, view: LiveView) -> None:
        flashes = tuple(view.retarget_flashes[-RING_POOL:])
        if not flashes and not self.flashes:
            return
        positions = np.tile(HIDDEN_POS, (RING_POOL, 1))
        scales = np.ones((RING_POOL, 3), dtype=np.float32)
        colors = np.tile(RETARGET_COLOR.astype(np.uint8), (RING_POOL, 1))
        now = view.snapshot.t_s
        for k, flash in enumerate(flashes):
            scale, color = flash_style(now - flash.t_s)
            positions[k] = np.asarray(flash.new_world) + [0.0, 0.0, self.flash_lift_m]
            scales[k, :2] = scale
            colors[k] = color
        self.rings.batched_positions = positions
        self.rings.batched_scales = scales
        self.rings.batched_colors = colors
        if flashes:
            self.lines.points = retarget_segments(flashes, self.flash_lift_m + 0.5 * RING_HEIGHT_M)
        if bool(flashes) != bool(self.flashes):
            self.lines.visible = bool(flashes)
        self.flashes = flashes


__all__ = ["RETARGET_COLOR", "STAND_COLOR", "StepMarks", "flash_style", "retarget_segments"]
