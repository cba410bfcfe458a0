"""The robot in the 3D view: its URDF's meshes, made light enough for a browser without a GPU, posed
from pinocchio configurations. Works for any robot of `contactnet.robots` (STL or COLLADA meshes).

A software-rendering browser spends most of each frame on the robot's triangles, so the meshes are
decimated by vertex clustering to at most `ROBOT_TRIANGLE_BUDGET` triangles (Solo12: 51k -> ~10k at
4 mm cells; Go2's COLLADA visuals, 80k triangles, need coarser cells). The visual meshes are used when
trimesh can read their format (COLLADA needs pycollada), else the collision meshes.
"""

from __future__ import annotations

import logging
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
import trimesh
import viser
from viser.extras import ViserUrdf

from contactnet.frames import quat_mul_wxyz
from contactnet.robots import Robot

log = logging.getLogger("contactnet.app.robot_display")

ROBOT_ROOT = "/robot"
ROBOT_COLOR = (0.32, 0.34, 0.40)
#: The other robots of compare mode: translucent teal, a colour nothing else in the scene uses.
GHOST_COLOR = (0.0, 0.62, 0.58, 0.45)
#: The finest clustering cell; coarser cells (x CELL_GROWTH each) until the robot fits the budget.
ROBOT_MESH_CELL_M = 0.004
CELL_GROWTH = 1.25
MAX_CELL_M = 0.05
ROBOT_TRIANGLE_BUDGET = 12_000


def cluster_decimate(mesh: trimesh.Trimesh, cell_m: float) -> trimesh.Trimesh:
    """A lighter copy of a mesh by vertex clustering: vertices in one cell of a `cell_m` grid merge
    into their mean; faces that collapse or repeat are dropped."""
    keys = np.floor(np.asarray(mesh.vertices) / cell_m).astype(np.int64)
    _, cluster, counts = np.unique(keys, axis=0, return_inverse=True, return_counts=True)
    cluster = cluster.ravel()
    vertices = np.zeros((len(counts), 3))
    np.add.at(vertices, cluster, mesh.vertices)
    vertices /= counts[:, None]
    faces = cluster[np.asarray(mesh.faces)]
    faces = faces[(faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2]) & (faces[:, 0] != faces[:, 2])]
    _, first = np.unique(np.sort(faces, axis=1), axis=0, return_index=True)
    return trimesh.Trimesh(vertices, faces[np.sort(first)], process=False)


def decimate_to_budget(
    meshes: dict[str, trimesh.Trimesh], budget: int = ROBOT_TRIANGLE_BUDGET
) -> tuple[dict[str, trimesh.Trimesh], float]:
    """(decimated meshes, cell size used): the finest cell from `ROBOT_MESH_CELL_M` up (by `CELL_GROWTH`)
    whose meshes have at most ``budget`` triangles in all. A part that a cell would erase keeps its mesh."""
    cell = ROBOT_MESH_CELL_M
    while True:
        decimated = {}
        for name, mesh in meshes.items():
            light = cluster_decimate(mesh, cell)
            decimated[name] = light if len(light.faces) else mesh
        if sum(len(m.faces) for m in decimated.values()) <= budget or cell * CELL_GROWTH > MAX_CELL_M:
            return decimated, cell
        cell *= CELL_GROWTH


def readable_meshes(urdf_path: Path, kind: str) -> bool:
    """Whether trimesh can read every mesh file of the URDF's ``kind`` ("visual" or "collision") elements."""
    formats = set(trimesh.available_formats())
    root = ET.parse(urdf_path).getroot()
    for element in root.iter(kind):
        for mesh in element.iter("mesh"):
            if Path(mesh.get("filename", "")).suffix.lower().lstrip(".") not in formats:
                return False
    return True


@dataclass
class DisplayUrdf:
    """A robot's URDF loaded for display: ``urdf`` (yourdfpy) with decimated meshes in its visual scene
    (``visual``) or, when the visual meshes cannot be read, in its collision scene."""

    urdf: Any
    visual: bool
    cell_m: float
    triangles: int


def load_display_urdf(urdf_path: Path, budget: int = ROBOT_TRIANGLE_BUDGET) -> DisplayUrdf:
    """A URDF for display, its meshes decimated to ``budget`` triangles (see the module docstring)."""
    import yourdfpy

    visual = readable_meshes(urdf_path, "visual")
    if not visual:
        log.warning("%s: visual meshes not readable here (COLLADA needs pycollada): showing the collision "
                    "meshes", urdf_path.name)
    urdf = yourdfpy.URDF.load(
        urdf_path,
        build_scene_graph=visual,
        load_meshes=visual,
        build_collision_scene_graph=not visual,
        load_collision_meshes=not visual,
        filename_handler=partial(yourdfpy.filename_handler_magic, dir=urdf_path.parent),
    )
    scene = urdf.scene if visual else urdf.collision_scene
    decimated, cell = decimate_to_budget(dict(scene.geometry), budget)
    scene.geometry.update(decimated)
    return DisplayUrdf(urdf, visual, cell, sum(len(m.faces) for m in decimated.values()))


class RobotDisplay:
    """Poses a robot's ViserUrdf from a pinocchio configuration.

    Joints map by name from pinocchio's order (the description's ``joint_names``) to the URDF's. A
    revolute joint's frame is origin * rotation(axis, q): its position never changes and its rotation is
    the origin's quaternion times the axis-angle one, so one update is 12 quaternion products (instead
    of yourdfpy's scene-graph update, which costs ~5 ms). Falls back to ViserUrdf.update_cfg if
    viser's internals are not as expected.
    """

    def __init__(
        self,
        server: viser.ViserServer,
        robot: Robot,
        root: str = ROBOT_ROOT,
        color: tuple[float, ...] = ROBOT_COLOR,
        display: DisplayUrdf | None = None,
    ):
        """``root``: the scene node the robot hangs from; ``color``: RGB, or RGBA for a translucent robot;
        ``display``: a loaded `DisplayUrdf` to share (another robot of the same kind), else loaded here."""
        joint_names = list(robot.description.joint_names)
        self.root = server.scene.add_frame(root, show_axes=False)
        self.display = display if display is not None else load_display_urdf(robot.files.urdf)
        self.urdf = ViserUrdf(
            server,
            self.display.urdf,
            root_node_name=root,
            mesh_color_override=color,
            collision_mesh_color_override=color,
            load_meshes=self.display.visual,
            load_collision_meshes=not self.display.visual,
        )
        names = self.urdf.get_actuated_joint_names()
        self.cfg_from_pin = np.array([joint_names.index(n) for n in names])
        self.urdf.update_cfg(np.zeros(len(names)))  # sets every joint frame's fixed position
        self._fast = None
        try:
            joints = list(self.urdf._urdf.joint_map.values())
            frames = list(self.urdf._joint_frames)[: len(joints)]
            handles, pin_index, origin_q, axes = [], [], [], []
            for joint, frame in zip(joints, frames, strict=True):
                if joint.type not in ("revolute", "continuous"):
                    continue
                handles.append(frame)
                pin_index.append(joint_names.index(joint.name))
                origin = np.eye(4) if joint.origin is None else np.asarray(joint.origin)
                origin_q.append(viser.transforms.SO3.from_matrix(origin[:3, :3]).wxyz)
                axis = np.asarray(joint.axis, dtype=float)
                axes.append(axis / np.linalg.norm(axis))
            self._fast = (handles, np.array(pin_index), np.array(origin_q), np.array(axes))
        except (AttributeError, ValueError, TypeError):
            self._fast = None
        self._last_q: np.ndarray | None = None

    @property
    def visible(self) -> bool:
        return bool(self.root.visible)

    @visible.setter
    def visible(self, value: bool) -> None:
        if bool(self.root.visible) != bool(value):
            self.root.visible = bool(value)

    def set(self, q: np.ndarray) -> None:
        q = np.asarray(q, dtype=float)
        if self._last_q is not None and np.array_equal(q, self._last_q):
            return
        self._last_q = q.copy()
        x, y, z, w = q[3:7]
        self.root.position = q[:3]
        self.root.wxyz = np.array([w, x, y, z])
        joints = q[7:]
        if self._fast is None:
            self.urdf.update_cfg(joints[self.cfg_from_pin])
            return
        handles, pin_index, origin_q, axes = self._fast
        half = 0.5 * joints[pin_index]
        motion = np.concatenate([np.cos(half)[:, None], np.sin(half)[:, None] * axes], axis=1)
        wxyz = quat_mul_wxyz(origin_q, motion)
        for handle, value in zip(handles, wxyz, strict=True):
            handle.wxyz = value


def robot_state_text(planner: str, done: str | None, x_m: float, steps: int) -> str:
    """A robot's label in compare mode, short: its planner and how it is doing (the panel has the details)."""
    if done and done.startswith("fell"):
        state = f"fell at x {x_m:.2f} m"
    elif done:
        state = f"{done}, {steps} steps"
    else:
        state = f"x {x_m:.1f} m · {steps} steps"
    return f"{planner}: {state}"


class CompareGhosts:
    """The robots of compare mode (`LiveView.compare`): the other robots drawn translucent teal at their own
    poses, each labelled with its planner and state, and a label over the main robot naming its planner.
    Nodes are made the first time compare mode is on and hidden (not removed) when it is off."""

    label_height_m = 0.28
    label_stack_m = 0.06  #: each robot's label this much above the previous one's: robots side by side stay readable

    def __init__(self, server: viser.ViserServer, robot: Robot, display: DisplayUrdf):
        self.server = server
        self.robot = robot
        self.display = display
        self.ghosts: list[RobotDisplay] = []
        self.labels: list[viser.LabelHandle] = []  # [main robot, ghost 0, ghost 1, ...]
        self._texts: list[str] = []
        self._on = False
        self.lane_dy_m = 0.0  #: side by side: other robot i is drawn (i + 1) * lane_dy_m along +y (0: over the main one)

    def _label(self, index: int, text: str, base: np.ndarray) -> None:
        position = np.asarray(base, dtype=float) + np.array([0.0, 0.0, self.label_height_m + index * self.label_stack_m])
        if index == len(self.labels):
            self.labels.append(
                self.server.scene.add_label(f"/compare/label_{index}", text, position=position, anchor="bottom-center")
            )
            self._texts.append(text)
            return
        label = self.labels[index]
        if self._texts[index] != text:
            label.text = text
            self._texts[index] = text
        if not np.allclose(label.position, position, atol=2e-3):
            label.position = position
        if not label.visible:
            label.visible = True

    def update(self, view: Any) -> None:
        compare = getattr(view, "compare", None)
        if not compare:
            if self._on:
                for node in (*self.ghosts, *self.labels):
                    node.visible = False
                self._on = False
            return
        self._on = True
        status, snap = view.status, view.snapshot
        self._label(0, robot_state_text(status.planner_active, status.done, float(snap.q[0]), snap.steps), snap.q[:3])
        for i, other in enumerate(compare):
            if i == len(self.ghosts):
                self.ghosts.append(
                    RobotDisplay(self.server, self.robot, root=f"/compare/robot_{i}", color=GHOST_COLOR,
                                 display=self.display)
                )
            ghost = self.ghosts[i]
            ghost.visible = True
            q = np.array(other.snapshot.q, dtype=float)
            q[1] += (i + 1) * self.lane_dy_m  # on its lane when side by side
            ghost.set(q)
            self._label(i + 1, robot_state_text(other.planner_active or other.planner, other.done, float(other.x_m),
                                                int(other.steps)), q[:3])
        for ghost in self.ghosts[len(compare):]:
            ghost.visible = False
        for label in self.labels[len(compare) + 1:]:
            label.visible = False
